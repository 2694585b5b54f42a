"""Design-space study: how low can the *re-measured* peak go inside the ISO 606 box? The
ISO forms, a main-job Adam optimum, the box's corners, a Sobol sample and main-effect lines
are re-measured (``optimize.problem.remeasure``) beside the design objective; the best also
under the second law, past the box and on a longer entry strand.

    python -m benchmarks.design_space            # full study (~74 designs, 3 speeds)
    python -m benchmarks.design_space --quick    # smoke run: 1 speed, ~13 designs
    python -m benchmarks.design_space --adam-results PATH   # that main-job run's optimum

Writes ``benchmarks/results/design_space.json`` (rewritten after every design, so an
interrupted run keeps what it measured) and ``design_space.png``.

Notes: benchmarks/design_space.md
"""

from __future__ import annotations

import json
import math
import time
from contextlib import contextmanager
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    OUT,
    figure,
    jsonable,
    loadavg,
    machine_info,
    parse,
    parser,
    write_atomic,
)
from optimize.problem import (  # noqa: E402
    Problem,
    Settings,
    iso_forms,
    make_problem,
    profile_values,
    remeasure,
)

ADAM = OUT / "optimize_iso" / "results.json"  # the main job in the ISO box (--problem iso)
SOBOL_SEED = 20240606
ISO_ENSEMBLE = (0.9, 1.0, 1.1)  # the speed factors of the study's committed results
EDGE_BAND = 0.01  # a peak this close (fraction of the window) to its start or end is clipped
SIGNIFICANT = 1e-3  # a design "beats" the min form by more than this fraction (re-measured
# peaks move by ~1e-6 under round-off-level changes of the model: the reproducibility floor)
EXTRA_ENTRY = 4  # strand-length check: entry rollers added to the problem's scene
EDGE = 1e-12  # corners: fractions clipped this far inside [0, 1] (x off by 1e-12·range)
NAMES = jc.design.PARAMETERS
SHORT = {"seating_radius": "ri", "seating_angle": "alpha", "flank_radius": "re",
         "tip_diameter": "da"}  # fmt: skip


#: what the study measures: (--quick, full study) for each entry
PLAN = {
    "ensemble": ((1.0,), ISO_ENSEMBLE),
    "corner_params": (("seating_radius", "seating_angle"), NAMES),
    "sobol": (4, 32),
    "effect_params": (("seating_radius",), NAMES),
    "effect_points": (3, 7),
    "hertz_top": (1, 3),
    "hertz_extra": (("iso_min",), ("adam", "iso_min", "iso_max")),
    "beyond_alpha": ((1.5,), (1.25, 1.5, 2.0)),
    "strand_top": (0, 3),
}


def plan(quick: bool) -> dict:
    return {k: v[0] if quick else v[1] for k, v in PLAN.items()}


def settings_for(quick: bool) -> Settings:
    """The problem's settings: the main job's defaults (one speed with ``--quick``)."""
    return Settings(
        problem="iso", ensemble=tuple(plan(quick)["ensemble"]), wear=(0.0,), temperature=0.02
    )  # the settings of the study's committed results


def peak_at(problem: Problem, member: dict) -> float:
    """Where in the window a re-measured member's sharp peak falls (0 = start, 1 = end),
    read from its own trace (no extra solve): a peak within ``EDGE_BAND`` of either end
    is an impact clipped by the window, not a whole one."""
    ts, force = np.asarray(member["ts"]), np.asarray(member["force"])
    if not member["ok"] or ts.size == 0:
        return float("nan")
    at = ts[int(np.argmax(force))] - problem.t_start
    return float(at / (problem.t1 - problem.t_start))


@contextmanager
def longer_entry(extra: int):
    """Diagnostic: inside, ``jc.scenes.engagement`` (what ``Problem.build`` calls) gets
    ``extra`` more entry rollers, so ``remeasure`` runs unchanged on a longer strand."""
    real = jc.scenes.engagement

    def engagement(*args, n_entry, **kwargs):
        return real(*args, n_entry=n_entry + extra, **kwargs)

    jc.scenes.engagement = engagement
    try:
        yield
    finally:
        jc.scenes.engagement = real


