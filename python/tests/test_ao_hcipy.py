"""`detnoise.ao.hcipy.DetnoiseDetector` behind HCIPy's own Shack-Hartmann: a flat wavefront on an
8 m pupil, 8 x 8 lenslets of 8 x 8 px (a 64 x 64 px frame), integrated and read many times;
each pixel's mean and variance over the frames against the readout's, on fixed seeds, with
tolerances in standard errors."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import detnoise
from conftest import simulator

ROOT = Path(__file__).resolve().parents[2]
MAP_64 = ROOT / "data-synthetic" / "scmos-darks-64x64.truth-rms_e.fits"
CAMERA_4 = Path(__file__).resolve().parent / "data" / "camera"  # 4x4 px (test_camera.py)
N_PX = 64
FRAMES = 2000
Z = 5.0  # tolerance in standard errors


@pytest.fixture(scope="module")
def hcipy():
    return simulator("hcipy")


@pytest.fixture(scope="module")
def DetnoiseDetector(hcipy):
    from detnoise.ao.hcipy import DetnoiseDetector

    return DetnoiseDetector


def shack_hartmann(hcipy, n_px=N_PX, brightest_e=300.0):
    """HCIPy's square Shack-Hartmann (8 lenslets, F/150 at 700 nm: spots of about 1.3 px)
    seeing a flat wavefront; its output wavefront on the detector plane, the brightest pixel
    receiving `brightest_e` photons per unit time."""
    diameter, sh_diameter = 8.0, 5e-3
    pupil = hcipy.make_pupil_grid(n_px, diameter)
    aperture = hcipy.evaluate_supersampled(hcipy.make_circular_aperture(diameter), pupil, 4)
    magnifier = hcipy.Magnifier(sh_diameter / diameter)
    optics = hcipy.SquareShackHartmannWavefrontSensorOptics(
        pupil.scaled(sh_diameter / diameter), 150, 8, sh_diameter
    )
    wf = optics(magnifier(hcipy.Wavefront(aperture, 700e-9)))
    wf.total_power *= brightest_e / wf.power.max()
    return wf


def expose(hcipy, detector, wf, frames):
    """`frames` frames of `detector`, each integrated in two parts (dt 0.25 with weight 2, dt
    0.5): 1 unit of time in all; and the expected photo-electrons per pixel from HCIPy's own
    NoiselessDetector integrated the same way."""
    def one(det):
        det.integrate(wf, 0.25, weight=2)
        det.integrate(wf, 0.5)
        return det.read_out()

    expected_e = np.asarray(one(hcipy.NoiselessDetector(detector.detector_grid)))
    out = [one(detector) for _ in range(frames)]
    assert out[0].grid is detector.detector_grid
    return np.asarray(out), expected_e


def var_fit(x, y, se):
    """Weighted least squares y = a x + b: (a, SE a, b, SE b)."""
    w = 1.0 / se**2
    design = np.stack([x, np.ones_like(x)], axis=1)
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    a, b = cov @ (design.T @ (w * y))
    return a, np.sqrt(cov[0, 0]), b, np.sqrt(cov[1, 1])


def chi2_within(z, what):
    """The sum of z^2 over pixels is chi-square with one degree per pixel: within Z of its SD."""
    chi2, dof = float(np.sum(z**2)), z.size
    assert abs(chi2 - dof) < Z * np.sqrt(2 * dof), f"{what}: chi2 {chi2:.0f} for {dof} pixels"
    return chi2


def test_scmos_map_pixels_have_their_own_read_noise_behind_hcipys_shack_hartmann(
    hcipy, DetnoiseDetector
):
    # 1.5 e- everywhere but 24 pixels at 6 e-, a few of them under the spots.
    sigma_e = np.full((N_PX, N_PX), 1.5)
    noisy = np.random.default_rng(7).choice(N_PX * N_PX, 20, replace=False)
    sigma_e.flat[noisy] = 6.0
    sigma_e[[27, 27, 36, 36], [27, 28, 35, 36]] = 6.0  # spot pixels
    wf = shack_hartmann(hcipy)
    det = DetnoiseDetector.from_noise_map(wf.grid, sigma_e, seed=11)
    frames, expected_e = expose(hcipy, det, wf, FRAMES)
    photons, s2 = expected_e, sigma_e.ravel() ** 2
    assert photons.max() > 250 and photons.min() < 1e-3  # bright spots and dark pixels

    mean, var = frames.mean(axis=0), frames.var(axis=0, ddof=1)
    total = photons + s2
    chi2_within((mean - photons) / np.sqrt(total / FRAMES), "per-pixel mean")
    # Var of a sample variance: 2 V^2 / (F - 1) + kappa4 / F, kappa4 = photons (Poisson).
    se_var = np.sqrt(2 * total**2 / (FRAMES - 1) + photons / FRAMES)
    chi2_within((var - total) / se_var, "per-pixel variance")
    # A scalar read noise at the map's rms cannot pass: the noisy pixels stand out.
    scalar = photons + det.readout.noise_scale_e(N_PX) ** 2
    z_scalar = (var - scalar) / np.sqrt(2 * scalar**2 / (FRAMES - 1) + photons / FRAMES)
    assert np.sum(z_scalar**2) > 10 * z_scalar.size
    # Variance against photons, each pixel's read variance taken off: slope 1, offset 0.
    a, se_a, b, se_b = var_fit(photons, var - s2, se_var)
    assert abs(a - 1.0) < Z * se_a and abs(b) < Z * se_b, (a, se_a, b, se_b)


def test_emccd_frames_have_the_registers_excess_noise(hcipy, DetnoiseDetector):
    gain, stages, read_noise_e = 500.0, 520, 50.0
    readout = detnoise.Readout(
        "emccd-stochastic", em_gain=gain, stages=stages, emccd_read_noise_e=read_noise_e, seed=5
    )
    wf = shack_hartmann(hcipy)
    frames, photons = expose(hcipy, DetnoiseDetector(wf.grid, readout), wf, FRAMES)
    # F^2 of a register of N stages of probability p = g^(1/N) - 1: 1 + (1 - p)(g - 1) / ((1 + p) g)
    # (1.974 here, not quite 2).
    p = gain ** (1.0 / stages) - 1.0
    excess = 1.0 + (1.0 - p) * (gain - 1.0) / ((1.0 + p) * gain)
    floor = (read_noise_e / gain) ** 2
    mean, var = frames.mean(axis=0), frames.var(axis=0, ddof=1)
    total = excess * photons + floor
    chi2_within((mean - photons) / np.sqrt(total / FRAMES), "per-pixel mean (input-referred)")
    # Var of a sample variance: 2 V^2 / (F - 1) + kappa4 / F; kappa4 = photons E[X^4] / g^4 for
    # one electron's output X, 24 photons for an exponential X (the register's is a little less).
    se_var = np.sqrt(2 * total**2 / (FRAMES - 1) + 24 * photons / FRAMES)
    bright = photons > 20
    assert bright.sum() > 200
    chi2_within(((var - total) / se_var)[bright], "bright pixels' variance")
    a, se_a, b, se_b = var_fit(photons[bright], var[bright], se_var[bright])
    assert abs(a - excess) < Z * se_a, (a, se_a, excess)
    assert abs(b - floor) < Z * se_b, (b, se_b, floor)
    assert abs(a - 2.0) > 3 * se_a  # the finite register is resolved from the factor 2
    # Pixels (almost) without light: the read noise divided by the gain.
    dark = photons < 1e-3
    se_dark = np.sqrt(np.sum(se_var[dark] ** 2)) / dark.sum()
    assert abs(var[dark].mean() - total[dark].mean()) < Z * se_dark


def test_integration_is_hcipys_noisy_detectors_with_subsampling(hcipy, DetnoiseDetector):
    wf = shack_hartmann(hcipy, n_px=2 * 16, brightest_e=50.0)
    detector_grid = hcipy.make_subsampled_grid(wf.grid, 2)
    reference = hcipy.NoisyDetector(detector_grid, include_photon_noise=False, subsampling=2)
    det = DetnoiseDetector(
        detector_grid, detnoise.Readout("scmos-constant:0"), 2, quantum_efficiency=0.8
    )
    assert det.input_grid.size == wf.grid.size
    for d, qe in ((reference, 0.8), (det, 1.0)):
        d.integrate(wf, 0.5 * qe, weight=3)
        d.integrate(wf.power, 0.1 * qe)
    np.testing.assert_allclose(det.accumulated_charge, reference.accumulated_charge, rtol=1e-12)
    frame = det.read_out()
    assert frame.grid is detector_grid and det.accumulated_charge == 0
    # Without read noise a frame is whole photo-electrons; a frame without light is dark.
    assert np.all(frame == np.round(frame)) and frame.sum() > 0
    assert np.all(det.read_out() == 0)


def test_the_same_seed_reads_the_same_frames(hcipy, DetnoiseDetector):
    wf = shack_hartmann(hcipy)

    def frames(seed, n=3):
        det = DetnoiseDetector.from_noise_map(wf.grid, MAP_64, seed=seed)
        assert det.readout.frame == 0  # the check at construction reads no frame of its own
        out = []
        for _ in range(n):
            det.integrate(wf, 1.0)
            out.append(np.asarray(det.read_out()))
        return np.array(out)

    first = frames(3)
    np.testing.assert_array_equal(first, frames(3))
    assert not np.array_equal(first[0], first[1])
    assert not np.array_equal(first, frames(4))


def test_report_folder_and_adu_frames(hcipy, DetnoiseDetector, tmp_path):
    grid = hcipy.make_pupil_grid(N_PX)
    shutil.copy(MAP_64, tmp_path / "rms_e.fits")
    light = np.full(grid.size, 40.0)

    def one(det):
        det.integrate(light, 1.0)
        return np.asarray(det.read_out())

    e = one(DetnoiseDetector.from_noise_map(grid, MAP_64, seed=2))
    np.testing.assert_array_equal(e, one(DetnoiseDetector.from_report(grid, tmp_path, seed=2)))
    adu = one(
        DetnoiseDetector.from_report(
            grid, tmp_path, seed=2, gain_e_per_adu=0.25, unit="adu", offset_adu=100.0
        )
    )
    np.testing.assert_allclose(adu, e / 0.25 + 100.0, rtol=1e-12)
    # A fixed window of a larger map reads that window's pixels.
    window = DetnoiseDetector.from_noise_map(
        hcipy.make_pupil_grid(16), MAP_64, window=(8, 40), seed=2
    )
    dark = np.array([np.asarray(window.read_out()) for _ in range(2000)])
    sigma = next(iter(detnoise.read_stack(MAP_64)))[8:24, 40:56].ravel()
    z = (dark.var(axis=0, ddof=1) - sigma**2) / (sigma**2 * np.sqrt(2.0 / 1999))
    chi2_within(z, "window's dark variance")


def test_camera_model_folder(hcipy, DetnoiseDetector):
    det = DetnoiseDetector.from_camera(hcipy.make_pupil_grid(4), CAMERA_4, exposure_s=1.0)
    det.integrate(np.full(16, 10.0), 1.0)
    assert det.read_out().shape == (16,)
    with pytest.raises(ValueError, match=r"camera is 4x4 px, the detector grid 8x8 px"):
        DetnoiseDetector.from_camera(hcipy.make_pupil_grid(8), CAMERA_4, exposure_s=1.0)
    with pytest.raises(ValueError, match="e- only"):
        DetnoiseDetector.from_camera(
            hcipy.make_pupil_grid(4), CAMERA_4, exposure_s=1.0, unit="adu"
        )


def test_bad_input_is_refused_at_construction(hcipy, DetnoiseDetector, tmp_path):
    square = hcipy.make_pupil_grid(N_PX)
    scmos = detnoise.Readout("scmos-constant:1")
    with pytest.raises(ValueError, match=r"detector_grid is 48x64 px \(rows x columns\)"):
        DetnoiseDetector(hcipy.make_pupil_grid([64, 48]), scmos)
    with pytest.raises(ValueError, match=r"map_e: the map is 32x32 px, the detector grid 64x64"):
        DetnoiseDetector.from_noise_map(square, np.ones((32, 32)))
    with pytest.raises(ValueError, match=re.escape(f"{MAP_64}: the map is 64x64 px, the det")):
        DetnoiseDetector.from_noise_map(hcipy.make_pupil_grid(32), MAP_64)
    with pytest.raises(ValueError, match=r"window 32x32 px at \(row 40, column 0\) is outside"):
        DetnoiseDetector.from_noise_map(hcipy.make_pupil_grid(32), MAP_64, window=(40, 0))
    with pytest.raises(FileNotFoundError, match="no rms_e.fits"):
        DetnoiseDetector.from_report(square, tmp_path)
    # The readout's own checks, at construction: a map smaller than the frame, adu without gain.
    with pytest.raises(ValueError, match="smaller than the 64x64"):
        DetnoiseDetector(square, detnoise.Readout("scmos-map", map_e=np.ones((32, 32))))
    with pytest.raises(ValueError, match="gain_e_per_adu"):
        DetnoiseDetector(square, scmos, unit="adu")
    with pytest.raises(ValueError, match="subsampling"):
        DetnoiseDetector(square, scmos, 1.5)
    with pytest.raises(ValueError, match="quantum_efficiency"):
        DetnoiseDetector(square, scmos, quantum_efficiency=1.2)
    with pytest.raises(TypeError, match="detnoise.Readout"):
        DetnoiseDetector(square, "scmos-constant:1")
    det = DetnoiseDetector(square, scmos, 2)
    with pytest.raises(ValueError, match=r"shape \(4096,\).*16384 points"):
        det.integrate(np.ones(square.size), 1.0)


def test_the_manual_example_runs(hcipy, monkeypatch, capsys):
    """Every ```python block of docs/ao-hcipy.md, in order, from the repository's root."""
    page = (ROOT / "docs" / "ao-hcipy.md").read_text(encoding="utf-8")
    code = re.findall(r"^```python\n(.*?)^```", page, flags=re.S | re.M)
    assert code
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": "__docs__"}
    for block in code:
        exec(compile(block, "docs/ao-hcipy.md", "exec"), namespace)
    assert "frame" in namespace
