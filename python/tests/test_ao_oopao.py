"""The measured camera as the detector of OOPAO's own Shack-Hartmann (`detnoise.ao.oopao`): the
pixel statistics of many frames of a flat wavefront against the readout's, with tolerances
from standard errors on fixed seeds, and against OOPAO's own Detector where they differ.

OOPAO is imported once per session, ~1.5 s of CPU: the modules used here do not import its numba
code (calibration/ao_cockpit_psim.py), even with an empty numba cache. The file takes ~9 s of
CPU."""

import contextlib
import copy
import io
from pathlib import Path

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


def variance_z(frames, photo_e, read_var):
    """Per-pixel sample variance, and its z against Poisson(photo_e) + Gaussian(read_var):
    the SE from the model's fourth cumulant, sqrt((photo_e + 2 var^2) / (n - 1))."""
    n = frames.shape[0]
    var = frames.var(axis=0, ddof=1)
    model = photo_e + read_var
    return var, (var - model) / np.sqrt((photo_e + 2.0 * model**2) / (n - 1))


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
    noisy = {(20, 20): 8.0, (21, 26): 12.0, (27, 21): 25.0, (2, 2): 10.0, (45, 3): 15.0}
    for pixel, sigma_e in noisy.items():
        m[pixel] = sigma_e
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
    var, zv = variance_z(f, mu, sigma**2)
    assert np.abs(zv).max() < 5.0
    noisy = sigma > 1.0
    assert np.abs(zv[noisy]).max() < 4.0
    # OOPAO's own scalar read noise (its median, 1 e-, rounded to whole electrons) misses the
    # noisy pixels by many standard errors (13 to 7300 at seed 11)
    _, z_scalar = variance_z(f[:, noisy], mu[noisy], 1.0)
    assert z_scalar.min() > 10.0
    assert cam.detnoise_readout.frame == FRAMES  # one read per frame; the shape probe reads none


def excess_factor(gain, stages):
    """F^2 of a multiplication register of `stages` stages of mean gain `gain`: a branching
    process of Bernoulli(p) stages, 1 + (1 - p)(g - 1) / ((1 + p) g), p = g^(1/stages) - 1."""
    p = gain ** (1.0 / stages) - 1.0
    return 1.0 + (1.0 - p) * (gain - 1.0) / ((1.0 + p) * gain)


def variance_ratio(frames, mu, floor):
    """sum(var - floor) / sum(mu) over the pixels of mu > 20 photons, and its SE."""
    bright = mu > 20.0
    var, se = variance_and_se(frames)
    total = mu[bright].sum()
    return (var[bright] - floor).sum() / total, np.sqrt((se[bright] ** 2).sum()) / total


def test_emccd_has_the_registers_excess_noise_oopaos_has_not(oopao, wfs):
    from OOPAO.Detector import Detector

    gain, read_e = 300.0, 3.0
    floor = (read_e / gain) ** 2
    mu = photons(wfs)
    readout = detnoise.Readout("emccd-stochastic", em_gain=gain, emccd_read_noise_e=read_e, seed=5)
    oopao.attach(wfs, oopao.DetnoiseDetector(readout))
    f = frames_of(wfs, 1000)
    z = (f.mean(axis=0) - mu) / np.sqrt(2.0 * mu / len(f) + 1e-12)
    assert np.abs(z[mu > 1.0]).max() < 5.0
    ratio, se = variance_ratio(f, mu, floor)
    f2 = excess_factor(gain, 520)  # 1.975 at 300 with the default 520 stages
    assert abs(ratio - f2) < 5.0 * se, (ratio, se, f2)
    # the register's output is continuous: about a tenth of the values lie within 0.05 e- of
    # a whole number of input electrons
    frac = lambda x: np.mean(np.abs(x - np.rint(x)) < 0.05)  # noqa: E731
    bright = mu > 20.0
    assert frac(f[:, bright]) < 0.2

    # OOPAO's own EMCCD at the same gain and read noise (frames divided by the gain, as ours)
    np.random.seed(6)  # its EM step draws from numpy's global generator
    cam = quiet(Detector, sensor="EMCCD", gain=int(gain), readoutNoise=read_e, photonNoise=False)
    cam.random_state_readout_noise = np.random.RandomState(7)
    cam.random_state_photon_noise = np.random.RandomState(8)
    wfs.cam = cam
    own = frames_of(wfs, 600) / gain
    own_ratio, own_se = variance_ratio(own, mu, floor)
    # its EM step alone is Poisson: 1 x photons, no excess noise
    assert abs(own_ratio - 1.0) < 5.0 * own_se
    assert own_ratio < ratio - 20.0 * np.hypot(se, own_se)
    # with its photon noise on, the EM step's second Poisson draw doubles the variance, but
    # every value is a whole number of input electrons: photon counting without error
    cam.photonNoise = True
    own = frames_of(wfs, 600) / gain
    own_ratio, own_se = variance_ratio(own, mu, floor)
    assert abs(own_ratio - 2.0) < 5.0 * own_se
    assert frac(own[:, bright]) > 0.99


