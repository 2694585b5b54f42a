"""Does the design model see what the nominal model sees? Random per-tooth patterns
around the uniform ISO 606 minimum form, each evaluated by the design objective and
re-measured with the nominal model, gap by gap.

    python -m benchmarks.design_fidelity                      # 12 patterns (~7 min)
    python -m benchmarks.design_fidelity --width 1 --dt 2     # a finer design model
    python -m benchmarks.design_fidelity --quick              # 2 patterns, looser

Writes ``benchmarks/results/design_fidelity.json`` and ``design_fidelity.png`` (with
``--width``/``--dt`` other than the design model's 3 µm and 4 µs:
``design_fidelity_w<width>_dt<dt>.*``).

The space of ``pattern_design`` (36 per-gap coordinates: seating radius ±20 µm and
clockwise seat angle ±0.04 rad around the ISO minimum form). Patterns u = σ·N(0, 1) for σ
in ``--sigmas`` (the designs of ``pattern_design`` reach |u| ≈ 6), ``--patterns`` seeds
each. For each pattern and each of the six turned members (together they mesh every
gap once):

* the design model's value: the every-gap objective's member value (soft peak over
  periods 2–4, fixed steps of ``--dt`` µs (4), contact onset over ``--width`` µm (3),
  joint creep band 20 mm/s), with the Johnson design law and with the second law (Hertz)
  regularized alike;
* the nominal model's: the sharp peak re-measured as ``pattern_remeasure`` does (nominal
  Johnson law and joint friction, Dopri8, dense output every ≤ 0.5 µs; then Hertz).

Each is taken relative to the uniform form's (u = 0), and the study reports how well the
design model's change predicts the nominal one: the correlation, the slope of the
least-squares line, and how often the signs agree, per member and for the worst gap. A
design model that does not rank patterns as the nominal model does cannot design them,
however good its gradients.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from benchmarks.common import finish, header, parse, parser, save_chart
from benchmarks.designs import add_model_options

LAWS = ("johnson", "hertz")


def agreement(design: np.ndarray, nominal: np.ndarray) -> dict:
    """How well the changes ``design`` predict ``nominal`` (1-D arrays of fractions)."""
    fit = len(design) > 2
    line = np.polyfit(design, nominal, 1) if fit else np.full(2, np.nan)
    gains = design < 0
    return {
        "points": len(design),
        "correlation": float(np.corrcoef(design, nominal)[0, 1]) if fit else float("nan"),
        "slope": float(line[0]),
        "residual": float(np.std(nominal - np.polyval(line, design))),  # about the line
        "sign_agreement": float(np.mean(np.sign(design) == np.sign(nominal))),
        "design_gains": int(np.sum(gains)),  # members the design model sees improve
        "confirmed_gains": int(np.sum(gains & (nominal < 0))),  # ... and the nominal model
        "design_spread": float(np.std(design)),
        "nominal_spread": float(np.std(nominal)),
    }


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    sigmas = sorted({p["sigma"] for p in results["patterns"]})
    for ax, law in zip(axes, LAWS, strict=True):
        for i, sigma in enumerate(sigmas):
            pts = [p for p in results["patterns"] if p["sigma"] == sigma]
            x = 100 * np.concatenate([p[law]["design_change"] for p in pts])
            y = 100 * np.concatenate([p[law]["nominal_change"] for p in pts])
            ax.plot(x, y, "o", ms=4, alpha=0.7, color=f"C{i}", label=f"members, σ = {sigma:g}")
            wx = [100 * p[law]["design_worst_change"] for p in pts]
            wy = [100 * p[law]["nominal_worst_change"] for p in pts]
            ax.plot(wx, wy, "*", ms=11, color=f"C{i}", mec="k", label=f"worst gap, σ = {sigma:g}")
        lim = np.max(np.abs(np.concatenate([ax.get_xlim(), ax.get_ylim()])))
        ax.plot([-lim, lim], [-lim, lim], "k-", lw=0.8, label="equal change")
        ax.axhline(0, color="0.6", lw=0.5)
        ax.axvline(0, color="0.6", lw=0.5)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        a = results["agreement"][law]["members"]
        ax.set_title(f"{law.capitalize()}: r = {a['correlation']:.2f}, slope {a['slope']:.2f}")
        ax.set_xlabel("design model: change of the member's soft peak [%]")
        ax.set_ylabel("nominal model: change of its sharp peak [%]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="2 patterns (σ = 1), re-measured at rtol 1e-7")
    ap.add_argument(
        "--sigmas", type=float, nargs="+", default=[1.0, 3.0], help="default %(default)s"
    )
    ap.add_argument("--patterns", type=int, default=6, help="per σ (default %(default)s)")
    add_model_options(ap)
    args = parse(ap, argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    from benchmarks import designs as gc
    from benchmarks.designs import (
        design_objectives,
        laws,
        model_options,
        remeasure as measure,
        suffix,
    )

    start = time.perf_counter()
    sigmas, count = ([1.0], 2) if args.quick else (args.sigmas, args.patterns)
    rtol = 1e-7 if args.quick else 1e-9
    space = gc.per_gap_space("min")
    model = model_options(args)
    design = design_objectives(space, **model)
    nominal = laws()

    def evaluate(u):
        profile = space.profile(jnp.asarray(u))
        out = {}
        for law in LAWS:
            members = np.asarray(design[law].value(u)[1].value)
            out[law] = {
                "design_members_N": members.tolist(),
                "nominal": measure(profile, nominal[law], rtol),
            }
        return out

    base = evaluate(np.zeros(space.size))
    patterns = []
    for sigma in sigmas:
        for seed in range(count):
            t = time.perf_counter()
            u = sigma * np.random.default_rng(seed).normal(size=space.size)
            entry = {"sigma": sigma, "seed": seed, "u": u.tolist(), **evaluate(u)}
            for law in LAWS:
                e, b = entry[law], base[law]
                d = np.asarray(e["design_members_N"]) / np.asarray(b["design_members_N"]) - 1
                n = np.asarray(e["nominal"]["members_N"]) / np.asarray(b["nominal"]["members_N"])
                e["design_change"] = d.tolist()
                e["nominal_change"] = (n - 1).tolist()
                e["design_worst_change"] = float(
                    np.max(e["design_members_N"]) / np.max(b["design_members_N"]) - 1
                )
                e["nominal_worst_change"] = e["nominal"]["peak_N"] / b["nominal"]["peak_N"] - 1
            entry["seconds"] = time.perf_counter() - t
            patterns.append(entry)
            print(
                f"σ {sigma:g} seed {seed}: worst gap, design vs nominal: " + ", ".join(
                    f"{law} {100 * entry[law]['design_worst_change']:+.1f} % / "
                    f"{100 * entry[law]['nominal_worst_change']:+.1f} %" for law in LAWS
                ), flush=True,
            )  # fmt: skip
    summary = {}
    for law in LAWS:
        d = np.concatenate([p[law]["design_change"] for p in patterns])
        n = np.concatenate([p[law]["nominal_change"] for p in patterns])
        wd = np.array([p[law]["design_worst_change"] for p in patterns])
        wn = np.array([p[law]["nominal_worst_change"] for p in patterns])
        summary[law] = {"members": agreement(d, n), "worst_gap": agreement(wd, wn)}
        for sigma in sigmas:
            pts = [p for p in patterns if p["sigma"] == sigma]
            summary[law][f"members_sigma_{sigma:g}"] = agreement(
                np.concatenate([p[law]["design_change"] for p in pts]),
                np.concatenate([p[law]["nominal_change"] for p in pts]),
            )
        a = summary[law]["members"]
        print(
            f"{law}: members r = {a['correlation']:.2f}, slope {a['slope']:.2f}, signs agree "
            f"{100 * a['sign_agreement']:.0f} %; worst gap r = "
            f"{summary[law]['worst_gap']['correlation']:.2f}"
        )
    results = {
        **header("design_fidelity", argv),
        "space": "36 per-gap coordinates around the ISO 606 minimum form: seating radius "
        "±20 µm, cw seat angle ±0.04 rad",
        "design_model": {"onset_width_m": model["width"], "dt_s": model["dt"],
                         "hertz_temperature_N": args.hertz_temperature},
        "rtol": rtol,
        "uniform": base,
        "patterns": patterns,
        "agreement": summary,
    }  # fmt: skip
    name = "design_fidelity" + suffix(args)
    return finish(results, args.out, name, chart, start)


if __name__ == "__main__":
    main()
