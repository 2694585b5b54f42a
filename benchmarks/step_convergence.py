"""Does the main job's design gradient converge as the fixed step shrinks?

    python -m benchmarks.step_convergence            # 4, 2 and 1 µs at two points (~5 min)
    python -m benchmarks.step_convergence --quick    # 4 and 2 µs at the box middle

The main job's default objective (``python -m optimize``: six operating points, the soft
maximum of their soft peaks, the 7-coordinate free-form tooth, the design contact law and
joint friction; built as the run builds it, from the committed run's settings and
reference in ``results/optimize_default/``) at fixed steps of 4 µs (the job's), 2 µs and
1 µs: its value and reverse-mode gradient at the middle of the box (u = 0) and at the
run's Nelder–Mead design. Reverse mode equals central differences of each discrete
objective (tests/test_design.py, tests/test_orders.py); this study asks whether those
discrete gradients approach one limit as the step shrinks, as the values do. Reported per
point and step, against the finest step: the value's relative change, the gradient's
relative distance |g − g_fine| / |g_fine| and its cosine with g_fine. Writes
``step_convergence.json`` and ``step_convergence.png``.
"""

from __future__ import annotations

import datetime
import json
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks._cli import finish, parse, parser, shown  # noqa: E402
from benchmarks.work_precision import machine_info  # noqa: E402
from optimize.problem import Settings, make_problem  # noqa: E402

RUN = Path(__file__).parent / "results" / "optimize_default" / "results.json"


def settings_of(run: dict, dt: float) -> Settings:
    """The run's settings (lists back to tuples) with the fixed step ``dt``."""
    s = Settings()
    for name, value in run["settings"].items():
        setattr(s, name, tuple(value) if isinstance(value, list) else value)
    s.dt = dt
    s.validate()
    return s


def measure(run: dict, steps, points: dict) -> list[dict]:
    """Value and gradient of the run's objective at every step and point."""
    reference = max(run["baselines"][f]["peak_N"] for f in ("min", "max", "mid"))
    rows = []
    for dt in steps:
        objective = make_problem(settings_of(run, dt)).make_objective(reference)
        for name, u in points.items():
            t = time.perf_counter()
            value, grad, _ = objective.value_and_grad(jnp.asarray(u, dtype=float))
            rows.append({"dt": dt, "point": name, "value_N": float(value),
                         "gradient": np.asarray(grad).tolist(),
                         "seconds": time.perf_counter() - t})  # fmt: skip
            print(f"dt {dt * 1e6:.0f} µs, {name:12s} value {float(value):8.2f} N, "
                  f"gradient {np.round(np.asarray(grad), 2).tolist()}")  # fmt: skip
    return rows


def analyse(rows: list[dict]) -> None:
    """Each row against the finest step at its point (added to the rows)."""
    for point in {r["point"] for r in rows}:
        mine = [r for r in rows if r["point"] == point]
        fine = min(mine, key=lambda r: r["dt"])
        gf = np.asarray(fine["gradient"])
        for r in mine:
            g = np.asarray(r["gradient"])
            r["value_change"] = r["value_N"] / fine["value_N"] - 1
            r["gradient_distance"] = float(np.linalg.norm(g - gf) / np.linalg.norm(gf))
            r["cosine"] = float(g @ gf / (np.linalg.norm(g) * np.linalg.norm(gf)))


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["rows"]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for point in sorted({r["point"] for r in rows}):
        mine = sorted((r for r in rows if r["point"] == point), key=lambda r: r["dt"])[1:]
        dts = [r["dt"] * 1e6 for r in mine]
        ax[0].plot(dts, [abs(r["value_change"]) for r in mine], "o-", label=point)
        ax[1].plot(dts, [r["gradient_distance"] for r in mine], "o-", label=point)
    fine = min(r["dt"] for r in rows) * 1e6
    ax[0].set_ylabel(f"|value change| against {fine:g} µs")
    ax[1].set_ylabel(f"|g − g({fine:g} µs)| / |g({fine:g} µs)|")
    ax[1].axhline(0.01, color="k", ls="--", lw=0.8, label="1 %")
    for a in ax:
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel("fixed step [µs]")
        a.legend()
    fig.suptitle(f"design objective of the main job: value and gradient against the step\n"
                 f"{results['command']} · {results['date']}", fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="4 and 2 µs at the box middle only")
    ap.add_argument("--run", type=Path, default=RUN, help="the main-job run's results.json")
    args = parse(ap, argv)
    if not args.run.exists():
        raise SystemExit(f"{args.run} not found: make it with python -m optimize --out <folder>")
    start = time.perf_counter()
    run = json.loads(args.run.read_text())
    size = len(run["gradient_free"]["best_u"])
    points = {"box middle": np.zeros(size)}
    if not args.quick:
        points["nelder_mead"] = np.asarray(run["gradient_free"]["best_u"])
    steps = (4e-6, 2e-6) if args.quick else (4e-6, 2e-6, 1e-6)
    rows = measure(run, steps, points)
    analyse(rows)
    given = sys.argv[1:] if argv is None else argv
    results = {
        "command": " ".join(["python -m benchmarks.step_convergence", *given]),
        "date": datetime.date.today().isoformat(),
        "machine": machine_info(),
        "run": shown(args.run),
        "points": {k: np.asarray(u).tolist() for k, u in points.items()},
        "rows": rows,
    }
    for r in rows:
        print(
            f"{r['point']:12s} {r['dt'] * 1e6:.0f} µs: value {100 * r['value_change']:+6.2f} %,"
            f" gradient distance {r['gradient_distance']:.3f}, cosine {r['cosine']:+.3f}"
        )
    return finish(results, args.out, "step_convergence", chart, start)


if __name__ == "__main__":
    main()
