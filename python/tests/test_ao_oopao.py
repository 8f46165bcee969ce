"""The measured camera as the detector of OOPAO's own Shack-Hartmann (`detnoise.ao.oopao`): the
pixel statistics of many frames of a flat wavefront against the readout's, with tolerances
from standard errors on fixed seeds, and against OOPAO's own Detector where they differ.

OOPAO is imported once per session (numba: the first import in a fresh environment compiles
for a minute; cached afterwards, ~1.5 s)."""

import contextlib
import io

import numpy as np
import pytest

import detnoise
from conftest import simulator

N_SUB, N_PX = 8, 6  # 8 x 8 sub-apertures of 6 x 6 px: a 48 x 48 px frame
MAGNITUDE = 10.0  # I band, 8 m, 1 ms: ~690 photons per sub-aperture
FRAMES = 2000


def quiet(call, *args, **kwargs):
    """OOPAO prints its objects' tables as it builds them."""
    with contextlib.redirect_stdout(io.StringIO()):
        return call(*args, **kwargs)


@pytest.fixture(scope="module")
def oopao():
    simulator("OOPAO")
    from detnoise.ao import oopao as adapter

    return adapter


@pytest.fixture()
def wfs(oopao):
    """A fresh 8 m telescope, I-band source and 8 x 8 Shack-Hartmann with OOPAO's own camera
    (its reference slopes taken noise-free at construction)."""
    from OOPAO.ShackHartmann import ShackHartmann
    from OOPAO.Source import Source
    from OOPAO.Telescope import Telescope

    tel = quiet(Telescope, resolution=N_SUB * N_PX, diameter=8.0, samplingTime=1e-3)
    src = quiet(Source, "I", magnitude=MAGNITUDE)
    quiet(lambda: src * tel)
    sensor = quiet(ShackHartmann, nSubap=N_SUB, telescope=tel, lightRatio=0.5)
    sensor.test_src, sensor.test_tel = src, tel
    return sensor


def frames_of(wfs, n=FRAMES):
    """n frames of the flat wavefront through wfs.cam, (n, 48, 48)."""
    src, tel = wfs.test_src, wfs.test_tel
    out = np.empty((n,) + wfs.raw_data.shape)
    with contextlib.redirect_stdout(io.StringIO()):
        for i in range(n):
            src**tel * wfs
            out[i] = wfs.cam.frame
    return out


def photons(wfs):
    """The noise-free frame of the flat wavefront: OOPAO's photons per pixel (QE 1)."""
    src, tel = wfs.test_src, wfs.test_tel
    with contextlib.redirect_stdout(io.StringIO()):
        src**tel * wfs
    return np.asarray(wfs.cam.perfect_frame, dtype=float)


def variance_and_se(frames):
    """Per-pixel sample variance and its standard error, sqrt((m4 - var^2) / n), from the
    sample's own fourth moment (the EMCCD's output is far from Gaussian)."""
    n = frames.shape[0]
    d = frames - frames.mean(axis=0)
    var = (d**2).sum(axis=0) / (n - 1)
    m4 = (d**4).mean(axis=0)
    return var, np.sqrt(np.maximum(m4 - var**2, 0.0) / n)


def noisy_map():
    """1 e- everywhere but a few noisy pixels (8 to 25 e-) in the lit and the dark parts."""
    m = np.ones((N_SUB * N_PX, N_SUB * N_PX))
    for (r, c), s in zip([(20, 20), (21, 26), (27, 21), (2, 2), (45, 3)], [8.0, 12.0, 25.0, 10.0, 15.0]):
        m[r, c] = s
    return m


def test_map_camera_mean_and_variance_are_the_readouts(oopao, wfs):
    mu = photons(wfs)  # photons; QE 1
    sigma = noisy_map()
    cam = oopao.attach(wfs, oopao.DetnoiseDetector.from_map(sigma, seed=11))
    f = frames_of(wfs)
    var_model = mu + sigma**2

    # mean: OOPAO's noise-free frame, every pixel within 5 SE, the chi2 of all within 5 sigma
    z = (f.mean(axis=0) - mu) / np.sqrt(var_model / len(f))
    assert np.abs(z).max() < 5.0
    assert abs((z**2).sum() - z.size) < 5.0 * np.sqrt(2.0 * z.size)

    # variance: photons + sigma_i^2 per pixel
    var, se = variance_and_se(f)
    zv = (var - var_model) / se
    assert np.abs(zv).max() < 5.0
    noisy = sigma > 1.0
    assert np.abs(zv[noisy]).max() < 4.0
    # OOPAO's own scalar read noise (its median, 1 e-, rounded to whole electrons) misses the
    # noisy pixels by many standard errors (9.5 to 32 at seed 11)
    z_scalar = (var - (mu + 1.0))[noisy] / se[noisy]
    assert z_scalar.min() > 8.0
    assert cam.detnoise_readout.frame == FRAMES  # one read per frame; the shape probe reads none
