"""`detnoise.campaign` on the getframes sCMOS campaign of tests/fixtures/campaign/scmos (4 dark
stacks of 150 frames, 32x32 px, K = 0.5 e-/adu): the conditions table, the decomposition's maps
against the files it wrote and against numpy, its options and its errors."""

from pathlib import Path

import numpy as np
import pytest

import detnoise

FIXTURE = Path(__file__).resolve().parents[2] / "tests" / "fixtures" / "campaign" / "scmos"
EXPOSURES_S = [0.01, 0.5, 2.0, 5.0]


def run(tmp_path, name="c", **options):
    return detnoise.campaign(
        manifest=FIXTURE / "manifest.csv",
        out=tmp_path / name,
        gain_e_per_adu=0.5,
        checksum=None,
        **options,
    )


def test_campaign_returns_its_table_and_maps(tmp_path):
    c = run(tmp_path)
    assert c.out == tmp_path / "c" and (c.out / "conditions.csv").is_file()
    assert [r["exposure_s"] for r in c.conditions] == EXPOSURES_S
    assert all(r["kind"] == "dark" and r["frames"] == 150 for r in c.conditions)
    # The table's mean level is the mean of the stack's frames.
    frames = np.stack(list(detnoise.read_stack(FIXTURE / "scmos-t5.000s.fits")))
    assert c.conditions[-1]["mean_adu"] == pytest.approx(frames.mean(), rel=1e-9)
    maps = c.maps
    assert {"offset_adu", "dark_current_e_per_s", "dark_current_se_e_per_s", "hot_class"} <= set(maps)
    assert "cic_e_per_frame" not in maps  # no EM register
    assert all(m.shape == (32, 32) and m.dtype == np.float64 for m in maps.values())
    # The maps are the files written; the dark current is getframes' 2 e-/s (median ~1.9).
    written = detnoise.read_stack(c.out / "dark_current_e_per_s.fits")
    np.testing.assert_array_equal(next(iter(written)), maps["dark_current_e_per_s"])
    assert 1.5 < np.median(maps["dark_current_e_per_s"]) < 2.5
    assert (maps["hot_class"] == 2).sum() == c.decomposition["hot_pixels"]["hot"] == 8
    assert c.summary["command"] == "campaign" and c.camera == c.out / "camera"
    assert "4 stacks" in repr(c)
    # Its camera model runs without an exposure: the campaign's shortest (0.01 s) is taken.
    r = detnoise.Readout.from_camera(c.camera)
    assert r.sensor == "scmos" and r.read(np.zeros((2, 8, 8))).shape == (2, 8, 8)


def test_campaign_options_reach_the_measurement_and_the_fit(tmp_path):
    plain = run(tmp_path, "plain")
    cm = run(tmp_path, "cm", common_mode=True, warm_sigma=2.0, hot_sigma=10.0, bad_fit_p_value=0.5)
    for a, b in zip(plain.conditions, cm.conditions):
        assert a["frame_rms_adu"] > 0.6 and b["frame_rms_adu"] < 0.3
        assert b["mean_adu"] == pytest.approx(a["mean_adu"], abs=1e-6)
    assert cm.decomposition["hot_pixels"]["warm"] > 0
    assert cm.decomposition["fit_quality"]["flag_p_value"] == 0.5
    absolute = run(tmp_path, "abs", warm_e_per_s=50.0, hot_e_per_s=1000.0)
    assert absolute.decomposition["hot_pixels"]["hot"] == 0


@pytest.mark.parametrize(
    "options, keyword",
    [
        ({"warm_sigma": 0.0}, "warm_sigma"),
        ({"warm_sigma": 30.0}, "hot_sigma"),
        ({"hot_sigma": 1e4}, "hot_sigma"),
        ({"warm_e_per_s": 5.0}, "hot_e_per_s"),
        ({"bad_fit_p_value": 1.0}, "bad_fit_p_value"),
        ({"sigma_clip": 1e4}, "sigma_clip"),
        ({"clip": 2, "sigma_clip": 3.0}, "sigma_clip"),
        ({"gain_e_per_adu": -1.0}, "gain_e_per_adu"),
        ({"temperature_term": "warm"}, "temperature_term"),
        ({"emva": FIXTURE / "manifest.csv"}, "manifest"),
    ],
)
def test_bad_settings_raise_value_error_naming_the_keyword(tmp_path, options, keyword):
    args = dict(manifest=FIXTURE / "manifest.csv", out=tmp_path / "c", gain_e_per_adu=0.5)
    args.update(options)
    with pytest.raises(ValueError, match=keyword):
        detnoise.campaign(**args)
    assert not (tmp_path / "c").exists()


def test_a_missing_manifest_is_an_os_error(tmp_path):
    with pytest.raises(OSError):
        detnoise.campaign(manifest=tmp_path / "none.csv", out=tmp_path / "c", gain_e_per_adu=0.5)


def test_progress_is_reported_per_stage(tmp_path):
    stages = []
    run(tmp_path, progress=lambda stage, done, total, unit: stages.append(stage))
    assert "campaign" in stages


def test_dark_maps_take_the_camera_models_dark_signal_off_before_the_light_check(tmp_path):
    c = run(tmp_path)
    long_dark = FIXTURE / "scmos-t5.000s.fits"  # ~10 e- of dark charge per pixel
    with pytest.raises(OSError, match="look illuminated"):
        detnoise.dark_maps(long_dark, checksum=None)
    maps = detnoise.dark_maps(long_dark, checksum=None, camera=c.camera, exposure_s=5.0)
    assert maps.offset_adu.shape == (32, 32)
    with pytest.raises(ValueError, match="exposure_s"):
        detnoise.dark_maps(long_dark, camera=c.camera)
    with pytest.raises(ValueError, match="camera"):
        detnoise.dark_maps(long_dark, exposure_s=5.0)
