"""`Readout.read` against analytic moments, with tolerances from the standard errors of the
sample sizes used (fixed seeds), and its contract: seeds, frames, units, shapes, errors."""

import os
import subprocess
import sys

import numpy as np
import pytest

import detnoise

Z = 5.0  # tolerance in standard errors


def check_mean_var(x, mean, var, mu4):
    """Sample mean and variance of `x` against the truth, within Z standard errors: the
    mean's SE sqrt(var / n), the variance's sqrt((mu4 - var^2) / n) (mu4: central 4th moment)."""
    n = x.size
    m, v = x.mean(), x.var(ddof=1)
    assert abs(m - mean) < Z * np.sqrt(var / n), (m, mean)
    assert abs(v - var) < Z * np.sqrt((mu4 - var**2) / n), (v, var)


def test_scmos_constant_with_shot_noise_has_poisson_plus_gaussian_moments():
    lam, sigma = 3.0, 1.5
    out = detnoise.Readout(f"scmos-constant:{sigma}").read(np.full((50_000, 4, 4), lam), seed=11)
    # X + Y, X ~ Poisson(lam), Y ~ N(0, sigma^2): central 4th moment lam (1 + 3 lam) +
    # 6 lam sigma^2 + 3 sigma^4.
    mu4 = lam * (1 + 3 * lam) + 6 * lam * sigma**2 + 3 * sigma**4
    check_mean_var(out, lam, lam + sigma**2, mu4)


def test_counts_without_photon_noise_get_read_noise_only():
    sigma = 0.8
    counts = np.tile(np.arange(16.0).reshape(4, 4), (40_000, 1, 1))
    out = detnoise.Readout(f"scmos-constant:{sigma}").read(counts, seed=3, photon_noise=False)
    check_mean_var(out - counts, 0.0, sigma**2, 3 * sigma**4)


def emccd_output_moments(lam, gain, stages, read_noise_e):
    """Mean, variance and 4th central moment (estimated as needed) of the exact register's
    output divided by its gain, for Poisson(lam) input and Gaussian read noise."""
    p = gain ** (1.0 / stages) - 1.0
    m = 1.0 + p  # one stage: 1 + Bernoulli(p)
    v_stage = p * (1.0 - p)
    # Galton-Watson: variance after N stages of one electron's output.
    v_n = v_stage * m ** (stages - 1) * (m**stages - 1.0) / (m - 1.0)
    enf_sq = 1.0 + v_n / gain**2
    return lam, lam * enf_sq + (read_noise_e / gain) ** 2


def test_emccd_stochastic_has_the_exact_registers_mean_and_excess_noise():
    lam, gain, stages, rn = 0.5, 300.0, 520, 50.0
    cam = detnoise.Readout("emccd-stochastic", em_gain=gain, stages=stages, emccd_read_noise_e=rn)
    out = cam.read(np.full((100_000, 4, 4), lam), seed=5).ravel()
    mean, var = emccd_output_moments(lam, gain, stages, rn)
    # The variance's SE uses the sample's own 4th moment (the register's tail has no short
    # closed form); 1.6e6 samples make that estimate good to a few percent.
    mu4 = np.mean((out - out.mean()) ** 4)
    check_mean_var(out, mean, var, mu4)
    assert cam.sensor == "emccd"


def test_scmos_map_reads_each_pixel_with_its_own_sigma():
    rng = np.random.default_rng(2)
    rms_e = rng.uniform(0.3, 3.0, (16, 16))
    cam = detnoise.Readout("scmos-map", map_e=rms_e)
    frames = 20_000
    out = cam.read(np.zeros((frames, 16, 16)), seed=9)
    # A frame as large as the map reads through the whole map: pixel (r, c) has sigma
    # rms_e[r, c]. Its sample variance has SE sigma^2 sqrt(2 / (n - 1)).
    v = out.var(axis=0, ddof=1)
    z = (v - rms_e**2) / (rms_e**2 * np.sqrt(2.0 / (frames - 1)))
    assert np.abs(z).max() < Z
    assert abs(z.mean()) < Z / np.sqrt(z.size)
    assert np.abs(out.mean(axis=0) / (rms_e / np.sqrt(frames))).max() < Z


