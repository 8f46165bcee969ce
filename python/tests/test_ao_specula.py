"""`detnoise.ao.specula.DetnoiseCCD` behind SPECULA's own Shack-Hartmann: a flat wavefront
through a circular pupil (64 px, 4 m), a 4x4 SH of 8x8 px (a 32x32 px frame), many frames. The
pixel statistics are checked against the readout's: each pixel's mean is its noise-free
intensity (the CCD's ``integrated_i``), its variance photons + sigma_i^2 with a per-pixel noise
map, F^2 photons + (read noise / gain)^2 with the EMCCD register. Tolerances are Z standard
errors from the model's moments, on fixed seeds. The page docs/ao-specula.md's parameter file
and Python example run here too."""

import logging
from pathlib import Path

import numpy as np
import pytest

import detnoise
from conftest import simulator

specula = simulator("specula")
specula.init(-1, precision=0, log_level=logging.WARNING)

from specula.data_objects.intensity import Intensity  # noqa: E402
from specula.data_objects.pupilstop import Pupilstop  # noqa: E402
from specula.data_objects.simul_params import SimulParams  # noqa: E402
from specula.data_objects.source import Source  # noqa: E402
from specula.processing_objects.atmo_propagation import AtmoPropagation  # noqa: E402
from specula.processing_objects.sh import SH  # noqa: E402

from detnoise.ao.specula import DetnoiseCCD  # noqa: E402

CAMERA = Path(__file__).resolve().parent / "data" / "camera"
Z = 5.0  # tolerance in standard errors
N = 32  # frame side, px: 4 sub-apertures of 8 px
FRAMES = 1500
DT = 0.001  # s, the time step and the integration time
EM_GAIN, EM_STAGES, EM_READ_E = 300.0, 520, 50.0
NOISY_PX = [(3, 3), (12, 11), (5, 5), (24, 3), (30, 6)]  # (row, column): 2 cores, 3 dim
NOISY_SIGMA_E = 6.0


def noise_map_e():
    """A 32x32 e- rms map: ~1 e- pixels and a few at 6 e-, spot cores and wings among them."""
    rms = np.random.default_rng(3).lognormal(0.0, 0.3, (N, N))
    for p in NOISY_PX:
        rms[p] = NOISY_SIGMA_E
    return rms


def simul_params():
    return SimulParams(pixel_pupil=64, pixel_pitch=0.0625, time_step=DT, total_time=FRAMES * DT)


def wfs(params, magnitude=10.0):
    """Source, pupil, propagation and SPECULA's SH: the objects in trigger order and the pupil
    (its time stamp renewed to make the chain run every step)."""
    source = Source(polar_coordinates=[0.0, 0.0], magnitude=magnitude, wavelengthInNm=600)
    pupil = Pupilstop(params)
    prop = AtmoPropagation(params, source_dict={"src": source})
    prop.inputs["common_layer_list"].set([pupil])
    sh = SH(wavelengthInNm=600, subap_wanted_fov=4.0, sensor_pxscale=0.5,
            subap_on_diameter=4, subap_npx=8)
    sh.inputs["in_ef"].set(prop.outputs["out_src_ef"])
    return [prop, sh], pupil


def run(cameras, frames, params):
    """Every camera behind one SH for `frames` steps: {name: (frames, n, n) e-} and the
    noise-free intensity of a frame (photons; the same every step with a flat wavefront)."""
    chain, pupil = wfs(params)
    sh = chain[-1]
    for cam in cameras.values():
        cam.inputs["in_i"].set(sh.outputs["out_i"])
    objs = chain + list(cameras.values())
    for obj in objs:
        obj.setup()
    out = {name: np.empty((frames, N, N)) for name in cameras}
    step = objs[0].seconds_to_t(DT)
    for k in range(frames):
        pupil.generation_time = k * step
        for obj in objs:
            if obj.check_ready(k * step):
                obj.trigger()
                obj.post_trigger()
        for name, cam in cameras.items():
            out[name][k] = cam.outputs["out_pixels"].pixels
    expected = np.array(next(iter(cameras.values())).outputs["integrated_i"].i, dtype=float)
    return out, expected


