"""A per-tooth pattern around a uniform ISO 606 form, designed by gradient on every gap and
re-measured.

    python -m benchmarks.pattern_design               # around the minimum form (~4 min)
    python -m benchmarks.pattern_design --form mid    # around the mid form
    python -m benchmarks.pattern_design --quick       # 2 Adam steps, looser re-measurement

Writes ``benchmarks/results/pattern_design_<form>.json`` and ``.png``.

Design space: each gap's seating radius ±20 µm and clockwise seat angle ±0.04 rad around
the uniform ISO 606 ``--form`` (a free-form tooth with one arc per flank, 36 coordinates).
Objective: ``gradient_cost.every_gap_objective`` (six members, the sprocket turned three
pitches further in each, so that together they mesh every gap; design contact law, fixed
4 µs steps, soft peak sampled 8 times per step, the members' soft maximum). Adam (learning
rate 1, as in the ``methods`` study) from u = σ·N(0, 1) (``--sigma``, seed 0: at u = 0
the turned members make the gradient equal for gaps k, k + 3, … and the steps would keep
that symmetry). The best pattern, the uniform form (u = 0) and Adam's start are then
re-measured as ``pattern_remeasure`` does (nominal Johnson law and nominal joint friction,
Dopri8, sharp peak on every gap; then the Hertz second law).
"""

from __future__ import annotations

import datetime
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks._cli import finish, parse, parser, save_chart
from benchmarks.work_precision import machine_info


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.3))
    hist = results["history"]
    axes[0].plot([h["step"] for h in hist], [h["objective_N"] for h in hist], "o-", color="C3")
    axes[0].axhline(results["uniform"]["objective_N"], color="k", lw=0.8, label="uniform form")
    axes[0].set_xlabel("Adam step")
    axes[0].set_ylabel("every-gap objective [N]")
    axes[0].legend()
    axes[0].grid(alpha=0.3)
    names = ("uniform", "start", "designed")
    for i, law in enumerate(("johnson", "hertz")):
        vals = [results[n]["remeasured"][law]["peak_N"] for n in names]
        bars = axes[1].bar(np.arange(3) + 0.4 * i - 0.2, vals, 0.4, label=law.capitalize())
        axes[1].bar_label(bars, fmt="%.0f", fontsize=8)
    axes[1].set_xticks(np.arange(3), ["uniform ISO " + results["form"], "Adam's start", "designed"])
    axes[1].set_ylabel("re-measured worst-gap peak [N]")
    axes[1].legend()
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="2 Adam steps, re-measured at rtol 1e-7")
    ap.add_argument("--form", choices=("min", "mid", "max"), default="min")
    ap.add_argument("--steps", type=int, default=12, help="Adam steps (default %(default)s)")
    ap.add_argument("--sigma", type=float, default=0.1, help="start noise (default %(default)s)")
    args = parse(ap, argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import optax

    from benchmarks import gradient_cost as gc
    from benchmarks.methods import LEARNING_RATE
    from benchmarks.pattern_remeasure import laws, measure

    start = time.perf_counter()
    steps = 2 if args.quick else args.steps
    rtol = 1e-7 if args.quick else 1e-9
    space = gc.per_gap_space(args.form)
    obj = gc.every_gap_objective(space, samples=8)
    u = jnp.asarray(args.sigma * np.random.default_rng(0).normal(size=space.size))
    u_start = u
    opt = optax.adam(LEARNING_RATE)
    state = opt.init(u)
    history = []
    for k in range(steps):
        t = time.perf_counter()
        value, grad, members = obj.value_and_grad(u)
        history.append({
            "step": k, "objective_N": float(value), "grad_norm": float(jnp.linalg.norm(grad)),
            "members_N": np.asarray(members.value).tolist(), "u": np.asarray(u).tolist(),
            "seconds": time.perf_counter() - t,
        })  # fmt: skip
        print(f"step {k}: {float(value):.2f} N, |g| {history[-1]['grad_norm']:.3g}", flush=True)
        updates, state = opt.update(grad, state)
        u = optax.apply_updates(u, updates)
    best = min(history, key=lambda h: h["objective_N"])
    models = laws()

    def remeasured(coords):
        profile = space.profile(jnp.asarray(coords))
        return {law: measure(profile, c, rtol) for law, c in models.items()}

    uniform_value = float(obj.value(jnp.zeros(space.size))[0])
    results = {
        "command": " ".join(["python -m benchmarks.pattern_design", *(
            sys.argv[1:] if argv is None else argv)]),
        "date": datetime.date.today().isoformat(),
        "machine": machine_info(),
        "form": args.form,
        "space": "36 per-gap coordinates: seating radius ±20 µm, cw seat angle ±0.04 rad",
        "sigma": args.sigma,
        "rtol": rtol,
        "history": history,
        "uniform": {"objective_N": uniform_value, "remeasured": remeasured(np.zeros(space.size))},
        "start": {"objective_N": history[0]["objective_N"], "remeasured": remeasured(u_start)},
        "designed": {"objective_N": best["objective_N"], "step": best["step"], "u": best["u"],
                     "remeasured": remeasured(best["u"])},
    }  # fmt: skip
    base = results["uniform"]["remeasured"]
    results["change_vs_uniform"] = {
        name: {law: results[name]["remeasured"][law]["peak_N"] / base[law]["peak_N"] - 1
               for law in models}
        for name in ("start", "designed")
    }  # fmt: skip
    for name in ("uniform", "start", "designed"):
        r = results[name]["remeasured"]
        print(
            f"{name:9s} objective {results[name]['objective_N']:.1f} N; re-measured worst gap "
            f"{r['johnson']['peak_N']:.1f} N (Johnson), {r['hertz']['peak_N']:.1f} N (Hertz)"
        )
    return finish(results, args.out, f"pattern_design_{args.form}", chart, start)


if __name__ == "__main__":
    main()
