"""Accuracy against the contact regularization and against the model's fidelity, with cost:
the roller/tooth law's regularization fields swept one at a time on the engagement strand
(bias, adaptive and fixed-step Tsit5), then lumped against clearance from the layout.

    python -m benchmarks.regularization            # full study (~25 min on 2 busy cores)
    python -m benchmarks.regularization --quick    # smoke run (~4–6 min on 2 busy cores)

Writes ``benchmarks/results/regularization.json`` and ``regularization.png``.

Notes: benchmarks/regularization.md
"""

from __future__ import annotations

import dataclasses
import json
import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import loadavg, machine_info, parse, parser, tooth_period  # noqa: E402
from benchmarks.precision import (  # noqa: E402
    engagement_scene,
    fixed_solve,
    log_bisect,
    plot_points,
    reference,
    step_runs,
)

CHAIN, TEETH, RPM, TENSION, RESTITUTION = "08B", 18, 1000.0, 1000.0, 0.7
PERIOD = tooth_period(TEETH, RPM)
LAW_FIELDS = ("width", "speed_floor", "clamp_width")
ADAPTIVE_RTOL, ADAPTIVE_ATOL = 1e-6, 1e-9  # simulate's defaults
MAX_STEPS = 400_000  # of every adaptive solve (static: one compile)
SAVE_DT = 1e-6  # dense adaptive solves (fidelity part) save the outputs every 1 µs
FIXED_DT = 4e-6  # the design loop's fixed step (optimize/problem.py, README)
FIXED_MAX_STEPS = 40_000  # static: one compile for every fixed step ≥ t1/40000
H0 = 2e-6  # the fixed-step grid starts here and moves by √2
K_UP, K_DOWN = 8, -3  # grid from H0·2^(K_DOWN/2) = 0.7 µs to H0·2^(K_UP/2) = 32 µs
ACCURATE = 0.05  # "accurate": peak within 5 % of the setting's own reference
BLOWUP = 10.0  # "stable": successful and peak below 10× the setting's own reference
SPAN_SOFTENING = 2000.0  # fidelity part: span springs = link stiffness / this
N_EXIT = 5  # 8 entry + 9 wrapped + 5 exit = 22 rollers: even, as the clearance model needs


# ----------------------------------------------------------------------------- scenes
def nominal_law():
    return jc.scenes.roller_law(jc.ChainSpec.iso606(CHAIN), RESTITUTION)


def law_with(law, **values):
    """``law`` with its regularization fields as float arrays (``values`` replacing some):
    a new value is then new data, not a new structure, so nothing recompiles."""
    vals = {n: values.get(n, getattr(law, n)) for n in LAW_FIELDS}
    return eqx.tree_at(
        lambda x: tuple(getattr(x, n) for n in LAW_FIELDS),
        law,
        tuple(jnp.asarray(vals[n], dtype=float) for n in LAW_FIELDS),
    )


def sweep_scene(law):
    """The engagement of the sweep (settled, default span springs) with roller law ``law``."""
    return engagement_scene(
        tension=TENSION,
        n_exit=N_EXIT,
        model=jc.scenes.ChainModel(restitution=RESTITUTION, roller_contact=law),
    )


def joint_laws_with(scene, **values):
    """``scene`` with every clearance joint's law regularization as arrays (``values``
    replacing some)."""
    pairs = tuple(
        eqx.tree_at(lambda g: g.element.law, g, law_with(g.element.law, **values))
        if isinstance(g.element, jc.ClearanceJoints)
        else g
        for g in scene.pairs
    )
    return dataclasses.replace(scene, pairs=pairs)


def fidelity_scene(fidelity, speed_rpm, span_softening=SPAN_SOFTENING):
    """The fidelity comparison's strand, from the layout, span springs of
    ``link stiffness / span_softening`` (None: the builder's default)."""
    chain = jc.ChainSpec.iso606(CHAIN)
    k_span = None
    if span_softening is not None:
        k_span = jc.scenes.link_stiffness(chain, TENSION) / span_softening
    sc = engagement_scene(
        speed_rpm=speed_rpm,
        tension=TENSION,
        n_exit=N_EXIT,
        fidelity=fidelity,
        span_stiffness=k_span,
        model=jc.scenes.ChainModel(
            restitution=RESTITUTION, settle=False, roller_contact=law_with(nominal_law())
        ),
    )
    return joint_laws_with(sc)


