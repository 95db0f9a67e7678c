"""The study notebooks (notebooks/*.ipynb, issue 7) execute from top to bottom without an
error, each in a fresh kernel of this environment's Python with notebooks/ as its working
directory; they are stored without outputs."""

import json
import os
import sys
import time
from pathlib import Path

import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import KernelManager
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
CELL_TIMEOUT_S = 600


def notebooks() -> list[Path]:
    return sorted(NOTEBOOKS.glob("*.ipynb"))


@pytest.fixture(scope="module")
def kernel_specs(tmp_path_factory) -> KernelSpecManager:
    """Kernel specs holding only "python3", started with this interpreter: a kernel registered
    elsewhere on the machine (another Python, another environment) is never used."""
    folder = tmp_path_factory.mktemp("kernels")
    (folder / "python3").mkdir()
    (folder / "python3" / "kernel.json").write_text(
        json.dumps(
            {
                "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                "display_name": f"Python {sys.version_info.major}.{sys.version_info.minor} "
                "(bayescal tests)",
                "language": "python",
            }
        )
    )
    return KernelSpecManager(kernel_dirs=[str(folder)], ensure_native_kernel=False)


@pytest.mark.parametrize("path", notebooks(), ids=lambda path: path.name)
def test_notebook_is_stored_without_outputs(path):
    notebook = nbformat.read(path, as_version=4)
    executed = [
        index
        for index, cell in enumerate(notebook.cells)
        if cell.cell_type == "code" and (cell.outputs or cell.execution_count is not None)
    ]
    assert not executed, f"{path.name}: clear the outputs of cells {executed} before committing"


@pytest.mark.parametrize("path", notebooks(), ids=lambda path: path.name)
def test_notebook_executes(path, kernel_specs, request, tmp_path):
    notebook = nbformat.read(path, as_version=4)
    if "shared_data" in notebook.metadata.get("bayescal", {}).get("requires", []):
        request.getfixturevalue("shared_data")  # skips when ../shared/data is absent
    manager = KernelManager(kernel_name="python3", kernel_spec_manager=kernel_specs)
    client = NotebookClient(
        notebook,
        km=manager,
        timeout=CELL_TIMEOUT_S,
        resources={"metadata": {"path": str(NOTEBOOKS)}},
    )
    started = time.perf_counter()
    try:
        # What the notebook writes to temporary folders lands in this test's tmp_path.
        client.execute(env={**os.environ, "TMPDIR": str(tmp_path)})
    finally:
        if manager.has_kernel:
            manager.shutdown_kernel()
    print(f"{path.name}: executed in {time.perf_counter() - started:.0f} s")
