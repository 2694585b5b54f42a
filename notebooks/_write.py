"""Shared by the notebook generators: write ``cells`` as ``notebooks/<name>``."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

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


# every notebook's first output: the jaxchain version, the commit of the checkout it is
# installed from, the date and the mode; the last cell (appended by ``write``) adds the run
# time to the same output. Inserted at the end of the first code cell, after ``import
# jaxchain as jc``.
STAMP = """
# what ran, and when: this line is the notebook's first output; its last cell adds the run time
import datetime
import subprocess
from time import perf_counter

import IPython.display


def commit():
    \"\"\"The commit of the checkout jaxchain is installed from (\"-dirty\": with local changes).\"\"\"
    repo = Path(jc.__file__).resolve().parents[1]
    if not (repo / ".git").exists():
        return "none (installed package)"
    try:
        git = ["git", "describe", "--always", "--dirty", "--abbrev=7"]
        out = subprocess.run(git, cwd=repo, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return "unknown (no git)"
    return out.stdout.strip() or "unknown"


START = perf_counter()
STAMP = (
    f"jaxchain {jc.__version__}, commit {commit()}, run "
    f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, "
    f"{'fast' if os.environ.get('JAXCHAIN_FAST') == '1' else 'full'} mode"
)
stamp = IPython.display.display({"text/plain": STAMP + ", running …"}, raw=True, display_id=True)
"""

# the last cell of every notebook (``write`` appends it): the run time, into the first output
ELAPSED = """RUN_TIME = perf_counter() - START  # from the first code cell to here
stamp.update({"text/plain": f"{STAMP}, run time {RUN_TIME:.0f} s"}, raw=True)
print(f"run time {RUN_TIME:.0f} s ({STAMP})")"""

# where a notebook runs from (``write(..., runs_from=...)``), appended to its first cell
PACKAGE = """**Runs from** any installation of jaxchain (a clone installed with `pip install -e .`, or
the package alone), from any directory."""
CHECKOUT = """**Runs from** a checkout of the repository with jaxchain installed from it (`pip install -e
".[optimize]"` in the clone, as the README's set-up does), from any directory: it {what},
found next to the installed package. The package installed on its own is not enough."""

# notebooks 01 and 05: jc.animate's GIF shown inline with matplotlib's JavaScript player
PLAYER = """import base64
import io
import tempfile

from IPython.display import HTML
from matplotlib.animation import FuncAnimation, HTMLWriter
from PIL import Image as PILImage, ImageSequence


class PaletteHTMLWriter(HTMLWriter):
    \"\"\"matplotlib's JavaScript player (as ``anim.to_jshtml()``), its frames stored as
    64-colour PNGs: a sixth of full-colour ones, so the notebook stays light.\"\"\"

    def grab_frame(self, **savefig_kwargs):
        rgba = io.BytesIO()
        self.fig.savefig(rgba, format="png", dpi=self.dpi, **savefig_kwargs)
        frame = io.BytesIO()
        PILImage.open(rgba).convert("RGB").quantize(64).save(frame, format="png", optimize=True)
        self._saved_frames.append(base64.encodebytes(frame.getvalue()).decode("ascii"))


def player(path, fps):
    \"\"\"The animation at ``path`` (a GIF from ``jc.animate``) inline, with play and scrub
    controls.\"\"\"
    with PILImage.open(path) as gif:
        frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(gif)]
    height, width = frames[0].shape[:2]
    fig = plt.figure(figsize=(width / 100, height / 100), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_axis_off()
    image = ax.imshow(frames[0])
    anim = FuncAnimation(fig, lambda i: [image.set_data(frames[i])], frames=len(frames))
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / "player.html"
        anim.save(page, writer=PaletteHTMLWriter(fps=fps, embed_frames=True, default_mode="loop"))
        html = page.read_text()
    plt.close(fig)
    return HTML(html)"""


def write(cells, name: str, *, checkout: str | None = None, runs_from: str | None = None) -> Path:
    """Write the notebook without outputs, with the stamp's closing cell appended (its first
    code cell must set up the stamp: ``STAMP``) and where it runs from added to its first
    (markdown) cell: any installation, or with ``checkout`` (what it imports from the
    repository: ``"imports `benchmarks.stability`"``) a checkout; ``runs_from`` replaces that
    text. Cell ids are the cells' positions
    (``cell-00``, ``cell-01``, …), so that writing the same cells again gives the same file."""
    first = next(c for c in cells if c.cell_type == "code")
    if STAMP.strip() not in first.source or cells[0].cell_type != "markdown":
        raise ValueError(f"{name}: the first cell must be markdown, the first code cell stamp")
    if runs_from is None:
        runs_from = PACKAGE if checkout is None else CHECKOUT.format(what=checkout)
    cells = [
        new_markdown_cell(cells[0].source + "\n\n" + runs_from),
        *cells[1:],
        new_code_cell(ELAPSED),
    ]
    nb = new_notebook(cells=cells)
    for i, cell in enumerate(nb.cells):
        cell.id = f"cell-{i:02d}"
        if cell.cell_type == "code":  # as ruff formats a notebook's cells
            cell.source = cell.source.rstrip("\n")
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