def test_noise_free_reference_slopes_through_the_camera(oopao, wfs):
    reference = np.array(wfs.sh_data["src_0"].reference_signal_2D, copy=True)
    units = wfs.slopes_units
    cam = oopao.attach(wfs, oopao.DetnoiseDetector.from_map(noisy_map(), seed=1, QE=0.7))
    frames_of(wfs, 3)
    quiet(wfs.initialize_wfs)  # OOPAO switches the camera's noise off, then back on
    np.testing.assert_allclose(wfs.sh_data["src_0"].reference_signal_2D, reference, atol=1e-12)
    np.testing.assert_allclose(wfs.slopes_units, units, rtol=1e-12)
    assert cam.photonNoise and cam.readoutNoise
    assert cam.detnoise_readout.frame == 3  # the noise-free frames drew nothing
    f = frames_of(wfs, 2)
    assert not np.array_equal(f[0], f[1])
    # both switches off for a block (OOPAO's InteractionMatrix does not switch them off itself):
    # the expected photo-electrons
    with cam.noise_free():
        f = frames_of(wfs, 2)
    np.testing.assert_array_equal(f[0], f[1])
    np.testing.assert_allclose(f[0], 0.7 * cam.perfect_frame, rtol=1e-12, atol=1e-12)
    assert cam.photonNoise and cam.readoutNoise
    assert cam.detnoise_readout.frame == 5


def test_reference_slopes_with_the_cameras_noise(oopao, wfs):
    oopao.attach(wfs, oopao.DetnoiseDetector.from_map(noisy_map(), seed=2))
    noise_free = np.array(wfs.sh_data["src_0"].reference_signal_2D, copy=True)
    reference = quiet(oopao.reference_slopes, wfs, 400)
    assert wfs.sh_data["src_0"].reference_signal_2D is reference
    assert not np.allclose(reference, noise_free)
    # the slopes of new frames of the same wavefront are zero on average about it
    src, tel = wfs.test_src, wfs.test_tel
    slopes = []
    with contextlib.redirect_stdout(io.StringIO()):
        for _ in range(400):
            src**tel * wfs
            slopes.append(wfs.signal.copy())
    slopes = np.array(slopes)
    z = slopes.mean(axis=0) / (slopes.std(axis=0, ddof=1) * np.sqrt(2.0 / len(slopes)))
    assert np.abs(z).max() < 5.0
    with pytest.raises(ValueError, match="frames"):
        oopao.reference_slopes(wfs, 0)


def test_photon_noise_alone_and_read_noise_alone(oopao, wfs):
    mu = photons(wfs)
    sigma = noisy_map()
    cam = oopao.attach(wfs, oopao.DetnoiseDetector.from_map(sigma, seed=3, readoutNoise=False))
    f = frames_of(wfs, 600)
    lit = mu > 1.0
    _, z = variance_z(f[:, lit], mu[lit], 0.0)
    assert np.abs(z).max() < 5.0
    assert np.all(f == np.rint(f))  # Poisson counts
    cam.photonNoise, cam.readoutNoise = False, True
    f = frames_of(wfs, 600)
    _, z = variance_z(f, 0.0, sigma**2)
    assert np.abs(z).max() < 5.0
    z = (f.mean(axis=0) - np.rint(mu)) / (sigma / np.sqrt(len(f)))
    assert np.abs(z).max() < 5.0