# ----------------------------------------------------------------------------- solves
def save_times(t1):
    return np.linspace(0.0, t1, int(round(t1 / SAVE_DT)) + 1)


def adaptive(scene, t1, rtol=ADAPTIVE_RTOL, dense=False):
    """Tsit5, PID controller (``simulate``'s default), atol = 1e-3·rtol; outputs at t0 and
    t1 only (for timing: saving costs an output evaluation per save time) or, ``dense``,
    every 1 µs (for peaks over a window)."""
    kw = dict(ts=save_times(t1)) if dense else dict(n_save=2)
    return jc.simulate(
        scene, t1, rtol=rtol, atol=rtol * 1e-3, max_steps=MAX_STEPS, throw=False, **kw
    )


def fixed(scene, t1, dt):
    return fixed_solve(scene, t1, dt, max_steps=FIXED_MAX_STEPS)


def timed(call, repeats):
    """(solution of the last call, first-call time, min and all of the warm times)."""
    t = time.perf_counter()
    sol = call()
    jax.block_until_ready(sol.peak_contact_force)
    first = time.perf_counter() - t
    walls = []
    for _ in range(repeats):
        t = time.perf_counter()
        sol = call()
        jax.block_until_ready(sol.peak_contact_force)
        walls.append(time.perf_counter() - t)
    return sol, first, min(walls), walls


def _rel(a, b):
    return a / b - 1.0 if math.isfinite(a) else None


def judge(sol, own_peak):
    peak = float(sol.peak_contact_force)
    stable = sol.ok and math.isfinite(peak) and peak < BLOWUP * own_peak
    return {
        "library_ok": sol.ok,
        "peak_N": peak if math.isfinite(peak) else None,
        "own_err": _rel(peak, own_peak),
        "stable": bool(stable),
        "accurate": bool(stable and abs(peak / own_peak - 1) <= ACCURATE),
    }


def step_search(scene, t1, own_peak, n_bisect):
    """Largest fixed Tsit5 steps that are stable / accurate (see the notes)."""
    runs, at = step_runs(lambda h: judge(fixed(scene, t1, h), own_peak) | {"dt": h})

    k = 0
    while at(H0 * 2 ** (k / 2))["stable"] and k < K_UP:
        k += 1
    k = 0
    while not at(H0 * 2 ** (k / 2))["accurate"] and k > K_DOWN:
        k -= 1

    def boundary(key):
        ok = bad = None
        for h in sorted(runs):
            if not runs[h][key]:
                bad = h
                break
            ok = h
        if ok is not None and bad is not None:
            ok, bad = log_bisect(lambda h: at(h)[key], ok, bad, n_bisect)
        return ok, bad

    h_acc, h_inacc = boundary("accurate")
    h_stab, h_unstab = boundary("stable")
    return {
        "largest_accurate_dt": h_acc,
        "smallest_inaccurate_dt": h_inacc,
        "largest_stable_dt": h_stab,
        "smallest_unstable_dt": h_unstab,
        "runs": [runs[h] for h in sorted(runs)],
    }


