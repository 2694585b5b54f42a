"""Which fidelity the meshing scene needs, from settled starts.

    python -m benchmarks.fidelity            # full study (~10 min on 2 cores)
    python -m benchmarks.fidelity --quick    # smoke run

Writes ``benchmarks/results/fidelity.json`` and ``fidelity.png``.

The engagement scene (08B, z = 18, 1000 rpm, 1000 N entry / 100 N exit tension, default
span springs), every variant started from its own static equilibrium
(:func:`jaxchain.scenes.equilibrate`):

* ``lumped``: rollers as point masses on elastic links;
* ``clearance``: rigid pin and roller links on pin/bush clearance joints, each roller a
  body on its own bush/roller clearance joint (the source paper's model);
* ``clearance/rollers-fixed``: the same with each roller fixed to its bush.

Meshing peaks are sensitive to everything (a roller rattles in its seat, and in the
clearance model in its joints), so each variant runs a small ensemble: the speed
perturbed by −0.1, −0.05, 0, +0.05, +0.1 % (quick: 0, +0.1 %), outputs saved every 1 µs,
Tsit5 at rtol 1e-6. Statistics are over *engagements*: the peak roller/tooth force of each
tooth period of each member (4 periods × 5 members = 20 per variant), mean ± standard
error; a difference between variants is quoted against its standard error. Also the entry
(tight) span's mean tension and the largest link tension. Cost: wall time of the nominal
member's solve saving only t0 and t1 (minimum of repeats after a first call), steps, and
the statics' time.
"""

from __future__ import annotations

import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    FRICTIONLESS,
    finish,
    machine_info,  # noqa: E402
    modelled,
    parse,
    parser,
    tooth_period,  # noqa: E402
)

CHAIN, TEETH, RPM, TENSION, RESTITUTION = "08B", 18, 1000.0, 1000.0, 0.7
PERIOD = tooth_period(TEETH, RPM)
SAVE_DT = 1e-6
RTOL = 1e-6
MAX_STEPS = 400_000
VARIANTS = {
    "lumped": ("lumped", "joint"),
    "clearance": ("clearance", "joint"),
    "clearance/rollers-fixed": ("clearance", "lumped"),
}


def scene(fidelity, rollers_on_bush, speed_rpm):
    return jc.scenes.engagement(
        CHAIN,
        TEETH,
        **modelled(
            speed_rpm=speed_rpm,
            tension=TENSION,
            n_entry=8,
            n_exit=5,
            fidelity=fidelity,
            **FRICTIONLESS,
            model=jc.scenes.ChainModel(restitution=RESTITUTION, rollers_on_bush=rollers_on_bush),
        ),
    )


def solve(sc, t1, dense):
    kw = dict(ts=np.linspace(0.0, t1, int(round(t1 / SAVE_DT)) + 1)) if dense else dict(n_save=2)
    sol = jc.simulate(sc, t1, rtol=RTOL, atol=RTOL * 1e-3, max_steps=MAX_STEPS, throw=False, **kw)
    jax.block_until_ready(sol.peak_contact_force)
    return sol


def member_stats(sol, periods):
    ts = np.asarray(sol.ts)
    f = np.asarray(sol.roller_sprocket_force).max(axis=1)
    lt = np.asarray(sol.link_tension)
    per = [float(f[(ts >= k * PERIOD) & (ts < (k + 1) * PERIOD)].max()) for k in range(periods)]
    return {
        "ok": bool(sol.ok),
        "engagement_peaks_N": per,
        "tight_span_mean_N": float(lt[:, 0].mean()),
        "link_peak_N": float(lt.max()),
        "steps": int(sol.stats["num_steps"]),
    }


def spread(xs):
    xs = np.asarray(xs, dtype=float)
    std = float(xs.std(ddof=1)) if len(xs) > 1 else 0.0
    return {
        "n": len(xs),
        "mean": float(xs.mean()),
        "std": std,
        "std_error": std / math.sqrt(len(xs)),
        "min": float(xs.min()),
        "max": float(xs.max()),
    }


