"""`Readout.from_camera`: a camera model folder (tests/data/camera, written by detnoise's
`CameraModel::write`) read at an operating point. The camera: 4x4 px, read noise 1.5 e-, dark
current 2 e-/s, CIC 0.1 e- per frame, frame-common noise 0.5 e-, 0.5 e- per adu, no register, no
temperature law, no campaign recorded."""

from pathlib import Path

import numpy as np
import pytest

import detnoise

CAMERA = Path(__file__).resolve().parent / "data" / "camera"
Z = 5.0  # tolerance in standard errors


def test_dark_pixels_have_the_operating_points_moments():
    t = 2.0
    dark = 2.0 * t + 0.1  # e- per frame, taken off as a master dark would
    # Read and frame-common noise, and the rounding to whole adu (0.5 e- steps), e-^2.
    gauss = 1.5**2 + 0.5**2 + 0.5**2 / 12
    r = detnoise.Readout.from_camera(CAMERA, exposure_s=t, seed=4)
    out = r.read(np.zeros((50_000, 4, 4)))
    x = out[:, 1, 2]  # one pixel over independent sub-aperture reads
    var = dark + gauss
    # Poisson(dark) + N(0, gauss): central 4th moment dark (1 + 3 dark) + 6 dark gauss + 3 gauss^2.
    mu4 = dark * (1 + 3 * dark) + 6 * dark * gauss + 3 * gauss**2
    n = x.size
    assert abs(x.mean()) < Z * np.sqrt(var / n)
    assert abs(x.var(ddof=1) - var) < Z * np.sqrt((mu4 - var**2) / n)
    # The frame term is shared by the pixels of a read: their covariance is 0.5^2.
    cov = np.cov(out[:, 0, 0], out[:, 3, 3])[0, 1]
    assert abs(cov - 0.25) < Z * np.sqrt((var * var + 0.25**2) / n)


def test_operating_points_the_camera_cannot_run_at_are_refused():
    with pytest.raises(ValueError, match="no EM register"):
        detnoise.Readout.from_camera(CAMERA, exposure_s=1.0, em_gain=100.0)
    with pytest.raises(ValueError, match="temperature law"):
        detnoise.Readout.from_camera(CAMERA, exposure_s=1.0, temperature_c=0.0)
    with pytest.raises(ValueError, match="exposure_s"):
        detnoise.Readout.from_camera(CAMERA, exposure_s=0.0)
    # Without an exposure the campaign's shortest dark exposure is taken: this folder has none.
    with pytest.raises(ValueError, match="records no campaign"):
        detnoise.Readout.from_camera(CAMERA)


def test_the_camera_without_a_register_is_an_scmos():
    assert detnoise.Readout.from_camera(CAMERA, exposure_s=1.0).sensor == "scmos"