def test_seeds_frames_and_threads_give_reproducible_noise():
    image = np.full((8, 6, 6), 2.0)
    cam = detnoise.Readout("scmos-random", seed=42)
    first, second = cam.read(image), cam.read(image)
    assert cam.frame == 2 and not np.array_equal(first, second)
    # An explicit seed reads as frame 0 of a camera with that seed, counter untouched.
    np.testing.assert_array_equal(cam.read(image, seed=42), first)
    assert cam.frame == 2
    cam.frame = 1
    np.testing.assert_array_equal(cam.read(image), second)
    # Sub-aperture i of a stack is sub-aperture i whatever the stack's length.
    np.testing.assert_array_equal(cam.read(image[:3], seed=42), first[:3])
    # One worker thread gives the same bits as many.
    code = (
        "import numpy as np, detnoise, sys;"
        "x = detnoise.Readout('emccd-stochastic').read(np.full((64, 8, 8), 1.5), seed=7);"
        "sys.stdout.write(x.tobytes().hex())"
    )
    outs = set()
    for threads in ("1", "3"):
        env = dict(os.environ, RAYON_NUM_THREADS=threads)
        proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        outs.add(proc.stdout)
    here = detnoise.Readout("emccd-stochastic").read(np.full((64, 8, 8), 1.5), seed=7)
    assert outs == {here.tobytes().hex()}


def test_adu_output_is_the_electrons_over_the_gain_plus_the_offset():
    cam = detnoise.Readout("scmos-constant:2", gain_e_per_adu=0.5)
    image = np.full((4, 5, 5), 10.0)
    e = cam.read(image, seed=1)
    np.testing.assert_allclose(cam.read(image, seed=1, unit="adu", offset_adu=100.0), e / 0.5 + 100.0)
    offset = np.arange(25.0).reshape(5, 5)
    np.testing.assert_allclose(cam.read(image, seed=1, unit="adu", offset_adu=offset), e / 0.5 + offset)
    with pytest.raises(ValueError, match="`gain_e_per_adu`"):
        detnoise.Readout("scmos-constant:2").read(image, unit="adu")


def test_bad_input_is_a_value_error_naming_the_argument():
    cam = detnoise.Readout("scmos-constant:1")
    for image, kwargs, keyword in [
        (np.zeros((3, 4)), {}, "`image_e`"),
        (np.zeros((2, 3, 4)), {}, "`image_e`"),
        (np.zeros(5), {}, "`image_e`"),
        (np.full((3, 3), -1.0), {}, "`image_e`"),
        (np.full((3, 3), np.nan), {}, "`image_e`"),
        (np.full((3, 3), 1.5), {"photon_noise": False}, "`image_e`"),
        (np.zeros((3, 3)), {"unit": "V"}, "`unit`"),
        (np.zeros((3, 3)), {"mean_e": np.zeros((2, 2))}, "`mean_e`"),
    ]:
        with pytest.raises(ValueError, match=keyword):
            cam.read(image, **kwargs)
    for model, kwargs, keyword in [
        ("nonsense", {}, "`model`"),
        ("scmos-map", {}, "`map_e`"),
        ("emccd-stochastic", {"em_gain": 0.5}, "`em_gain`"),
        ("emccd-stochastic", {"em_gain": 5000.0, "stages": 5}, "`stages`"),
        ("scmos-constant", {"sigma_e": -1.0}, "`sigma_e`"),
        ("scmos-random", {"pdf": "paper", "pdf_model": "lognormal+tail"}, "`pdf_model`"),
        ("scmos-map", {"map_e": np.ones((4, 4, 4))}, "`map_e`"),
    ]:
        with pytest.raises(ValueError, match=keyword):
            detnoise.Readout(model, **kwargs)
    with pytest.raises(TypeError, match="gain"):
        detnoise.Readout("emccd-simple", gain=500)
    # A map smaller than the frame is refused when that frame comes.
    small = detnoise.Readout("scmos-map", map_e=np.ones((4, 4)))
    with pytest.raises(ValueError, match="smaller than"):
        small.read(np.zeros((8, 8)))


