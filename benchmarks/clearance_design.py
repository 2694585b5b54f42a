"""How much the tooth form moves the clearance-joint chain's meshing peak, and whether the
lumped chain ranks tooth forms as the clearance chain does.

    python -m benchmarks.clearance_design            # full study
    python -m benchmarks.clearance_design --quick    # smoke run (2 designs, 3 engagements)

Writes ``benchmarks/results/clearance_design.json`` and ``clearance_design.png``.

The designs: the three ISO 606 forms (min, mid, max), the main job's delivered free-form
tooth (``benchmarks/results/optimize_default/profile.json``) and ``--random`` free-form
teeth drawn uniformly from the main job's design box (seed 0; every corner of it is a
valid tooth), all for the 08B chain on an 18-tooth driver under 1000 N.

Each design is measured at one operating point (``--rpm``, ``--wear``; by default the main
job's worst, 1500 rpm with the chain worn 2 %) on the engagement strand from a settled
start, the first two tooth periods discarded, with every meshing event's peak
(:class:`jc.observers.EngagementPeaks`):

* clearance-joint chain, default (Dahl) joint friction, dry or (``--viscosity``) with an
  oil film in its joints: ``--engagements`` events (30);
* lumped chain, default joint friction: 8 events (it scatters by a few per cent).

Reported per design: both chains' mean per-engagement peak with its 95 % interval, and
the difference of the clearance mean against the best ISO form's (Welch 95 % interval);
over the designs: the spread of the clearance means against their intervals' half-width,
and the rank correlation (Spearman) of the lumped means with the clearance means.
"""

from __future__ import annotations

import json
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402
from optimize.clearance import DISCARD, measure  # noqa: E402

CHAIN, TEETH, TENSION, BASE_RPM = "08B", 18, 1000.0, 1000.0
LUMPED_ENGAGEMENTS = 8
DELIVERED = Path(__file__).parent / "results" / "optimize_default" / "profile.json"


def designs(n_random: int) -> dict:
    """name -> tooth profile."""
    from optimize.problem import gentle_space

    chain = jc.ChainSpec.iso606(CHAIN)
    out = {f"ISO {f}": jc.ToothProfile.iso606(chain, TEETH, f) for f in ("min", "mid", "max")}
    if DELIVERED.exists():
        out["delivered free-form"] = jc.load_profile(DELIVERED)
    space, _ = gentle_space(chain, TEETH)
    rng = np.random.default_rng(0)
    for i in range(n_random):
        # uniform in the box: u = logit of a uniform fraction (the space's smooth map)
        frac = rng.uniform(0.02, 0.98, space.size)
        out[f"random {i}"] = space.profile(np.log(frac / (1 - frac)))
    return out


def stats_of(peaks) -> dict:
    s = jc.peak_statistics(peaks)
    return {"n": s.n, "mean": s.mean, "std": s.std, "p95": s.p95, "max": s.max} | {
        "ci": [s.ci_low, s.ci_high]
    }


def summarize(results: dict) -> None:
    """From the measured peaks: each design against the best ISO form in the clearance
    chain (Welch 95 % interval), the rank correlation of the lumped means with the
    clearance means, the spread of both, and the least-squares slope of the clearance
    mean on the lumped mean with its 95 % interval."""
    measured = results["designs"]
    iso = [n for n in measured if n.startswith("ISO") and "clearance" in measured[n]]
    best = min(iso, key=lambda n: measured[n]["clearance"]["mean"])
    results["best_iso_clearance"] = best
    base = measured[best]["clearance_run"]["peaks_N"]
    for name, d in measured.items():
        if "clearance" in d and name != best:
            c = jc.compare_peaks(base, d["clearance_run"]["peaks_N"])
            d["against_best_iso"] = {
                "difference_N": c.difference,
                "relative": c.relative,
                "ci": [c.ci_low, c.ci_high],
                "excludes_zero": bool(c.excludes_zero),
            }
    both = [d for d in measured.values() if "clearance" in d and "lumped" in d]
    lumped = np.array([d["lumped"]["mean"] for d in both])
    clear = np.array([d["clearance"]["mean"] for d in both])
    half = [0.5 * (d["clearance"]["ci"][1] - d["clearance"]["ci"][0]) for d in both]
    results["spread"] = {
        "clearance_means_N": [float(clear.min()), float(clear.max())],
        "clearance_ci_half_width_N": [min(half), max(half)],
        "lumped_means_N": [float(lumped.min()), float(lumped.max())],
    }
    if len(both) < 3:
        return
    rho, p = stats.spearmanr(lumped, clear)
    r, rp = stats.pearsonr(lumped, clear)
    results["rank_correlation"] = {
        "spearman": float(rho),
        "p": float(p),
        "pearson": float(r),
        "pearson_p": float(rp),
        "n": len(both),
    }
    fit = stats.linregress(lumped, clear)
    t = float(stats.t.ppf(0.975, len(both) - 2))
    results["slope"] = {
        "clearance_per_lumped": float(fit.slope),
        "ci": [float(fit.slope - t * fit.stderr), float(fit.slope + t * fit.stderr)],
        "intercept_N": float(fit.intercept),
    }


def report(results: dict) -> None:
    keys = ("rank_correlation", "spread", "slope")
    print(json.dumps({k: results[k] for k in keys if k in results}, indent=1))
    best = results["best_iso_clearance"]
    for name, d in results["designs"].items():
        if "against_best_iso" in d:
            a = d["against_best_iso"]
            print(
                f"{name:22s} vs {best}: {100 * a['relative']:+.1f} % "
                f"[{a['ci'][0]:+.0f}, {a['ci'][1]:+.0f}] N"
            )


