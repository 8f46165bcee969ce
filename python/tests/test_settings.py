"""Python's keywords held to the settings registry (`detnoise.SETTINGS`), the one definition the
command line is generated from: every readout keyword exists, takes the registry's range and
default, and the run settings of simulate/effective/report state the registry's defaults."""

import inspect
import math

import pytest

import detnoise

SETTINGS = {s["key"]: s for s in detnoise.SETTINGS}
READOUT = [s for s in detnoise.SETTINGS if s["group"] == "readout"]
RUN = [s for s in detnoise.SETTINGS if s["group"] == "run"]


def probes(s):
    """Values at and just beyond each finite end of a setting's range: (value, taken)."""
    if s["kind"] == "choice":
        return [(w, True) for w in s["choices"]] + [("no-such-word", False)]
    if s["kind"] == "whole":
        out = [(s["lo"], True), (s["hi"], True), (-1, False)]
        if s["lo"] > 0:
            out.append((s["lo"] - 1, False))
        if s["hi"] < 2**64 - 1:
            out.append((s["hi"] + 1, False))
        return out
    if s["kind"] == "real":
        out = [(math.nan, False), (math.inf, False)]
        step = lambda a: max(abs(a), 1.0) * 1e-9  # noqa: E731
        if s["lo"] is not None:
            lo = s["lo"]
            out += [(lo, False), (lo + step(lo), True)] if s["lo_open"] else [
                (lo, True), (lo - step(lo), False)]
        if s["hi"] is not None:
            hi = s["hi"]
            out += [(hi, False), (hi - step(hi), True)] if s["hi_open"] else [
                (hi, True), (hi + step(hi), False)]
        return out
    return []


def test_the_readout_keywords_are_the_registrys():
    assert detnoise.MODEL_PARAMS == [s["key"] for s in READOUT]
    assert isinstance(detnoise.MODEL_NAMES, list) and "scmos-random" in detnoise.MODEL_NAMES
    assert SETTINGS["map_e"]["flag"] == "--map" and SETTINGS["register"]["flag"] == "--register"
    with pytest.raises(TypeError, match="readout-model parameters are: em_gain"):
        detnoise.Readout("scmos-constant", em_gian=100)


# The operating point of a camera model applies only with `camera`: its settings' ranges are
# probed by test_camera.py and the Rust settings tests.
OPERATING_POINT = ("exposure_s", "temperature_c", "frame_rate_hz")


@pytest.mark.parametrize(
    "setting",
    [s for s in READOUT if probes(s) and s["key"] not in OPERATING_POINT],
    ids=lambda s: s["key"],
)
def test_each_readout_keyword_takes_exactly_the_registrys_range(setting):
    key = setting["key"]
    # A register of few stages needs a small gain (a stage at most doubles the charge).
    extra = {"em_gain": 2.0} if key == "stages" else {}
    model = "emccd-pp" if key in ("pp_rule", "pp_lambda") else "scmos-constant"
    for value, taken in probes(setting):
        if taken:
            detnoise.Readout(model, **{key: value}, **extra)
        else:
            with pytest.raises(ValueError, match=f"`{key}`"):
                detnoise.Readout(model, **{key: value}, **extra)


def test_pixel_prior_is_taken_as_on_the_command_line():
    # It was refused by Python alone before the registry.
    cam = detnoise.Readout("emccd-pp", pp_rule="pixel-prior", em_gain=300)
    assert cam is not None
    with pytest.raises(ValueError, match="poisson-prior, equal-density, pixel-prior"):
        detnoise.Readout("emccd-pp", pp_rule="pixel")


@pytest.mark.parametrize("function", ["simulate", "effective", "report"])
def test_run_settings_default_to_the_registrys(function):
    params = inspect.signature(getattr(detnoise, function)).parameters
    checked = 0
    others = [s for s in detnoise.SETTINGS if s["group"] in ("centroid", "precision", "report")]
    for s in RUN + others:
        if s["key"] not in params:
            continue
        checked += 1
        default = params[s["key"]].default
        # None: the command's own list (its grid, every centroider in a report); `...`: a
        # library constant (Precision's targets), tied to the registry by the Rust tests.
        if default is None or default is Ellipsis:
            continue
        assert default == s["default"], (function, s["key"], default, s["default"])
    assert checked >= 6, params


@pytest.mark.parametrize("setting", [s for s in RUN if probes(s)], ids=lambda s: s["key"])
def test_each_run_setting_is_refused_outside_the_registrys_range(setting):
    for value, taken in probes(setting):
        if taken:
            continue
        with pytest.raises(ValueError, match=f"`{setting['key']}`"):
            detnoise.simulate("scmos-constant", **{"iters": 2, setting["key"]: value})


def test_centroiders_are_keywords_of_simulate_effective_and_report(tmp_path):
    records = detnoise.simulate("scmos-median", iters=200, centroider="cog,tcog:2")
    assert [r["centroider"] for r in records] == ["cog", "tcog:2"]
    with pytest.raises(ValueError, match="`centroider`"):
        detnoise.effective("scmos-random", centroider="no-such-method")
    with pytest.raises(ValueError, match="`mask_above`"):
        detnoise.simulate("scmos-median", iters=200, centroider="cog", mask_above=3)
    with pytest.raises(ValueError, match="`subap_mask`"):
        detnoise.report("x.fits", out=tmp_path / "r", subap_mask="m.fits")
    assert not (tmp_path / "r").exists()


def test_report_with_centroiders_and_a_subaperture_grid_writes_what_the_cli_writes(
    data, cli, tmp_path
):
    darks = data / "scmos-darks-64x64.fits"
    grid = dict(subap_px=[4], spot="airy:2", signal_photons=[50], iters=300, max_iters=600)
    r = detnoise.report(darks, out=tmp_path / "py", gain_e_per_adu=0.25, quick=True,
                        centroider="cog,tcog", subap_grid="16", **grid)
    names = {p.name for p in r.files}
    assert any(n.startswith("subaps") for n in names), names
    cli("report", "--darks", darks, "--gain-e-per-adu", 0.25, "--quick", "--subap", "4",
        "--spot", "airy:2", "--signal", "50", "--iters", 300, "--max-iters", 600,
        "--centroider", "cog,tcog", "--subap-grid", "16", "--out", tmp_path / "cli")
    for name in sorted(names - {"index.html", "manifest.json"}):
        if name.endswith((".json", ".csv")):
            assert (tmp_path / "py" / name).read_text() == (tmp_path / "cli" / name).read_text(), name
