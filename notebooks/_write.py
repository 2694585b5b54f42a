"""Shared by the notebook generators: write ``cells`` as ``notebooks/<name>``."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_notebook

HERE = Path(__file__).parent

# what every notebook's first cell sets up (inserted into its source by the generators):
# float64, and the persistent compilation cache in the repository
X64 = """jax.config.update("jax_enable_x64", True)  # jaxchain never changes JAX config itself
os.environ.setdefault("EQX_ON_ERROR", "nan")  # failures are result codes here (see below)
"""
CACHE = """
# compiled solves persist across kernel restarts in the repository's .jax_cache/ (XLA keeps
# computations without host callbacks: hence equinox's in-graph checks as NaN above)
CACHE = Path(jc.__file__).resolve().parents[1] / ".jax_cache"
jax.config.update(
    "jax_compilation_cache_dir", os.environ.get("JAX_COMPILATION_CACHE_DIR", str(CACHE))
)
"""

# notebooks that read or run a study import it from the repository's benchmarks/
BENCHMARKS = """
root = Path(jc.__file__).resolve().parents[1]  # the repository, for benchmarks/
if (root / "benchmarks").is_dir() and str(root) not in sys.path:
    sys.path.insert(0, str(root))
"""


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