@pytest.fixture(scope="module")
def frames():
    params = simul_params()
    common = dict(simul_params=params, size=[N, N], dt=DT, bandw=300)
    cameras = {
        "map": DetnoiseCCD(readout="scmos-map", readout_params={"map_e": noise_map_e()},
                           seed=11, **common),
        "map_same_seed": DetnoiseCCD(readout="scmos-map",
                                     readout_params={"map_e": noise_map_e()}, seed=11, **common),
        "map_other_seed": DetnoiseCCD(readout="scmos-map",
                                      readout_params={"map_e": noise_map_e()}, seed=12, **common),
        "emccd": DetnoiseCCD(readout="emccd-stochastic", seed=5, readout_params={
            "em_gain": EM_GAIN, "stages": EM_STAGES, "emccd_read_noise_e": EM_READ_E}, **common),
    }
    return run(cameras, FRAMES, params)


def moments(x, var_model, kappa4_model):
    """Per-pixel mean and variance over the frames (axis 0), and their standard errors under
    the model (variance, fourth cumulant): the sample's own fourth moment underestimates them
    in dim EMCCD pixels, where a few frames hold all the signal."""
    n = x.shape[0]
    mean_se = np.sqrt(var_model / n)
    var_se = np.sqrt((kappa4_model + 2.0 * var_model**2) / n)
    return x.mean(axis=0), x.var(axis=0, ddof=1), mean_se, var_se


def test_the_sh_spots_span_dark_and_bright_pixels(frames):
    _, photons = frames
    assert photons.shape == (N, N)
    assert photons.max() > 200 and np.median(photons) < 5  # cores and wings
    assert min(photons[p] for p in NOISY_PX) < 5 < max(photons[p] for p in NOISY_PX)


def test_pixels_have_the_noise_maps_per_pixel_statistics(frames):
    out, photons = frames
    sigma_e = noise_map_e()
    expected = photons + sigma_e**2
    # Poisson's cumulants are all its mean; a Gaussian adds none beyond the second.
    mean, var, mean_se, var_se = moments(out["map"], expected, photons)
    assert np.all(np.abs(mean - photons) < Z * mean_se)
    assert np.all(np.abs(var - expected) < Z * var_se)
    # Pooled over the frame: the variance over its expectation is 1 to a fraction of a percent.
    ratio_se = np.sqrt(((var_se / expected) ** 2).sum()) / expected.size
    assert abs((var / expected).mean() - 1.0) < Z * ratio_se
    # The noisy pixels are the map's, not the median's: SPECULA's scalar readout_level fails
    # where the read noise dominates.
    scalar = photons + np.median(sigma_e) ** 2
    dim = [p for p in NOISY_PX if photons[p] < NOISY_SIGMA_E**2]
    assert len(dim) >= 3
    for p in dim:
        assert var[p] - scalar[p] > 10 * var_se[p], p


def test_emccd_pixels_have_the_registers_excess_noise(frames):
    out, photons = frames
    g, s = EM_GAIN, EM_STAGES
    f2 = 2.0 * (g - 1.0) * g ** (-(s + 1.0) / s) + 1.0 / g  # excess noise factor^2 of the register
    read_var = (EM_READ_E / g) ** 2
    expected = f2 * photons + read_var
    # Compound Poisson of ~exponential single-electron outputs: fourth cumulant 24 photons.
    mean, var, mean_se, var_se = moments(out["emccd"], expected, 24.0 * photons)
    assert np.all(np.abs(mean - photons) < Z * mean_se)
    assert np.all(np.abs(var - expected) < Z * var_se)
    bright = photons > 50
    assert bright.sum() >= 10
    f2_hat = (var[bright] - read_var).sum() / photons[bright].sum()
    f2_se = np.sqrt((var_se[bright] ** 2).sum()) / photons[bright].sum()
    assert abs(f2_hat - f2) < Z * f2_se
    assert abs(f2_hat - 2.0) < 0.05 and f2_se < 0.02  # ~2, far from the Poisson 1


