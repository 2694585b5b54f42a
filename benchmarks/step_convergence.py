"""Does the main job's design gradient converge as the fixed step shrinks?

    python -m benchmarks.step_convergence            # 4, 2, 1 µs, three forms (~25 min)
    python -m benchmarks.step_convergence --quick    # 4 and 2 µs at the box middle, job's form

The main job's default objective (``python -m optimize``: six operating points, the soft
maximum of their soft peaks, the 7-coordinate free-form tooth, the design contact law and
joint friction; built as the run builds it, from the committed run's settings and
reference in ``results/optimize_default/``) at fixed steps of 4 µs (the job's), 2 µs and
1 µs, at the middle of the box (u = 0) and at the run's Nelder–Mead design, in three
forms:

* ``integrated``: the soft peak's window integral taken by the solver's stages
  (:class:`jaxchain.observers.SoftPeak`), every member solved over the slowest member's
  2 tooth periods (the fastest, at 3× its speed, over 6 of its own);
* ``sampled``: the integral by the trapezoid rule on 8 parts of each step
  (:class:`jaxchain.observers.SampledSoftPeak`), the same horizons;
* ``own horizon``: sampled, each member over 2 of its own tooth periods
  (``--horizon own``: one compiled solve per speed) — the job's.

Reverse mode equals central differences of each discrete objective (tests/test_design.py,
tests/test_orders.py); this study asks whether those discrete gradients approach one limit
as the step shrinks, as the values do. Reported per point, form and step, against the
finest step: the value's relative change, the gradient's relative distance
|g − g_fine| / |g_fine| and its cosine with g_fine.

Then the horizon itself: one member alone (1.5× speed, 2 % wear) at the Nelder–Mead
design, sampled, over 2, 4 and 6 of its own tooth periods at 4 and 2 µs — whether the two
steps' gradients part as the simulated time grows (sensitivity to the state growing along
the solve), which the values do not show. Writes ``step_convergence.json`` and
``step_convergence.png``.
"""

from __future__ import annotations

import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks.common import finish, header, parse, parser, shown  # noqa: E402
from benchmarks.designs import add_run_option, read_run, settings_of  # noqa: E402
from optimize.problem import make_problem  # noqa: E402

# the objective's forms: the soft peak's samples per step, the members' horizon
FORMS = {
    "integrated": (0, "slowest"),  # by the solver's stages, every member 2 slowest periods
    "sampled": (8, "slowest"),  # trapezoid on 8 parts per step
    "own horizon": (8, "own"),  # sampled, each member 2 of its own periods (the job's)
}


def measure(run: dict, steps, points: dict, forms=tuple(FORMS)) -> list[dict]:
    """Value and gradient of the run's objective at every step, point and form (the soft
    peak's ``samples``: 0 integrated by the stages, else sampled; the members' horizon)."""
    reference = max(run["baselines"][f]["peak_N"] for f in ("min", "max", "mid"))
    rows = []
    for form in forms:
        samples, horizon = FORMS[form]
        for dt in steps:
            s = settings_of(run, dt, samples, horizon)
            objective = make_problem(s).make_objective(reference)
            for name, u in points.items():
                rows.append(_row(objective, u, dt, form, point=name))
    return rows


def horizon(run: dict, u, steps, periods=(2, 4, 6), member=(1.5, 0.02)) -> list[dict]:
    """One member alone (speed factor, wear) over ``periods`` of its own tooth periods
    (the first the window's warm-up), sampled soft peak, at each step."""
    reference = max(run["baselines"][f]["peak_N"] for f in ("min", "max", "mid"))
    rows = []
    for n in periods:
        for dt in steps:
            s = settings_of(run, dt, 8)
            s.ensemble, s.wear, s.periods, s.warmup = (member[0],), (member[1],), n, 1
            objective = make_problem(s).make_objective(reference)
            rows.append(_row(objective, u, dt, "sampled", point=f"{n} periods"))
    return rows


