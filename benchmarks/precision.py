"""The solver-precision toolkit the speed and accuracy studies share: diffrax's solvers by
name, the lumped engagement and short drive they are measured on, a float64 reference
with its continuous peak, sweeps over tolerances and steps, and the best time at an
error level (``work_precision``, ``scipy_engagement``, ``regularization``, ``fidelity``);
fixed-step solves and the search for a step boundary (``regularization``, ``stability``).
"""

from __future__ import annotations

import math
import time

import diffrax
import numpy as np

import jaxchain as jc
from benchmarks.common import FRICTIONLESS, RPM, modelled, timed

ATOL_PER_RTOL = 1e-3  # atol = 1e-3·rtol: positions ~5e-2 m, speeds ~1 m/s
REF_RTOL = 1e-11

# name -> (factory, family)
SOLVERS = {
    "Euler": (diffrax.Euler, "fixed"),
    "Heun": (diffrax.Heun, "fixed"),
    "Bosh3": (diffrax.Bosh3, "explicit"),
    "Tsit5": (diffrax.Tsit5, "explicit"),
    "Dopri5": (diffrax.Dopri5, "explicit"),
    "Dopri8": (diffrax.Dopri8, "explicit"),
    "Kvaerno3": (diffrax.Kvaerno3, "implicit"),
    "Kvaerno5": (diffrax.Kvaerno5, "implicit"),
    "KenCarp4": (diffrax.KenCarp4, "imex"),
}
STYLE = {
    "Euler": ("tab:gray", "x"),
    "Heun": ("tab:brown", "+"),
    "Bosh3": ("tab:olive", "v"),
    "Tsit5": ("tab:blue", "o"),
    "Dopri5": ("tab:cyan", "s"),
    "Dopri8": ("tab:green", "D"),
    "Kvaerno3": ("tab:pink", "^"),
    "Kvaerno5": ("tab:red", "<"),
    "KenCarp4": ("tab:purple", ">"),
}


# ----------------------------------------------------------------------------- scenes
def engagement_scene(**kw):
    """The 08B z = 18 engagement at 1000 rpm, frictionless joints; ``kw``: the builder's and
    the chain model's keywords (``jc.scenes.engagement``, ``jc.scenes.ChainModel``)."""
    return jc.scenes.engagement("08B", 18, **modelled(**{"speed_rpm": RPM, **FRICTIONLESS, **kw}))


# The drive starts from its layout (settle=False): jc.scenes.drive's static equilibrium
# does not converge for this short (9, 18)/40-link drive (it warns after ~80 s and falls
# back to the layout anyway), so the load is ramped in over the default one revolution.
DRIVE = dict(teeth=(9, 18), n_links=40, speed_rpm=RPM, settle=False)


def drive_scene():
    return jc.scenes.drive("08B", **modelled(**DRIVE, **FRICTIONLESS))


# ----------------------------------------------------------------------------- solves
def fixed_solve(scene, t1, dt, *, max_steps, solver=None, n_save=2):
    """One fixed-step solve (``solver``, default Tsit5, at step ``dt``), not thrown on
    failure: the ``jc.Solution``."""
    return jc.simulate(
        scene,
        t1,
        solver=diffrax.Tsit5() if solver is None else solver,
        stepsize_controller=diffrax.ConstantStepSize(),
        dt0=dt,
        max_steps=max_steps,
        n_save=n_save,
        throw=False,
    )


def step_runs(run):
    """``(runs, at)``: ``at(h)`` returns ``run(h)`` of a step ``h``, run once and kept in
    ``runs`` (step -> result) for the boundary searches over fixed steps."""
    runs = {}

    def at(h):
        h = float(h)
        if h not in runs:
            runs[h] = run(h)
        return runs[h]

    return runs, at


def log_bisect(passes, ok, bad, n):
    """``n`` log-bisections of the steps between ``ok`` (passes) and ``bad`` (fails);
    ``passes(h)`` says whether step ``h`` passes. The new ``(ok, bad)``."""
    for _ in range(n):
        mid = math.sqrt(ok * bad)
        if passes(mid):
            ok = mid
        else:
            bad = mid
    return ok, bad


def solve(scene, t1, name, *, rtol=None, dt=None, max_steps=200_000):
    """One solve; returns a dict of JAX arrays (peak, q1, ok, steps, …), not yet synced."""
    factory, family = SOLVERS[name]
    solver = factory()  # an IMEX solver takes the whole field implicit (jc.SolveOptions)
    if family == "fixed":
        kw = dict(dt0=dt, stepsize_controller=diffrax.ConstantStepSize())
    else:
        kw = dict(rtol=rtol, atol=ATOL_PER_RTOL * rtol)
    sol = jc.simulate(scene, t1, solver=solver, n_save=2, max_steps=max_steps, throw=False, **kw)
    return dict(
        peak=sol.peak_contact_force,
        q1=sol.y1.q,
        ok=sol.result == jc.Result.successful,
        stats=sol.stats,
        message=sol.message,
    )


