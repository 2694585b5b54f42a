"""Shared helpers of the studies that compare per-engagement meshing peaks of the
clearance-joint chain between variants (``lubrication``, ``cushion_ring``): the strand,
one variant's measured engagements by roller population, their statistics and the Welch
comparison of two variants."""

from __future__ import annotations

import time

import numpy as np

import jaxchain as jc
from benchmarks.common import modelled

CHAIN, TEETH, TENSION = "08B", 18, 1000.0
DISCARD = 2  # tooth periods of start transient
MAX_STEPS = 4_000_000
POPULATIONS = ((1, "first"), (2, "second"))


def period(rpm: float) -> float:
    """One tooth period of the z = 18 driver at ``rpm`` [s]."""
    return 60.0 / (TEETH * rpm)


def strand(rpm: float, n_entry: int, **model):
    """The 08B z = 18 meshing strand at ``rpm`` under 1000 N, clearance chain unless
    ``model`` says otherwise (``jc.scenes.engagement``'s keywords)."""
    model = {"fidelity": "clearance", **model}
    return jc.scenes.engagement(
        CHAIN, TEETH, **modelled(speed_rpm=rpm, tension=TENSION, n_entry=n_entry, **model)
    )


def stats(peaks) -> dict:
    """n, mean, p95, max, CV and the 95 % interval on the mean of peaks [N]."""
    s = jc.peak_statistics(peaks)
    return {
        "n": s.n,
        "mean": s.mean,
        "p95": s.p95,
        "max": s.max,
        "cv": s.std / s.mean,
        "ci": [s.ci_low, s.ci_high],
    }


def measure(rpm: float, n_entry: int, label: str, **model) -> dict:
    """One variant's per-engagement peaks (onsets after the start transient), by
    population, and its solve's cost."""
    t0 = time.perf_counter()
    scene = strand(rpm, n_entry, **model)
    build = time.perf_counter() - t0
    t1 = n_entry * period(rpm)
    obs = jc.observers.EngagementPeaks.for_solve(scene, t1)
    t0 = time.perf_counter()
    sol = jc.simulate(scene, t1, n_save=2, max_steps=MAX_STEPS, observers=(obs,))
    wall = time.perf_counter() - t0
    ev = jc.engagement_peaks(sol, t_start=DISCARD * period(rpm)).select(sprocket=0)
    pop = ev.populations()
    out = {
        "label": label,
        "rpm": rpm,
        "build_s": build,
        "solve_s": wall,
        "steps": int(sol.stats["num_steps"]),
        "peaks": ev.peak.tolist(),
        "population": pop.tolist(),
        "all": stats(ev.peak),
    }
    for k, name in POPULATIONS:
        if np.count_nonzero(pop == k) >= 2:
            out[name] = stats(ev.peak[pop == k])
    a = out["all"]
    print(
        f"  {rpm:.0f} rpm {label}: {a['n']} engagements, mean {a['mean']:.0f} N, p95 "
        f"{a['p95']:.0f} N ({out['steps']} steps, {wall:.0f} s)",
        flush=True,
    )
    return out


def compare(base: dict, other: dict) -> dict:
    """``other`` against ``base``, over all engagements and per population: the difference
    of the means with Welch's 95 % interval, and the relative change of the p95."""
    out = {}
    for name in ("all", "first", "second"):
        if name not in base or name not in other:
            continue
        a, b = np.asarray(base["peaks"]), np.asarray(other["peaks"])
        if name != "all":
            k = dict((v, k) for k, v in POPULATIONS)[name]
            a = a[np.asarray(base["population"]) == k]
            b = b[np.asarray(other["population"]) == k]
        c = jc.compare_peaks(a, b)
        out[name] = {
            "difference": c.difference,
            "relative": c.relative,
            "ci": [c.ci_low, c.ci_high],
            "excludes_zero": c.excludes_zero,
            "p95_relative": float(np.percentile(b, 95) / np.percentile(a, 95) - 1),
        }
    return out


def boxes(ax, runs: list[dict], title: str) -> None:
    """Box plots (whiskers 5–95 %, mean marked) of each run's peaks per population."""
    data, labels = [], []
    for r in runs:
        pk, pop = np.asarray(r["peaks"]), np.asarray(r["population"])
        for k, short in ((1, "1st"), (2, "2nd")):
            if np.any(pop == k):
                data.append(pk[pop == k])
                labels.append(f"{r['label']}\n{short} roller")
    ax.boxplot(data, whis=(5, 95), showmeans=True)
    ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=6, rotation=30, ha="right")
    ax.set_ylabel("per-engagement peak roller/tooth force [N]")
    ax.set_title(f"{title} (whiskers 5–95 %, ▲ mean)", fontsize=9)