def test_integer_and_list_input_is_accepted():
    cam = detnoise.Readout("scmos-constant:1")
    out = cam.read([[1, 2], [3, 4]], seed=2)
    assert out.shape == (2, 2) and out.dtype == np.float64
    np.testing.assert_array_equal(out, cam.read(np.array([[1.0, 2.0], [3.0, 4.0]]), seed=2))


def test_a_broadcast_view_too_large_to_expand_is_refused_before_any_allocation():
    cam = detnoise.Readout("scmos-constant:1")
    # 1e10 elements held by one: converting it would allocate 74.5 GiB (and the output as much).
    huge = np.broadcast_to(1.0, (1, 100_000, 100_000))
    with pytest.raises(ValueError, match=r"`image_e`: shape \[1, 100000, 100000\] has "
                                         r"10000000000 elements \(74\.5 GiB.*holds 1 "):
        cam.read(huge)
    with pytest.raises(ValueError, match="`mean_e`: shape"):
        cam.read(np.ones((4, 4)), mean_e=np.broadcast_to(1.0, (20_000, 20_000)))
    with pytest.raises(ValueError, match="`rms_e`: shape"):
        detnoise.fit_pdf(np.broadcast_to(1.0, (20_000, 20_000)))
    with pytest.raises(ValueError, match="`map_e`: shape"):
        detnoise.Readout("scmos-map", map_e=np.broadcast_to(1.0, (20_000, 20_000)))
    # A view of a modest size is read as the array it stands for.
    flat = np.broadcast_to(5.0, (3, 4, 4))
    np.testing.assert_array_equal(cam.read(flat, seed=1), cam.read(np.full((3, 4, 4), 5.0), seed=1))


def test_complex_arrays_are_refused_naming_the_argument():
    cam = detnoise.Readout("scmos-constant:1", gain_e_per_adu=2.0)
    image = np.full((4, 4), 3.0 + 1.0j)
    for call, keyword in [
        (lambda: cam.read(image), "`image_e`"),
        (lambda: cam.read([[1j, 0], [0, 0]]), "`image_e`"),
        (lambda: cam.read(image.real, mean_e=image), "`mean_e`"),
        (lambda: cam.read(image.real, unit="adu", offset_adu=image), "`offset_adu`"),
        (lambda: detnoise.Readout("scmos-map", map_e=image), "`map_e`"),
        (lambda: detnoise.fit_pdf(image.ravel()), "`rms_e`"),
        (lambda: detnoise.fit_pdf(np.ones(16), flags=image.ravel()), "`flags`"),
    ]:
        with pytest.raises(ValueError, match=f"{keyword}: complex values"):
            call()


def test_arrays_of_text_or_objects_are_refused_naming_the_argument():
    # numpy would read ["1.5"] as 1.5 and objects as whatever float() makes of them.
    cam = detnoise.Readout("scmos-constant:1", gain_e_per_adu=2.0)
    for call, keyword, dtype in [
        (lambda: cam.read(np.array([["1.5", "2"], ["0", "0"]])), "`image_e`", "<U3"),
        (lambda: cam.read(np.array([[1.0, None], [0, 0]], dtype=object)), "`image_e`", "object"),
        (lambda: detnoise.fit_pdf(np.array(["1.0"] * 16)), "`rms_e`", "<U3"),
    ]:
        with pytest.raises(ValueError, match=f"{keyword}: values of dtype {dtype}, not numbers"):
            call()
    # Booleans and integers are numbers.
    assert cam.read(np.ones((4, 4), dtype=np.int16), seed=1).shape == (4, 4)