# ----------------------------------------------------------------------------- sweep
def setting_row(param, value, nominal_value, scene, t1, nominal_ref, p):
    """Every measurement of one regularization setting (see the notes)."""
    is_nominal = value == nominal_value
    print(f"{param} = {value:.3g}{' (nominal)' if is_nominal else ''}", flush=True)
    ref = nominal_ref if is_nominal else reference(scene, t1, rtol=p["ref_rtol"])
    ref = {k: v for k, v in ref.items() if k != "q1"}
    own, nom = ref["peak_N"], nominal_ref["peak_N"]
    row = {"param": param, "value": value, "nominal": is_nominal, "reference": ref}
    row["bias"] = own / nom - 1
    sol, first, wall, walls = timed(lambda: adaptive(scene, t1), p["repeats"])
    peak = float(sol.peak_contact_force)
    row["adaptive"] = {
        "solver": "Tsit5",
        "rtol": ADAPTIVE_RTOL,
        "atol": ADAPTIVE_ATOL,
        "ok": sol.ok,
        "peak_N": peak,
        "err": _rel(peak, nom),
        "own_err": _rel(peak, own),
        "steps": int(sol.stats["num_steps"]),
        "rejected": int(sol.stats["num_rejected_steps"]),
        "wall_s": wall,
        "walls_s": walls,
        "first_call_s": first,
    }
    if is_nominal:
        row["adaptive"]["compile_s"] = first - wall
    t = time.perf_counter()
    sol = fixed(scene, t1, FIXED_DT)
    peak = float(sol.peak_contact_force)
    row["fixed_common"] = {
        "solver": "Tsit5",
        "dt": FIXED_DT,
        "first_call_s": time.perf_counter() - t,
        "ok": sol.ok,
        "peak_N": peak if math.isfinite(peak) else None,
        "err": _rel(peak, nom),
        "own_err": _rel(peak, own),
    }
    search = step_search(scene, t1, own, p["n_bisect"])
    row["fixed_search"] = search
    h = search["largest_accurate_dt"]
    if h is not None:
        sol, first, wall, walls = timed(lambda: fixed(scene, t1, h), p["repeats"])
        peak = float(sol.peak_contact_force)
        row["fixed_at_accurate"] = {
            "dt": h,
            "peak_N": peak,
            "err": _rel(peak, nom),
            "own_err": _rel(peak, own),
            "steps": int(sol.stats["num_steps"]),
            "wall_s": wall,
            "walls_s": walls,
            "first_call_s": first,
        }
    a = row["adaptive"]
    hs = search["largest_stable_dt"]
    print(
        f"  bias {row['bias']:+.2%}; Tsit5 rtol 1e-6: err {a['err']:+.2%} "
        f"{a['steps']} steps {a['wall_s']:.2f} s; fixed {FIXED_DT * 1e6:g} µs: "
        f"err {row['fixed_common']['err'] or float('nan'):+.2%}; largest stable "
        f"{(hs or float('nan')) * 1e6:.2f} µs, accurate {(h or float('nan')) * 1e6:.2f} µs",
        flush=True,
    )
    return row


def regularization_sweep(p):
    t1 = p["periods"] * PERIOD
    base = nominal_law()
    nominal = {n: float(getattr(base, n)) for n in LAW_FIELDS}
    t = time.perf_counter()
    scene = sweep_scene(law_with(base))
    build_s = time.perf_counter() - t
    v_ref = float(scene.impact_speed)
    print(f"regularization sweep, {p['periods']} tooth periods, nominal law {nominal}")
    nominal_ref = reference(scene, t1, rtol=p["nominal_ref_rtol"])
    values = {
        "width": [nominal["width"] * 10 ** (k / 2) for k in p["width_half_decades"]],
        "speed_floor": [nominal["speed_floor"]] + [f * v_ref for f in p["floor_fractions"]],
        "clamp_width": [nominal["clamp_width"]] + list(p["clamp_widths"]),
    }
    rows = []
    for param, vals in values.items():
        for v in vals:
            if param != "width" and v == nominal[param]:
                # the nominal setting is the width sweep's first row: measured once
                rows.append({"param": param, "value": v, "nominal": True, "same_as": "width"})
                continue
            sc = scene if v == nominal[param] else sweep_scene(law_with(base, **{param: v}))
            rows.append(setting_row(param, v, nominal[param], sc, t1, nominal_ref, p))
    return {
        "scene": {
            "chain": CHAIN,
            "teeth": TEETH,
            "speed_rpm": RPM,
            "tension_N": TENSION,
            "restitution": RESTITUTION,
            "start": "settled (each setting settled with its own law)",
            "n_rollers": scene.n_rollers,
            "tooth_periods": p["periods"],
            "t1_s": t1,
            "impact_speed_m_s": v_ref,
            "build_s_incl_compile": build_s,
        },
        "nominal_law": nominal,
        "link_law": "LinkSprings (linear spring-damper): no regularization field",
        "criteria": {"accurate_within": ACCURATE, "blowup_factor": BLOWUP, "fixed_dt": FIXED_DT},
        "nominal_reference": {k: v for k, v in nominal_ref.items() if k != "q1"},
        "rows": rows,
    }


