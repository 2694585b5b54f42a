"""A per-tooth pattern around a uniform ISO 606 form, designed by gradient on every gap and
re-measured.

    python -m benchmarks.archive.pattern_design               # around the minimum form (~4 min)
    python -m benchmarks.archive.pattern_design --form mid    # around the mid form
    python -m benchmarks.archive.pattern_design --robust      # against both contact laws (~8 min)
    python -m benchmarks.archive.pattern_design --robust --hertz-temperature 5 --member-max 5 \
        --lr 0.2 --steps 16                           # the worst gap under both laws
    python -m benchmarks.archive.pattern_design --quick       # 2 Adam steps, looser re-measurement

Writes ``benchmarks/archive/results/pattern_design_<form>[_robust][...].json`` and ``.png``, a
suffix naming each design-model or Adam option that differs from its default
(``--width``/``--dt``: the contact onset [µm] and step [µs], 3 and 4;
``--hertz-temperature``: the Hertz design objective's soft peak [N], 20; ``--member-max``:
the members' soft maximum at that temperature [N] instead of their mean; ``--lr``).

Design space: each gap's seating radius ±20 µm and clockwise seat angle ±0.04 rad around
the uniform ISO 606 ``--form`` (a free-form tooth with one arc per flank, 36 coordinates).
Objective: ``gradient_cost.every_gap_objective`` (six members, the sprocket turned three
pitches further in each, so that together they mesh every gap; design contact law, fixed
4 µs steps, soft peak sampled 8 times per step, the members' mean). Adam (learning
rate 1, as in the ``methods`` study) from u = σ·N(0, 1) (``--sigma``, seed 0: at u = 0
the turned members make the gradient equal for gaps k, k + 3, … and the steps would keep
that symmetry). The best pattern, the uniform form (u = 0) and Adam's start are then
re-measured as ``pattern_remeasure`` does (nominal Johnson law and nominal joint friction,
Dopri8, sharp peak on every gap; then the Hertz second law).

``--robust``: the objective is the soft maximum (temperature 1 %) of the every-gap
objective under two design laws, each relative to its value for the uniform form: the
Johnson design law and the second law (Hertz, ``optimize.problem.second_law``) with its
onset regularized over the same 3 µm. A pattern must then lower the peak under both laws
to lower the objective (1 = the uniform form).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.common import ARCHIVE, finish, header, parse, parser, save_chart
from benchmarks.designs import (
    add_model_options,
    design_objectives,
    model_options,
    suffix,
)

# the robust objective's soft maximum over the two laws' relative values
LAW_TEMPERATURE = 0.01


def plain_objective(space, **model):
    """``u -> (value [N], gradient, parts)``: the every-gap objective (Johnson design law;
    ``model``: :func:`design_objectives`'s); ``parts``: the six members' values."""
    obj = design_objectives(space, **model)["johnson"]

    def design(u):
        value, grad, members = obj.value_and_grad(u)
        return float(value), grad, {"members_N": np.asarray(members.value).tolist()}

    return design


def robust_objective(space, **model):
    """``u -> (value, gradient, parts)``: the soft maximum over the Johnson design law and
    the regularized second law of the every-gap objective relative to its value for the
    uniform form (u = 0; the first call fixes the scales); ``parts``: each law's
    objective [N] and members. ``model``: :func:`design_objectives`'s."""
    objs = design_objectives(space, **model)
    scale = {}

    def design(u):
        parts, values, grads = {}, [], []
        for law, obj in objs.items():
            value, grad, members = obj.value_and_grad(u)
            scale.setdefault(law, float(value))
            parts[f"{law}_N"] = float(value)
            parts[f"{law}_members_N"] = np.asarray(members.value).tolist()
            values.append(float(value) / scale[law])
            grads.append(grad / scale[law])
        r = np.asarray(values) / LAW_TEMPERATURE
        e = np.exp(r - r.max())  # log-mean-exp and its weights (softmax)
        value = LAW_TEMPERATURE * (r.max() + np.log(np.mean(e)))
        grad = sum(float(w) * g for w, g in zip(e / e.sum(), grads, strict=True))
        return float(value), grad, parts

    return design


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.3))
    hist = results["history"]
    axes[0].plot([h["objective"] for h in hist], "o-", color="C3")
    axes[0].axhline(results["uniform"]["objective"], color="k", lw=0.8, label="uniform form")
    axes[0].set_xlabel("Adam step")
    axes[0].set_ylabel(f"every-gap objective [{results['objective_unit']}]")
    axes[0].legend()
    axes[0].grid(alpha=0.3)
    names = ("uniform", "start", "designed")
    for i, law in enumerate(("johnson", "hertz")):
        vals = [results[n]["remeasured"][law]["peak_N"] for n in names]
        bars = axes[1].bar(np.arange(3) + 0.4 * i - 0.2, vals, 0.4, label=law.capitalize())
        axes[1].bar_label(bars, fmt="%.0f", fontsize=8)
    axes[1].set_xticks(np.arange(3), ["uniform ISO " + results["form"], "Adam's start", "designed"])
    axes[1].set_ylabel("re-measured worst-gap peak [N]")
    axes[1].legend(loc="lower right")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, out=ARCHIVE, quick_help="2 Adam steps, re-measured at rtol 1e-7")
    ap.add_argument("--form", choices=("min", "mid", "max"), default="min")
    ap.add_argument("--steps", type=int, default=12, help="Adam steps (default %(default)s)")
    ap.add_argument("--sigma", type=float, default=0.1, help="start noise (default %(default)s)")
    ap.add_argument("--lr", type=float, default=None, help="Adam's learning rate (default 1)")
    ap.add_argument("--robust", action="store_true", help="design against both contact laws")
    add_model_options(ap)
    ap.add_argument(
        "--member-max", type=float, default=None, metavar="TEMPERATURE",
        help="the members' soft maximum at this temperature [N] (default: their mean)",
    )  # fmt: skip
    args = parse(ap, argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import optax

    from benchmarks import designs as gc
    from benchmarks.designs import LEARNING_RATE, laws, remeasure as measure

    start = time.perf_counter()
    steps = 2 if args.quick else args.steps
    rtol = 1e-7 if args.quick else 1e-9
    space = gc.per_gap_space(args.form)
    unit = "× uniform form" if args.robust else "N"
    model = model_options(args) | {"member_max": args.member_max}
    design = (robust_objective if args.robust else plain_objective)(space, **model)
    uniform = design(jnp.zeros(space.size))
    u = jnp.asarray(args.sigma * np.random.default_rng(0).normal(size=space.size))
    u_start = u
    lr = LEARNING_RATE if args.lr is None else args.lr
    opt = optax.adam(lr)
    state = opt.init(u)
    history = []
    for k in range(steps):
        t = time.perf_counter()
        value, grad, parts = design(u)
        history.append({
            "step": k, "objective": value, "grad_norm": float(jnp.linalg.norm(grad)), **parts,
            "u": np.asarray(u).tolist(), "seconds": time.perf_counter() - t,
        })  # fmt: skip
        print(f"step {k}: {value:.4g} {unit}, |g| {history[-1]['grad_norm']:.3g}", flush=True)
        updates, state = opt.update(grad, state)
        u = optax.apply_updates(u, updates)
    best = min(history, key=lambda h: h["objective"])
    models = laws()

    def remeasured(coords):
        profile = space.profile(jnp.asarray(coords))
        return {law: measure(profile, c, rtol) for law, c in models.items()}

    results = {
        **header("pattern_design", argv),
        "form": args.form,
        "robust": args.robust,
        "design_model": {"onset_width_m": model["width"], "dt_s": model["dt"],
                         "hertz_temperature_N": args.hertz_temperature,
                         "member_max_temperature_N": args.member_max},
        "objective_unit": unit,
        "space": "36 per-gap coordinates: seating radius ±20 µm, cw seat angle ±0.04 rad",
        "sigma": args.sigma,
        "learning_rate": lr,
        "rtol": rtol,
        "history": history,
        "uniform": {"objective": uniform[0], **uniform[2],
                    "remeasured": remeasured(np.zeros(space.size))},
        "start": {"objective": history[0]["objective"], "remeasured": remeasured(u_start)},
        "designed": {"objective": best["objective"], "step": best["step"], "u": best["u"],
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
            f"{name:9s} objective {results[name]['objective']:.4g} {unit}; re-measured worst gap "
            f"{r['johnson']['peak_N']:.1f} N (Johnson), {r['hertz']['peak_N']:.1f} N (Hertz)"
        )
    name = f"pattern_design_{args.form}" + ("_robust" if args.robust else "")
    name += suffix(args)
    return finish(results, args.out, name, chart, start)


if __name__ == "__main__":
    main()
