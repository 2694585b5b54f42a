"""``python -m optimize --problem quiet``: a quiet sprocket, designed where the meshing peak
is made and re-measured in the source paper's clearance-joint chain, dry and in oil.

Two designs, each a run of the main job's machinery (:func:`optimize.run.run`: Adam with
gradients through the lumped chain's solve, Nelder–Mead beside it, both re-measured by a
tight-tolerance solve under two contact laws, the better delivered):

* ``tooth``: the free-form asymmetric tooth alone (problem ``gentle``), in ``tooth/``;
* ``tooth_ring``: the tooth with a cushion ring on both faces (problem ``ring``: its
  radius, stiffness and damping beside the tooth's seven coordinates), in
  ``tooth_ring/``.

Both are designed in the lumped chain: over ten teeth it ranks tooth forms as the
lubricated clearance-joint chain does (Spearman 0.93, ``benchmarks/clearance_design.py
--viscosity 0.01``), at a fraction of the cost, and its gradients hold over the design
window where the clearance chain's do not (``benchmarks/clearance_gradient.py``).

Then every design and the best ISO 606 form of the tooth run (no ring) mesh
``engagements`` rollers on the clearance-joint strand at each speed of ``speeds``, with
dry joints (the default Dahl joint friction) and with an oil film in them
(:class:`jc.contact.OilFilm` at ``viscosity``); the first two tooth periods are discarded.
Each solve is kept in ``clearance/`` as it finishes, so an interrupted run resumes
losing none. Reported per speed and lubrication: each design's per-engagement peaks
(mean, p95, both roller populations) and its difference against the ISO form (Welch's
interval on the mean, a bootstrap interval on the p95), against the goals: the tooth
alone ≥ 10 % lower mean and p95, the tooth with rings ≥ 30 %, each interval excluding
zero, and no worse than +5 % on the lumped chain.

Writes ``results.json`` (``summary.designs`` lists each design's files relative to the
folder) and ``peaks.png`` (the designs' peak distributions side by side).
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import jaxchain as jc

from . import clearance
from .problem import Settings, iso_forms, make_problem, profile_values, solve_all
from .run import (
    RESULTS,
    delivered_design,
    jsonable,
    log,
    run as run_design,
    save_figure,
    versions,
    write_atomic,
)

DESIGNS = {"tooth": "gentle", "tooth_ring": "ring"}  # design name -> problem
RING_ITERATIONS = 30  # Adam's iterations for the tooth with its ring (10 coordinates)
GOALS = {"tooth": 0.10, "tooth_ring": 0.30}  # lower mean and p95 than the ISO form, fraction
LUMPED_LIMIT = 0.05  # no worse than +5 % on the lumped chain
LUBRICATIONS = ("dry", "oil")
POPULATIONS = {1: "first", 2: "second"}


@dataclass
class QuietSettings:
    """What defines a quiet run (saved with its results)."""

    # speed factors (of 1000 rpm) measured in the clearance chain: the design band's
    # 500, 1000 and 1500 rpm and two speeds above it (below it the solves cost more: the
    # ISO form's dry solve took 589 s at 300 rpm, 134 s at 2000 rpm)
    speeds: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5)
    engagements: int = 64  # per speed and lubrication: >= 30 per roller population
    viscosity: float = 0.01  # the lubricated measurement's oil [Pa·s] (hot engine oil)
    iterations: int | None = None  # of each design run (None: RING_ITERATIONS for the
    # ring's ten coordinates, the main job's default for the tooth)
    fast: bool = False  # small design runs (smoke tests)

    def validate(self) -> None:
        if not self.speeds or not all(0.2 <= f <= 5 for f in self.speeds):
            raise ValueError(f"speeds must be factors in [0.2, 5] of 1000 rpm, got {self.speeds}")
        if not 2 <= self.engagements <= 1000:
            raise ValueError(
                "engagements must be in [2, 1000] (60 or more: >= 30 per roller population), "
                f"got {self.engagements}"
            )
        if not (math.isfinite(self.viscosity) and self.viscosity > 0):
            raise ValueError(f"viscosity must be > 0 Pa·s, got {self.viscosity}")
        if self.iterations is not None and self.iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {self.iterations}")


def design_settings(qs: QuietSettings, problem: str) -> Settings:
    """The main job's settings of one design run (its own clearance re-measurement off:
    this run measures both populations, dry and lubricated)."""
    s = Settings(problem=problem, clearance_engagements=0)
    if qs.iterations is not None:
        s.iterations = qs.iterations
    elif problem == "ring":
        s.iterations = RING_ITERATIONS
    if qs.fast:
        from .__main__ import fast_settings

        s = fast_settings(s, frozenset({"clearance_engagements"}))
    return s


def _design_run(qs: QuietSettings, name: str, out: Path, resume: bool, quiet: bool) -> dict:
    """One design's run, or its results where a finished run of the same settings is
    there already (``resume``)."""
    folder = out / name
    settings = design_settings(qs, DESIGNS[name])
    done = folder / RESULTS
    if resume and done.exists():
        results = json.loads(done.read_text())
        if results.get("settings") == settings.as_dict():
            log(f"{name}: finished run found in {folder}", quiet)
            return results
    log(f"designing {name} (problem {settings.problem}) in {folder} ...", quiet)
    resume_it = resume and (folder / "checkpoint.json").exists()
    return run_design(settings, folder, resume=resume_it, quiet=quiet)


def _space_of(design):
    """The design space whose leaves name a design's numbers (None: the ISO four)."""
    if isinstance(design, jc.ToothProfile):
        return None
    problem = "ring" if isinstance(design, jc.design.SprocketDesign) else "gentle"
    return make_problem(Settings(problem=problem)).space