# ----------------------------------------------------------------------------- fidelity
def window_stats(sol, t1):
    """Peaks of a solve saved every 1 µs, over the later engagements (t ≥ one period)."""
    ts = np.asarray(sol.ts)
    f = np.asarray(sol.roller_sprocket_force).max(axis=1)
    lt = np.asarray(sol.link_tension)
    win = ts >= PERIOD
    periods = int(round(t1 / PERIOD))
    per = [float(f[(ts >= k * PERIOD) & (ts < (k + 1) * PERIOD)].max()) for k in range(periods)]
    return {
        "ok": sol.ok,
        "window_peak_N": float(f[win].max()),
        "step_sampled_peak_N": float(sol.peak_contact_force),
        "per_period_peak_N": per,
        "tight_span_mean_N": float(lt[win, 0].mean()),
        "tight_span_peak_N": float(lt[win, 0].max()),
        "link_peak_N": float(lt[win].max()),
        "steps": int(sol.stats["num_steps"]),
    }


def _spread(xs):
    xs = np.asarray(xs, dtype=float)
    return {
        "n": len(xs),
        "mean": float(xs.mean()),
        "std": float(xs.std(ddof=1)) if len(xs) > 1 else 0.0,
        "min": float(xs.min()),
        "max": float(xs.max()),
        "range_rel": float((xs.max() - xs.min()) / xs.mean()),
    }


def _solve_stats(scene, t1, rtol=ADAPTIVE_RTOL):
    t = time.perf_counter()
    sol = adaptive(scene, t1, rtol, dense=True)
    jax.block_until_ready(sol.peak_contact_force)
    return window_stats(sol, t1) | {"rtol": rtol, "wall_s_dense": time.perf_counter() - t}


def fidelity_one(fid, t1, p):
    """One fidelity: the speed ensemble, the solver's share, the cost."""
    # nominal speed first: its first call holds the compile (clearance)
    offsets = sorted(p["speed_offsets"], key=lambda d: (d != 0, d))
    members = []
    for d in offsets:
        m = _solve_stats(fidelity_scene(fid, RPM * (1 + d)), t1) | {"speed_offset": d}
        m["speed_rpm"] = RPM * (1 + d)
        members.append(m)
        print(
            f"  {fid:9s} speed {d:+.2%}: window peak {m['window_peak_N']:7.1f} N "
            f"(per period {[round(x) for x in m['per_period_peak_N']]}), tight span "
            f"{m['tight_span_mean_N']:.0f} N mean, {m['steps']} steps",
            flush=True,
        )
    nominal = fidelity_scene(fid, RPM)
    sol, first, wall, walls = timed(lambda: adaptive(nominal, t1), p["fid_repeats"])
    cost = {
        "wall_s": wall,
        "walls_s": walls,
        "first_call_s": first,
        "steps": int(sol.stats["num_steps"]),
        "n_bodies": nominal.n_bodies,
        "n_rollers": nominal.n_rollers,
    }
    checks = []
    for rtol in p["check_rtols"]:
        c = _solve_stats(nominal, t1, rtol)
        c["window_peak_rel_diff"] = c["window_peak_N"] / members[0]["window_peak_N"] - 1
        checks.append(c)
        print(
            f"  {fid:9s} nominal speed, rtol {rtol:.0e}: window peak {c['window_peak_N']:.1f} N "
            f"({c['window_peak_rel_diff']:+.2%} vs rtol {ADAPTIVE_RTOL:.0e}), {c['steps']} steps",
            flush=True,
        )
    keys = ("window_peak_N", "tight_span_mean_N", "tight_span_peak_N", "link_peak_N")
    solver_peaks = [members[0]["window_peak_N"]] + [c["window_peak_N"] for c in checks]
    print(f"  {fid}: cost {cost['wall_s']:.2f} s, {cost['steps']} steps", flush=True)
    return {
        "members": members,
        "stats": {k: _spread([m[k] for m in members]) for k in keys},
        "solver_checks": checks,
        "solver_spread": _spread(solver_peaks),
        "cost": cost,
    }