def errors(out, ref) -> dict:
    """Relative peak-force error and max abs roller-position error at t1 [m]."""
    peak = float(out["peak"])
    q1 = np.asarray(out["q1"])
    ok = bool(out["ok"]) and bool(np.isfinite(peak)) and bool(np.all(np.isfinite(q1)))
    if not ok:
        return {"ok": False, "peak_N": peak, "peak_rel_err": None, "q_abs_err_m": None}
    return {
        "ok": True,
        "peak_N": peak,
        "peak_rel_err": abs(peak - ref["peak_N"]) / ref["peak_N"],
        "q_abs_err_m": float(np.max(np.abs(q1[:, :2] - ref["q1"][:, :2]))),
    }


N_DENSE = 20_001  # save times of each reference pass (one shape: one compile)


def dense_peak(scene, t1, rtol, *, n=N_DENSE, max_steps=400_000) -> dict:
    """The continuous peak of the roller/tooth force of a Dopri8 solve at ``rtol``.

    ``Solution.peak_contact_force`` reads each accepted step's top from 5 samples (parabolas
    through consecutive triples): at a tight tolerance an 8th-order method takes ~1 µs
    steps through an impact that rises in ~5 µs, and that estimate overshoots by 2.2e-6
    (parabolas through a lopsided top; the steps' ends and midpoints alone were up to
    ~1e-3 low). Here
    the force is read from the dense output: pass 1 on ``n`` equally spaced times, pass
    2 on ``n`` times packed into windows of ±2 coarse spacings around the largest local
    maxima of pass 1 (spacing there ~1e-4 of the coarse one). Returns the dense and the
    recorded peaks, the state at t1 and the solve's statistics.
    """
    kw = dict(
        solver=diffrax.Dopri8(),
        rtol=rtol,
        atol=ATOL_PER_RTOL * rtol,
        max_steps=max_steps,
        throw=False,
    )
    coarse = np.linspace(0.0, t1, n)
    s1 = jc.simulate(scene, t1, ts=coarse, **kw)
    if s1.result != jc.Result.successful:
        raise RuntimeError(f"reference solve failed: {s1.message}")
    f1 = np.asarray(s1.roller_sprocket_force).max(axis=1)
    h = coarse[1] - coarse[0]
    fp = np.concatenate([[-np.inf], f1, [-np.inf]])
    loc = [i for i in range(n) if fp[i + 1] >= fp[i] and fp[i + 1] >= fp[i + 2]]
    loc = sorted((i for i in loc if f1[i] >= 0.9 * f1.max()), key=lambda i: -f1[i])[:4]
    m = n // len(loc)
    wins = [np.linspace(coarse[i] - 2 * h, coarse[i] + 2 * h, m) for i in loc]
    rest = np.linspace(0.0, t1, n - m * len(loc))
    fine = np.sort(np.clip(np.concatenate(wins + [rest]), 0.0, t1))
    s2 = jc.simulate(scene, t1, ts=fine, **kw)
    f2 = np.asarray(s2.roller_sprocket_force).max(axis=1)
    step_peak = float(s1.peak_contact_force)
    return {
        # true values of the dense output only: the recorded peak's parabolas may
        # overshoot (by 2.2e-6 at rtol 1e-11 on the engagement)
        "peak_N": max(float(f2.max()), float(f1.max())),
        "step_sampled_peak_N": step_peak,
        "peak_time_s": float(fine[np.argmax(f2)]),
        "candidate_times_s": [float(coarse[i]) for i in loc],
        "window_spacing_s": 4 * h / (m - 1),
        "q1": np.asarray(s1.y1.q),
        "steps": int(s1.stats["num_steps"]),
    }


def reference(scene, t1, *, rtol=REF_RTOL) -> dict:
    """Dopri8 at ``rtol`` with the dense peak; shown converged by the same at 10·rtol."""
    t = time.perf_counter()
    ref = dense_peak(scene, t1, rtol)
    wall = time.perf_counter() - t
    loose = dense_peak(scene, t1, 10 * rtol)
    ref.update(solver="Dopri8", rtol=rtol, atol=ATOL_PER_RTOL * rtol, wall_s_incl_compile=wall)
    ref["check_rtol"] = 10 * rtol
    ref["check_peak_rel_err"] = abs(loose["peak_N"] - ref["peak_N"]) / ref["peak_N"]
    ref["check_q_abs_err_m"] = float(np.max(np.abs(loose["q1"][:, :2] - ref["q1"][:, :2])))
    ref["step_sampled_peak_rel_err"] = (
        abs(ref["step_sampled_peak_N"] - ref["peak_N"]) / ref["peak_N"]
    )
    print(
        f"  reference Dopri8 rtol {rtol:.0e}: dense peak {ref['peak_N']:.6f} N at "
        f"{ref['peak_time_s'] * 1e3:.4f} ms, {ref['steps']} steps; vs rtol {10 * rtol:.0e}: "
        f"peak rel diff {ref['check_peak_rel_err']:.1e}, q diff {ref['check_q_abs_err_m']:.1e} m;"
        f" recorded peak {ref['step_sampled_peak_N']:.3f} N "
        f"(off by {ref['step_sampled_peak_rel_err']:.1e})",
        flush=True,
    )
    return ref