def profile_at(problem: Problem, fraction) -> jc.ToothProfile:
    """The profile at fractions of the ISO ranges, *not* clipped to the box (diagnostic:
    beyond the standard), built on the design space's template as ``DesignSpace.profile``."""
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    x = lo + (hi - lo) * np.asarray(fraction, dtype=float)
    return eqx.tree_at(
        lambda p: [getattr(p, n) for n in NAMES],
        problem.space.template,
        [jnp.asarray(v) for v in x],
    )


def coordinate(fraction) -> jnp.ndarray:
    """``u`` of fractions of the box (clipped ``EDGE`` inside it: corners stay finite)."""
    f = np.clip(np.asarray(fraction, dtype=float), EDGE, 1 - EDGE)
    return jnp.asarray(np.log(f) - np.log1p(-f))


def key_of(fraction) -> tuple:
    return tuple(np.round(np.asarray(fraction, dtype=float), 9).tolist())


def fraction_of(problem: Problem, profile) -> np.ndarray:
    x = np.array([float(getattr(profile, n)) for n in NAMES])
    lo, hi = np.asarray(problem.space.lower), np.asarray(problem.space.upper)
    return (x - lo) / (hi - lo)


def moved(base: np.ndarray, name: str, v: float) -> np.ndarray:
    """``base`` (fractions) with parameter ``name`` at ``v``."""
    f = base.copy()
    f[NAMES.index(name)] = v
    return f


def effect_line(base: np.ndarray, name: str, points: int) -> tuple[np.ndarray, list]:
    """A main-effect line: ``name`` at ``points`` values across its range, the others at
    ``base``; the values and the fractions."""
    vs = np.linspace(0.0, 1.0, points)
    return vs, [moved(base, name, v) for v in vs]


# ----------------------------------------------------------------------------- designs
def design_list(problem: Problem, p: dict, adam: dict | None) -> list[dict]:
    """Every design as {name, group, fraction, u, profile}; ISO forms first (they fix the
    objective's reference), duplicates (same fractions) listed once under the first name."""
    from scipy.stats import qmc

    forms = iso_forms(problem)
    out: list[dict] = []
    seen: dict[tuple, dict] = {}

    def add(name, group, fraction, profile=None, u=None):
        fraction = np.asarray(fraction, dtype=float)
        k = key_of(fraction)
        if k in seen:
            seen[k]["aliases"].append(name)
            return
        if profile is None:
            u = coordinate(fraction) if u is None else jnp.asarray(u, dtype=float)
            profile = problem.space.profile(u)
        if u is None:
            u = problem.space.coordinates(profile, margin=EDGE)
        d = dict(name=name, group=group, fraction=fraction, u=u, profile=profile, aliases=[])
        seen[k] = d
        out.append(d)

    for form in ("min", "max", "mid"):
        add(f"iso_{form}", "iso", fraction_of(problem, forms[form]), profile=forms[form])
    if adam is not None:
        u = jnp.asarray(adam["u"], dtype=float)
        add("adam", "adam", np.asarray(problem.space.fraction(u)), u=u)
    base = fraction_of(problem, forms["min"])
    idx = [NAMES.index(n) for n in p["corner_params"]]
    for bits in range(2 ** len(idx)):
        f = base.copy()
        for j, i in enumerate(idx):
            f[i] = float((bits >> j) & 1)
        label = "".join(f"{SHORT[NAMES[i]]}{int(f[i])}" for i in idx)
        add(f"corner_{label}", "corner", f)
    sobol = qmc.Sobol(d=4, scramble=True, seed=SOBOL_SEED)
    for k, f in enumerate(sobol.random(p["sobol"])):
        add(f"sobol_{k:02d}", "sobol", f)
    for name in p["effect_params"]:
        for v, f in zip(*effect_line(base, name, p["effect_points"]), strict=True):
            add(f"effect_{SHORT[name]}_{v:.3f}", "effect", f)
    return out