def fidelity_study(p):
    t1 = p["periods"] * PERIOD
    print(f"fidelity: lumped vs clearance, {p['periods']} tooth periods from the layout")
    out = {
        "setting": {
            "start": "layout (both)",
            "window_start_s": PERIOD,
            "window": "from the second tooth period on (the later engagements)",
            "t1_s": t1,
            "tooth_periods": p["periods"],
            "save_spacing_s": SAVE_DT,
            "span_stiffness_over_link": 1 / SPAN_SOFTENING,
            "speed_offsets": list(p["speed_offsets"]),
            "solver": "Tsit5",
            "rtol": ADAPTIVE_RTOL,
            "check_rtols": list(p["check_rtols"]),
        },
        "fidelities": {fid: fidelity_one(fid, t1, p) for fid in ("lumped", "clearance")},
    }
    lum, clr = (out["fidelities"][k] for k in ("lumped", "clearance"))
    a, b = lum["stats"]["window_peak_N"], clr["stats"]["window_peak_N"]
    n = a["n"]
    se = math.sqrt((a["std"] ** 2 + b["std"] ** 2) / n)
    noise = max(
        v["stats"]["window_peak_N"]["max"] - v["stats"]["window_peak_N"]["min"] for v in (lum, clr)
    )
    noise = max(
        [noise] + [v["solver_spread"]["max"] - v["solver_spread"]["min"] for v in (lum, clr)]
    )
    out["comparison"] = {
        "window_peak_ratio_clearance_over_lumped": b["mean"] / a["mean"],
        "window_peak_diff_N": b["mean"] - a["mean"],
        "diff_over_std_error": (b["mean"] - a["mean"]) / se if se > 0 else None,
        "largest_range_N": noise,
        "diff_over_largest_range": (b["mean"] - a["mean"]) / noise if noise > 0 else None,
        "noise_note": "largest range over the speed ensembles and the solver checks of both",
        "tight_span_mean_ratio": clr["stats"]["tight_span_mean_N"]["mean"]
        / lum["stats"]["tight_span_mean_N"]["mean"],
        "link_peak_ratio": clr["stats"]["link_peak_N"]["mean"]
        / lum["stats"]["link_peak_N"]["mean"],
        "wall_ratio": clr["cost"]["wall_s"] / lum["cost"]["wall_s"],
        "steps_ratio": clr["cost"]["steps"] / lum["cost"]["steps"],
    }
    # the clearance joints' onset width, on the nominal member
    nominal = fidelity_scene("clearance", RPM)
    law0 = next(g.element.law for g in nominal.pairs if isinstance(g.element, jc.ClearanceJoints))
    rows = []
    for w in p["joint_widths"]:
        r = _solve_stats(joint_laws_with(nominal, width=w), t1) | {"joint_width_m": w}
        r["window_peak_rel_diff"] = r["window_peak_N"] / clr["members"][0]["window_peak_N"] - 1
        rows.append(r)
        print(
            f"  clearance, joint onset width {w:.0e} m: window peak {r['window_peak_N']:.1f} N "
            f"({r['window_peak_rel_diff']:+.2%}), {r['steps']} steps",
            flush=True,
        )
    out["joint_width"] = {"nominal_m": float(law0.width), "rows": rows}
    if p["operating_point"]:  # why the soft span springs: the default ones, from the layout
        op = {"span_stiffness": "engagement default", "nominal_tension_N": TENSION}
        for fid in ("lumped", "clearance"):
            op[fid] = _solve_stats(fidelity_scene(fid, RPM, span_softening=None), t1)
            print(
                f"  default span springs, {fid}: tight span mean "
                f"{op[fid]['tight_span_mean_N']:.0f} N, window peak "
                f"{op[fid]['window_peak_N']:.0f} N",
                flush=True,
            )
        out["operating_point"] = op
    return out