def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    rows = results["designs"]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.8))
    names = list(rows)
    for name in names:
        r = rows[name]
        if "clearance" not in r or "lumped" not in r:
            continue
        c, lu = r["clearance"], r["lumped"]
        colour = "C3" if name.startswith("ISO") else ("C2" if "delivered" in name else "C0")
        ax.errorbar(
            lu["mean"],
            c["mean"],
            xerr=[[lu["mean"] - lu["ci"][0]], [lu["ci"][1] - lu["mean"]]],
            yerr=[[c["mean"] - c["ci"][0]], [c["ci"][1] - c["mean"]]],
            fmt="o",
            color=colour,
            capsize=3,
        )
        ax.annotate(name, (lu["mean"], c["mean"]), fontsize=7, xytext=(4, 4),
                    textcoords="offset points")  # fmt: skip
    rho = results.get("rank_correlation", {"spearman": np.nan, "p": np.nan, "n": 0})
    if "slope" in results:
        sl = results["slope"]
        x = np.array(ax.get_xlim())
        ax.plot(x, sl["intercept_N"] + sl["clearance_per_lumped"] * x, "k--", lw=0.8,
                label=f"least squares: slope {sl['clearance_per_lumped']:.2f} "
                f"[{sl['ci'][0]:.2f}, {sl['ci'][1]:.2f}]")  # fmt: skip
        ax.legend(fontsize=8, loc="upper left")
    ax.set_xlabel("lumped chain: mean per-engagement peak [N] (95 % CI)")
    ax.set_ylabel("clearance chain: mean per-engagement peak [N] (95 % CI)")
    ax.set_title(
        f"{results['rpm']:g} rpm, wear {100 * results['wear']:g} %: Spearman ρ = "
        f"{rho['spearman']:+.2f} (p = {rho['p']:.2g}, n = {rho['n']})",
        fontsize=9,
    )
    ax.grid(alpha=0.3)
    for i, name in enumerate(names):
        r = rows[name].get("clearance")
        if r is None:
            continue
        peaks = rows[name]["clearance_run"]["peaks_N"]
        bx.scatter(np.full(len(peaks), i) + np.linspace(-0.2, 0.2, len(peaks)), peaks, s=6,
                   color="0.5")  # fmt: skip
        bx.errorbar(i, r["mean"], yerr=[[r["mean"] - r["ci"][0]], [r["ci"][1] - r["mean"]]],
                    fmt="s", color="k", capsize=4)  # fmt: skip
    bx.set_xticks(range(len(names)), names, rotation=40, ha="right", fontsize=7)
    bx.set_ylabel("clearance chain: per-engagement peak [N]")
    bx.set_title("every engagement (grey), mean and 95 % CI (black)", fontsize=9)
    bx.grid(alpha=0.3, axis="y")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--engagements", type=int, default=30, help="clearance chain, per design")
    ap.add_argument("--random", type=int, default=6, help="random designs from the design box")
    ap.add_argument("--rpm", type=float, default=1500.0, help="driver speed [rpm]")
    ap.add_argument("--wear", type=float, default=0.02, help="chain elongation (0.02 = 2 %%)")
    ap.add_argument(
        "--viscosity",
        type=float,
        default=None,
        help="oil in the clearance chain's joints (jc.contact.OilFilm, Pa·s); default dry",
    )
    ap.add_argument(
        "--replot",
        action="store_true",
        help="recompute the statistics and the chart from --out's clearance_design.json",
    )
    args = parse(ap, argv)
    if args.replot:
        path = args.out / "clearance_design.json"
        results = json.loads(path.read_text())
        summarize(results)
        report(results)
        path.write_text(json.dumps(results, indent=1))
        chart(results, args.out / "clearance_design.png")
        return results
    start = time.perf_counter()
    results = header("clearance_design", argv)
    engagements, n_random = args.engagements, args.random
    if args.quick:
        engagements, n_random = 3, 0
    chosen = designs(n_random)
    if args.quick:
        chosen = {k: chosen[k] for k in ("ISO min", "ISO max")}
    results.update(
        chain=CHAIN,
        teeth=TEETH,
        tension_N=TENSION,
        rpm=args.rpm,
        wear=args.wear,
        viscosity=args.viscosity,
        engagements=engagements,
        lumped_engagements=LUMPED_ENGAGEMENTS if not args.quick else 3,
        discarded_periods=DISCARD,
        designs={},
    )
    jobs = [(name, "clearance", engagements) for name in chosen]
    jobs += [(name, "lumped", results["lumped_engagements"]) for name in chosen]

    def one(job):
        name, fidelity, n = job
        row = measure(
            chosen[name],
            chain=CHAIN,
            teeth=TEETH,
            rpm=args.rpm,
            tension=TENSION,
            wear=args.wear,
            engagements=n,
            fidelity=fidelity,
            lubrication=None if args.viscosity is None else jc.contact.OilFilm(args.viscosity),
        )
        print(
            f"  {name:22s} {fidelity:9s}: {row['steps']} steps, {row['wall_s']:.0f} s, "
            f"{len(row['peaks_N'])} engagements"
            + (f", mean {np.mean(row['peaks_N']):.0f} N" if row["peaks_N"] else "")
            + ("" if row["ok"] else f" FAILED: {row['message']}"),
            flush=True,
        )
        return row

    with ThreadPoolExecutor(2) as pool:  # one XLA solve per core
        rows = list(pool.map(one, jobs))
    for (name, fidelity, _), row in zip(jobs, rows, strict=True):
        d = results["designs"].setdefault(name, {})
        d[f"{fidelity}_run"] = row
        if len(row["peaks_N"]) >= 2:
            d[fidelity] = stats_of(row["peaks_N"])
    summarize(results)
    report(results)
    return finish(results, args.out, "clearance_design", chart, start)


if __name__ == "__main__":
    main()
