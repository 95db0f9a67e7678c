"""The study notebooks (notebooks/*.ipynb, issue 7) are stored without outputs: the docs build
executes them (tests/test_docs.py runs it; a cell that raises fails it) and renders them with
their figures, so a committed output would only be a stale copy of what the build makes."""

from pathlib import Path

import nbformat
import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"


@pytest.mark.parametrize("path", sorted(NOTEBOOKS.glob("*.ipynb")), ids=lambda path: path.name)
def test_notebook_is_stored_without_outputs(path):
    notebook = nbformat.read(path, as_version=4)
    executed = [
        index
        for index, cell in enumerate(notebook.cells)
        if cell.cell_type == "code" and (cell.outputs or cell.execution_count is not None)
    ]
    assert not executed, f"{path.name}: clear the outputs of cells {executed} before committing"
