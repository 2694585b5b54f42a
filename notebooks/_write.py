"""Shared by the notebook generators: write ``cells`` as ``notebooks/<name>``."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_notebook

HERE = Path(__file__).parent


def write(cells, name: str) -> Path:
    nb = new_notebook(cells=cells)
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
