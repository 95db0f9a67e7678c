"""Shared fixtures: the real recordings and reference values in ../shared/data."""

import os
from pathlib import Path

import pytest

from bayescal._caches import enable_caches, release_compiled_code

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


def pytest_runtest_teardown(item, nextitem):
    """Each test worker compiles thousands of models in one process; their code would pass
    Linux's limit on memory maps near the end of a run and kill the worker inside XLA (seen:
    a segmentation fault at 65,408 maps). The library drops it before each public fit;
    tests that call the layers below directly are covered here."""
    release_compiled_code()
