#!/usr/bin/env python3
"""Write the bundled EMVA 1288 dataset data-synthetic/emva-cmos-64x96/ with its truth.

Our own forward model of a linear camera (not the reference implementation's simulator, so
that detnoise is not checked against the code it is compared with), per pixel i and frame:

    charge = Poisson(QE * photons) + Poisson(dark_current_i * t), clipped to [0, full_well]
    electrons = charge + dsnu_offset_i + Normal(0, read_noise)   (e-, at readout)
    DN = round(K * (1 + prnu_i) * electrons + offset), clipped to [0, 2^bits - 1]

with a fixed pattern made of row, column and pixel parts (DSNU in e-, PRNU on the gain), and
the dark current of each pixel spread around its mean. The photon-transfer series varies the
exposure time at one irradiance (as the reference dataset generator does by default), a dark
pair at each exposure; the spatial stacks (bright near 50 % of saturation and dark) are at one
exposure. One single-frame gzip FITS file per image, listed by a descriptor written as the
reference implementation writes it (`i images\\name`, Windows separators).

truth.json holds the generating parameters and the realised fixed patterns' statistics
(their standard deviations over the pixels and their row / column / pixel split), in the
units their keys state.

Regenerate (from the repository root; numpy and astropy):
    /tmp/aoenv/bin/python scripts/make_emva_synthetic.py data-synthetic/emva-cmos-64x96
"""
import gzip
import io
import json
import shutil
import sys
from pathlib import Path

import numpy as np
from astropy.io import fits

ROWS, COLS, BITS = 64, 96, 12
K = 0.40  # DN/e-
QE = 0.60
READ_NOISE_E = 6.0
OFFSET_DN = 100.0
FULL_WELL_E = 9000.0
DARK_CURRENT_E_S = 200.0  # mean over pixels
DARK_CURRENT_SPREAD = 0.2  # relative, per pixel
DSNU_ROW_E, DSNU_COL_E, DSNU_PIXEL_E = 1.0, 1.5, 2.5
PRNU_ROW, PRNU_COL, PRNU_PIXEL = 0.002, 0.004, 0.010
POINTS = 60
EXPOSURE_MIN_S, EXPOSURE_MAX_S = 0.001, 0.060
# Photons per pixel per second: saturation (full well) at 80 % of the longest exposure.
PHOTON_RATE = FULL_WELL_E / QE / (0.8 * EXPOSURE_MAX_S)
SPATIAL_FRAMES = 24
SEED = 1288


def split(pattern):
    """Standard deviations of a fixed pattern: total, rows, columns, pixels (R4.0 parts)."""
    rows = pattern.mean(axis=1)
    cols = pattern.mean(axis=0)
    pixel = pattern - rows[:, None] - cols[None, :] + pattern.mean()
    return {
        "total": float(pattern.std()),
        "row": float(rows.std()),
        "col": float(cols.std()),
        "pixel": float(pixel.std()),
    }


