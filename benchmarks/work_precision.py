"""Work–precision: error against wall time for diffrax's solvers on two lumped scenes.

    python -m benchmarks.work_precision            # full study
    python -m benchmarks.work_precision --quick    # smoke run: engagement, 3 explicit solvers

Writes ``benchmarks/results/work_precision.json`` and ``work_precision.png``.

Scenes: the meshing engagement (08B, z = 18, 1000 rpm, settled start; 4 tooth periods,
2 with ``--quick``) and a short closed drive (08B, teeth (9, 18), 40 links, 1000 rpm, its
first 2 ms = 0.3 driver tooth periods; started from the layout, see ``DRIVE`` below; full
run only). The drive's horizon is short on purpose: from the layout its rollers rattle in
their seats, and past ~2.5 ms that rattling is chaotic (the states of Dopri8 at rtol 1e-9
and 1e-10 part by ~10× every 0.3 ms, to 1e-5 m at 6.7 ms), so the state at t1 would no
longer be a convergent measure.

Solvers: explicit Euler and Heun on fixed steps (fractions of the explicit stability
limit of the start state); Bosh3, Tsit5, Dopri5, Dopri8 adaptive; implicit Kvaerno3,
Kvaerno5 and the IMEX KenCarp4 (whole field in the implicit part: ``jc.simulate`` builds a
single ``ODETerm``, so KenCarp4 runs through a copy of ``simulate``'s solve here, with
the same peak record). Adaptive solvers use ``simulate``'s PID controller (max norm) with
atol = 1e-3·rtol.

Errors, against a float64 reference (Dopri8 at rtol 1e-11; 1e-10 with ``--quick``):
* relative error of ``Solution.peak_contact_force`` (the force sampled at every accepted
  step: what a user gets) against the reference's *continuous* peak, read from Dopri8's
  dense output (:func:`dense_peak`; the reference's own step-sampled peak is off by ~1e-3
  and is reported too);
* max abs error of the roller positions at t1 (``Solution.y1.q[:, :2]``) [m].
The reference is shown converged by the same two numbers for Dopri8 at 10× its rtol.

Wall time: minimum over 3 repeats after a warm-up call; the first call's excess over
that (the compile time) is reported per solver. The tighter settings of a solver are
skipped once one run exceeds a time budget (recorded as ``skipped``).
"""

from __future__ import annotations

import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks._cli import (  # noqa: E402
    FRICTIONLESS,
    finish,
    machine_info,
    parse,
    parser,
)

RPM = 1000.0
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
def tooth_period(teeth: int, rpm: float = RPM) -> float:
    return 60.0 / rpm / teeth


def engagement_scene():
    return jc.scenes.engagement("08B", 18, speed_rpm=RPM, **FRICTIONLESS)


# The drive starts from its layout (settle=False): jc.scenes.drive's static equilibrium
# does not converge for this short (9, 18)/40-link drive (it warns after ~80 s and falls
# back to the layout anyway), so the load is ramped in over the default one revolution.
DRIVE = dict(teeth=(9, 18), n_links=40, speed_rpm=RPM, settle=False)


def drive_scene():
    return jc.scenes.drive("08B", **DRIVE, **FRICTIONLESS)


# ----------------------------------------------------------------------------- solves
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


MAX_REPEATS = 15  # timing runs at most (see more_repeats)


def more_repeats(walls, at_least: int, min_time_s: float, max_repeats: int = MAX_REPEATS) -> bool:
    """Whether a timing needs another run: fewer than ``at_least`` so far, or less than
    ``min_time_s`` timed in fewer than ``max_repeats`` runs — a short run's minimum needs
    more samples to get past the bursts of a shared machine. (One rule for every side of
    a comparison: :func:`timed` and the SciPy study's loop.)"""
    return len(walls) < at_least or (sum(walls) < min_time_s and len(walls) < max_repeats)