def _job_file(out: Path, job) -> Path:
    name, f, lub = job
    return out / "clearance" / f"{name}_{f:g}x_{lub}.json"


def measure_all(qs: QuietSettings, out: Path, designs: dict, resume: bool, quiet: bool) -> dict:
    """Every design at every speed, dry and oiled, in the clearance-joint chain; each
    job's result read back from ``clearance/`` where ``resume`` finds it."""
    problem = make_problem(Settings())
    s = problem.settings
    jobs = [(n, f, lub) for f in qs.speeds for lub in LUBRICATIONS for n in designs]

    # what a kept solve must have measured: each design's own numbers
    keys = {n: jsonable(profile_values(d, _space_of(d))) for n, d in designs.items()}

    done = {}
    for job in jobs:
        path = _job_file(out, job)
        if resume and path.exists():
            row = json.loads(path.read_text())
            if (
                row.get("engagements") == qs.engagements
                and row.get("viscosity") == (qs.viscosity if job[2] == "oil" else None)
                and row.get("design") == keys[job[0]]
            ):
                done[job] = row
    todo = [j for j in jobs if j not in done]
    log(
        f"clearance-joint chain: {len(todo)} of {len(jobs)} solves to run ({qs.engagements} "
        f"engagements each, {len(designs)} designs x {len(qs.speeds)} speeds x dry/oil) ...",
        quiet,
    )

    def one(job):
        name, f, lub = job
        viscosity = qs.viscosity if lub == "oil" else None
        row = clearance.measure(
            designs[name],
            chain=problem.chain,
            teeth=s.teeth,
            rpm=s.speed_rpm * f,
            tension=s.load,
            wear=0.0,
            engagements=qs.engagements,
            lubrication=None if viscosity is None else jc.contact.OilFilm(viscosity),
        )
        row |= {"engagements": qs.engagements, "viscosity": viscosity, "design": keys[name]}
        write_atomic(_job_file(out, job), json.dumps(jsonable(row)))
        log(
            f"  {name} at {f:g}x, {lub}: {len(row['peaks_N'])} engagements, "
            f"{row['wall_s']:.0f} s{'' if row['ok'] else ' FAILED: ' + row['message']}",
            quiet,
        )
        return row

    for job, row in zip(todo, solve_all(one, todo), strict=True):
        done[job] = row
    return done


def _stats(peaks) -> dict:
    st = jc.peak_statistics(peaks)
    return {"n": st.n, "mean_N": st.mean, "p95_N": st.p95, "ci95_N": [st.ci_low, st.ci_high]}


def _difference(base, mine) -> dict:
    c = jc.compare_peaks(base, mine)  # mine − base
    return {
        "mean": c.relative,
        "mean_ci95_N": [c.ci_low, c.ci_high],
        "p95": c.p95_difference / c.a.p95,
        "p95_ci95_N": [c.p95_ci_low, c.p95_ci_high],
        "excludes_zero": bool(c.ci_high < 0 or c.ci_low > 0)
        and bool(c.p95_ci_high < 0 or c.p95_ci_low > 0),
    }