def _row(objective, u, dt, form, **what) -> dict:
    t = time.perf_counter()
    value, grad, _ = objective.value_and_grad(jnp.asarray(u, dtype=float))
    row = {"dt": dt, "form": form, **what, "value_N": float(value),
           "gradient": np.asarray(grad).tolist(), "seconds": time.perf_counter() - t}  # fmt: skip
    print(f"{what} {form} dt {dt * 1e6:.0f} µs: value {float(value):8.2f} N, "
          f"gradient {np.round(np.asarray(grad), 2).tolist()}", flush=True)  # fmt: skip
    return row


def analyse(rows: list[dict]) -> None:
    """Each row against the finest step at its point and form (added to the rows)."""
    for key in {(r["point"], r["form"]) for r in rows}:
        mine = [r for r in rows if (r["point"], r["form"]) == key]
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

    rows, long = results["rows"], results.get("horizon", [])
    fig, ax = plt.subplots(1, 3 if long else 2, figsize=(15 if long else 11, 4))
    for point, form in sorted({(r["point"], r["form"]) for r in rows}):
        mine = [r for r in rows if (r["point"], r["form"]) == (point, form)]
        mine = sorted(mine, key=lambda r: r["dt"])[1:]
        dts = [r["dt"] * 1e6 for r in mine]
        label = f"{point}, {form}"
        style = {"integrated": "s:", "sampled": "o--"}.get(form, "D-")
        ax[0].plot(dts, [max(abs(r["value_change"]), 1e-7) for r in mine], style, label=label)
        ax[1].plot(dts, [r["gradient_distance"] for r in mine], style, label=label)
    fine = min(r["dt"] for r in rows) * 1e6
    ax[0].set_ylabel(f"|value change| against {fine:g} µs")
    ax[1].set_ylabel(f"|g − g({fine:g} µs)| / |g({fine:g} µs)|")
    ax[1].axhline(0.01, color="k", ls="--", lw=0.8, label="1 %")
    for a in ax[:2]:
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel("fixed step [µs]")
        a.legend(fontsize=7)
    if long:
        coarse = [r for r in long if r["dt"] == max(x["dt"] for x in long)]
        coarse = sorted(coarse, key=lambda r: int(r["point"].split()[0]))
        periods = [int(r["point"].split()[0]) for r in coarse]
        ax[2].semilogy(periods, [r["gradient_distance"] for r in coarse], "o-")
        ax[2].set_xlabel("simulated tooth periods of the member")
        ax[2].set_ylabel("|g(4 µs) − g(2 µs)| / |g(2 µs)|")
        ax[2].set_title(results["horizon_member"], fontsize=8)
        ax[2].axhline(0.01, color="k", ls="--", lw=0.8)
    fig.suptitle(f"design objective of the main job: value and gradient against the step\n"
                 f"{results['command']} · {results['date']}", fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="4 and 2 µs at the box middle, the job's form only")
    add_run_option(ap)
    args = parse(ap, argv)
    run = read_run(args.run)
    start = time.perf_counter()
    size = len(run["gradient_free"]["best_u"])
    points = {"box middle": np.zeros(size)}
    if not args.quick:
        points["nelder_mead"] = np.asarray(run["gradient_free"]["best_u"])
    steps = (4e-6, 2e-6) if args.quick else (4e-6, 2e-6, 1e-6)
    rows = measure(run, steps, points, forms=("own horizon",) if args.quick else tuple(FORMS))
    analyse(rows)
    member = (1.5, 0.02)
    long = [] if args.quick else horizon(run, points["nelder_mead"], (4e-6, 2e-6), member=member)
    analyse(long)
    results = {
        **header("step_convergence", argv),
        "run": shown(args.run),
        "points": {k: np.asarray(u).tolist() for k, u in points.items()},
        "rows": rows,
        "horizon_member": f"one member alone at Nelder–Mead's design: {member[0]}× speed, "
        f"{100 * member[1]:g} % wear, sampled",
        "horizon": long,
    }
    for r in rows + long:
        print(
            f"{r['point']:12s} {r['form']:12s} {r['dt'] * 1e6:.0f} µs:"
            f" value {100 * r['value_change']:+6.2f} %, gradient distance"
            f" {r['gradient_distance']:.3f}, cosine {r['cosine']:+.3f}"
        )
    return finish(results, args.out, "step_convergence", chart, start)


if __name__ == "__main__":
    main()
