"""`detnoise.report`: the report the CLI writes, and its numbers as Python objects."""

import json

import pytest

import detnoise

GRID = dict(subap_px=[4, 6], spot="airy:2", signal_photons=[50], iters=500, max_iters=2000)
CLI_GRID = ["--subap", "4,6", "--spot", "airy:2", "--signal", "50", "--iters", 500,
            "--max-iters", 2000]


def test_report_writes_what_the_cli_writes_and_returns_it(data, cli, tmp_path):
    darks = data / "scmos-darks-64x64.fits"
    out = tmp_path / "py"
    r = detnoise.report(darks, out=out, gain_e_per_adu=0.25, quick=True, **GRID)
    assert (out / "index.html").exists() and r.out_dir == out
    assert {p.name for p in r.files} >= {"summary.json", "index.html", "rms_e.fits"}
    assert r.summary == json.loads((out / "summary.json").read_text())
    assert r.effective == json.loads((out / "effective_noise.json").read_text())
    assert r.pdf_fit is not None and r.pdf_fit.to_dict() == json.loads(
        (out / "pdf_fit.json").read_text()
    )
    assert len(r.comparison) > 0 and all("r_px" in c for c in r.comparison)
    assert set(r.to_dict()) == {"summary", "effective", "comparison", "pdf_fit", "out_dir", "files"}
    # The same report from the command line: the same tables, bit for bit.
    cli("report", "--darks", darks, "--gain-e-per-adu", 0.25, "--quick", *CLI_GRID,
        "--out", tmp_path / "cli")
    for name in ("effective_noise.json", "r_vs_signal.csv", "pdf_fit.json"):
        assert (out / name).read_text() == (tmp_path / "cli" / name).read_text(), name


def test_report_refuses_bad_options_before_reading_anything(data, tmp_path):
    darks = data / "scmos-darks-64x64.fits"
    with pytest.raises(ValueError, match="`subap_px`"):
        detnoise.report(darks, out=tmp_path / "a", gain_e_per_adu=0.25, subap_px=[1])
    with pytest.raises(ValueError, match="`detector`"):
        detnoise.report(darks, out=tmp_path / "b", detector="ccd")
    with pytest.raises(OSError, match="missing.fits"):
        detnoise.report(tmp_path / "missing.fits", out=tmp_path / "c", gain_e_per_adu=0.25)
    assert not (tmp_path / "a").exists() and not (tmp_path / "c").exists()