def tables(qs: QuietSettings, rows: dict, baseline: str, names) -> list[dict]:
    """Per speed and lubrication: each design's statistics (all engagements and by roller
    population) and, against ``baseline``, the relative differences of the mean and the
    p95 with their intervals."""
    out = []
    for f in sorted(qs.speeds):
        for lub in LUBRICATIONS:
            entry = {"speed_factor": f, "lubrication": lub}
            base = rows[(baseline, f, lub)]
            for name in names:
                r = rows[(name, f, lub)]
                peaks, pops = np.asarray(r["peaks_N"]), np.asarray(r["populations"])
                item = {"ok": r["ok"], "message": r["message"], "steps": r["steps"]}
                if r["ok"] and peaks.size >= 2:
                    item |= _stats(peaks)
                    for k, label in POPULATIONS.items():
                        if np.sum(pops == k) >= 2:
                            item[label] = _stats(peaks[pops == k])
                    if name != baseline and base["ok"] and len(base["peaks_N"]) >= 2:
                        item["against_baseline"] = _difference(base["peaks_N"], peaks)
                        bp = np.asarray(base["populations"])
                        bpeaks = np.asarray(base["peaks_N"])
                        for k, label in POPULATIONS.items():
                            if min(np.sum(pops == k), np.sum(bp == k)) >= 2:
                                item[label]["against_baseline"] = _difference(
                                    bpeaks[bp == k], peaks[pops == k]
                                )
                entry[name] = item
            out.append(entry)
    return out


def lumped_changes(runs: dict, baseline: str) -> dict:
    """Per design: its lumped-chain re-measured peak (nominal law) against the ISO
    form's at every operating point of the design band, as a relative change."""
    base = runs["tooth"]["remeasured"][baseline]["johnson"]["members"]
    out = {}
    for name, r in runs.items():
        mine = r["remeasured"]["optimized"]["johnson"]["members"]
        out[name] = [
            {
                "speed_factor": m["speed_factor"],
                "wear": m["wear"],
                "change": m["peak_N"] / b["peak_N"] - 1,
            }
            for m, b in zip(mine, base, strict=True)
        ]
    return out


def goals(table: list[dict], lumped: dict, members: dict) -> dict:
    """Each design against its goal: met where every speed and lubrication shows a mean
    and a p95 lower by the goal's fraction with intervals excluding zero, and the lumped
    chain's peak no more than +5 % above the ISO form's at every operating point of the
    band (``members``; ``lumped``: the worst member's reduction, the runs' headline)."""
    out = {}
    for name, goal in GOALS.items():
        cells = []
        for e in table:
            d = e[name].get("against_baseline")
            met = d is not None and -d["mean"] >= goal and -d["p95"] >= goal and d["excludes_zero"]
            cells.append(
                {
                    "speed_factor": e["speed_factor"],
                    "lubrication": e["lubrication"],
                    "mean_reduction": None if d is None else -d["mean"],
                    "p95_reduction": None if d is None else -d["p95"],
                    "resolved": None if d is None else d["excludes_zero"],
                    "met": bool(met),
                }
            )
        lumped_ok = all(m["change"] <= LUMPED_LIMIT for m in members[name])
        out[name] = {
            "goal": goal,
            "lumped_reduction": lumped[name],
            "lumped_members": members[name],
            "lumped_ok": bool(lumped_ok),
            "cells": cells,
            "met": bool(lumped_ok and all(c["met"] for c in cells)),
        }
    return out


def run(qs: QuietSettings, out: Path, *, resume: bool = False, quiet: bool = False) -> dict:
    """Design both, measure them in the clearance chain, write ``out``/results.json."""
    qs.validate()
    t0 = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = {name: _design_run(qs, name, out, resume, quiet) for name in DESIGNS}
    better = runs["tooth"]["better_baseline"]  # the best ISO form (lumped, nominal law)
    forms = iso_forms(make_problem(Settings()))
    designs = {better: forms[better.removeprefix("iso_")]}
    designs |= {name: delivered_design(r) for name, r in runs.items()}
    rows = measure_all(qs, out, designs, resume, quiet)
    table = tables(qs, rows, better, list(designs))
    lumped = {name: r["reduction_vs_better_baseline"]["johnson"] for name, r in runs.items()}
    met = goals(table, lumped, lumped_changes(runs, better))
    files = {name: {k: f"{name}/{v}" for k, v in runs[name]["files"].items()} for name in runs}
    results = {
        "summary": {
            "objective": "per-engagement peak roller/tooth force in the clearance-joint "
            "chain (mean and p95), dry and lubricated",
            "unit": "N",
            "baseline": f"ISO 606 {better.removeprefix('iso_')} form, no ring",
            "designs": files,
            "goals": met,
        },
        "settings": dataclasses.asdict(qs),
        "versions": versions(),
        "design_model": "lumped chain (the runs in tooth/ and tooth_ring/)",
        "clearance": {
            "model": clearance.model_text(jc.ChainSpec.iso606(Settings().chain))
            + ", Dahl joint friction; oil: jc.contact.OilFilm in every joint",
            "rpm": [1000.0 * f for f in sorted(qs.speeds)],
            "engagements_requested": qs.engagements,
            "discarded_periods": clearance.DISCARD,
            "table": table,
        },
        "wall_s": time.perf_counter() - t0,
    }
    write_atomic(out / RESULTS, json.dumps(jsonable(results), indent=1))
    figure(out, qs, rows, list(designs))
    log(report(results), quiet)
    return results


