#!/usr/bin/env python3
"""Write small interoperability fixtures with the ecosystem's own writers.

Every file holds the same 4-frame, 5 x 7 (rows x cols, non-square) stack, so detnoise must
read each of them to identical values. The reference values are stored as raw little-endian
arrays beside them (reference-u16.bin: uint16; reference-half.bin: float32 copies of small
integers exact in half precision), so the Rust tests need no Python.

Regenerate (from the repository root):
    pip install astropy tifffile imagecodecs numpy OpenEXR
    python3 scripts/make_interop_fixtures.py tests/fixtures/interop
"""
import gzip
import shutil
import sys
from pathlib import Path

import numpy as np
from astropy.io import fits
import tifffile
import OpenEXR

FRAMES, ROWS, COLS = 4, 5, 7


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20151)
    # Full uint16 range, so BZERO handling (values above 32767) is exercised.
    u16 = rng.integers(0, 65536, size=(FRAMES, ROWS, COLS), dtype=np.uint16)
    u16[0, 0, 0], u16[0, 0, 1] = 0, 65535
    small = (u16 % 2048).astype(np.float32)  # exact in half precision
    u16.astype("<u2").tofile(out / "reference-u16.bin")
    small.astype("<f4").tofile(out / "reference-half.bin")

    # FITS (astropy): uint16 as int16 + BZERO 32768, float32, multi-extension, RICE tiles, gzip.
    fits.PrimaryHDU(u16).writeto(out / "astropy-u16-bzero.fits", overwrite=True)
    fits.PrimaryHDU(u16.astype(np.float32)).writeto(out / "astropy-f32.fits", overwrite=True)
    hdus = [fits.PrimaryHDU()] + [fits.ImageHDU(f, name=f"FRAME{k}") for k, f in enumerate(u16)]
    fits.HDUList(hdus).writeto(out / "astropy-mef.fits", overwrite=True)
    comp = [fits.PrimaryHDU()] + [fits.CompImageHDU(f, compression_type="RICE_1") for f in u16]
    fits.HDUList(comp).writeto(out / "astropy-rice.fits", overwrite=True)
    with open(out / "astropy-u16-bzero.fits", "rb") as src, gzip.open(out / "astropy-u16-bzero.fits.gz", "wb") as dst:
        shutil.copyfileobj(src, dst)

    # TIFF (tifffile): multi-page, LZW, Deflate, BigTIFF, ImageJ, float32, big-endian.
    tifffile.imwrite(out / "tifffile-multipage.tif", u16, photometric="minisblack")
    tifffile.imwrite(out / "tifffile-lzw.tif", u16, photometric="minisblack", compression="lzw")
    tifffile.imwrite(out / "tifffile-deflate.tif", u16, photometric="minisblack", compression="zlib")
    tifffile.imwrite(out / "tifffile-bigtiff.tif", u16, photometric="minisblack", bigtiff=True)
    tifffile.imwrite(out / "tifffile-imagej.tif", u16, imagej=True, metadata={"axes": "ZYX"})
    # One IFD with every frame after it, as ImageJ does for stacks over 4 GB.
    tifffile.imwrite(out / "tifffile-imagej-one-ifd.tif", u16, imagej=True, truncate=True, metadata={"axes": "ZYX"})
    tifffile.imwrite(out / "tifffile-f32.tif", u16.astype(np.float32), photometric="minisblack")
    tifffile.imwrite(out / "tifffile-bigendian.tif", u16, photometric="minisblack", byteorder=">")

    # OpenEXR: float32 and half, one part per frame (multi-layer), and one file per frame.
    def part(name, data):
        return OpenEXR.Part({"compression": OpenEXR.ZIP_COMPRESSION}, {"Y": np.ascontiguousarray(data)}, name=name)

    OpenEXR.File([part(f"frame{k}", f.astype(np.float32)) for k, f in enumerate(u16)]).write(str(out / "openexr-f32-layers.exr"))
    OpenEXR.File([part(f"frame{k}", f.astype(np.float16)) for k, f in enumerate(small)]).write(str(out / "openexr-half-layers.exr"))
    OpenEXR.File([part(f"frame{k}", f.astype(np.uint32)) for k, f in enumerate(u16)]).write(str(out / "openexr-u32-layers.exr"))
    for k, f in enumerate(u16):
        single = out / "openexr-files"
        single.mkdir(exist_ok=True)
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION}, {"Y": f.astype(np.float32)}).write(str(single / f"frame{k}.exr"))


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "tests/fixtures/interop"))
