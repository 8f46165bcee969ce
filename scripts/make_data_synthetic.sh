#!/bin/sh
# Regenerate data-synthetic/ (small committed stacks with known truth) from a built detnoise.
# Usage (repository root): cargo build --release && sh scripts/make_data_synthetic.sh [path/to/detnoise]
# (--force: the stacks and truth files already exist and are replaced.)
set -eu
DN=${1:-target/release/detnoise}
OUT=data-synthetic
mkdir -p "$OUT"

# sCMOS darks, 64x64 pixels, 100 frames, read noise from the paper's pdf, 0.25 e/adu:
# the same data in FITS, TIFF and EXR.
for fmt in fits tiff exr; do
  ext=$fmt; [ "$fmt" = tiff ] && ext=tif
  "$DN" synth --force --detector scmos --shape 64x64 --frames 100 --format "$fmt" --seed 2015 --out "$OUT/scmos-darks-64x64.$ext"
done

# sCMOS flats of the same camera (same seed = same pixels) at four light levels (e-/pixel/frame).
for light in 100 400 1600 6400; do
  "$DN" synth --force --detector scmos --shape 64x64 --frames 50 --format fits --seed 2015 --light-e "$light" \
    --out "$OUT/scmos-flat-64x64-${light}e.fits"
done

# EMCCD: darks (CIC only) and low light (0.2 e-/pixel/frame), EM gain 300, 50 e- read noise,
# 10 e/adu, non-square 32x48.
"$DN" synth --force --detector emccd --shape 32x48 --frames 200 --format fits --seed 2015 --out "$OUT/emccd-darks-32x48.fits"
"$DN" synth --force --detector emccd --shape 32x48 --frames 200 --format fits --seed 2015 --light-e 0.2 --out "$OUT/emccd-lowlight-32x48.fits"

# sCMOS darks of the same camera (same seed = same pixels) with non-Gaussian noise: 3 % RTS
# pixels (two levels 8 e- apart +- 25 %, dwell 12 and 6 frames), row noise 0.5 e-, column
# noise 0.3 e-, 0.2 % hot pixels (50 e- a frame); 200 frames. The RTS truth goes to
# scmos-rts-64x64.truth-rts.csv (the columns of `darks`' rts.csv).
"$DN" synth --force --detector scmos --shape 64x64 --frames 200 --format fits --seed 2015 \
  --rts-fraction 0.03 --rts-steps-e 8 --rts-dwell-frames 12,6 --row-noise-e 0.5 --column-noise-e 0.3 \
  --hot-fraction 0.002 --hot-dark-e 50 --out "$OUT/scmos-rts-64x64.fits"