# ----------------------------------------------------------------------------- measure
def measure(problem: Problem, d: dict) -> dict:
    """Re-measured peaks (Johnson law) of one design: worst and per speed factor."""
    t = time.perf_counter()
    m = remeasure(problem, d["profile"])
    seconds = time.perf_counter() - t
    peaks = [r["peak_N"] for r in m["members"]]
    worst = int(np.nanargmax(peaks)) if np.any(np.isfinite(peaks)) else None
    return {
        "name": d["name"],
        "group": d["group"],
        "aliases": d["aliases"],
        "fraction": np.asarray(d["fraction"]).tolist(),
        "u": None if d["u"] is None else np.asarray(d["u"]).tolist(),
        "params": profile_values(d["profile"]),
        "peak_N": m["peak_N"],
        "mean_peak_N": m["mean_peak_N"],
        "member_peaks_N": peaks,
        "worst_speed_factor": None if worst is None else problem.settings.ensemble[worst],
        "member_peak_at": [peak_at(problem, r) for r in m["members"]],
        "member_ok": [bool(r["ok"]) for r in m["members"]],
        "member_steps": [r["steps"] for r in m["members"]],
        "member_messages": [r["message"] for r in m["members"] if r["message"]],
        "remeasure_s": seconds,
        "loadavg": loadavg(),
        "_trace": None if worst is None else m["members"][worst],
    }


def objective(problem: Problem, u) -> dict:
    """The design objective at ``u`` and its members' smooth peaks."""
    t = time.perf_counter()
    value, members = problem.objective.value(u)
    return {
        "objective_N": float(value),
        "objective_member_soft_N": np.atleast_1d(np.asarray(members.soft)).tolist(),
        "objective_failures": [m for m in jc.result_messages(members.result) if m],
        "objective_s": time.perf_counter() - t,
    }


def remeasured(problem: Problem, profile, extra: dict | None = None, **law) -> dict:
    """A check's re-measurement of ``profile`` (``law``: ``remeasure``'s): worst and per
    speed factor, where each member's peak falls, ``extra`` and the time taken."""
    t = time.perf_counter()
    m = remeasure(problem, profile, **law)
    return {
        "peak_N": m["peak_N"],
        "member_peaks_N": [r["peak_N"] for r in m["members"]],
        "member_peak_at": [peak_at(problem, r) for r in m["members"]],
        "member_ok": [bool(r["ok"]) for r in m["members"]],
        **(extra or {}),
        "seconds": time.perf_counter() - t,
        "loadavg": loadavg(),
    }


# ----------------------------------------------------------------------------- analysis
def spearman(a, b) -> dict:
    from scipy.stats import kendalltau, spearmanr

    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3:
        return {"n": int(ok.sum()), "rho": None, "p": None}
    r = spearmanr(a[ok], b[ok])
    k = kendalltau(a[ok], b[ok])
    return {
        "n": int(ok.sum()),
        "rho": float(r.statistic),
        "p": float(r.pvalue),
        "kendall_tau": float(k.statistic),
    }


def roughness(values) -> dict:
    """Along a line: total variation / net change (1 = monotone) and direction changes."""
    v = np.asarray(values, dtype=float)
    d = np.diff(v)
    tv = float(np.sum(np.abs(d)))
    net = float(abs(v[-1] - v[0]))
    s = np.sign(d[d != 0])
    return {
        "range": float(np.max(v) - np.min(v)),
        "total_variation": tv,
        "net_change": net,
        "tv_over_net": tv / net if net > 0 else None,
        "direction_changes": int(np.sum(s[1:] != s[:-1])),
        "largest_step": float(np.max(np.abs(d))) if d.size else 0.0,
    }