def variant(key, p):
    fid, rob = VARIANTS[key]
    t1 = p["periods"] * PERIOD
    members, settle_s = [], []
    for d in p["speed_offsets"]:
        t = time.perf_counter()
        sc = scene(fid, rob, RPM * (1 + d))
        settle_s.append(time.perf_counter() - t)
        m = member_stats(solve(sc, t1, dense=True), p["periods"]) | {"speed_offset": d}
        members.append(m)
        print(
            f"  {key:24s} speed {d:+.2%}: engagement peaks "
            f"{[round(x) for x in m['engagement_peaks_N']]} N, tight span "
            f"{m['tight_span_mean_N']:.0f} N, {m['steps']} steps",
            flush=True,
        )
    nominal = scene(fid, rob, RPM)
    solve(nominal, t1, dense=False)  # compile
    walls = []
    for _ in range(p["repeats"]):
        t = time.perf_counter()
        sol = solve(nominal, t1, dense=False)
        walls.append(time.perf_counter() - t)
    peaks = [x for m in members for x in m["engagement_peaks_N"]]
    out = {
        "members": members,
        "engagement_peak_N": spread(peaks),
        "tight_span_mean_N": spread([m["tight_span_mean_N"] for m in members]),
        "link_peak_N": spread([m["link_peak_N"] for m in members]),
        "wall_s": min(walls),
        "wall_per_rev_s": min(walls) * (60 / RPM) / t1,
        "steps": int(sol.stats["num_steps"]),
        "n_bodies": nominal.n_bodies,
        "settle_s": spread(settle_s[1:] or settle_s),  # the first holds the compile
    }
    e = out["engagement_peak_N"]
    print(
        f"  {key}: engagement peak {e['mean']:.0f} ± {e['std_error']:.0f} N (n = {e['n']}), "
        f"cost {out['wall_per_rev_s']:.1f} s/rev, {out['steps']} steps, "
        f"statics {out['settle_s']['mean']:.1f} s",
        flush=True,
    )
    return out


def compare(a, b):
    """b against a: mean engagement peak difference over its standard error, cost."""
    ea, eb = a["engagement_peak_N"], b["engagement_peak_N"]
    se = math.sqrt(ea["std_error"] ** 2 + eb["std_error"] ** 2)
    diff = eb["mean"] - ea["mean"]
    return {
        "peak_ratio": eb["mean"] / ea["mean"],
        "peak_diff_N": diff,
        "peak_diff_over_std_error": diff / se if se > 0 else None,
        "tight_span_ratio": b["tight_span_mean_N"]["mean"] / a["tight_span_mean_N"]["mean"],
        "link_peak_ratio": b["link_peak_N"]["mean"] / a["link_peak_N"]["mean"],
        "cost_ratio": b["wall_s"] / a["wall_s"],
        "steps_ratio": b["steps"] / a["steps"],
    }


def chart(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(results["variants"])
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2))
    for i, k in enumerate(keys):
        v = results["variants"][k]
        peaks = [x for m in v["members"] for x in m["engagement_peaks_N"]]
        jitter = np.linspace(-0.15, 0.15, len(peaks))
        ax[0].plot(i + jitter, peaks, "o", alpha=0.5, color=f"C{i}")
        e = v["engagement_peak_N"]
        ax[0].errorbar(i, e["mean"], yerr=2 * e["std_error"], fmt="s", color="k", capsize=6)
    ax[0].set_xticks(range(len(keys)), keys)
    ax[0].set_ylabel("peak roller/tooth force per engagement [N]")
    ax[0].set_title("engagement peaks (dots), mean ± 2 standard errors")
    ax[1].bar(
        keys, [results["variants"][k]["wall_per_rev_s"] for k in keys], color=["C0", "C1", "C2"]
    )
    ax[1].set_ylabel("wall time per revolution [s]")
    ax[1].set_title("cost (Tsit5, rtol 1e-6)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = parser(__doc__)
    args = parse(ap, argv)
    p = (
        dict(periods=2, speed_offsets=(0.0, 1e-3), repeats=1)
        if args.quick
        else dict(periods=4, speed_offsets=(0.0, -1e-3, -5e-4, 5e-4, 1e-3), repeats=2)
    )
    start = time.perf_counter()
    results = {"machine": machine_info(), "quick": args.quick, "plan": p}
    print(f"fidelity from settled starts, {p['periods']} tooth periods per member:", flush=True)
    results["variants"] = {k: variant(k, p) for k in VARIANTS}
    v = results["variants"]
    results["clearance_vs_lumped"] = compare(v["lumped"], v["clearance"])
    results["rollers_fixed_vs_on_joint"] = compare(v["clearance"], v["clearance/rollers-fixed"])
    for name in ("clearance_vs_lumped", "rollers_fixed_vs_on_joint"):
        c = results[name]
        print(
            f"{name}: engagement peak ×{c['peak_ratio']:.3f} ({c['peak_diff_N']:+.0f} N = "
            f"{c['peak_diff_over_std_error']:+.1f} standard errors), tight span "
            f"×{c['tight_span_ratio']:.3f}, link peak ×{c['link_peak_ratio']:.3f}, cost "
            f"×{c['cost_ratio']:.2f}",
            flush=True,
        )
    return finish(results, args.out, "fidelity", chart, start)


if __name__ == "__main__":
    main()
