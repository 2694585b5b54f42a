"""The main job's re-measurement in the clearance-joint chain: the source paper's model
(rigid links on pin/bush clearance joints, each roller on its own bush/roller joint, the
default Dahl joint friction), where each roller rattles in its joints and a meshing peak
is one sample of a distribution. Each design meets ``engagements`` meshing events per
operating point on a strand that starts settled; the first two tooth periods (the start
transient) are discarded. Reported per operating point: the per-engagement peaks'
statistics (n, mean, p95, max, the 95 % confidence interval on the mean) and the
difference of the means against the baseline with Welch's interval."""

from __future__ import annotations

import numpy as np

import jaxchain as jc

from .problem import Problem, solve_all

__all__ = ["remeasure", "points_for", "lines", "measure"]

DISCARD = 2  # tooth periods of start transient left out of the statistics
STEPS_PER_PERIOD = 25_000  # step budget per tooth period (Dahl joints: ~5 k at 1250 rpm)
POINTS = ("worst", "all")


def measure(
    design,
    *,
    chain,
    teeth: int,
    rpm: float,
    tension: float,
    wear: float,
    engagements: int,
    fidelity: str = "clearance",
    lubrication=None,
) -> dict:
    """Per-engagement peaks [N] of ``design`` (a tooth profile, or a
    :class:`~jaxchain.design.SprocketDesign`: its tooth and cushion ring) on the
    engagement strand (the builder's default joint friction of ``fidelity``;
    ``engagements`` rollers mesh after the discarded start, one more closes the last
    window), which of its link's rollers each is (``populations``: 1 first, 2 second,
    :meth:`jc.Engagements.populations <jaxchain.Engagements.populations>`), with the
    solve's outcome (Tsit5 at ``simulate``'s default tolerances); ``lubrication``: an oil
    film in the clearance chain's joints (None: dry)."""
    n_entry = engagements + DISCARD + 1
    profile = jc.design.profile_of(design)
    spec = jc.scenes.StrandSpec(
        chain=chain,
        speed_rpm=rpm,
        fidelity=fidelity,
        sprocket=jc.scenes.SprocketSpec(teeth, profile=profile, load=None),
        tension=tension,
        n_entry=n_entry,
        elongation=wear,
        lubrication=lubrication if fidelity == "clearance" else None,
        cushion=getattr(design, "cushion", None),
    )
    scene = spec.build()
    return jc.design.engagement_sample(scene, discard=DISCARD, steps_per_period=STEPS_PER_PERIOD)


def _stats(peaks) -> dict:
    if len(peaks) < 2:
        return {"n": len(peaks)}
    st = jc.peak_statistics(peaks)
    return {
        "n": st.n,
        "mean_N": st.mean,
        "std_N": st.std,
        "p95_N": st.p95,
        "max_N": st.max,
        "ci95_N": [st.ci_low, st.ci_high],
    }


def remeasure(
    problem: Problem,
    designs: dict,
    baseline: str,
    points: list[tuple[float, float]],
    engagements: int,
    *,
    threads: int | None = None,
) -> dict:
    """Every design of ``designs`` (name → profile) at every operating point of
    ``points`` ((speed factor, wear) pairs), ``engagements`` meshing events each; the
    solves, independent of each other, run ``threads`` at a time. Each member's
    ``difference`` compares a design's mean peak with ``baseline``'s (Welch's 95 %
    interval on optimized − baseline; ``relative``: the difference over the baseline's
    mean)."""
    jobs = [(name, f, e) for f, e in points for name in designs]

    s = problem.settings

    def one(job):
        name, f, e = job
        return measure(
            designs[name],
            chain=problem.chain,
            teeth=s.teeth,
            rpm=s.speed_rpm * f,
            tension=s.load,
            wear=e,
            engagements=engagements,
        )

    rows = solve_all(one, jobs, threads)
    by = {job: row for job, row in zip(jobs, rows, strict=True)}
    members = []
    for f, e in points:
        member = {"speed_factor": f, "wear": e}
        for name in designs:
            row = by[(name, f, e)]
            member[name] = _stats(row["peaks_N"]) | {
                k: row[k] for k in ("ok", "message", "steps", "wall_s", "peaks_N")
            }
        base = by[(baseline, f, e)]["peaks_N"]
        for name in designs:
            mine = by[(name, f, e)]["peaks_N"]
            if name == baseline or min(len(mine), len(base)) < 2:
                continue
            c = jc.compare_peaks(base, mine)  # mine − base
            member[name]["difference"] = {
                "mean_N": c.difference,
                "ci95_N": [c.ci_low, c.ci_high],
                "relative": c.relative,
                "excludes_zero": bool(c.excludes_zero),
            }
        members.append(member)
    return {
        "fidelity": "clearance",
        "model": model_text(problem.chain)
        + ", Dahl joint friction (jc.scenes.CLEARANCE_JOINT_FRICTION), Johnson law at the teeth",
        "engagements_per_point": engagements,
        "discarded_periods": DISCARD,
        "baseline": baseline,
        "members": members,
    }


def model_text(chain) -> str:
    """What the clearance-joint chain of ``chain`` is made of, in words."""
    if chain.has_roller:
        return "rigid links on pin/bush clearance joints, rollers on bush/roller joints"
    return (
        "rigid links on pin/bush clearance joints, the bushes engaging the teeth (a bush "
        "chain; Dahl friction at the teeth, jc.scenes.BUSH_TOOTH_FRICTION)"
    )


def points_for(problem: Problem, which: str, lumped_peaks: list[float]):
    """The operating points to re-measure: ``"all"``, or ``"worst"``: the one where the
    baseline's lumped-chain peak is highest."""
    if which not in POINTS:
        raise ValueError(f"clearance points must be one of {POINTS}, got {which!r}")
    pts = problem.operating_points
    if which == "all":
        return pts
    return [pts[int(np.argmax(lumped_peaks))]]


def lines(c: dict, names: dict) -> list[str]:
    """The summary's lines for a clearance re-measurement (``names``: design → label)."""
    out = [
        f"clearance-joint chain ({c['engagements_per_point']} engagements requested per "
        f"operating point, start transient of {c['discarded_periods']} periods discarded):"
    ]
    for m in c["members"]:
        head = f"  {m['speed_factor']:g}x speed, wear {100 * m['wear']:g} %:"
        parts = []
        for name, label in names.items():
            r = m[name]
            if "mean_N" not in r:
                parts.append(f"{label} failed ({r['message']})")
                continue
            lo, hi = r["ci95_N"]
            text = f"{label} mean {r['mean_N']:.0f} N [{lo:.0f}, {hi:.0f}], n {r['n']}"
            if "difference" in r:
                d = r["difference"]
                text += (
                    f", {100 * d['relative']:+.1f} % "
                    f"(difference CI [{d['ci95_N'][0]:.0f}, {d['ci95_N'][1]:.0f}] N)"
                )
            parts.append(text)
        out.append(head + " " + "; ".join(parts))
    return out