def report(r: dict) -> str:
    lines = ["", f"against the {r['summary']['baseline']} (clearance-joint chain):"]
    for name, g in r["summary"]["goals"].items():
        worst = max(g["lumped_members"], key=lambda m: m["change"])
        lines.append(
            f"  {name}: goal {100 * g['goal']:.0f} % lower mean and p95 -> "
            f"{'met' if g['met'] else 'not met'}; lumped chain: worst member "
            f"{-100 * g['lumped_reduction']:+.1f} %, at most {100 * worst['change']:+.1f} % "
            f"({worst['speed_factor']:g}x, wear {100 * worst['wear']:g} %)"
        )
        for c in g["cells"]:
            if c["mean_reduction"] is None:
                lines.append(f"    {c['speed_factor']:g}x {c['lubrication']}: failed")
                continue
            lines.append(
                f"    {c['speed_factor']:g}x {c['lubrication']}: mean "
                f"{-100 * c['mean_reduction']:+.1f} %, p95 {-100 * c['p95_reduction']:+.1f} %"
                f"{'' if c['resolved'] else ' (an interval spans zero)'}"
            )
    return "\n".join(lines)


def figure(out: Path, qs: QuietSettings, rows: dict, names: list[str]) -> None:
    """``peaks.png`` in ``out``: :func:`draw`."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = draw(rows, qs.speeds, names)
    save_figure(fig, out / "peaks.png")
    plt.close(fig)


def draw(rows: dict, speeds, names: list[str]):
    """The designs' per-engagement peaks side by side, a row per lubrication and a column
    per speed, each roller population its own marker (``rows``: (design, speed factor,
    lubrication) → a solve's ``peaks_N`` and ``populations``). Returns the figure."""
    import matplotlib.pyplot as plt

    speeds = sorted(speeds)
    fig, axes = plt.subplots(
        len(LUBRICATIONS), len(speeds), figsize=(2.9 * len(speeds) + 1, 7.5),
        sharey="row", squeeze=False,
    )  # fmt: skip
    rng = np.random.default_rng(0)
    for row, lub in enumerate(LUBRICATIONS):
        for ax, f in zip(axes[row], speeds, strict=True):
            data = [np.asarray(rows[(n, f, lub)]["peaks_N"]) for n in names]
            ax.boxplot(data, whis=(5, 95), showfliers=False)
            for i, n in enumerate(names):
                pops = np.asarray(rows[(n, f, lub)]["populations"])
                for k, (marker, color) in {1: ("o", "tab:blue"), 2: ("^", "tab:red")}.items():
                    y = data[i][pops == k]
                    x = i + 1 + rng.uniform(-0.15, 0.15, y.size)
                    label = f"{POPULATIONS[k]} roller" if i == 0 else None
                    ax.scatter(x, y, s=8, marker=marker, color=color, alpha=0.6, label=label)
            ax.set_xticks(range(1, len(names) + 1), names, rotation=20)
            ax.set_title(f"{1000 * f:.0f} rpm, {lub}", fontsize=10)
            ax.grid(alpha=0.3, axis="y")
        axes[row, 0].set_ylabel(f"{lub} joints: per-engagement peak [N]")
    axes = axes[:, 0]
    axes[0].legend(loc="upper left", fontsize=8)
    fig.suptitle(
        "Clearance-joint chain: meshing peaks of the ISO form and the designs "
        "(boxes: quartiles, whiskers 5-95 %)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig
