"""The package's layers: every import (module level or inside a function) goes one way,
recording -> classical -> models -> navigation -> inference -> capabilities -> report -> cli,
and no module imports itself back through others. The command line loads nothing heavy to
parse its arguments."""

import ast
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bayescal"
LAYERS = (
    "recording",
    "classical",
    "models",
    "navigation",
    "inference",
    "capabilities",
    "report",
    "cli",
)
FOUNDATION = (
    "bayescal._errors",
    "bayescal._output",
    "bayescal._caches",
    "bayescal._threads",
    "bayescal._stages",
    "bayescal._x64",
    "bayescal",
)
"""Imported by every layer: the errors, the atomic writer, the compilation caches, the
threads of the parallel steps, the stages' timer, JAX's precision, the lazy public names."""


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """The bayescal modules ``path`` imports, anywhere in it."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names if alias.name.startswith("bayescal")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            if not target.startswith("bayescal"):
                continue
            for alias in node.names:  # `from . import _x` imports a module
                candidate = f"{target}.{alias.name}"
                is_module = (PACKAGE.parent / (candidate.replace(".", "/") + ".py")).exists()
                is_package = (PACKAGE.parent / candidate.replace(".", "/")).is_dir()
                found.add(candidate if is_module or is_package else target)
    return found


def layer(module: str) -> int:
    if module in FOUNDATION:
        return -1
    return LAYERS.index(module.split(".")[1])


GRAPH = {module_name(path): imports(path) for path in PACKAGE.rglob("*.py")}


def test_every_module_belongs_to_a_layer():
    for module in GRAPH:
        assert module in FOUNDATION or module.split(".")[1] in LAYERS, module


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_go_one_way(module):
    for target in GRAPH[module]:
        assert layer(target) <= layer(module), f"{module} imports {target}, a layer above it"


def test_no_import_cycle():
    state: dict[str, int] = {}

    def visit(module, path):
        if state.get(module) == 1:
            raise AssertionError("import cycle: " + " -> ".join([*path, module]))
        if state.get(module) == 2:
            return
        state[module] = 1
        for target in sorted(GRAPH.get(module, ())):
            if target != "bayescal":  # the lazy public list imports nothing at load
                visit(target, [*path, module])
        state[module] = 2

    for module in sorted(GRAPH):
        visit(module, [])


def test_the_command_line_parses_without_the_heavy_libraries():
    """``bayescal --help`` and argument errors must answer at once: parsing imports none of
    JAX, ArviZ, numba, SciPy's statistics or matplotlib (benchmarks/cli_startup.py times it)."""
    code = (
        "import sys, json; from bayescal.cli._main import build_parser; build_parser(); "
        "print(json.dumps(sorted(m for m in sys.modules)))"
    )
    loaded = json.loads(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout
    )
    heavy = {"jax", "arviz", "arviz_base", "numba", "matplotlib", "scipy.stats", "emcee"}
    assert not heavy & set(loaded), heavy & set(loaded)


def test_a_classical_only_run_loads_neither_jax_nor_scipys_statistics(tmp_path):
    """``bayescal noise FILE --classical-only`` reads, analyses and reports without JAX (the
    registry of terms: about 1 s to import), SciPy's statistics (0.5-1 s), ArviZ or emcee."""
    path = tmp_path / "gyro.csv"
    # Values on no grid: a grid's step is tested (recording._levels) with SciPy's statistics.
    values = (f"{0.01 * math.sin(1.7 * k * k):.12f}" for k in range(600))
    path.write_text("gyro_x\n" + "\n".join(values))
    code = (
        "import sys, json, io, contextlib; from bayescal.cli._main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    code = main(['noise', {str(path)!r}, '--channel', 'gyro_x', '--rate', '100', "
        "'--classical-only'])\n"
        "print(json.dumps([code, sorted(m for m in sys.modules)]))"
    )
    code, loaded = json.loads(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.splitlines()[-1]
    )
    assert code == 0
    heavy = {"jax", "equinox", "scipy.stats", "arviz", "arviz_base", "arviz_stats", "emcee"}
    assert not heavy & set(loaded), heavy & set(loaded)
