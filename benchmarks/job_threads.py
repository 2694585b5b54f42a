"""The main job's objective on every core: its speed groups one after the other, against
each group built, settled and solved in a thread of its own (``SpeedGroups``' default).

    python -m benchmarks.job_threads            # 3 interleaved repeats (~6 min)
    python -m benchmarks.job_threads --quick    # 1 repeat

The objective is the committed main-job run's (``results/optimize_default/``: six
operating points in three speed groups, the 7-coordinate free-form tooth), at the middle
of its box. After the first calls (compiles), each repeat times ``value_and_grad`` and
``value`` one group after the other (``threads=1``) and in threads (one per core), the
two ways interleaved so that both see the machine alike; the wall and CPU times of each
call are recorded, and the two ways' results compared bit for bit. Writes
``job_threads.json`` and ``job_threads.png``.
"""

from __future__ import annotations

import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart, shown  # noqa: E402
from benchmarks.designs import add_run_option, read_run, settings_of  # noqa: E402
from optimize.problem import make_problem  # noqa: E402

WAYS = {"one by one": 1, "threads": None}  # SpeedGroups.threads


def _timed(call) -> tuple[float, float, list]:
    """Wall and CPU seconds of ``call()`` (its arrays waited for), and its arrays."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = [np.asarray(x) for x in call()[:-1]]
    return time.perf_counter() - wall, time.process_time() - cpu, out


def measure(run: dict, repeats: int) -> dict:
    s = settings_of(run, run["settings"]["dt"], run["settings"]["samples"], "own")
    reference = max(run["baselines"][f]["peak_N"] for f in ("min", "max", "mid"))
    objective = make_problem(s).make_objective(reference)
    u = np.zeros(len(run["gradient_free"]["best_u"]))
    first = {}
    for name, call in (("value_and_grad", objective.value_and_grad), ("value", objective.value)):
        wall, cpu, _ = _timed(lambda call=call: call(u))
        first[name] = {"wall_s": wall, "cpu_s": cpu}
    rows, kept, same = [], {}, True
    for k in range(repeats):
        for way, threads in WAYS.items():
            objective.threads = threads
            for name in ("value_and_grad", "value"):
                wall, cpu, out = _timed(lambda name=name: getattr(objective, name)(u))
                rows.append({"repeat": k, "way": way, "call": name, "wall_s": wall, "cpu_s": cpu})
                ref = kept.setdefault(name, out)
                same &= all(np.array_equal(a, b) for a, b in zip(ref, out, strict=True))
                print(f"repeat {k} {way:10s} {name:14s} {wall:6.1f} s wall, {cpu:6.1f} s CPU")
    summary = {}
    for name in ("value_and_grad", "value"):
        walls = {
            way: [r["wall_s"] for r in rows if r["way"] == way and r["call"] == name]
            for way in WAYS
        }
        summary[name] = {
            "median_wall_s": {way: float(np.median(w)) for way, w in walls.items()},
            "speed_up": float(np.median(walls["one by one"]) / np.median(walls["threads"])),
        }
    return {
        "groups": len(objective.groups),
        "members": len(s.ensemble) * len(s.wear),
        "threads": jc.design.solve_threads(),
        "first_calls": first,
        "rows": rows,
        "summary": summary,
        "bit_for_bit": bool(same),
    }


def chart(results: dict, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8, 3.2))
    for ax, name in zip(axes, ("value_and_grad", "value"), strict=True):
        for i, way in enumerate(WAYS):
            walls = [r["wall_s"] for r in results["rows"] if r["way"] == way and r["call"] == name]
            ax.scatter([i] * len(walls), walls, label=way)
            ax.hlines(np.median(walls), i - 0.2, i + 0.2, color="k")
        ax.set_xticks(range(len(WAYS)), list(WAYS))
        ax.set_xlim(-0.5, len(WAYS) - 0.5)
        ax.set_ylim(bottom=0)
        speed_up = results["summary"][name]["speed_up"]
        ax.set_title(f"{name}: {speed_up:.2f}× in threads", fontsize=9)
        ax.set_ylabel("wall time per call [s]")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="one repeat")
    add_run_option(ap)
    args = parse(ap, argv)
    run = read_run(args.run)
    start = time.perf_counter()
    results = {
        **header("job_threads", argv),
        "run": shown(args.run),
        **measure(run, 1 if args.quick else 3),
    }
    for name, row in results["summary"].items():
        walls = row["median_wall_s"]
        print(
            f"{name}: one by one {walls['one by one']:.1f} s, in threads {walls['threads']:.1f}"
            f" s: {row['speed_up']:.2f}x; bit for bit: {results['bit_for_bit']}"
        )
    return finish(results, args.out, "job_threads", chart, start)


if __name__ == "__main__":
    main()
