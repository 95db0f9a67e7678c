"""Shared fixtures: the real recordings and reference values in ../shared/data."""

import getpass
import os
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("JAX_PLATFORMS", "cpu")
# One cache for the run, shared by the xdist workers and the docs build's notebook kernels
# (they inherit this environment; set before JAX is first imported, which reads it then): what
# one test traced and compiled, a later test of the same structure loads (JAX's compilation
# cache, bayescal.inference._traced). Both are keyed by content digests, so a cache an earlier
# run left can never serve a stale result; deleting the folder gives a cold run.
_CACHE = Path(tempfile.gettempdir()) / f"bayescal-test-cache-{getpass.getuser()}"
os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(_CACHE / "jax"))
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
os.environ.setdefault("BAYESCAL_TRACE_CACHE", str(_CACHE / "traces"))

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