def test_same_seed_same_frames(oopao, wfs):
    oopao.attach(wfs, oopao.DetnoiseDetector.from_map(noisy_map(), seed=9))
    a = frames_of(wfs, 5)
    oopao.attach(wfs, oopao.DetnoiseDetector.from_map(noisy_map(), seed=9))
    np.testing.assert_array_equal(frames_of(wfs, 5), a)
    wfs.cam.detnoise_readout.frame = 2  # rewind: frame 2 again
    np.testing.assert_array_equal(frames_of(wfs, 1)[0], a[2])
    oopao.attach(wfs, oopao.DetnoiseDetector.from_map(noisy_map(), seed=10))
    assert not np.array_equal(frames_of(wfs, 1)[0], a[0])
    # a deep copy (OOPAO copies its objects) shares the readout: the frames continue
    twin = copy.deepcopy(wfs.cam)
    assert twin.detnoise_readout is wfs.cam.detnoise_readout and twin.frame is not wfs.cam.frame
    quiet(twin.integrate, wfs.cam.perfect_frame)
    assert wfs.cam.detnoise_readout.frame == 2


# OOPAO centroids the empty frame of the first loop step of a longer exposure (as with its own
# Detector, which starts from a zero frame too)
@pytest.mark.filterwarnings("ignore:invalid value encountered in divide:RuntimeWarning")
def test_exposure_of_several_loop_steps_and_qe(oopao, wfs):
    mu = photons(wfs)
    sigma = noisy_map()
    camera = oopao.DetnoiseDetector.from_map(sigma, seed=4, QE=0.8, integrationTime=2e-3)
    cam = oopao.attach(wfs, camera)
    f = frames_of(wfs, 1200)[1::2]  # a new frame every second loop step
    assert cam.detnoise_readout.frame == 600
    expected = 2.0 * 0.8 * mu
    z = (f.mean(axis=0) - expected) / np.sqrt((expected + sigma**2) / len(f))
    assert np.abs(z).max() < 5.0
    _, z = variance_z(f, expected, sigma**2)
    assert np.abs(z).max() < 5.0


def test_binning_sums_before_the_read(oopao):
    kw = dict(binning=2, photonNoise=False, readoutNoise=False)
    cam = quiet(oopao.DetnoiseDetector.from_map, np.ones((4, 4)), **kw)
    cam.integrate(np.arange(64.0).reshape(8, 8))
    np.testing.assert_array_equal(cam.frame, np.arange(64.0).reshape(4, 2, 4, 2).sum(axis=(1, 3)))
    with pytest.raises(ValueError, match="map is 4x4 px, the detector's 8x8"):
        quiet(oopao.DetnoiseDetector.from_map, np.ones((4, 4))).integrate(np.zeros((8, 8)))


def test_a_camera_model_folder(oopao, data):
    """The bundled 4x4 px camera model (1.5 e- read noise, 2 e-/s dark current, 0.1 e- CIC,
    0.5 e- frame-common noise, 0.5 e- per adu) on a 2 x 2 Shack-Hartmann of 2 x 2 px."""
    from OOPAO.ShackHartmann import ShackHartmann
    from OOPAO.Source import Source
    from OOPAO.Telescope import Telescope

    camera = Path(__file__).resolve().parent / "data" / "camera"
    tel = quiet(Telescope, resolution=4, diameter=2.0, samplingTime=1e-3)
    src = quiet(Source, "I", magnitude=10.0)
    quiet(lambda: src * tel)
    sensor = quiet(ShackHartmann, nSubap=2, telescope=tel, lightRatio=0.5)
    sensor.test_src, sensor.test_tel = src, tel
    mu = photons(sensor)
    oopao.attach(sensor, quiet(oopao.DetnoiseDetector.from_camera, camera, exposure_s=1e-3, seed=3))
    f = frames_of(sensor)
    # dark (2 e-/s x 1 ms + CIC) drawn and its mean taken off; read, frame and adu steps Gaussian
    dark, gauss = 2e-3 + 0.1, 1.5**2 + 0.5**2 + 0.5**2 / 12
    z = (f.mean(axis=0) - mu) / np.sqrt((mu + dark + gauss) / len(f))
    assert np.abs(z).max() < 5.0
    _, z = variance_z(f, mu + dark, gauss)
    assert np.abs(z).max() < 5.0