def timed(call, repeats: int, *, min_time_s: float = 0.0, max_repeats: int = MAX_REPEATS):
    """(result of the last call, first-call time, min and all warm times): ``repeats``
    warm calls, more (up to ``max_repeats``) until they add up to ``min_time_s`` (see
    :func:`more_repeats`)."""
    t = time.perf_counter()
    out = call()
    jax.block_until_ready(out["peak"])
    first = time.perf_counter() - t
    walls = []
    while more_repeats(walls, repeats, min_time_s, max_repeats):
        t = time.perf_counter()
        out = call()
        jax.block_until_ready(out["peak"])
        walls.append(time.perf_counter() - t)
    return out, first, min(walls), walls


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


# ----------------------------------------------------------------------------- study
def plan(quick: bool):
    """Per scene: horizon and, per solver, its settings (loosest first; None: fixed steps
    from the stability limit). ``--quick`` skips the drive and the implicit solvers (each
    compiles for ~1 min and runs for tens of seconds even at rtol 1e-3)."""
    rt = lambda *e: [10.0**-k for k in e]  # noqa: E731
    if quick:
        eng = {"Heun": None, "Tsit5": rt(3, 5, 7), "Dopri8": rt(5, 8)}
        return dict(eng_periods=2, eng=eng, drv=None, ref_rtol=1e-10, repeats=3, budget=6.0)
    eng = {
        "Euler": None,
        "Heun": None,
        "Bosh3": rt(3, 4, 5, 6, 7),
        "Tsit5": rt(3, 4, 5, 6, 7, 8, 9),
        "Dopri5": rt(3, 4, 5, 6, 7, 8, 9),
        "Dopri8": rt(3, 4, 5, 6, 7, 8, 9),
        "Kvaerno3": rt(3, 4, 5),
        "Kvaerno5": rt(3, 4, 5, 6, 7),
        "KenCarp4": rt(3, 4, 5, 6),
    }
    drv = {
        "Heun": None,
        "Bosh3": rt(3, 5, 7),
        "Tsit5": rt(3, 4, 5, 6, 7, 8),
        "Dopri5": rt(3, 5, 7),
        "Dopri8": rt(3, 5, 7, 9),
        "Kvaerno5": rt(3, 5),
    }
    return dict(
        eng_periods=4, eng=eng, drv=drv, drv_periods=0.3, ref_rtol=REF_RTOL, repeats=3, budget=30.0
    )


def fixed_steps(scene, name, t1, quick):
    """Fixed steps for Euler/Heun as fractions of the explicit stability limit of the
    start state's fastest mode (|λ|max of the Jacobian)."""
    from jax.flatten_util import ravel_pytree

    flat, unravel = ravel_pytree(jc.initial_state(scene))
    jac = jax.jacfwd(lambda x: ravel_pytree(jc.vector_field(0.0, unravel(x), scene))[0])(flat)
    lam = float(np.max(np.abs(np.linalg.eigvals(np.asarray(jac)))))
    # Heun is stable to |λ|dt ≈ 0.9 here (damping ratio ~0.09 of the fastest mode),
    # Euler only to ≈ 0.17; halve from just under each
    top = 0.8 if name == "Heun" else 0.16
    n = 2 if quick else (5 if name == "Heun" else 3)
    return [top / lam / 2**k for k in range(n)], lam


def run_scene(label, scene, t1, solvers, *, ref_rtol, repeats, budget, quick, max_steps=400_000):
    print(f"{label}: t1 = {t1 * 1e3:.3f} ms")
    ref = reference(scene, t1, rtol=ref_rtol)
    rows, lam = [], None
    for name, settings in solvers.items():
        if settings is None:
            settings, lam = fixed_steps(scene, name, t1, quick)
        rows += sweep(
            scene,
            t1,
            ref,
            name,
            settings,
            repeats=repeats,
            budget_s=budget,
            max_steps=max_steps,
        )
    ref_out = {k: v for k, v in ref.items() if k != "q1"}
    levels = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6]
    out = {
        "t1_s": t1,
        "n_bodies": scene.n_bodies,
        "reference": ref_out,
        "max_abs_eigenvalue_at_start": lam,
        "rows": rows,
        "best_peak": best_table(rows, levels),
        "best_q": best_table(rows, [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9], "q_abs_err_m"),
    }
    for line in out["best_peak"]:
        if line["best"]:
            print(
                f"  peak error ≤ {line['error']:.0e}: best {line['best']} "
                f"{line['best_wall_s']:.3f} s"
            )
    return out