def main(out: Path) -> None:
    rng = np.random.default_rng(SEED)
    dsnu = (
        rng.normal(0, DSNU_ROW_E, (ROWS, 1))
        + rng.normal(0, DSNU_COL_E, (1, COLS))
        + rng.normal(0, DSNU_PIXEL_E, (ROWS, COLS))
    )
    prnu = (
        rng.normal(0, PRNU_ROW, (ROWS, 1))
        + rng.normal(0, PRNU_COL, (1, COLS))
        + rng.normal(0, PRNU_PIXEL, (ROWS, COLS))
    )
    dark_current = np.clip(
        DARK_CURRENT_E_S * (1 + DARK_CURRENT_SPREAD * rng.standard_normal((ROWS, COLS))), 0, None
    )
    gain = K * (1 + prnu)
    top = 2**BITS - 1

    def grab(photons, t):
        # Charge in the well (photo-electrons and dark current) saturates at the full well;
        # the read noise and the fixed offset pattern are added at readout.
        e = rng.poisson(QE * photons, (ROWS, COLS)).astype(float)
        e += rng.poisson(dark_current * t)
        np.clip(e, 0, FULL_WELL_E, out=e)
        e += dsnu + rng.normal(0, READ_NOISE_E, (ROWS, COLS))
        dn = np.rint(gain * e + OFFSET_DN)
        return np.clip(dn, 0, top).astype(np.uint16)

    if out.exists():
        shutil.rmtree(out)
    (out / "images").mkdir(parents=True)
    lines = ["# EMVA 1288 dataset written by scripts/make_emva_synthetic.py (detnoise)",
             "v 4.0", f"n {BITS} {COLS} {ROWS}"]
    count = 0

    def point(header, photons, t, n):
        nonlocal count
        lines.append(header)
        for _ in range(n):
            name = f"image{count:04d}.fits.gz"
            raw = io.BytesIO()
            fits.PrimaryHDU(grab(photons, t)).writeto(raw)
            # mtime 0: the same bytes on every run.
            (out / "images" / name).write_bytes(gzip.compress(raw.getvalue(), mtime=0))
            lines.append(f"i images\\{name}")
            count += 1

    exposures_s = np.linspace(EXPOSURE_MIN_S, EXPOSURE_MAX_S, POINTS)
    photons_of = {}
    for t in exposures_s:
        ns = round(t * 1e9, 1)
        photons = PHOTON_RATE * t
        photons_of[ns] = photons
        point(f"b {ns:.1f} {photons:.3f}", photons, t, 2)
        point(f"d {ns:.1f}", 0.0, t, 2)
    # Spatial stacks at the exposure nearest 50 % of the full well.
    t50 = exposures_s[np.argmin(np.abs(QE * PHOTON_RATE * exposures_s - 0.5 * FULL_WELL_E))]
    ns50 = round(t50 * 1e9, 1)
    point(f"b {ns50:.1f} {PHOTON_RATE * t50:.3f}", PHOTON_RATE * t50, t50, SPATIAL_FRAMES)
    point(f"d {ns50:.1f}", 0.0, t50, SPATIAL_FRAMES)
    (out / "EMVA1288descriptor.txt").write_text("\n".join(lines) + "\n")

    dark_at_50 = dsnu + dark_current * t50
    truth = {
        "what": "EMVA 1288 dataset of a linear CMOS camera (scripts/make_emva_synthetic.py)",
        "seed": SEED,
        "rows": ROWS,
        "cols": COLS,
        "bits": BITS,
        "photon_transfer_points": POINTS,
        "exposure_min_s": EXPOSURE_MIN_S,
        "exposure_max_s": EXPOSURE_MAX_S,
        "photons_per_px_per_s": PHOTON_RATE,
        "spatial_frames": SPATIAL_FRAMES,
        "spatial_exposure_s": float(t50),
        "spatial_photons_per_px": float(PHOTON_RATE * t50),
        "K_dn_per_e": K,
        "K_pixel_average_dn_per_e": float(gain.mean()),
        "qe": QE,
        "read_noise_e": READ_NOISE_E,
        "offset_dn": OFFSET_DN,
        "full_well_e": FULL_WELL_E,
        "saturation_photons_per_px": FULL_WELL_E / QE,
        "saturation_exposure_s": 0.8 * EXPOSURE_MAX_S,
        "dark_current_e_per_s": DARK_CURRENT_E_S,
        "dark_current_realised_mean_e_per_s": float(dark_current.mean()),
        "dark_current_relative_spread": DARK_CURRENT_SPREAD,
        "dsnu_generating_sigma_e": {"row": DSNU_ROW_E, "col": DSNU_COL_E, "pixel": DSNU_PIXEL_E},
        "dsnu_offset_pattern_e": split(dsnu),
        "dsnu_at_spatial_exposure_e": split(dark_at_50),
        "prnu_generating_sigma_percent": {
            "row": 100 * PRNU_ROW, "col": 100 * PRNU_COL, "pixel": 100 * PRNU_PIXEL},
        "prnu_realised_percent": {k: 100 * v for k, v in split(prnu).items()},
        "notes": [
            "DN = round(K (1 + prnu) e + offset): the read noise, DSNU and dark signal in DN "
            "carry the pixel's gain too (1 % effect).",
            "The temporal dark noise in DN is sqrt((K read_noise)^2 + K^2 dark_current t + 1/12).",
            "Saturation is at the full well (9000 e-, 3700 DN), below the 12-bit ceiling; the "
            "read noise and DSNU are added after the well saturates, so the saturated pairs "
            "keep the read noise.",
        ],
    }
    (out / "truth.json").write_text(json.dumps(truth, indent=1) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "data-synthetic/emva-cmos-64x96"))
