"""Shared fixtures: the bundled synthetic stacks and the installed `detnoise` command."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data-synthetic"


def detnoise_command():
    """The `detnoise` command installed with the package (beside this Python first)."""
    beside = Path(sys.executable).parent / "detnoise"
    if beside.exists():
        return str(beside)
    found = shutil.which("detnoise")
    if found is None:
        pytest.skip("the detnoise command is not installed")
    return found


@pytest.fixture(scope="session")
def data():
    """The bundled synthetic data directory."""
    assert DATA.is_dir(), f"missing {DATA}"
    return DATA


@pytest.fixture(scope="session")
def cli():
    """Run the installed `detnoise` command; returns the completed process."""

    def run(*args, check=True):
        proc = subprocess.run(
            [detnoise_command(), *map(str, args)],
            capture_output=True,
            text=True,
        )
        if check and proc.returncode != 0:
            raise AssertionError(f"detnoise {args} failed ({proc.returncode}): {proc.stderr}")
        return proc

    return run


def simulator(name):
    """Import an AO simulator for an adapter's test. Skipped when it is not installed, except
    under ``DETNOISE_REQUIRE_AO=1`` (set by ``.ci/run``, which installs them): there a missing
    simulator fails the test instead of hiding it."""
    import importlib
    import os

    try:
        return importlib.import_module(name)
    except ImportError as e:
        if os.environ.get("DETNOISE_REQUIRE_AO") == "1":
            raise AssertionError(f"{name} must be installed for this test ({e})") from e
        pytest.skip(f"{name} is not installed")
