"""The trace cache (bayescal.inference._traced): a traced function stored by one run is
loaded by the next and computes the same numbers, to the last bit; what cannot be described
stably is never stored; an unreadable entry is traced again; a first trace says so beside
the progress bar; the caches are on for the library by default (bayescal._caches)."""

import os

import jax.numpy as jnp
import numpy as np
import pytest

from bayescal.inference import _traced


def _weighted_norm(scale, vector, power):
    return scale * jnp.sum(jnp.abs(vector) ** power)


class _Unstable:
    """A static argument printed with its address: no stable key."""

    def __init__(self, power):
        self.power = power


def _with_object(vector, holder):
    return jnp.sum(vector**holder.power)


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv(_traced.TRACE_CACHE, str(tmp_path))
    return tmp_path


def test_a_stored_function_is_loaded_by_the_next_run_and_computes_the_same(folder, monkeypatch):
    vector = np.linspace(-1.0, 2.0, 7)
    first = _traced.persistent_jit(_weighted_norm)(np.float64(1.5), vector, 3.0)
    stored = list(folder.glob("_weighted_norm-*.stablehlo"))
    assert len(stored) == 1
    # A new process: a fresh wrapper, which must load and never trace.
    monkeypatch.setattr(_traced, "_export_and_store", lambda *a: pytest.fail("traced again"))
    second = _traced.persistent_jit(_weighted_norm)(np.float64(1.5), vector, 3.0)
    assert np.asarray(second).tobytes() == np.asarray(first).tobytes()
    assert float(first) == pytest.approx(1.5 * np.sum(np.abs(vector) ** 3), rel=1e-14)


def test_static_values_and_shapes_key_separate_entries(folder):
    cached = _traced.persistent_jit(_weighted_norm)
    cached(np.float64(1.0), np.ones(4), 2.0)
    cached(np.float64(1.0), np.ones(4), 3.0)  # another static power
    cached(np.float64(1.0), np.ones(5), 2.0)  # another shape
    cached(np.float64(2.0), np.ones(4), 2.0)  # another value of an array: the same entry
    assert len(list(folder.glob("*.stablehlo"))) == 3


def test_an_unstable_static_argument_is_computed_but_never_stored(folder):
    value = _traced.persistent_jit(_with_object)(np.arange(3.0), _Unstable(2))
    assert float(value) == 5.0
    assert not list(folder.iterdir())


def test_an_unreadable_entry_is_traced_and_stored_again(folder):
    vector = np.arange(4.0)
    expected = float(_traced.persistent_jit(_weighted_norm)(np.float64(1.0), vector, 2.0))
    (entry,) = folder.glob("*.stablehlo")
    entry.write_bytes(b"not a flatbuffer")
    again = float(_traced.persistent_jit(_weighted_norm)(np.float64(1.0), vector, 2.0))
    assert again == expected
    assert entry.read_bytes() != b"not a flatbuffer"


def test_without_the_variable_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.delenv(_traced.TRACE_CACHE, raising=False)
    monkeypatch.chdir(tmp_path)
    assert float(_traced.persistent_jit(_weighted_norm)(np.float64(2.0), np.ones(3), 2.0)) == 6.0
    assert not list(tmp_path.iterdir())


def test_a_function_with_captured_values_is_computed_but_never_stored(folder):
    """Two closures share one qualified name and capture different powers: keyed by the name,
    the second would be served the first's trace."""

    def power_of(power):
        return lambda vector: jnp.sum(vector**power)

    def apply(function, vector):
        return function(vector)

    cached = _traced.persistent_jit(apply)
    assert float(cached(power_of(2), np.arange(3.0))) == 5.0
    assert float(cached(power_of(3), np.arange(3.0))) == 9.0
    assert not list(folder.iterdir())


def test_a_first_trace_is_announced_once_where_progress_was_asked(folder, capsys):
    vector = np.arange(3.0)
    with _traced.announcing(True):
        _traced.persistent_jit(_weighted_norm)(np.float64(1.0), vector, 1.0)
        _traced.persistent_jit(_weighted_norm)(np.float64(1.0), vector, 3.0)  # another trace
    assert capsys.readouterr().err.count("compiling the model's functions") == 1
    _traced.persistent_jit(_weighted_norm)(np.float64(1.0), vector, 4.0)  # not asked for
    assert capsys.readouterr().err == ""


def test_the_caches_default_to_the_users_cache_folder_and_leave_a_set_variable(
    tmp_path, monkeypatch
):
    from bayescal import _caches

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv(_caches.TRACE_CACHE, raising=False)
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "elsewhere"))
    _caches.enable_caches()
    assert os.environ[_caches.TRACE_CACHE] == str(tmp_path / "bayescal" / "traces")
    assert os.environ["JAX_COMPILATION_CACHE_DIR"] == str(tmp_path / "elsewhere")
    assert (tmp_path / "bayescal" / "jax").is_dir()


@pytest.mark.skipif(not os.path.exists("/proc/self/maps"), reason="memory maps are read on Linux")
def test_compiled_code_is_released_before_the_process_runs_out_of_memory_maps(monkeypatch):
    """XLA's CPU code holds memory maps until JAX drops the function: past Linux's limit
    the next compilation dies of a segmentation fault (seen in a full test run), so a public
    call drops them first when the maps pass the given fraction of the limit, and a
    dropped function computes the same numbers when compiled again."""
    import jax

    from bayescal import _caches

    def maps():
        with open("/proc/self/maps") as file:
            return sum(1 for _ in file)

    vector = np.linspace(-1.0, 2.0, 7)
    functions = [jax.jit(lambda v, k=k: jnp.sum(v ** (k % 5)) + k) for k in range(40)]
    before = [float(f(vector)) for f in functions]
    held = maps()
    assert not _caches.release_compiled_code(fraction=1.0)
    assert maps() >= held - 10
    limit = int(_caches.MAP_LIMIT.read_text())
    assert _caches.release_compiled_code(fraction=(held - 1) / limit)
    assert maps() < held - 40  # forty functions' code returned
    assert [float(f(vector)) for f in functions] == before
