"""`simulate` and `effective`: records, the CLI's numbers, the effective read noise of a
constant-sigma camera, progress, Ctrl-C and bad options."""

import json
import os
import signal
import sys
import threading
import time

import pytest

import detnoise


def test_effective_noise_of_a_constant_sigma_camera_is_its_sigma():
    sigma = 1.2
    records = detnoise.effective(
        f"scmos-constant:{sigma}",
        subap_px=[6, 8],
        spot="airy:2",
        signal_photons=100,
        iters=2000,
        max_iters=20_000,
    )
    assert len(records) == 2
    for r in records:
        assert r["status"] == "ok", r
        # sigma_eff solves R(sigma_eff) = R(camera) on common random numbers: a constant
        # camera is found at its own sigma, within the SE the solver states.
        assert abs(r["sigma_eff_e"] - sigma) <= 4 * r["sigma_eff_se_e"], r
        assert r["sigma_eff_se_e"] <= max(0.05, 0.025 * r["sigma_eff_e"])
        assert r["model"] == f"scmos-constant:{sigma}" and r["spot"] == "airy:2"


def test_effective_noise_of_a_centroider_is_referred_to_the_same_centroider():
    # A uniform camera read through wcog is matched against uniform cameras read through wcog:
    # it comes back at its own sigma; the cog-equivalent is a value of its own, and for cog it
    # is sigma_eff itself.
    sigma = 1.2
    records = detnoise.effective(
        f"scmos-constant:{sigma}",
        subap_px=6,
        spot="airy:2",
        signal_photons=50,
        iters=3000,
        max_iters=40_000,
        centroider=["cog", "wcog"],
    )
    assert [r["centroider"] for r in records] == ["cog", "wcog"]
    for r in records:
        assert r["status"] == "ok", r
        assert abs(r["sigma_eff_e"] - sigma) <= 3 * r["sigma_eff_se_e"], r
        assert r["sigma_cog_equiv_e"] is not None and r["sigma_cog_equiv_se_e"] > 0, r
    cog = records[0]
    assert cog["sigma_cog_equiv_e"] == cog["sigma_eff_e"]


def test_simulate_returns_the_records_the_cli_writes(cli):
    kwargs = dict(subap_px=[4, 6], spot="airy:2", signal_photons=[20, 200], iters=500, seed=3)
    records = detnoise.simulate("scmos-mean,emccd-simple", **kwargs)
    proc = cli(
        "simulate", "--model", "scmos-mean,emccd-simple", "--subap", "4,6", "--spot", "airy:2",
        "--signal", "20,200", "--iters", 500, "--seed", 3, "--format", "json",
    )
    assert records == json.loads(proc.stdout)
    assert len(records) == 8
    assert {r["model"] for r in records} == {"scmos-mean", "emccd-simple"}
    assert all(r["r_se_px"] > 0 and "bg_levels_e" in r for r in records)


def test_records_make_a_dataframe():
    pandas = pytest.importorskip("pandas")
    records = detnoise.simulate(["scmos-median"], subap_px=4, iters=200)
    frame = pandas.DataFrame(records)
    assert list(frame["model"]) == ["scmos-median"] and frame["r_px"].iloc[0] > 0


def test_library_warnings_arrive_as_python_warnings_naming_the_keyword():
    # A grid that stops far below the optimum background of a 3 e- camera (several e-).
    with pytest.warns(detnoise.DetnoiseWarning, match="widen `bg_grid`"):
        records = detnoise.simulate("scmos-constant:3", subap_px=4, iters=200, bg_grid="0:0.1:0.05")
    assert records[0]["b_at_grid_edge"] is True


def test_progress_reaches_every_stages_total():
    calls = []
    detnoise.simulate(
        "scmos-median", subap_px=4, iters=3000, progress=lambda *a: calls.append(a)
    )
    assert calls[0][:2] == ("simulate", 0)
    stage, done, total, unit = calls[-1]
    assert (stage, done, total, unit) == ("simulate", 3000, 3000, "frames")
    assert all(0 <= c[1] <= c[2] for c in calls)


