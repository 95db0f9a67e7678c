"""Shared fixtures: the real recordings and reference values in ../shared/data."""

import os
from pathlib import Path

import pytest

from bayescal._caches import enable_caches

os.environ.setdefault("JAX_PLATFORMS", "cpu")
# The caches the command line keeps (JAX's compilations and bayescal's traced optimisers), set
# before JAX is imported: both test workers, the notebooks' kernels of the docs build and the
# commands run in-process share what one of them compiled, as a user's runs do. Their keys are
# the computations themselves, and a cached function gives the same numbers to the last bit
# (tests/test_traced.py), so sharing them changes no result, only the time.
enable_caches()

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """../shared/data beside the project root (present in CI)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture
def run_cli(capsys):
    """Run ``bayescal`` in-process; returns (exit code, stdout, stderr)."""
    from bayescal.cli import main

    def run(*argv):
        try:
            code = main([str(arg) for arg in argv])
        except SystemExit as exit_:
            code = exit_.code
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return run