def analyse(problem: Problem, rows: list[dict], hz: dict, p: dict) -> dict:
    by_name = {r["name"]: r for r in rows}
    by_key = {key_of(r["fraction"]): r for r in rows}
    base = by_name["iso_min"]["peak_N"]
    better = min(("iso_min", "iso_max"), key=lambda n: by_name[n]["peak_N"])
    ok = [r for r in rows if np.isfinite(r["peak_N"])]
    ranked = sorted(ok, key=lambda r: r["peak_N"])
    best = ranked[0]
    obj = [r["objective_N"] for r in rows]
    peak = [r["peak_N"] for r in rows]
    sample = [r for r in rows if r["group"] in ("corner", "sobol")]
    corr = {
        "objective_vs_worst_peak": spearman(obj, peak),
        "objective_vs_mean_peak": spearman(obj, [r["mean_peak_N"] for r in rows]),
        "objective_vs_worst_peak_box_sample": spearman(
            [r["objective_N"] for r in sample], [r["peak_N"] for r in sample]
        ),
    }
    for k, f in enumerate(problem.settings.ensemble):
        corr[f"member_{f}_soft_vs_sharp"] = spearman(
            [r["objective_member_soft_N"][k] for r in rows],
            [r["member_peaks_N"][k] for r in rows],
        )
        corr[f"member_{f}_sharp_vs_worst"] = spearman([r["member_peaks_N"][k] for r in rows], peak)
    worst_counts = {
        str(f): sum(1 for r in rows if r["worst_speed_factor"] == f)
        for f in problem.settings.ensemble
    }
    # where the peaks fall: a peak at the window's edge is an impact the window clips
    clipped = {
        str(f): sum(1 for r in ok if not EDGE_BAND <= r["member_peak_at"][k] <= 1 - EDGE_BAND)
        for k, f in enumerate(problem.settings.ensemble)
    }
    timing = {
        "edge_band": EDGE_BAND,
        "designs_with_clipped_peak_per_speed": clipped,
        "peak_at_range_per_speed": {
            str(f): [
                float(np.nanmin([r["member_peak_at"][k] for r in ok])),
                float(np.nanmax([r["member_peak_at"][k] for r in ok])),
            ]
            for k, f in enumerate(problem.settings.ensemble)
        },
    }
    lines = {}
    min_form = fraction_of(problem, iso_forms(problem)["min"])
    for name in p["effect_params"]:
        vs, fractions = effect_line(min_form, name, p["effect_points"])
        line = [by_key.get(key_of(f)) for f in fractions]
        if any(r is None for r in line):
            continue
        pk = [r["peak_N"] for r in line]
        ob = [r["objective_N"] for r in line]
        lines[name] = {
            "fraction": vs.tolist(),
            "peak_N": pk,
            "member_peaks_N": [r["member_peaks_N"] for r in line],
            "objective_N": ob,
            "peak_roughness": roughness(pk),
            "objective_roughness": roughness(ob),
            "best_reduction_vs_min_form": 1 - min(pk) / base,
        }
    h = {}
    if "iso_min" in hz:
        hb = hz["iso_min"]["peak_N"]
        hbetter = min(hz[n]["peak_N"] for n in ("iso_min", "iso_max") if n in hz)
        h = {
            "baseline_min_form_N": hb,
            "better_iso_N": hbetter,
            "designs": {
                n: {
                    "peak_N": v["peak_N"],
                    "johnson_peak_N": by_name[n]["peak_N"],
                    "reduction_vs_min_form": 1 - v["peak_N"] / hb,
                    "reduction_vs_better_iso": 1 - v["peak_N"] / hbetter,
                }
                for n, v in hz.items()
            },
        }
        checked = [n for n in hz if n not in ("iso_min", "iso_max")]
        if checked:
            hbest = min(checked, key=lambda n: hz[n]["peak_N"])
            h["best_checked"] = hbest
            h["best_reduction_vs_min_form"] = 1 - hz[hbest]["peak_N"] / hb
            h["best_reduction_vs_better_iso"] = 1 - hz[hbest]["peak_N"] / hbetter
            h["top_johnson_design_reduction_vs_min_form"] = 1 - hz[best["name"]]["peak_N"] / hb
    return {
        "baseline_min_form_N": base,
        "better_iso": better,
        "best": {
            "name": best["name"],
            "fraction": best["fraction"],
            "u": best["u"],
            "params": best["params"],
            "peak_N": best["peak_N"],
            "member_peaks_N": best["member_peaks_N"],
            "reduction_vs_min_form": 1 - best["peak_N"] / base,
            "reduction_vs_better_iso": 1 - best["peak_N"] / by_name[better]["peak_N"],
        },
        "target_20pct_N": 0.8 * by_name[better]["peak_N"],
        "designs_below_target": [
            r["name"] for r in ok if r["peak_N"] <= 0.8 * by_name[better]["peak_N"]
        ],
        "ranking": [
            {
                "name": r["name"],
                "peak_N": r["peak_N"],
                "reduction_vs_min_form": 1 - r["peak_N"] / base,
            }
            for r in ranked[:10]
        ],
        "significant": SIGNIFICANT,
        "designs_beating_min_form": sum(1 for r in ok if r["peak_N"] < (1 - SIGNIFICANT) * base),
        "designs_total": len(rows),
        "failed": [r["name"] for r in rows if not np.isfinite(r["peak_N"])],
        "spearman": corr,
        "worst_member_counts": worst_counts,
        "peak_timing": timing,
        "soft_bias_mean": float(np.nanmean([r["objective_N"] / r["peak_N"] - 1 for r in ok])),
        "main_effects": lines,
        "hertz": h,
    }


