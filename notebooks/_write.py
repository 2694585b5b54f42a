"""Shared by the notebook generators: write ``cells`` as ``notebooks/<name>``."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_notebook

HERE = Path(__file__).parent


def write(cells, name: str) -> Path:
    """Write the notebook without outputs. Cell ids are the cells' positions
    (``cell-00``, ``cell-01``, …), so that writing the same cells again gives the same file."""
    nb = new_notebook(cells=cells)
    for i, cell in enumerate(nb.cells):
        cell.id = f"cell-{i:02d}"
    nb.metadata["kernelspec"] = {
        "display_name": "Python 3",
        "language": "python",
        "name": "python3",
    }
    nbformat.validate(nb)
    path = HERE / name
    nbformat.write(nb, path)
    print(f"wrote {path}")
    return path
