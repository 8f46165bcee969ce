"""`detnoise.datasheet` on the bundled EMVA 1288 camera (data-synthetic/emva-cmos-64x96, its
truth in truth.json): the sheet against the truth and against the files written, the maps,
and the bad inputs refused before any work."""

import json
from pathlib import Path

import numpy as np
import pytest

import detnoise
from astropy.io import fits

DATA = Path(__file__).resolve().parents[2] / "data-synthetic" / "emva-cmos-64x96"
DESCRIPTOR = DATA / "EMVA1288descriptor.txt"
TRUTH = json.loads((DATA / "truth.json").read_text())


def rows(sheet):
    return {r["key"]: r for s in sheet["sections"] for r in s["rows"]}


def test_the_sheet_recovers_the_camera_and_is_the_file_written(tmp_path):
    ds = detnoise.datasheet(emva=DESCRIPTOR, out=tmp_path / "ds")
    assert ds.out == tmp_path / "ds"
    assert ds.sheet == json.loads((ds.out / "datasheet.json").read_text())
    r = rows(ds.sheet)
    for key, truth in [
        ("system_gain_dn_per_e", TRUTH["K_dn_per_e"]),
        ("dark_noise_e", TRUTH["read_noise_e"]),
        ("quantum_efficiency_percent", 100 * TRUTH["qe"]),
    ]:
        q = r[key]
        assert q["status"] == "ok", q
        # Within 3 standard errors of the simulated camera.
        assert abs(q["value"] - truth) < 3 * q["se"], (key, q, truth)


def test_the_maps_are_the_fits_files_and_agree_with_the_sheet(tmp_path):
    ds = detnoise.datasheet(emva=DESCRIPTOR, out=tmp_path / "ds")
    assert sorted(ds.maps) == sorted(
        [
            "gain_dn_per_e",
            "gain_se_dn_per_e",
            "dark_current_e_per_s",
            "dark_current_se_e_per_s",
            "rms_e",
            "rms_se_e",
        ]
    )
    for name, image in ds.maps.items():
        assert image.shape == (TRUTH["rows"], TRUTH["cols"]), name
        np.testing.assert_array_equal(image, fits.getdata(ds.out / f"{name}.fits"))
    k = rows(ds.sheet)["system_gain_dn_per_e"]
    # The per-pixel K scatters widely (one pixel's variances), but its mean is the camera's K:
    # within 3 combined standard errors of the datasheet's.
    g = ds.maps["gain_dn_per_e"]
    se = np.hypot(g.std() / np.sqrt(g.size), k["se"])
    assert abs(g.mean() - k["value"]) < 3 * se, (g.mean(), k, se)


def test_bad_inputs_are_refused_naming_the_keyword(tmp_path):
    with pytest.raises(ValueError, match="`emva`"):
        detnoise.datasheet(out=tmp_path / "a")
    with pytest.raises(ValueError, match="`emva`"):
        detnoise.datasheet(emva=DESCRIPTOR, manifest=DESCRIPTOR, out=tmp_path / "b")
    with pytest.raises(ValueError, match="`defect_sigma`"):
        detnoise.datasheet(emva=DESCRIPTOR, out=tmp_path / "c", defect_sigma=0)
    with pytest.raises(ValueError):
        detnoise.datasheet(emva=DESCRIPTOR, out=tmp_path / "d", operating_point="200,airy:2,50")
    assert not any((tmp_path / n).exists() for n in "abcd")


def test_a_folder_of_the_users_is_not_replaced(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(Exception, match="mine"):
        detnoise.datasheet(emva=DESCRIPTOR, out=mine)
    assert (mine / "notes.txt").read_text() == "keep me"
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt"]
