"""Frames, dark maps and the calibration fits against numpy and against the CLI's outputs."""

import json

import numpy as np
import pytest

import detnoise

SCMOS = "scmos-darks-64x64"
GAIN_E_PER_ADU = 0.25


def stack(data, ext="fits"):
    return np.stack(list(detnoise.read_stack(data / f"{SCMOS}.{ext}")))


def test_the_three_formats_of_the_bundled_stack_hold_the_same_frames(data):
    it = detnoise.read_stack(data / f"{SCMOS}.fits")
    assert (len(it), it.shape) == (100, (64, 64))
    fits = stack(data, "fits")
    assert fits.shape == (100, 64, 64) and fits.dtype == np.float64
    # uint16 samples: whole numbers near the 100 adu offset.
    assert np.all(fits == np.round(fits)) and 80 < fits.mean() < 120
    for ext in ("tif", "exr"):
        np.testing.assert_array_equal(stack(data, ext), fits)


def test_dark_maps_are_the_per_pixel_mean_and_standard_deviation(data):
    maps = detnoise.dark_maps(data / f"{SCMOS}.fits", gain_e_per_adu=GAIN_E_PER_ADU)
    frames = stack(data)
    np.testing.assert_allclose(maps.offset_adu, frames.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(maps.rms_adu, frames.std(axis=0, ddof=1), rtol=1e-10)
    np.testing.assert_allclose(maps.rms_e, maps.rms_adu * GAIN_E_PER_ADU, rtol=1e-15)
    assert maps.flags.dtype == np.int32 and maps.flags.shape == (64, 64)
    s = maps.summary
    assert (s["frames"], s["shape"], s["outputs"]) == (100, [64, 64], [])
    assert s == maps.to_dict()


def test_dark_maps_equal_the_fits_maps_the_cli_writes(data, cli, tmp_path):
    out = tmp_path / "darks"
    path = data / f"{SCMOS}.fits"
    cli("darks", path, "--out", out, "--gain-e-per-adu", GAIN_E_PER_ADU)
    maps = detnoise.dark_maps(path, gain_e_per_adu=GAIN_E_PER_ADU)
    for name in ("offset_adu", "rms_adu", "rms_e", "flags", "excess_kurtosis"):
        (written,) = list(detnoise.read_stack(out / f"{name}.fits"))
        np.testing.assert_array_equal(getattr(maps, name), written, err_msg=name)
    summary = json.loads((out / "summary.json").read_text())
    assert summary.pop("outputs")
    mine = maps.summary
    mine.pop("outputs")
    assert mine == summary


def test_fit_pdf_matches_the_cli_and_recovers_the_synthetic_median(data, cli, tmp_path):
    maps = detnoise.dark_maps(data / f"{SCMOS}.fits", gain_e_per_adu=GAIN_E_PER_ADU)
    fit = detnoise.fit_pdf(maps.rms_e, flags=maps.flags)
    darks, out = tmp_path / "darks", tmp_path / "fit"
    cli("darks", data / f"{SCMOS}.fits", "--out", darks, "--gain-e-per-adu", GAIN_E_PER_ADU)
    cli("fit-pdf", darks / "rms_e.fits", "--out", out)
    written = json.loads((out / "pdf_fit.json").read_text())
    assert fit.to_dict() == written
    assert fit.best_model in fit.models
    params, se = fit.params(), fit.param_se()
    assert set(params) >= set(k for k, v in se.items() if v is not None)
    # The synthetic camera's read noise follows the paper's pdf, median 0.7994 e- (manifest):
    # the map's median, over 4096 pixels, within 5 of its standard errors
    # (SE of a median = 1 / (2 f(m) sqrt(n)), f from the fitted pdf's spread near the median).
    manifest = json.loads((data / f"{SCMOS}.manifest.json").read_text())
    values = np.sort(maps.rms_e.ravel())
    n = values.size
    f_median = 0.1 / (np.quantile(values, 0.55) - np.quantile(values, 0.45))
    se_median = 1.0 / (2.0 * f_median * np.sqrt(n))
    assert abs(written["data"]["median_e"] - manifest["rms_e_median"]) < 5 * se_median


def test_fit_emgain_recovers_the_synthetic_gain_within_its_standard_error(data, cli, tmp_path):
    path = data / "emccd-lowlight-32x48.fits"
    fit = detnoise.fit_emgain(path, gain_e_per_adu=10.0, stages=520)
    truth = json.loads((data / "emccd-lowlight-32x48.manifest.json").read_text())["spec"]["camera"]
    assert fit.em_gain_units == "e-/e-"
    assert abs(fit.em_gain - truth["em_gain"]) < 5 * fit.em_gain_se
    assert abs(fit.bias_adu - truth["bias_adu"]) < 5 * fit.bias_adu_se + 0.5
    cli("emgain", path, "--out", tmp_path / "em", "--gain-e-per-adu", 10, "--stages", 520)
    written = json.loads((tmp_path / "em" / "emgain.json").read_text())
    assert fit.to_dict() == written


def test_bad_options_are_value_errors_naming_the_keyword(data):
    path = data / f"{SCMOS}.fits"
    for kwargs, keyword in [
        ({"hot_sigma": -1.0}, "`hot_sigma`"),
        ({"dead_fraction": 2.0}, "`dead_fraction`"),
        ({"gain_e_per_adu": 0.0}, "`gain_e_per_adu`"),
        ({"clip": 2, "sigma_clip": 3.0}, "`sigma_clip`"),
        ({"checksum": "md5"}, "`checksum`"),
    ]:
        with pytest.raises(ValueError, match=keyword):
            detnoise.dark_maps(path, **kwargs)
    with pytest.raises(ValueError, match="`upper_cut_e`"):
        detnoise.fit_pdf(np.ones(100), upper_cut_e=-1.0)


def test_missing_and_unreadable_files_are_os_errors(data, tmp_path):
    with pytest.raises(OSError, match="missing.fits: no such file"):
        detnoise.dark_maps(tmp_path / "missing.fits")
    with pytest.raises(OSError, match="missing"):
        list(detnoise.read_stack(tmp_path / "missing.fits"))
    bad = tmp_path / "bad.fits"
    bad.write_bytes(b"SIMPLE  =                    T" + b" " * 100)
    with pytest.raises(OSError, match="bad.fits"):
        list(detnoise.read_stack(bad))
    with pytest.raises(OSError):
        detnoise.Readout("scmos-map", map_e=tmp_path / "missing.fits")
