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

import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, machine_info, parse, parser, tooth_period  # noqa: E402
from benchmarks.precision import (  # noqa: E402
    ATOL_PER_RTOL,
    DRIVE,
    REF_RTOL,
    STYLE,
    best_table,
    drive_scene,
    engagement_scene,
    reference,
    sweep,
)


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
                ax.legend(fontsize=8, ncol=2)
    fig.suptitle(
        f"work–precision, float64, {results['machine']['cpu_count']} CPU cores "
        f"(jax {results['machine']['versions']['jax']}, diffrax "
        f"{results['machine']['versions']['diffrax']})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