# ----------------------------------------------------------------------------- run
def adam_optimum(path: Path, size: int) -> dict:
    """The gradient run's best iterate of a main-job ``results.json`` (its history: the
    run may have delivered another method's design), which must be a design in the ISO
    box (``python -m optimize --problem iso``)."""
    saved = json.loads(path.read_text())
    best = min(saved["history"], key=lambda h: h["objective_N"])
    if len(best["u"]) != size:
        raise ValueError(
            f"{path} holds a {len(best['u'])}-coordinate design (problem "
            f"{saved.get('problem')!r}); --adam-results needs a run in the ISO 606 box "
            f"({size} coordinates): python -m optimize --problem iso"
        )
    return {
        "u": best["u"],
        "iteration": best["iteration"],
        "objective_N": best["objective_N"],
        "source": str(path),
        "source_settings": saved.get("settings"),
    }


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--adam-results", type=Path, default=ADAM,
                    help="main-job results.json whose optimum is re-measured too")  # fmt: skip
    args = parse(ap, argv)
    path = args.out / "design_space.json"
    start = time.perf_counter()
    p = plan(args.quick)
    settings = settings_for(args.quick)
    problem = make_problem(settings)
    adam = None
    if args.adam_results.exists():
        adam = adam_optimum(args.adam_results, problem.space.size)
    designs = design_list(problem, p, adam)
    results = {
        "machine": machine_info(),
        "quick": args.quick,
        "settings": settings.as_dict(),
        "plan": {k: list(v) if isinstance(v, tuple) else v for k, v in p.items()},
        "sobol_seed": SOBOL_SEED,
        "design_space": {
            "parameters": list(NAMES),
            "lower": np.asarray(problem.space.lower).tolist(),
            "upper": np.asarray(problem.space.upper).tolist(),
        },
        "adam_source": None if adam is None else adam["source"],
        "adam_source_same_space": None
        if adam is None or adam["source_settings"] is None
        else all(
            adam["source_settings"].get(k) == getattr(settings, k) for k in ("chain", "teeth")
        ),
        "designs": [],
        "hertz": {},
    }
    rows: list[dict] = []
    traces: dict[str, dict] = {}

    def save(stage: str):
        results["stage"] = stage
        results["designs"] = [{k: v for k, v in r.items() if k != "_trace"} for r in rows]
        results["elapsed_s"] = time.perf_counter() - start
        write_atomic(path, json.dumps(jsonable(results), indent=1))

    n = len(designs)
    print(f"design space: {n} designs, {len(settings.ensemble)} speed(s) each", flush=True)
    n_iso = sum(1 for d in designs if d["group"] == "iso")
    for k, d in enumerate(designs):
        row = measure(problem, d)
        if problem.objective is not None:
            row.update(objective(problem, d["u"]))
        rows.append(row)
        traces[row["name"]] = row["_trace"]
        obj = row.get("objective_N")
        print(
            f"[{k + 1}/{n}] {d['name']:<22s} peak {row['peak_N']:7.1f} N "
            f"({', '.join(f'{v:.0f}' for v in row['member_peaks_N'])})"
            + (f"  objective {obj:7.1f} N" if obj is not None else "")
            + f"  {row['remeasure_s']:.1f} s  load {row['loadavg'][0]:.1f}",
            flush=True,
        )
        if k + 1 == n_iso:  # the ISO forms fix the objective's scale, as in optimize.run
            ref = max(r["peak_N"] for r in rows)
            problem.make_objective(ref)
            results["reference_N"] = ref
            results["temperature_N"] = settings.temperature * ref
            for r, dd in zip(rows, designs, strict=False):
                r.update(objective(problem, dd["u"]))
        save("johnson")

    # second law on the best designs, the Adam optimum and the ISO min/max forms
    ranked = sorted((r for r in rows if np.isfinite(r["peak_N"])), key=lambda r: r["peak_N"])
    names = [r["name"] for r in ranked[: p["hertz_top"]]]
    names += [x for x in p["hertz_extra"] if x not in names]
    by_name = {d["name"]: d for d in designs}
    for x in (n for n in names if n in by_name):
        h = {"name": x, **remeasured(problem, by_name[x]["profile"], law="hertz")}
        results["hertz"][x] = h
        print(
            f"[hertz] {x:<22s} peak {h['peak_N']:7.1f} N  {h['seconds']:.1f} s "
            f"load {h['loadavg'][0]:.1f}",
            flush=True,
        )
        save("hertz")

    # diagnostics outside the study proper: (1) the seating angle beyond the ISO maximum,
    # others at the min form (continues the main-effect line); (2) the best designs on a
    # longer entry strand (same remeasure, same window)
    base = fraction_of(problem, iso_forms(problem)["min"])
    results["beyond_box"] = []
    for v in p["beyond_alpha"]:
        f = moved(base, "seating_angle", v)
        d = dict(name=f"beyond_alpha_{v:.2f}", group="beyond", fraction=f, aliases=[])
        d["profile"] = profile_at(problem, f)
        d["u"] = None
        row = measure(problem, d)
        row.pop("_trace")
        results["beyond_box"].append(row)
        print(f"[beyond] {d['name']:<22s} peak {row['peak_N']:7.1f} N", flush=True)
        save("beyond")
    if p["strand_top"] and settings.scene == "engagement":
        results["longer_strand"] = {}
        names = [r["name"] for r in ranked[: p["strand_top"]]]
        names += [x for x in ("adam", "iso_min", "iso_max") if x not in names]
        with longer_entry(EXTRA_ENTRY):
            for x in (n for n in names if n in by_name):
                default = next(r["peak_N"] for r in rows if r["name"] == x)
                m = remeasured(problem, by_name[x]["profile"], {"default_strand_peak_N": default})
                results["longer_strand"][x] = m
                print(f"[strand] {x:<22s} peak {m['peak_N']:7.1f} N", flush=True)
                save("longer_strand")
        results["longer_strand_extra_entry_rollers"] = EXTRA_ENTRY

    results["analysis"] = analyse(problem, rows, results["hertz"], p)
    results["total_s"] = time.perf_counter() - start
    results["machine"]["loadavg_at_end"] = loadavg()
    save("done")
    chart(problem, results, rows, traces, args.out / "design_space.png")
    print(summary(results), flush=True)
    return results