# ----------------------------------------------------------------------------- main
def plan(quick):
    if quick:
        return dict(
            periods=2,
            nominal_ref_rtol=1e-10,
            ref_rtol=1e-9,
            width_half_decades=(0, 6),
            floor_fractions=(1.0,),
            clamp_widths=(),
            repeats=1,
            n_bisect=1,
            speed_offsets=(0.0, 1e-3),
            fid_repeats=1,
            check_rtols=(1e-7,),
            joint_widths=(),
            operating_point=False,
        )
    return dict(
        periods=4,
        nominal_ref_rtol=1e-11,
        ref_rtol=1e-10,
        width_half_decades=tuple(range(7)),
        floor_fractions=(0.1, 0.3, 1.0),
        clamp_widths=(0.0, 0.5),
        repeats=3,
        n_bisect=2,
        speed_offsets=(-1e-3, -5e-4, 0.0, 5e-4, 1e-3),
        fid_repeats=2,
        check_rtols=(1e-7, 1e-8),
        joint_widths=(1e-7, 1e-6),
        operating_point=True,
    )


def main(argv=None):
    ap = parser(__doc__)
    args = parse(ap, argv)
    p = plan(args.quick)
    start = time.perf_counter()
    results = {"machine": machine_info(), "quick": args.quick, "plan": p}
    results["regularization"] = regularization_sweep(p)
    results["timing_s"] = {"regularization": time.perf_counter() - start}
    t = time.perf_counter()
    results["fidelity"] = fidelity_study(p)
    results["timing_s"]["fidelity"] = time.perf_counter() - t
    results["total_s"] = time.perf_counter() - start
    results["machine"]["loadavg_at_end"] = loadavg()
    summary(results)
    (args.out / "regularization.json").write_text(json.dumps(results, indent=1))
    chart(results, args.out / "regularization.png")
    print(
        f"wrote {args.out / 'regularization.json'} and regularization.png "
        f"({results['total_s']:.0f} s)"
    )
    return results


def _fmt(x, spec, scale=1.0):
    return "—" if x is None else format(x * scale, spec)


def summary(results):
    reg = results["regularization"]
    ref = reg["nominal_reference"]
    print(
        f"\nnominal reference {ref['peak_N']:.3f} N (Dopri8 rtol {ref['rtol']:.0e}; vs "
        f"{ref['check_rtol']:.0e}: {ref['check_peak_rel_err']:.1e})"
    )
    print("param        value     bias    Tsit5 err  steps  wall s  4µs err  stable µs  5% µs")
    for r in reg["rows"]:
        if "same_as" in r:
            continue
        a, fc, fs = r["adaptive"], r["fixed_common"], r["fixed_search"]
        print(
            f"{r['param']:11s} {r['value']:8.2g} {r['bias']:+8.2%} {a['err']:+9.2%} "
            f"{a['steps']:6d} {a['wall_s']:7.2f} {_fmt(fc['err'], '+8.2%')} "
            f"{_fmt(fs['largest_stable_dt'], '9.2f', 1e6)} "
            f"{_fmt(fs['largest_accurate_dt'], '6.2f', 1e6)}"
        )
    fid = results["fidelity"]
    for k, v in fid["fidelities"].items():
        s = v["stats"]["window_peak_N"]
        print(
            f"{k:9s}: window peak {s['mean']:.0f} N ± {s['std']:.0f} (range {s['min']:.0f}–"
            f"{s['max']:.0f}), tight span {v['stats']['tight_span_mean_N']['mean']:.0f} N, "
            f"cost {v['cost']['wall_s']:.2f} s, {v['cost']['steps']} steps"
        )
        for c in v["solver_checks"]:
            print(f"  rtol {c['rtol']:.0e}: window peak {c['window_peak_N']:.0f} N")
    c = fid["comparison"]
    print(
        f"clearance/lumped: peak ×{c['window_peak_ratio_clearance_over_lumped']:.3f}, "
        f"difference {c['window_peak_diff_N']:+.0f} N = "
        f"{_fmt(c['diff_over_largest_range'], '+.2f')} × the largest range "
        f"({c['largest_range_N']:.0f} N); wall ×{c['wall_ratio']:.1f}, "
        f"steps ×{c['steps_ratio']:.1f}"
    )