def test_a_callback_that_raises_stops_the_run_with_its_exception():
    def stop(stage, done, total, unit):
        if done > 0:
            raise KeyboardInterrupt

    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        detnoise.effective("scmos-random", subap_px=16, signal_photons=50, spot="airy:2",
                           iters=1_000_000, max_iters=1_000_000, progress=stop)
    assert time.monotonic() - start < 60


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="needs POSIX signals")
def test_ctrl_c_interrupts_a_long_run():
    main = threading.get_ident()
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(main, signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            detnoise.simulate("scmos-random", subap_px=16, iters=200_000_000)
    finally:
        timer.cancel()
    # The engine checks between batches (64 x 256 frames): far under a second here.
    assert time.monotonic() - start < 30


def test_bad_options_are_value_errors_naming_the_keyword():
    for kwargs, keyword in [
        ({"subap_px": 1}, "`subap_px`"),
        ({"qe": 1.5}, "`qe`"),
        ({"iters": 1}, "`iters`"),
        ({"spot": "square:2"}, "`spot`"),
        ({"signal_photons": -5}, "`signal_photons`"),
        ({"bg_grid": "1:0:1"}, "`bg_grid`"),
        ({"sampling": "area"}, "`sampling`"),
        ({"position_half_range_px": 3.0}, "`position_half_range_px`"),
        ({"em_gain": 0.0}, "`em_gain`"),
    ]:
        with pytest.raises(ValueError, match=keyword):
            detnoise.simulate("scmos-median", **{"subap_px": 4, **kwargs})
    with pytest.raises(ValueError, match="`model`"):
        detnoise.simulate("scmos-median,nonsense")
    with pytest.raises(ValueError, match="`target_rel`"):
        detnoise.effective(target_rel=2.0)
    with pytest.raises(ValueError, match="`max_iters`"):
        detnoise.effective(iters=5000, max_iters=100)
    with pytest.raises(TypeError):
        detnoise.simulate("scmos-median", subap=4)


def test_the_command_runs_the_cli(cli):
    proc = cli("--help")
    assert "simulate" in proc.stdout and "Exit status" in proc.stdout
    bad = cli("simulate", "--qe", "2", check=False)
    assert bad.returncode == 2 and "--qe" in bad.stderr
    missing = cli("darks", "missing.fits", "--out", os.devnull + "-x", check=False)
    assert missing.returncode == 1 and "missing.fits" in missing.stderr


def test_list_arguments_of_the_wrong_type_or_value_name_the_keyword():
    for kwargs, error, message in [
        ({"subap_px": -8}, ValueError, r"`subap_px`: -8: must be a whole number of pixels"),
        ({"subap_px": [4, -8]}, ValueError, r"`subap_px`: -8: must be a whole number"),
        ({"subap_px": 8.5}, TypeError, r"`subap_px` takes a whole number of pixels, 2 to 128 .*not float 8\.5"),
        ({"subap_px": "8"}, TypeError, r"`subap_px` takes .*not str '8'"),
        ({"spot": 2}, TypeError, r"`spot` takes a spot text such as \"airy:2\".*not int 2"),
        ({"spot": ["airy:2", 3]}, TypeError, r"`spot` takes .*not int 3"),
        ({"signal_photons": "50"}, TypeError, r"`signal_photons` takes a number of photons"),
        ({"subap_px": []}, ValueError, r"`subap_px`: an empty list"),
        ({"spot": []}, ValueError, r"`spot`: an empty list"),
        ({"signal_photons": ()}, ValueError, r"`signal_photons`: an empty list"),
        ({"centroider": []}, ValueError, r"`centroider`: an empty list"),
    ]:
        for run in (detnoise.simulate, detnoise.effective):
            with pytest.raises(error, match=message):
                run(**kwargs)
    with pytest.raises(TypeError, match="`models` takes a model name"):
        detnoise.simulate(5)
    with pytest.raises(ValueError, match="`models`: an empty list"):
        detnoise.simulate([])
    with pytest.raises(ValueError, match=r"`spot`: 'airy:2,airy:3': 'airy:3' is not a diameter"):
        detnoise.simulate(spot="airy:2,airy:3")


def test_progress_stays_where_it_was_when_the_run_is_stopped():
    calls = []

    def stop(stage, done, total, unit):
        calls.append((done, total))
        if done > 0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        detnoise.simulate("scmos-random", subap_px=16, iters=200_000_000, progress=stop)
    # Not called again after it raised: the stage's end does not report its total.
    done, total = calls[-1]
    assert 0 < done < total and len([c for c in calls if c[0] > 0]) == 1, calls


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"), reason="needs POSIX signals")
def test_progress_bar_stays_where_it_was_on_ctrl_c(capfd, monkeypatch):
    # The text bar (no tqdm): its last line is the percentage reached, ended by a newline.
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    main = threading.get_ident()
    timer = threading.Timer(0.5, lambda: signal.pthread_kill(main, signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            detnoise.simulate("scmos-random", subap_px=16, iters=200_000_000, progress=True)
    finally:
        timer.cancel()
    err = capfd.readouterr().err
    last = err.rstrip("\n").split("\r")[-1]
    assert err.endswith("\n") and "100.0 %" not in err, repr(err[-300:])
    assert last.startswith("simulate: ") and "% of 200000000 frames" in last, repr(last)
