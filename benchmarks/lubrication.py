"""What oil in the joints does to the clearance-joint chain: the per-engagement meshing peak
of both roller populations, dry and lubricated, at two speeds, and what the film costs.

    python -m benchmarks.lubrication            # full study (~25 min on 2 busy cores)
    python -m benchmarks.lubrication --quick    # smoke run (4 engagements per variant)

Writes ``benchmarks/results/lubrication.json`` and ``lubrication.png``.

The scene: the 08B strand meshing an 18-tooth driver under 1000 N
(``jc.scenes.engagement(..., fidelity="clearance")``, settled start, Dahl joint friction,
Tsit5 at ``simulate``'s default tolerances), ``n_entry`` rollers on the entry span meshing
one per tooth period; engagements whose onset falls in the first two tooth periods are
discarded as the start transient. Each engagement's peak is
:class:`jc.observers.EngagementPeaks`' (window half a tooth period, threshold 1 N).

**Variants.** Dry joints (the builders' default) against hot engine oil in the pin/bush
and bush/roller joints (``lubrication=jc.contact.OilFilm(viscosity=0.01)``, SAE 30 near
100 °C; ``--viscosity`` adds others), at ``--speeds`` (default 1000 and 2000 rpm).

**Populations.** A roller link carries two rollers; the one that meshes first (its link
still hanging from the pin link before it) and the second (its link already seated at the
other bush) are two populations: with an even tooth count each gap always meets the same
one. Which is which is read off the onsets: of the two rollers of a roller link, the one
whose engagement starts first.

**Statistics.** Per variant and population: n, mean, p95, CV (std/mean) and the 95 %
interval on the mean (``jc.peak_statistics``); oil against dry: the difference of the
means with Welch's 95 % interval (``jc.compare_peaks``).

**Cost.** The solver's steps per millisecond of simulated time, dry and lubricated, at
100, 1000 and 3000 rpm (a 2 ms solve each after the settled start): the film's squeeze
damping is the stiffest term it adds.
"""

from __future__ import annotations

import time

import jax

jax.config.update("jax_enable_x64", True)

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402
from benchmarks.engagement_stats import (  # noqa: E402
    CHAIN,
    DISCARD,
    MAX_STEPS,
    TEETH,
    TENSION,
    boxes,
    compare,
    measure,
    period,
    strand,
)

COST_SPEEDS = (100.0, 1000.0, 3000.0)
COST_WINDOW = 2e-3  # s of simulated time per cost solve


def oil(viscosity: float | None, cap: float | None = None) -> dict:
    """``engagement`` keywords of a variant: dry (None) or an oil film."""
    if viscosity is None:
        return {}
    caps = {} if cap is None else {"eccentricity_max": cap}
    return {"lubrication": jc.contact.OilFilm(viscosity=viscosity, **caps)}


def label(viscosity: float | None, cap: float | None = None) -> str:
    if viscosity is None:
        return "dry"
    return f"oil {viscosity:g} Pa·s" + (f", cap {cap:g}" if cap else "")


def cost(rpm: float, viscosity: float | None) -> dict:
    """Steps per ms of simulated time from the settled start."""
    scene = strand(rpm, 4, **oil(viscosity))
    t1 = min(COST_WINDOW, 3.5 * period(rpm))
    t0 = time.perf_counter()
    sol = jc.simulate(scene, t1, n_save=2, max_steps=MAX_STEPS, throw=False)
    return {
        "rpm": rpm,
        "viscosity": viscosity,
        "ok": bool(sol.ok),
        "window_s": t1,
        "steps": int(sol.stats["num_steps"]),
        "steps_per_ms": int(sol.stats["num_steps"]) / (1e3 * t1),
        "wall_s": time.perf_counter() - t0,
    }


def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    runs = results["runs"]
    speeds = sorted({r["rpm"] for r in runs})
    fig, axes = plt.subplots(1, len(speeds), figsize=(6 * len(speeds), 4.2), squeeze=False)
    for ax, rpm in zip(axes[0], speeds, strict=True):
        boxes(ax, [r for r in runs if r["rpm"] == rpm], f"{rpm:.0f} rpm")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--speeds", type=float, nargs="+", default=[1000.0, 2000.0])
    ap.add_argument("--viscosity", type=float, nargs="+", default=[0.01])
    ap.add_argument("--n-entry", type=int, default=35)
    ap.add_argument(
        "--caps",
        type=float,
        nargs="*",
        default=[0.9],
        help="eccentricity_max values also run at the first speed (the default cap's sensitivity)",
    )
    args = parse(ap, argv)
    n_entry = 6 if args.quick else args.n_entry
    start = time.perf_counter()
    results = header("lubrication", argv)
    results.update(
        scene=f"{CHAIN} z={TEETH} engagement strand, clearance chain, {TENSION:.0f} N, "
        f"n_entry={n_entry}, first {DISCARD} tooth periods discarded",
        runs=[],
        comparisons=[],
        cost=[],
    )
    for rpm in args.speeds:
        dry = measure(rpm, n_entry, label(None))
        results["runs"].append(dry)
        variants = [(mu, None) for mu in args.viscosity]
        if rpm == args.speeds[0] and not args.quick:
            variants += [(args.viscosity[0], cap) for cap in args.caps]
        for mu, cap in variants:
            wet = measure(rpm, n_entry, label(mu, cap), **oil(mu, cap))
            wet.update(viscosity=mu, eccentricity_max=cap)
            results["runs"].append(wet)
            results["comparisons"].append(
                {"rpm": rpm, "viscosity": mu, "eccentricity_max": cap,
                 "oil_vs_dry": compare(dry, wet)}
            )  # fmt: skip
    for rpm in () if args.quick else COST_SPEEDS:
        for mu in (None, args.viscosity[0]):
            results["cost"].append(cost(rpm, mu))
            c = results["cost"][-1]
            print(f"  cost {rpm:.0f} rpm {label(mu)}: {c['steps_per_ms']:.0f} steps/ms", flush=True)
    return finish(results, args.out, "lubrication", chart, start)


if __name__ == "__main__":
    main()
