"""Independent re-measurement of per-tooth designs: the every-gap row of the ``methods``
study, every gap meshed with the nominal model.

    python -m benchmarks.archive.pattern_remeasure            # the every-gap designs (~6 min)
    python -m benchmarks.archive.pattern_remeasure --quick    # the start and Adam's design, looser

Writes ``benchmarks/archive/results/pattern_remeasure.json`` and ``pattern_remeasure.png``.

``python -m benchmarks.methods --dimensions 36g`` designs a per-tooth pattern (each gap's
seating radius ±20 µm and clockwise seat angle ±0.04 rad around the ISO 606 mid form, 36
coordinates) against the design model's soft peak over every gap: the sprocket turned
three pitches further in each of six members, fixed 4 µs Tsit5 steps, contact onset
widened to 3 µm, joint creep band 20 mm/s. Here each method's best pattern, the uniform
start (u = 0) and the uniform ISO 606 minimum form (the better ISO form on this scene) are
solved again as the main job re-measures: the same six turned members settled afresh with
the nominal roller law (Johnson, 10 nm onset) and nominal joint friction, Dopri8 at rtol
``--rtol`` (atol rtol·1e-3), and the *sharp* maximum of the roller/tooth force over tooth
periods 2–4 from dense output every ≤ 0.5 µs; then once more with the second law (Hertz,
one stiffness for every design, ``optimize.problem.second_law``). The worst member is the
worst gap's engagement.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from benchmarks.common import ARCHIVE, finish, header, parse, parser, save_chart, shown

RESULT = Path(__file__).parents[1] / "results" / "methods_every_gap.json"


def run_name(run: dict) -> str:
    """A methods run's name: its method, and its seed where it has one."""
    return run["method"] + (f" seed {run['seed']}" if run.get("seed") is not None else "")


def designs(result: dict, size: int, quick: bool) -> dict[str, np.ndarray | None]:
    """The coordinates re-measured: the start (u = 0), each method's best pattern (Adam
    only with ``quick``); ``None`` stands for the uniform ISO minimum form."""
    row = result["rows"][0]
    out: dict = {"start (uniform ISO mid)": np.zeros(size)}
    for run in row["runs"]:
        if quick and run["method"] != "Adam":
            continue
        out[run_name(run)] = np.asarray(run["best_u"])
    if not quick:
        out["uniform ISO min form"] = None
    return out


def main(argv=None) -> dict:
    ap = parser(__doc__, out=ARCHIVE, quick_help="the start and Adam's design, rtol 1e-7")
    ap.add_argument("--result", type=Path, default=RESULT, help="a methods result file")
    ap.add_argument("--rtol", type=float, default=None, help="default 1e-9 (quick: 1e-7)")
    args = parse(ap, argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxchain as jc
    from benchmarks import designs as gc
    from benchmarks.designs import laws, remeasure as measure, space_of

    result = json.loads(args.result.read_text())
    row = result["rows"][0]
    if not row["space"].endswith("g"):
        raise SystemExit(f"{args.result}: its first row ({row['space']}) is not an every-gap row")
    rtol = args.rtol or (1e-7 if args.quick else 1e-9)
    start = time.perf_counter()
    space = space_of(row["space"], gc.spaces())
    models = laws()
    iso_min = jc.ToothProfile.iso606(gc.CHAIN, gc.Z, "min")
    objective = {run_name(r): r["best_N"] for r in row["runs"]}
    rows = []
    for name, u in designs(result, space.size, args.quick).items():
        profile = iso_min if u is None else space.profile(u)
        design_value = row["start_N"] if name.startswith("start") else objective.get(name)
        entry = {
            "design": name,
            "u": None if u is None else u.tolist(),
            "objective_N": design_value,
        }
        for law, contact in models.items():
            t = time.perf_counter()
            entry[law] = measure(profile, contact, rtol)
            entry[law]["seconds"] = time.perf_counter() - t
        rows.append(entry)
        print(
            f"{name:24s} Johnson worst gap {entry['johnson']['peak_N']:7.1f} N, Hertz "
            f"{entry['hertz']['peak_N']:7.1f} N",
            flush=True,
        )
    base = rows[0]
    for r in rows:
        r["change_vs_start"] = {law: r[law]["peak_N"] / base[law]["peak_N"] - 1 for law in models}
    results = {
        **header("pattern_remeasure", argv),
        "source": shown(args.result),
        "space": f"{row['space']}: {space.size} per-gap coordinates of {row['names']}",
        "rtol": rtol,
        "window_s": [gc.PERIOD, gc.EVERY_GAP_PERIODS * gc.PERIOD],
        "rows": rows,
    }
    return finish(results, args.out, "pattern_remeasure", chart, start)


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["rows"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    for ax, law, title in zip(
        axes, ("johnson", "hertz"), ("nominal law (Johnson)", "second law (Hertz)"), strict=True
    ):
        for i, r in enumerate(rows):
            m = r[law]["members_N"]
            ax.plot(np.arange(len(m)) + 0.08 * (i - len(rows) / 2), m, "o", label=r["design"])
        ax.set_xlabel("member (sprocket turned 3 more pitches each)")
        ax.set_ylabel("sharp peak, periods 2–4 [N]")
        ax.set_title(f"Re-measured: {title}, rtol {results['rtol']:g}")
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(rows), fontsize=8)
    save_chart(fig, results, path, rect=(0, 0.07, 1, 1))


if __name__ == "__main__":
    main()