def summary(res: dict) -> str:
    a = res["analysis"]
    b = a["best"]
    lines = [
        f"min form {a['baseline_min_form_N']:.1f} N; best {b['name']} {b['peak_N']:.1f} N = "
        f"{100 * b['reduction_vs_min_form']:.1f} % below the min form (Johnson), at fractions "
        + ", ".join(f"{SHORT[n]} {f:.2f}" for n, f in zip(NAMES, b["fraction"], strict=True)),
        f"designs beating the min form by > {100 * SIGNIFICANT:.1f} %: "
        f"{a['designs_beating_min_form']} of "
        f"{a['designs_total']}; below the 20 % target ({a['target_20pct_N']:.0f} N): "
        f"{len(a['designs_below_target'])}",
    ]
    h = a["hertz"]
    if h.get("best_checked"):
        lines.append(
            f"Hertz: best checked {h['best_checked']} "
            f"{100 * h['best_reduction_vs_min_form']:.1f} % vs min form; Johnson-best design "
            f"{100 * h['top_johnson_design_reduction_vs_min_form']:.1f} %"
        )
    s = a["spearman"]["objective_vs_worst_peak"]
    if s["rho"] is not None:
        lines.append(f"Spearman(objective, re-measured worst peak) = {s['rho']:.2f} (n={s['n']})")
    c = a["peak_timing"]["designs_with_clipped_peak_per_speed"]
    lines.append(f"designs whose peak the window clips, per speed factor: {c}")
    for row in res.get("beyond_box", []):
        lines.append(
            f"beyond ISO: alpha at {row['fraction'][1]:.2f} of the range "
            f"({math.degrees(row['params']['seating_angle']):.1f} deg): {row['peak_N']:.0f} N, "
            f"{100 * (1 - row['peak_N'] / a['baseline_min_form_N']):.1f} % below the min form"
        )
    s = res.get("longer_strand", {})
    if "iso_min" in s:
        ref = s["iso_min"]["peak_N"]
        lines.append(
            f"longer strand (+{EXTRA_ENTRY} entry rollers): "
            + ", ".join(
                f"{n} {v['peak_N']:.0f} N ({100 * (v['peak_N'] / ref - 1):+.1f} %)"
                for n, v in s.items()
                if isinstance(v, dict)
            )
        )
    lines.append(f"total {res['total_s']:.0f} s")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- chart