def test_the_same_seed_reads_the_same_frames(frames):
    out, _ = frames
    np.testing.assert_array_equal(out["map"], out["map_same_seed"])
    assert not np.array_equal(out["map"][0], out["map_other_seed"][0])


def test_without_photon_noise_a_noiseless_camera_reads_the_rounded_intensity():
    params = simul_params()
    cam = DetnoiseCCD(params, size=[N, N], dt=DT, bandw=300, readout="scmos-constant:0",
                      photon_noise=False, background_level=2.5)
    out, photons = run({"cam": cam}, 3, params)
    np.testing.assert_array_equal(out["cam"], np.broadcast_to(np.rint(photons + 2.5), (3, N, N)))


def test_a_camera_folder_reads_at_the_ccds_integration_time():
    # The 4x4 px camera of test_camera.py, with 2 e-/s of dark current: integrating 2 s, each
    # frame is a read of the camera at exposure_s = 2 s.
    params = SimulParams(pixel_pupil=8, pixel_pitch=0.5, time_step=2.0)
    cam = DetnoiseCCD(params, size=[4, 4], dt=2.0, bandw=1.0, readout="camera",
                      readout_params={"camera": CAMERA}, seed=9)
    light = Intensity(4, 4)
    light.i[:] = 30.0
    cam.inputs["in_i"].set(light)
    cam.setup()
    step = cam.seconds_to_t(2.0)
    same = detnoise.Readout("camera", camera=CAMERA, exposure_s=2.0, seed=9)
    other = detnoise.Readout("camera", camera=CAMERA, exposure_s=1.0, seed=9)
    for k in range(3):
        light.generation_time = k * step
        assert cam.check_ready(k * step)
        cam.trigger()
        cam.post_trigger()
        pixels = np.array(cam.outputs["out_pixels"].pixels)
        np.testing.assert_array_equal(pixels, same.read(np.full((4, 4), 60.0)))
        assert not np.array_equal(pixels, other.read(np.full((4, 4), 60.0)))