def test_bad_input_is_refused(oopao, wfs):
    from OOPAO.tools.tools import OopaoError

    Detnoise = oopao.DetnoiseDetector
    with pytest.raises(ValueError, match="map is 40x40 px, the detector's 48x48 px frame"):
        oopao.attach(wfs, quiet(Detnoise.from_map, np.ones((40, 40))))
    with pytest.raises(ValueError, match="map is 64x64 px"):
        oopao.attach(wfs, quiet(Detnoise.from_map, np.ones((64, 64))))
    # a fixed window of a larger map is the frame's
    oopao.attach(wfs, quiet(Detnoise.from_map, np.ones((64, 64)), window=(8, 16, 48)))
    with pytest.raises(ValueError, match="not inside"):
        quiet(Detnoise.from_map, np.ones((64, 64)), window=(20, 0, 48))
    with pytest.raises(ValueError, match="square"):
        quiet(Detnoise.from_map, np.ones((48, 40)))
    with pytest.raises(ValueError, match="2-D"):
        quiet(Detnoise.from_map, np.ones(48))
    camera = Path(__file__).resolve().parent / "data" / "camera"
    with pytest.raises(ValueError, match="map is 4x4 px, the detector's 48x48"):
        oopao.attach(wfs, quiet(Detnoise.from_camera, camera, exposure_s=1e-3))
    with pytest.raises(ValueError, match="map is 48x48 px, the detector's 40x40"):
        quiet(Detnoise.from_map, np.ones((48, 48)), nRes=40)
    # a readout without a map the adapter knows: the readout's own refusal, named
    small = detnoise.Readout("scmos-map", map_e=np.ones((16, 16)))
    with pytest.raises(ValueError, match="cannot read the detector's 48x48 px frame"):
        oopao.attach(wfs, quiet(Detnoise, small))
    with pytest.raises(ValueError, match="not square"):
        quiet(Detnoise, small).integrate(np.zeros((8, 6)))
    with pytest.raises(TypeError, match="detnoise.Readout"):
        Detnoise(1.5)
    with pytest.raises(TypeError, match="detnoise.Readout"):
        oopao.attach(wfs, 1.5)
    with pytest.raises(ValueError, match="QE"):
        Detnoise(small, QE=0.0)
    with pytest.raises(ValueError, match="binning"):
        oopao.attach(wfs, quiet(Detnoise, small, binning=2))
    with pytest.raises(OopaoError, match="readoutNoise=2.5 is a switch"):
        quiet(Detnoise, small).readoutNoise = 2.5
    with pytest.raises(OopaoError, match="photonNoise='yes' is a switch"):
        quiet(Detnoise, small, photonNoise="yes")
    cam = oopao.attach(wfs, quiet(Detnoise.from_map, np.ones((48, 48))))
    cam.darkCurrent = 5.0
    with pytest.raises(OopaoError, match="darkCurrent"):
        frames_of(wfs, 1)


def test_the_manual_pages_example_runs(oopao):
    """docs/ao-oopao.md's example, as printed."""
    page = Path(__file__).resolve().parents[2] / "docs" / "ao-oopao.md"
    text = page.read_text(encoding="utf-8")
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    namespace = {}
    quiet(exec, compile(code, str(page), "exec"), namespace)
    wfs = namespace["wfs"]
    assert isinstance(wfs.cam, oopao.DetnoiseDetector)
    assert wfs.cam.detnoise_readout.model_name == "emccd-stochastic"
    assert wfs.cam.detnoise_readout.frame == 100


def test_a_map_file_and_a_bare_readout(oopao, wfs):
    """from_map reads a FITS map (the bundled camera's 4x4 px read noise, 1.5 e-); attach wraps
    a Readout with the defaults."""
    path = Path(__file__).resolve().parent / "data" / "camera" / "read_noise_e.fits"
    cam = quiet(oopao.DetnoiseDetector.from_map, str(path), nRes=4, photonNoise=False)
    assert cam.map_shape == (4, 4)
    frames = []
    for _ in range(2000):
        cam.integrate(np.full((4, 4), 3.0))
        frames.append(cam.frame)
    _, z = variance_z(np.array(frames), 0.0, 1.5**2)
    assert np.abs(z).max() < 5.0
    cam = quiet(oopao.attach, wfs, detnoise.Readout("scmos-map", map_e=noisy_map(), seed=1))
    assert isinstance(wfs.cam, oopao.DetnoiseDetector) and cam.photonNoise and cam.readoutNoise
