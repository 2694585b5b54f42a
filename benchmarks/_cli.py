"""What every study shares: the command line (``--quick``, a short run, and ``--out``), the
machine it ran on, and the result file's header."""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

OUT = Path(__file__).parent / "results"


def loadavg() -> list[float] | None:
    """1/5/15-minute load averages (None where the OS has none): the machine is shared."""
    return list(os.getloadavg()) if hasattr(os, "getloadavg") else None


def machine_info() -> dict:
    """The machine and the versions a result was measured with."""
    import diffrax
    import equinox as eqx
    import jax
    import numpy as np
    import scipy

    import jaxchain as jc

    return {
        "platform": platform.platform(),
        "processor": platform.processor(),
        "cpu_count": os.cpu_count(),
        "cpu_affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "loadavg_at_start": loadavg(),
        "python": platform.python_version(),
        "jax_backend": jax.default_backend(),
        "versions": {
            "jax": jax.__version__,
            "diffrax": diffrax.__version__,
            "equinox": eqx.__version__,
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "jaxchain": jc.__version__,
        },
    }


def parser(doc: str | None, quick_help: str = "small, fast smoke run") -> argparse.ArgumentParser:
    """A parser with the study's docstring as its help, ``--quick`` and ``--out``; add the
    study's own options to it."""
    ap = argparse.ArgumentParser(
        description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument(
        "--out",
        type=Path,
        default=OUT,
        help="folder for the JSON and the chart (default: %(default)s)",
    )
    return ap


def parse(ap: argparse.ArgumentParser, argv=None) -> argparse.Namespace:
    """Parse, and create the output folder."""
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def shown(path: Path) -> str:
    """``path`` relative to the repository when it lies inside it (as results record it)."""
    try:
        return str(path.resolve().relative_to(Path(__file__).resolve().parents[1]))
    except ValueError:
        return str(path)


def header(study: str, argv=None) -> dict:
    """A result file's opening: the command that reproduces it (``argv``: the study's
    arguments, default the command line's), the date, and the machine (at the start)."""
    given = sys.argv[1:] if argv is None else argv
    return {
        "command": " ".join([f"python -m benchmarks.{study}", *given]),
        "date": datetime.date.today().isoformat(),
        "machine": machine_info(),
    }


def finish(
    results: dict, out: Path, name: str, chart: Callable[[dict, Path], None], start: float
) -> dict:
    """End a study: its wall time since ``start`` and the load average at the end into
    ``results``, ``out/<name>.json`` and the chart ``out/<name>.png`` written, and said."""
    results["total_s"] = time.perf_counter() - start
    results["machine"]["loadavg_at_end"] = loadavg()
    (out / f"{name}.json").write_text(json.dumps(results, indent=1))
    chart(results, out / f"{name}.png")
    print(f"wrote {out / f'{name}.json'} and {name}.png ({results['total_s']:.0f} s)")
    return results


def save_chart(fig, results: dict, path: Path, rect=(0, 0, 1, 1)) -> None:
    """Title ``fig`` with the study's command and date, lay it out inside ``rect`` (room
    left for a figure legend), write it to ``path``, close it."""
    import matplotlib.pyplot as plt

    fig.suptitle(f"{results['command']} — {results['date']}", fontsize=8)
    fig.tight_layout(rect=rect)
    fig.savefig(path, dpi=120)
    plt.close(fig)


#: The studies' scenes have frictionless chain joints (``joint_friction=None``): they
#: measure the numerical methods (solvers, tolerances, contact regularization, costs) on
#: the model their committed results were run with.
FRICTIONLESS = {"joint_friction": None}


def single_thread_env() -> None:
    """Environment of a study's solve processes (inherited at spawn): one thread each,
    equinox's in-graph checks as NaN (failures are result codes)."""
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "")
        + " --xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"
    ).strip()
    os.environ["OMP_NUM_THREADS"] = "1"
    os.environ.setdefault("EQX_ON_ERROR", "nan")
