"""Regenerate the notebooks from their scripts (``notebooks/_make_0N_<name>.py``)
and, with ``--execute``, execute them in full mode in place, storing the outputs (the form
the notebooks are committed in). Run from anywhere:

    .venv/bin/python notebooks/_make_all.py --execute      # all of them
    .venv/bin/python notebooks/_make_all.py --execute 03   # notebook 03 only
    .venv/bin/python notebooks/_make_all.py                # regenerate, without outputs

Full mode: ``JAXCHAIN_FAST`` is removed from the environment the kernels inherit. The
notebooks are executed one at a time with nbclient (kernel ``python3``, no cell timeout),
each in a temporary working directory, so that files a notebook writes (01's animation)
stay out of the repository. ``MPLBACKEND`` is set to matplotlib's inline backend (Agg
rendering, no display needed): the pyplot figures of 01 and 02 are stored as outputs,
which they would not be with ``MPLBACKEND=Agg``. A notebook whose execution fails is left
regenerated without outputs; the others are still executed, and the script exits with
status 1. The test suite executes the notebooks in fast mode (``JAXCHAIN_FAST=1``) without
writing them.
"""

import argparse
import importlib
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

import nbformat
from nbclient import NotebookClient

HERE = Path(__file__).parent
INLINE = "module://matplotlib_inline.backend_inline"  # figures become outputs


def generators(numbers=()):
    """The generator modules' names, in notebook order (only ``numbers`` if given)."""
    names = sorted(p.stem for p in HERE.glob("_make_0*.py"))
    if numbers:
        names = [n for n in names if n.split("_")[2] in numbers]
        missing = set(numbers) - {n.split("_")[2] for n in names}
        if missing:
            raise SystemExit(f"no generator for notebook(s) {', '.join(sorted(missing))}")
    return names


def execute(path: Path) -> float:
    """Execute the notebook at ``path`` in full mode and write it with its outputs; the
    wall time [s]."""
    nb = nbformat.read(path, as_version=4)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as cwd:
        client = NotebookClient(
            nb,
            timeout=None,
            kernel_name="python3",
            record_timing=False,
            resources={"metadata": {"path": cwd}},
        )
        client.execute()
    nbformat.write(nb, path)
    return time.perf_counter() - start


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--execute", action="store_true", help="execute in full mode, in place")
    ap.add_argument("numbers", nargs="*", help="notebook numbers (01, 02, …); default all")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(HERE))  # the generators import _write
    paths = [importlib.import_module(name).main() for name in generators(args.numbers)]
    if not args.execute:
        return 0
    os.environ.pop("JAXCHAIN_FAST", None)  # full mode
    os.environ["MPLBACKEND"] = INLINE
    failed = []
    for path in paths:
        print(f"executing {path.name} in full mode …", flush=True)
        try:
            wall = execute(path)
        except Exception:
            traceback.print_exc()
            print(f"{path.name} failed: left without outputs", flush=True)
            failed.append(path.name)
        else:
            print(f"executed {path.name} in {wall:.0f} s", flush=True)
    if failed:
        print(f"failed: {', '.join(failed)}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