def test_bad_input_is_refused_clearly():
    params = simul_params()
    common = dict(simul_params=params, dt=DT, bandw=300)
    bigger = np.ones((N + 8, N + 8))
    with pytest.raises(ValueError, match="square"):
        DetnoiseCCD(size=[N, N // 2], readout="scmos-constant:1", **common)
    with pytest.raises(ValueError, match="multiple of binning"):
        DetnoiseCCD(size=[N, N], binning=3, readout="scmos-constant:1", **common)
    with pytest.raises(ValueError, match="larger than the 32x32 px frame.*crop"):
        DetnoiseCCD(size=[N, N], readout="scmos-map", readout_params={"map_e": bigger}, **common)
    with pytest.raises(ValueError, match="cannot read the 32x32 px frame.*smaller"):
        DetnoiseCCD(size=[N, N], readout="scmos-map",
                    readout_params={"map_e": np.ones((16, 16))}, **common)
    with pytest.raises(ValueError, match="larger than"):  # a built Readout is probed the same
        DetnoiseCCD(size=[N, N], readout=detnoise.Readout("scmos-map", map_e=bigger), **common)
    with pytest.raises(ValueError, match="readout 'no-such-model'"):
        DetnoiseCCD(size=[N, N], readout="no-such-model", **common)
    with pytest.raises(ValueError, match="give its parameters and seed to Readout"):
        DetnoiseCCD(size=[N, N], readout=detnoise.Readout("scmos-constant:1"), seed=3, **common)
    with pytest.raises(ValueError, match="background_level"):
        DetnoiseCCD(size=[N, N], readout="scmos-constant:1", background_level=-1.0, **common)
    cam = DetnoiseCCD(size=[16, 16], readout="scmos-constant:1", **common)
    cam.inputs["in_i"].set(Intensity(N, N))
    with pytest.raises(ValueError, match="in_i is 32x32 px but size is 16x16"):
        cam.setup()


DOC = Path(__file__).resolve().parents[2] / "docs" / "ao-specula.md"

# The SH chain the page's parameter-file fragment (its `main` and `detector`) goes into.
CHAIN_YML = """
main:
  class: 'SimulParams'
  root_dir: './calib'
  pixel_pupil: 128
  pixel_pitch: 0.0625
  total_time: 0.003
  time_step: 0.001
source:
  class: 'Source'
  polar_coordinates: [0.0, 0.0]
  magnitude: 12
  wavelengthInNm: 600
pupilstop:
  class: 'Pupilstop'
  simul_params_ref: 'main'
prop:
  class: 'AtmoPropagation'
  simul_params_ref: 'main'
  source_dict_ref: ['source']
  inputs:
    common_layer_list: ['pupilstop']
  outputs: ['out_source_ef']
sh:
  class: 'SH'
  subap_wanted_fov: 4.0
  sensor_pxscale: 0.5
  subap_npx: 8
  subap_on_diameter: 8
  wavelengthInNm: 600
  inputs:
    in_ef: 'prop.out_source_ef'
  outputs: ['out_i']
"""


def doc_block(info):
    """The one fenced block of docs/ao-specula.md with this info string."""
    parts = DOC.read_text(encoding="utf-8").split(f"```{info}\n")
    assert len(parts) == 2, f"docs/ao-specula.md: expected one {info} block"
    return parts[1].split("```", 1)[0]


@pytest.fixture
def in_scratch(tmp_path, monkeypatch):
    """A scratch directory as the working directory, the bundled data linked in, the page's
    map written where its `detnoise darks` command writes it."""
    from astropy.io import fits

    root = Path(__file__).resolve().parents[2]
    (tmp_path / "data-synthetic").symlink_to(root / "data-synthetic")
    monkeypatch.chdir(tmp_path)
    rms_e = detnoise.dark_maps("data-synthetic/scmos-darks-64x64.fits", gain_e_per_adu=0.25).rms_e
    (tmp_path / "darks-out").mkdir()
    fits.writeto("darks-out/rms_e.fits", rms_e)
    return tmp_path


def page_simulation(**detector_extra):
    """The chain with the page's `main` and `detector` sections, as a parameter file."""
    import yaml

    params = yaml.safe_load(CHAIN_YML)
    page = yaml.safe_load(doc_block("yaml"))
    params["main"].update(page["main"])
    params["detector"] = {**page["detector"], **detector_extra}
    Path("params.yml").write_text(yaml.safe_dump(params))
    return "params.yml"


def test_the_pages_parameter_file_swaps_it_for_specula_ccd(in_scratch):
    from specula.simul import Simul

    sim = Simul(page_simulation(), log_level="warning")
    sim.run()
    cam = sim.objs["detector"]
    assert type(cam) is DetnoiseCCD
    # The static chain triggers the camera once: frame 0 of a camera of the page's seed, 1.
    assert cam.readout.frame == 1
    photons = 0.8 * np.array(cam.outputs["integrated_i"].i, dtype=float)
    expected = detnoise.Readout("scmos-map", map_e="darks-out/rms_e.fits", seed=1).read(photons)
    np.testing.assert_array_equal(cam.outputs["out_pixels"].pixels, expected)


def test_a_parameter_file_keeping_speculas_noise_options_is_refused(in_scratch):
    from specula.simul import Simul

    sim = Simul(page_simulation(readout_level=1.0), log_level="warning")
    with pytest.raises(ValueError, match="readout_level is not expected by class DetnoiseCCD"):
        sim.run()


def test_the_pages_python_example_runs(in_scratch, capsys):
    exec(compile(doc_block("python"), str(DOC), "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.startswith("(100, 64, 64) ")