def main(argv=None):
    ap = parser(__doc__)
    args = parse(ap, argv)
    p = plan(args.quick)
    start = time.perf_counter()
    results = {"machine": machine_info(), "quick": args.quick, "atol_per_rtol": ATOL_PER_RTOL}
    t = time.perf_counter()
    eng = engagement_scene()
    results["engagement_build_s"] = time.perf_counter() - t
    results["engagement"] = run_scene(
        "engagement 08B z18 lumped",
        eng,
        p["eng_periods"] * tooth_period(18),
        p["eng"],
        ref_rtol=p["ref_rtol"],
        repeats=p["repeats"],
        budget=p["budget"],
        quick=args.quick,
    )
    results["engagement"]["tooth_periods"] = p["eng_periods"]
    if p["drv"] is not None:
        t = time.perf_counter()
        drv = drive_scene()
        results["drive_build_s"] = time.perf_counter() - t
        results["drive"] = run_scene(
            f"drive 08B {DRIVE['teeth']} {DRIVE['n_links']} links lumped",
            drv,
            p["drv_periods"] * tooth_period(DRIVE["teeth"][0]),
            p["drv"],
            ref_rtol=p["ref_rtol"],
            repeats=p["repeats"],
            budget=p["budget"],
            quick=args.quick,
        )
        results["drive"]["setting"] = {
            k: list(v) if isinstance(v, tuple) else v for k, v in DRIVE.items()
        }
        results["drive"]["driver_tooth_periods"] = p["drv_periods"]
    finish(results, args.out, "work_precision", chart, start)


def chart(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = [k for k in ("engagement", "drive") if k in results]
    fig, axes = plt.subplots(2, len(keys), figsize=(6.5 * len(keys), 9), squeeze=False)
    for col, key in enumerate(keys):
        res = results[key]
        for row, (err, label) in enumerate(
            (("peak_rel_err", "relative error of the peak contact force"),
             ("q_abs_err_m", "max abs error of roller positions at t1 [m]"))
        ):  # fmt: skip
            ax = axes[row, col]
            for name in dict.fromkeys(r["solver"] for r in res["rows"]):
                pts = [
                    (r["wall_s"], max(r[err], 1e-16))
                    for r in res["rows"]
                    if r["solver"] == name and r.get("ok")
                ]
                if not pts:
                    continue
                color, marker = STYLE[name]
                ax.loglog(*zip(*pts, strict=True), marker=marker, color=color, label=name)
            ref = res["reference"]
            chk = ref["check_peak_rel_err"] if row == 0 else ref["check_q_abs_err_m"]
            ax.axhline(
                max(chk, 1e-16), color="k", ls=":", lw=1,
                label=f"Dopri8 rtol {ref['check_rtol']:.0e} vs reference",
            )  # fmt: skip
            ax.set_xlabel("wall time, min of repeats, compile excluded [s]")
            ax.set_ylabel(label)
            ax.set_title(f"{key}, t1 = {res['t1_s'] * 1e3:.2f} ms")
            ax.grid(True, which="both", alpha=0.3)
            if row == 0:
                ax.legend(fontsize=7, ncol=2)
    fig.suptitle(
        f"work–precision, float64, {results['machine']['cpu_count']} CPU cores "
        f"(jax {results['machine']['versions']['jax']}, diffrax "
        f"{results['machine']['versions']['diffrax']})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