def chart(results, path=None):
    """The study's figure (a matplotlib Figure; saved to ``path`` if given)."""
    from matplotlib.figure import Figure

    reg, fid = results["regularization"], results["fidelity"]
    rows = [r for r in reg["rows"] if "same_as" not in r]
    wr = [r for r in rows if r["param"] == "width"]
    w = [r["value"] for r in wr]
    fig = Figure(figsize=(17, 9.5))
    axes = fig.subplots(2, 3)

    ax = axes[0, 0]
    for key, label, style in (
        ("bias", "converged (Dopri8): the width's own bias", "k-o"),
        ("adaptive", f"Tsit5 rtol {ADAPTIVE_RTOL:.0e}", "C0-s"),
        ("fixed_common", f"Tsit5 fixed {FIXED_DT * 1e6:g} µs", "C1-^"),
        ("fixed_at_accurate", "Tsit5 fixed, largest 5 % step", "C2-v"),
    ):
        pts = []
        for r in wr:
            v = r["bias"] if key == "bias" else (r.get(key) or {}).get("err")
            if v is not None:
                pts.append((r["value"], 100 * v))
        plot_points(ax.semilogx, pts, style, label=label)
    ax.axhline(0, color="gray", lw=0.8)
    ax.set_xlabel("roller/tooth onset width [m]")
    ax.set_ylabel("peak force vs nominal converged reference [%]")
    ax.set_title(f"accuracy against the onset width ({reg['scene']['tooth_periods']} periods)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[0, 1]
    ax.semilogx(w, [r["adaptive"]["steps"] for r in wr], "C0-s", label="Tsit5 rtol 1e-6: steps")
    fw = [(r["value"], r["fixed_at_accurate"]["steps"]) for r in wr if "fixed_at_accurate" in r]
    plot_points(ax.semilogx, fw, "C2-v", label="Tsit5 fixed, largest 5 % step: steps")
    ax.set_ylim(bottom=0)
    ax.set_xlabel("roller/tooth onset width [m]")
    ax.set_ylabel("steps over the horizon")
    ax4 = ax.twinx()
    ax4.semilogx(w, [r["adaptive"]["wall_s"] for r in wr], "C0:", marker=".", label="wall")
    fw = [(r["value"], r["fixed_at_accurate"]["wall_s"]) for r in wr if "fixed_at_accurate" in r]
    plot_points(ax4.semilogx, fw, "C2:", marker=".")
    ax4.set_ylim(bottom=0)
    ax4.set_ylabel("wall time, min of repeats [s] (dotted; shared CPU)")
    ax.set_title("cost against the width")
    ax.grid(True, which="both", alpha=0.3)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax4.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="lower left")

    ax = axes[0, 2]
    for key, style, label in (
        ("largest_stable_dt", "C3-o", "largest stable (bounded, successful)"),
        ("largest_accurate_dt", "C2-v", "largest accurate (peak within 5 %)"),
    ):
        pts = [(r["value"], r["fixed_search"][key] * 1e6) for r in wr if r["fixed_search"][key]]
        plot_points(ax.semilogx, pts, style, label=label)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("roller/tooth onset width [m]")
    ax.set_ylabel("fixed Tsit5 step [µs]")
    ax.set_title("largest fixed step against the width")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[1, 0]
    others = [r for r in rows if r["param"] != "width" or r["nominal"]]
    x = np.arange(len(others))
    ax.bar(x - 0.2, [100 * r["bias"] for r in others], 0.4, label="bias (converged)")
    ax.bar(x + 0.2, [100 * r["adaptive"]["err"] for r in others], 0.4, label="Tsit5 1e-6")
    ticks = ["\n".join([*r["param"].split("_"), f"{r['value']:.3g}"]) for r in others]
    ax.set_xticks(x, ticks, fontsize=8)
    ax.set_ylabel("peak force vs nominal converged reference [%]")
    ax3 = ax.twinx()
    ax3.plot(x, [r["adaptive"]["steps"] for r in others], "k*", label="Tsit5 steps")
    ax3.set_ylabel("Tsit5 steps")
    ax3.set_ylim(bottom=0)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax3.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="lower left")
    ax.set_title("damping regularization: speed floor [m/s], no-pull clamp")
    ax.grid(True, axis="y", alpha=0.3)

    ax = axes[1, 1]
    names = list(fid["fidelities"])
    for i, v in enumerate(fid["fidelities"].values()):
        peaks = [m["window_peak_N"] for m in v["members"]]
        s = v["stats"]["window_peak_N"]
        xs = i - 0.15 + np.linspace(-0.08, 0.08, len(peaks))
        ax.plot(xs, peaks, "o", color=f"C{i}", ms=5, label="speed ensemble" if i == 0 else None)
        ax.errorbar(i - 0.15, s["mean"], yerr=s["std"], fmt="k_", ms=14, capsize=4)
        chk = v["solver_checks"]
        ax.plot(
            [i + 0.1] * len(chk),
            [c["window_peak_N"] for c in chk],
            "kd",
            mfc="none",
            label="nominal speed, tighter rtol" if i == 0 else None,
        )
        # one label per peak level: checks within 5 N of each other share it
        levels = []
        for c in sorted(chk, key=lambda c: c["window_peak_N"]):
            if levels and c["window_peak_N"] - levels[-1][0] < 5.0:
                levels[-1][1].append(f"{c['rtol']:.0e}")
            else:
                levels.append((c["window_peak_N"], [f"{c['rtol']:.0e}"]))
        for peak, tols in levels:
            ax.annotate(
                ", ".join(tols), (i + 0.1, peak), fontsize=8, xytext=(5, -3),
                textcoords="offset points",
            )  # fmt: skip
        ax.annotate(
            f"{v['cost']['wall_s']:.1f} s, {v['cost']['steps']} steps\n"
            f"tight span {v['stats']['tight_span_mean_N']['mean']:.0f} N",
            (i, min(peaks + [c["window_peak_N"] for c in chk])),
            textcoords="offset points",
            xytext=(0, -26),
            ha="center",
            fontsize=8,
        )
    jw = fid["joint_width"]["rows"]
    for r in jw:
        x = names.index("clearance") + 0.3
        ax.plot(x, r["window_peak_N"], "C3x", label="joint onset width" if r is jw[0] else None)
        ax.annotate(f"{r['joint_width_m']:.0e} m", (x, r["window_peak_N"]), fontsize=8,
                    xytext=(4, -2), textcoords="offset points")  # fmt: skip
    ax.set_xticks(range(len(names)), names)
    ax.set_xlim(-0.6, len(names) - 0.3)
    ax.margins(y=0.3)
    ax.set_ylabel("peak roller/tooth force, later engagements [N]")
    ax.set_title(f"fidelity, from the layout (mean ± std; rtol {ADAPTIVE_RTOL:.0e})")
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, axis="y", alpha=0.3)

    ax = axes[1, 2]
    for i, (name, v) in enumerate(fid["fidelities"].items()):
        for j, m in enumerate(v["members"]):
            per = m["per_period_peak_N"]
            ax.plot(
                np.arange(1, len(per) + 1) + 0.06 * (i - 0.5), per, "-o", color=f"C{i}",
                alpha=0.6, ms=3, label=name if j == 0 else None,
            )  # fmt: skip
    offs = ", ".join(f"{100 * d:+g} %" for d in fid["setting"]["speed_offsets"])
    ax.set_xlabel("tooth period (the first: snap from the layout, outside the window)")
    ax.set_ylabel("peak roller/tooth force in the period [N]")
    ax.set_title(f"per-period peaks, speed {offs}", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)

    m = results["machine"]
    fig.suptitle(
        f"regularization and fidelity, engagement 08B z={TEETH} {RPM:g} rpm, float64, "
        f"{m['cpu_count']} CPU cores (jax {m['versions']['jax']})"
    )
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


if __name__ == "__main__":
    main()
