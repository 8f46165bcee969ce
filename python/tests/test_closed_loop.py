"""The closed-loop example (examples/closed_loop, docs/closed-loop.md) in its short version: OOPAO
with the measured camera (a), its references through the camera (a'), Gaussian cameras at the
median (b) and at sigma_random (c), photon noise only (d). Tolerances are the run's own paired
standard errors over its segments, not stored numbers."""

import importlib.util
from pathlib import Path

import pytest

from conftest import ROOT, simulator

SCRIPT = ROOT / "examples" / "closed_loop" / "closed_loop.py"


def load_example():
    spec = importlib.util.spec_from_file_location("closed_loop_example", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    simulator("OOPAO")
    out = tmp_path_factory.mktemp("loop") / "out"
    result = load_example().main([str(out), "--quick"], log=lambda *_: None)
    return out, result


def test_the_measured_camera_is_worse_than_its_median_and_its_references_remove_part_of_it(quick_run):
    _, r = quick_run
    case = {c["case"]: c for c in r["cases"]}
    diff = {d["difference"]: d for d in r["differences"]}
    # Every case's residual is resolved by its segments.
    for c in case.values():
        assert c["residual_se_nm"] > 0 and c["residual_nm"] > 20 * c["residual_se_nm"], c
    # The median is badly optimistic: (a) above (b) by many paired SEs.
    assert diff["a - b"]["value_nm"] > 8 * diff["a - b"]["se_nm"], diff["a - b"]
    # Read noise only adds: photon noise alone (d) is below the median camera (b).
    assert diff["b - d"]["value_nm"] > -3 * diff["b - d"]["se_nm"], diff["b - d"]
    # References through the camera take out the static part: (a') below (a).
    assert diff["a - a'"]["value_nm"] > 8 * diff["a - a'"]["se_nm"], diff["a - a'"]


def test_the_static_aberration_is_resolved_and_accounts_for_a_minus_a_prime(quick_run):
    _, r = quick_run
    q = r["quadrature"]
    # The fixed pattern's slope bias through the reconstructor: far above its reference noise.
    assert q["static_flat_nm"] > 5 * q["static_reference_noise_nm"], q
    assert r["static_slope_bias"]["rms_px"] > 0
    # In the loop the same pattern (correlation near -1: the residual is minus the DM's offset)...
    assert q["in_loop_flat_correlation"] < -0.9, q
    # ...and a^2 - a'^2 is that in-loop static aberration squared, within 4 SE.
    assert abs(q["a2_minus_ap2_nm2"] - q["static_in_loop2_nm2"]) < 4 * q["a2_minus_ap2_se_nm2"], q


def test_the_outputs_are_written_and_a_foreign_folder_is_refused(quick_run, tmp_path):
    out, r = quick_run
    for name in ["results.json", "results.csv", "differences.csv", "closed_loop.png", "closed_loop.svg",
                 "noise_map_e.fits", "static_aberration_nm.fits"]:
        assert (out / name).stat().st_size > 0, name
    assert r["setup"]["frame_px"] == 128 and r["setup"]["quick"] is True
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "keep.txt").write_text("not the example's")
    with pytest.raises(SystemExit, match="was not written by closed_loop.py"):
        load_example().main([str(foreign), "--quick"], log=lambda *_: None)
    assert (foreign / "keep.txt").read_text() == "not the example's"
    assert sorted(p.name for p in foreign.iterdir()) == ["keep.txt"]
    assert not any(p.name.startswith(".foreign.tmp-") for p in tmp_path.iterdir())