GROUP_STYLE = {
    "iso": ("k", "s"),
    "adam": ("tab:red", "*"),
    "corner": ("tab:blue", "D"),
    "sobol": ("tab:green", "o"),
    "effect": ("tab:orange", "^"),
}


def chart(problem: Problem, res: dict, rows: list[dict], traces: dict, path: Path) -> None:
    import matplotlib.pyplot as plt

    a = res["analysis"]
    base = a["baseline_min_form_N"]
    target = a["target_20pct_N"]
    fig, ax = figure(2, 3, figsize=(17, 10))

    # (a) design objective vs re-measured worst peak
    g = ax[0, 0]
    for group, (c, m) in GROUP_STYLE.items():
        sel = [r for r in rows if r["group"] == group]
        if sel:
            g.scatter([r["objective_N"] for r in sel], [r["peak_N"] for r in sel], c=c,
                      marker=m, s=60 if group in ("iso", "adam") else 25, label=group)  # fmt: skip
    g.axhline(base, color="k", ls=":", lw=1, label="ISO min form")
    g.axhline(target, color="tab:red", ls="--", lw=1, label="20 % below better ISO")
    s = a["spearman"]["objective_vs_worst_peak"]
    rho = "n/a" if s["rho"] is None else f"{s['rho']:.2f}"
    g.set_title(f"objective vs re-measured peak (Spearman {rho})")
    g.set_xlabel("design objective (smooth, mean of speeds) [N]")
    g.set_ylabel("re-measured peak, worst speed [N]")

    # (b) main effects, relative to the min form
    g = ax[0, 1]
    for k, (name, line) in enumerate(a["main_effects"].items()):
        c = f"C{k}"
        f = line["fraction"]
        g.plot(f, 100 * (np.asarray(line["peak_N"]) / base - 1), "o-", color=c,
               label=f"{SHORT[name]}: re-measured")  # fmt: skip
        ob0 = next(r["objective_N"] for r in rows if r["name"] == "iso_min")
        g.plot(f, 100 * (np.asarray(line["objective_N"]) / ob0 - 1), "x--", color=c, lw=1,
               label=f"{SHORT[name]}: objective")  # fmt: skip
    beyond = res.get("beyond_box", [])
    if beyond and "seating_angle" in a["main_effects"]:
        k = list(a["main_effects"]).index("seating_angle")
        line = a["main_effects"]["seating_angle"]
        g.plot(
            [line["fraction"][-1]] + [r["fraction"][1] for r in beyond],
            [100 * (line["peak_N"][-1] / base - 1)]
            + [100 * (r["peak_N"] / base - 1) for r in beyond],
            "o:",
            color=f"C{k}",
            mfc="none",
            label="alpha beyond ISO max",
        )
        g.axvline(1, color="0.5", lw=0.8)
        inside = [100 * (v / base - 1) for ln in a["main_effects"].values() for v in ln["peak_N"]]
        top = max(inside) + 10
        g.set_ylim(-30, top)
        for r in beyond:
            change = 100 * (r["peak_N"] / base - 1)
            if change > top:
                g.annotate(f"{r['peak_N']:.3g} N (off scale)", (r["fraction"][1], top),
                           xytext=(-90, -15), textcoords="offset points", fontsize=7,
                           arrowprops=dict(arrowstyle="->", lw=0.8))  # fmt: skip
    g.axhline(-20, color="tab:red", ls="--", lw=1)
    g.axhline(0, color="k", ls=":", lw=1)
    g.set_xlabel("fraction of the ISO range (others at the min form)")
    g.set(ylabel="change vs min form [%]", title="main effects through the min form")

    # (c) per-speed peaks, designs sorted by the worst
    g = ax[0, 2]
    order = sorted((r for r in rows if np.isfinite(r["peak_N"])), key=lambda r: r["peak_N"])
    for k, f in enumerate(res["settings"]["ensemble"]):
        g.plot([r["member_peaks_N"][k] for r in order], "o", ms=3, label=f"speed × {f}")
    g.plot([r["peak_N"] for r in order], "k-", lw=1, label="worst (the metric)")
    g.axhline(base, color="k", ls=":", lw=1)
    g.set(xlabel="design, sorted by re-measured worst peak", ylabel="sharp peak [N]")
    g.set_title("per-speed re-measured peaks")

    # (d) reductions of the best designs, both laws
    g = ax[1, 0]
    top = order[:10]
    y = np.arange(len(top))
    g.barh(y, [100 * (1 - r["peak_N"] / base) for r in top], height=0.3, label="Johnson")
    h = a["hertz"].get("designs", {})
    hy = [(i, h[r["name"]]["reduction_vs_min_form"]) for i, r in enumerate(top) if r["name"] in h]
    if hy:
        g.barh([i + 0.3 for i, _ in hy], [100 * v for _, v in hy], height=0.3,
               label="Hertz (second law)")  # fmt: skip
    s = res.get("longer_strand", {})
    if "iso_min" in s:
        sy = [(i, 1 - s[r["name"]]["peak_N"] / s["iso_min"]["peak_N"])
              for i, r in enumerate(top) if r["name"] in s]  # fmt: skip
        g.barh([i + 0.6 for i, _ in sy], [100 * v for _, v in sy], height=0.3,
               label=f"Johnson, +{EXTRA_ENTRY} entry rollers")  # fmt: skip
    g.set_yticks(y + 0.3, [r["name"] for r in top], fontsize=7)
    g.axvline(20, color="tab:red", ls="--", lw=1, label="goal 20 %")
    g.axvline(0, color="k", lw=0.5)
    g.invert_yaxis()
    g.set(xlabel="reduction vs ISO min form [%]", title="best designs in the box")

    # (e) force histories at the worst speed
    g = ax[1, 1]
    for name, c in [("iso_min", "k"), (a["best"]["name"], "tab:green"), ("adam", "tab:red")]:
        tr = traces.get(name)
        if tr is not None:
            g.plot(tr["ts"] * 1e3, tr["force"], color=c, lw=1,
                   label=f"{name} (× {tr['speed_factor']}): {tr['peak_N']:.0f} N")  # fmt: skip
    g.set(xlabel="time [ms]", ylabel="largest roller/tooth force [N]")
    g.set_title("re-measured force, worst speed of each design")

    # (f) outlines
    g = ax[1, 2]
    forms = iso_forms(problem)
    for form, st in [("min", ":"), ("max", "--")]:
        xy = forms[form].outline(n=80)
        g.plot(xy[:, 0] * 1e3, xy[:, 1] * 1e3, "k" + st, lw=1, label=f"ISO {form} form")
    best = problem.space.profile(jnp.asarray(a["best"]["u"]))
    xy = best.outline(n=80)
    g.plot(xy[:, 0] * 1e3, xy[:, 1] * 1e3, color="tab:green", lw=2, label=a["best"]["name"])
    g.set(aspect="equal", xlabel="x [mm]", ylabel="y [mm]", title="tooth gap")
    for g in ax.flat:  # each panel's legend, after its artists
        g.legend(fontsize=7, ncol=2 if g is ax[0, 1] else 1)

    m = res["machine"]
    fig.suptitle(
        f"design space of the default problem ({len(rows)} designs, speeds "
        f"{res['settings']['ensemble']}; remeasure: Dopri8 rtol "
        f"{res['settings']['remeasure_rtol']:.0e}, sharp peak) — {m['cpu_count']} CPUs, "
        f"load {m['loadavg_at_start'][0]:.1f}→{m['loadavg_at_end'][0]:.1f}, "
        f"{res['total_s'] / 60:.0f} min"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    main()
