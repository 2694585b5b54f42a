"""What every study shares: the command line (``--quick``, a short run, and ``--out``), the
machine it ran on, the result file's header and chart, timing on a shared machine, and
the standard operating point's tooth period."""

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
#: the archived one-off studies' results (``benchmarks/archive/``)
ARCHIVE = Path(__file__).parent / "archive" / "results"


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


def parser(
    doc: str | None, quick_help: str = "small, fast smoke run", out: Path = OUT
) -> argparse.ArgumentParser:
    """A parser with the study's docstring as its help, ``--quick`` and ``--out`` (default
    ``out``: ``benchmarks/results``, or an archived study's own folder); add the study's own
    options to it."""
    ap = argparse.ArgumentParser(
        description=doc, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument(
        "--out",
        type=Path,
        default=out,
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


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so a reader (or a resumed study) sees the old file or
    the new one, never half of one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def jsonable(x):
    """``x`` as JSON takes it: numpy scalars as numbers, non-finite floats as null,
    arrays in dicts left out."""
    import math

    import numpy as np

    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def save_chart(fig, results: dict, path: Path, rect=(0, 0, 1, 1)) -> None:
    """Title ``fig`` with the study's command and date, lay it out inside ``rect`` (room
    left for a figure legend), write it to ``path``, close it."""
    write_chart(fig, path, f"{results['command']} — {results['date']}", rect=rect, fontsize=8)


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


RPM = 1000.0  # the standard operating point's driver speed


def tooth_period(teeth: int, rpm: float = RPM) -> float:
    """One tooth period [s] of a ``teeth``-tooth sprocket at ``rpm``."""
    return 60.0 / rpm / teeth


MAX_REPEATS = 15  # timing runs at most (see more_repeats)


def more_repeats(walls, at_least: int, min_time_s: float, max_repeats: int = MAX_REPEATS) -> bool:
    """Whether a timing needs another run: fewer than ``at_least`` so far, or less than
    ``min_time_s`` timed in fewer than ``max_repeats`` runs — a short run's minimum needs
    more samples to get past the bursts of a shared machine. (One rule for every side of
    a comparison: :func:`timed` and the SciPy study's loop.)"""
    return len(walls) < at_least or (sum(walls) < min_time_s and len(walls) < max_repeats)


def timed(call, repeats: int, *, min_time_s: float = 0.0, max_repeats: int = MAX_REPEATS):
    """(result of the last call, first-call time, min and all warm times): ``repeats``
    warm calls, more (up to ``max_repeats``) until they add up to ``min_time_s`` (see
    :func:`more_repeats`)."""
    import jax

    t = time.perf_counter()
    out = call()
    jax.block_until_ready(out["peak"])
    first = time.perf_counter() - t
    walls = []
    while more_repeats(walls, repeats, min_time_s, max_repeats):
        t = time.perf_counter()
        out = call()
        jax.block_until_ready(out["peak"])
        walls.append(time.perf_counter() - t)
    return out, first, min(walls), walls


def vf_time(scene, n=2000) -> float:
    """µs per vector-field call inside a jitted loop."""
    import jax

    import jaxchain as jc

    y0 = jc.initial_state(scene)

    @jax.jit
    def run(y, sc):
        def body(i, y):
            d = jc.vector_field(i * 1e-9, y, sc)
            return jax.tree_util.tree_map(lambda a, b: a + 1e-15 * b, y, d)

        return jax.lax.fori_loop(0, n, body, y)

    jax.block_until_ready(run(y0, scene))
    t = time.perf_counter()
    jax.block_until_ready(run(y0, scene))
    return (time.perf_counter() - t) / n * 1e6


# ------------------------------------------------------------------------ standard scenes
# the closed drive of the quiet_drive and drive_gradient studies
DRIVE_CHAIN = "08B"
DRIVE_Z, DRIVE_Z_DRIVEN, DRIVE_N_LINKS = 18, 36, 60
DRIVE_LOAD, DRIVE_PRETENSION = 40.0, 300.0


def quiet_drive_scene(driver, rpm: float, **model):
    """The study's settled drive with ``driver`` as the z = 18 driver's profile at ``rpm``
    (``model``: fields of its ``jc.scenes.ChainModel``: ``roller_contact``,
    ``joint_friction``, ...)."""
    import jaxchain as jc

    chain = jc.ChainSpec.iso606(DRIVE_CHAIN)
    return jc.scenes.drive(
        chain,
        teeth=(DRIVE_Z, DRIVE_Z_DRIVEN),
        n_links=DRIVE_N_LINKS,
        speed_rpm=rpm,
        load_torque=DRIVE_LOAD,
        pretension=DRIVE_PRETENSION,
        profiles=[driver, jc.ToothProfile.iso606(chain, DRIVE_Z_DRIVEN, "min")],
        model=jc.scenes.ChainModel(**model),
    )


def modelled(**kwargs) -> dict:
    """A builder's keywords with the chain model's fields (``jc.scenes.ChainModel``) moved
    into ``model=``: for studies that gather a scene's keywords in a dict (as
    :data:`FRICTIONLESS`)."""
    import dataclasses

    import jaxchain as jc

    names = {f.name for f in dataclasses.fields(jc.scenes.ChainModel)}
    fields = {k: kwargs.pop(k) for k in list(kwargs) if k in names}
    if fields:
        model = kwargs.pop("model", None) or jc.scenes.ChainModel()
        kwargs["model"] = model.replace(**fields)
    return kwargs


# ------------------------------------------------------------------ timed solves, charts
def timed_solve(scene, t1: float, **kw):
    """A solve of ``scene`` over ``t1`` (``throw=False``), its wall time and this process's
    CPU time (all threads) [s]."""
    import jax

    import jaxchain as jc

    t, c = time.perf_counter(), time.process_time()
    sol = jc.simulate(scene, t1, throw=False, **kw)
    jax.block_until_ready(sol.peak_contact_force)
    return sol, time.perf_counter() - t, time.process_time() - c


def compile_time(scene, t1: float = 2e-5) -> tuple[float, float]:
    """Compile time of ``simulate`` on ``scene``: a first call over ``t1`` (3 saves) less
    a warm one, in wall and in CPU time [s]."""
    _, cold, cold_cpu = timed_solve(scene, t1, n_save=3)
    _, warm, warm_cpu = timed_solve(scene, t1, n_save=3)
    return cold - warm, cold_cpu - warm_cpu


def probe_drive(n_links: int, fidelity: str = "lumped"):
    """The compile probes' drive: 08B, 18/36 teeth, ``n_links`` links, frictionless joints
    (:data:`FRICTIONLESS`), started from its layout (not settled)."""
    import jaxchain as jc

    return jc.scenes.drive(
        "08B",
        **modelled(
            teeth=(18, 36),
            n_links=n_links,
            fidelity=fidelity,
            **FRICTIONLESS,
            model=jc.scenes.ChainModel(settle=False),
        ),
    )


def figure(*args, **kwargs):
    """``plt.subplots(*args, **kwargs)`` on matplotlib's file backend (Agg)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


def write_chart(fig, path: Path, title: str | None = None, rect=(0, 0, 1, 1), **title_kw) -> None:
    """Title ``fig`` with ``title`` (if given; ``title_kw``: ``suptitle``'s keywords), lay
    it out inside ``rect``, write it to ``path`` at 120 dpi, close it."""
    import matplotlib.pyplot as plt

    if title is not None:
        fig.suptitle(title, **title_kw)
    fig.tight_layout(rect=rect)
    fig.savefig(path, dpi=120)
    plt.close(fig)