def sweep(
    scene, t1, ref, name, settings, *, repeats, budget_s, max_steps, min_time_s=0.0
) -> list[dict]:
    """Rows for one solver over its settings (loosest first); stops after a run over
    ``budget_s`` (the tighter settings would take longer still). Each time is the minimum
    of ``repeats`` warm runs, more until ``min_time_s`` of them (see :func:`timed`)."""
    family = SOLVERS[name][1]
    key = "dt" if family == "fixed" else "rtol"
    rows, over = [], False
    for i, val in enumerate(settings):
        row = {"solver": name, "family": family, key: val}
        if over:
            row["skipped"] = f"a looser setting took over the {budget_s:.0f} s budget"
            rows.append(row)
            continue
        ms = max_steps if family != "fixed" else max(max_steps, int(1.05 * t1 / val) + 10)
        out, first, wall, walls = timed(
            lambda val=val, ms=ms: solve(scene, t1, name, max_steps=ms, **{key: val}),
            repeats,
            min_time_s=min_time_s,
        )
        row.update(errors(out, ref))
        stats = out["stats"]
        row.update(
            steps=int(stats["num_steps"]),
            rejected=int(stats["num_rejected_steps"]),
            wall_s=wall,
            us_per_step=wall / max(int(stats["num_steps"]), 1) * 1e6,
            walls_s=walls,
            first_call_s=first,
        )
        if i == 0:
            row["compile_s"] = first - wall
        if not row["ok"]:
            row["message"] = out.get("message") or "failed (diverged or no convergence)"
        rows.append(row)
        pe = row["peak_rel_err"]
        qe = row["q_abs_err_m"]
        print(
            f"  {name:8s} {key} {val:8.1e}: {row['steps']:7d} steps  {wall:8.3f} s  "
            + (f"peak err {pe:8.2e}  q err {qe:8.2e} m" if row["ok"] else "FAILED")
            + (f"  (compile {row['compile_s']:.1f} s)" if i == 0 else ""),
            flush=True,
        )
        over = wall > budget_s
    return rows


# ----------------------------------------------------------------------------- analysis
def time_at_error(rows, level, err_key="peak_rel_err"):
    """Wall time a method needs for ``err_key`` ≤ ``level``, from its error–time curve.

    Each run's *reliable* error is the largest error of it and of every more expensive
    run (so a lucky loose run does not count); the time is interpolated log–log between
    the two runs whose reliable errors bracket ``level``. None if never reached; the
    cheapest run's time (an upper bound, flagged) if even that one is below ``level``.
    """
    pts = sorted(
        (r["wall_s"], r[err_key] if r.get("ok") else math.inf) for r in rows if "wall_s" in r
    )
    if not pts:
        return None, None
    rel = []
    worst = 0.0
    for t, e in reversed(pts):
        worst = max(worst, max(e, 1e-300))
        rel.append((t, worst))
    rel.reverse()
    if rel[-1][1] > level:
        return None, None
    if rel[0][1] <= level:
        return rel[0][0], "upper bound (the cheapest run already meets it)"
    for (t0, e0), (t1, e1) in zip(rel[:-1], rel[1:], strict=True):
        if e0 > level >= e1:
            if not math.isfinite(e0):
                return t1, "upper bound (the next cheaper run failed)"
            x = (math.log(level) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + x * (math.log(t1) - math.log(t0))), "interpolated"
    return None, None


def best_table(rows, levels, err_key="peak_rel_err"):
    """Per error level: every solver's time at that error, and the fastest."""
    table = []
    for level in levels:
        per = {}
        for name in dict.fromkeys(r["solver"] for r in rows):
            t, how = time_at_error([r for r in rows if r["solver"] == name], level, err_key)
            if t is not None:
                per[name] = {"wall_s": t, "how": how}
        best = min(per, key=lambda k: per[k]["wall_s"]) if per else None
        table.append(
            {
                "error": level,
                "best": best,
                "best_wall_s": per[best]["wall_s"] if best else None,
                "per_solver": per,
            }
        )
    return table


# ----------------------------------------------------------------------------- charts
def plot_points(plot, pts, *args, **kw):
    """``plot`` (``ax.plot``, ``ax.semilogx``, …) the (x, y) pairs ``pts``, if there are any."""
    if pts:
        plot(*zip(*pts, strict=True), *args, **kw)
