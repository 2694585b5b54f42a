"""Stability of fixed-step solvers against stiffness, and gradients against horizon: the
measured fixed-step boundary of Euler, Heun and Tsit5 on the stiffness-scaled engagement
against the bounds the linearization predicts, and the soft peak's gradient in the tooth
profile's coordinates against the horizon.

    python -m benchmarks.stability            # full study (~16 min on 2 busy cores)
    python -m benchmarks.stability --quick    # map only, 3 scales, 1 tooth period (2-3 min)
    python -m benchmarks.stability --quick --gradient   # ... plus gradients at 1, 2 periods

Writes ``benchmarks/results/stability.json`` and ``stability.png``.

Notes: benchmarks/stability.md
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import time
import warnings

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import optimistix as optx  # noqa: E402
from jax.flatten_util import ravel_pytree  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import parse, parser, tooth_period  # noqa: E402
from benchmarks.precision import (  # noqa: E402
    engagement_scene,
    fixed_solve,
    log_bisect,
    plot_points,
    step_runs,
)

GROWTH = 1e8  # amplification over the horizon counted as divergence (see the notes)
BLOWUP = 10.0  # a "successful" solve whose peak force exceeds 10× the reference blew up
LOWEST = 6  # the map's grid reaches down to 2^(-LOWEST/2) × the predicted bound
RPM, TEETH, TENSION = 1000.0, 18, 1000.0
PERIOD = tooth_period(TEETH, RPM)  # [s]
METHODS = ("Euler", "Heun", "Tsit5")


# ----------------------------------------------------------------- stability functions
def _tableau_matrix(solver):
    """(A, b) of an RK solver's Butcher tableau; None for Euler (R = 1 + z)."""
    tab = getattr(type(solver), "tableau", None)
    if tab is None:
        if not isinstance(solver, diffrax.Euler):
            raise ValueError(f"no Butcher tableau for {type(solver).__name__}")
        return None
    s = len(tab.b_sol)
    a = np.zeros((s, s))
    for i, row in enumerate(tab.a_lower):
        a[i + 1, : len(row)] = row
    if tab.a_diagonal is not None:
        a[np.diag_indices(s)] = tab.a_diagonal
    return a, np.asarray(tab.b_sol, dtype=float)


def stability_function(solver):
    """R(z) of a diffrax Runge–Kutta solver: y_{n+1} = R(hλ)·y_n for y' = λy."""
    ab = _tableau_matrix(solver)
    if ab is None:
        return lambda z: 1.0 + np.asarray(z, dtype=complex)
    a, b = ab
    s = len(b)
    if not np.any(np.diag(a)):  # explicit: R is the polynomial 1 + Σ bᵀA^(k−1)𝟙 z^k
        coef, v = [1.0], np.ones(s)
        for _ in range(s):
            coef.append(float(b @ v))
            v = a @ v
        poly = np.asarray(coef[::-1])
        return lambda z: np.polyval(poly, np.asarray(z, dtype=complex))

    def rat(z):
        z = np.asarray(z, dtype=complex)
        m = np.eye(s) - z[..., None, None] * a
        x = np.linalg.solve(m, np.broadcast_to(np.ones(s), z.shape + (s,))[..., None])[..., 0]
        return 1.0 + z * (x @ b)

    return rat


def axis_limit(solver, direction: complex, y_max: float = 10.0) -> float:
    """Largest y with |R(y·direction)| ≤ 1 on the whole segment (0, y]."""
    r = stability_function(solver)
    ys = np.linspace(1e-6, y_max, 200_001)
    bad = np.nonzero(np.abs(r(ys * direction)) > 1 + 1e-12)[0]
    return float(ys[bad[0] - 1]) if len(bad) else math.inf


def predicted_step(solver, eigs, horizon=None, growth=GROWTH, h_lo=1e-12, h_hi=1e-3) -> float:
    """Largest fixed step h [s] whose scan from h_lo up keeps |R(hλ)| ≤ 1 (``horizon``
    None) or |R(hλ)|^(horizon/h) ≤ growth, for every eigenvalue λ."""
    r = stability_function(solver)
    hs = np.geomspace(h_lo, h_hi, 4001)
    amp = np.abs(r(hs[:, None] * eigs[None, :])).max(axis=1)
    if horizon is None:
        ok = amp <= 1 + 1e-12
    else:
        ok = (horizon / hs) * np.log(np.maximum(amp, 1e-300)) <= math.log(growth)
    bad = np.nonzero(~ok)[0]
    return float(hs[bad[0] - 1]) if len(bad) and bad[0] > 0 else (math.nan if len(bad) else h_hi)


# ----------------------------------------------------------------------- scenes
def limiting_modes(solver, eigs, contact_frac, horizon, n=4):
    """The n modes with the smallest horizon bound: bound [s], |λ| [rad/s], damping ratio
    ζ and contact fraction of each."""
    up = eigs.imag >= 0
    rows = [
        (predicted_step(solver, np.array([lam]), horizon), lam, f)
        for lam, f in zip(eigs[up], contact_frac[up], strict=True)
    ]
    rows.sort(key=lambda r: r[0])
    return [
        {
            "dt": h,
            "abs_lambda": float(abs(lam)),
            "zeta": float(-lam.real / abs(lam)),
            "contact_fraction": float(f),
        }
        for h, lam, f in rows[:n]
    ]


def stiffened(scene: jc.Scene, s: float) -> jc.Scene:
    """Every elastic element × s (dampers × √s: same damping ratio), then settled."""
    law = scene.roller_law
    name = _stiffness_field(law)
    sc = eqx.tree_at(
        lambda x: getattr(x.roller_law, name), scene, getattr(law, name) * jnp.asarray(s)
    )
    if not all(isinstance(g.element, jc.LinkSprings) for g in sc.pairs):
        raise ValueError("stiffened() scales the lumped scene's link springs only")
    links = tuple(
        eqx.tree_at(
            lambda g: (g.element.stiffness, g.element.damping),
            g,
            (g.element.stiffness * s, g.element.damping * math.sqrt(s)),
        )
        for g in sc.pairs
    )
    sc = dataclasses.replace(sc, pairs=links)
    an = sc.anchors
    sc = eqx.tree_at(
        lambda x: (x.anchors.stiffness, x.anchors.damping),
        sc,
        (an.stiffness * s, an.damping * math.sqrt(s)),
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        settled = jc.scenes.equilibrate(sc)
    if caught:
        raise RuntimeError(f"scale {s}: {caught[0].message}")
    return settled


def linearization(scene: jc.Scene):
    """Eigenvalues λ of ∂f/∂y at the settled state (t = 0), zero modes (free roller spins,
    the driver's prescribed angle) dropped, and each mode's contact fraction: the share
    of its elastic energy φᴴKφ in the roller/tooth contacts (K split into the contacts'
    part and the rest, the latter from the same scene with the contacts switched off)."""
    jac = np.asarray(_jacobian(scene))
    off = eqx.tree_at(
        lambda x: getattr(x.roller_law, _stiffness_field(x.roller_law)),
        scene,
        getattr(scene.roller_law, _stiffness_field(scene.roller_law)) * 1e-12,
    )
    jac_bilateral = np.asarray(_jacobian(off))
    nq = scene.q0.size  # DriveState flattens as q, v, theta, omega
    q, v = slice(0, nq), slice(nq, 2 * nq)
    mass = np.repeat(np.asarray(scene.mass), 3)[:, None]
    k_all, k_bi = -mass * jac[v, q], -mass * jac_bilateral[v, q]
    eigs, vecs = np.linalg.eig(jac)
    keep = np.abs(eigs) > 1e-6 * np.abs(eigs).max()
    frac = []
    for j in np.nonzero(keep)[0]:
        phi = vecs[q, j]
        e_contact = abs(np.vdot(phi, (k_all - k_bi) @ phi))
        e_bilateral = abs(np.vdot(phi, k_bi @ phi))
        frac.append(e_contact / max(e_contact + e_bilateral, 1e-300))
    return eigs[keep], np.asarray(frac)


def _stiffness_field(law) -> str:
    return "modulus" if isinstance(law, jc.contact.JohnsonCylinder) else "stiffness"


@eqx.filter_jit
def _jacobian(scene):
    flat, unravel = ravel_pytree(jc.initial_state(scene))

    def f(x):
        return ravel_pytree(jc.vector_field(0.0, unravel(x), scene))[0]

    return jax.jacfwd(f)(flat)


def stiffest_element(scene: jc.Scene) -> dict:
    """k_max (links, and the roller/tooth contact's tangent stiffness at the settled
    depths) and m_min: the cheap estimate ω ≈ √(k_max/m_min)."""
    y0 = jc.initial_state(scene)
    spr = scene.sprockets[0]
    xr, _ = jc.roller_kinematics(y0, scene)
    c, s = jnp.cos(y0.theta[0]), jnp.sin(y0.theta[0])
    rel = xr - spr.centre
    local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
    depth, _ = jax.vmap(jc.gap_contact, in_axes=(None, 0))(spr.profile, local)
    law = scene.roller_law
    k_contact = float(jnp.max(jax.vmap(jax.grad(law.elastic_force))(depth)))
    k_link = max(float(jnp.max(g.element.stiffness)) for g in scene.pairs)
    m_min = float(jnp.min(scene.mass))
    return {
        "k_contact_N_per_m": k_contact,
        "k_link_N_per_m": k_link,
        "m_min_kg": m_min,
        "omega_estimate": math.sqrt(max(k_contact, k_link) / m_min),
    }


# ---------------------------------------------------------------------- the map
def fixed_run(scene, solver, h, horizon, max_steps, ref_peak):
    """One fixed-step solve, judged twice: by the library (``Result``) and by the truth
    (a peak roller/tooth force above ``BLOWUP`` × the reference peak is a blow-up)."""
    sol = fixed_solve(scene, horizon, h, solver=solver, max_steps=max_steps, n_save=41)
    peak = float(sol.peak_contact_force)
    outs = [np.asarray(x) for x in (sol.roller_position, sol.roller_sprocket_force)]
    finite = bool(all(np.all(np.isfinite(x)) for x in outs)) and math.isfinite(peak)
    vel = np.asarray(sol.roller_velocity)
    with np.errstate(over="ignore", invalid="ignore"):  # blown-up runs reach 1e300 m/s
        speed = np.hypot(vel[..., 0], vel[..., 1])
    speed = speed[np.isfinite(speed)]
    v_chain = float(scene.sprockets[0].speed * scene.sprockets[0].profile.pitch_radius)
    blown = not finite or not peak <= BLOWUP * ref_peak
    return {
        "dt": float(h),
        "result": jc.result_names(sol.result)[0],
        "library_ok": sol.ok,
        "stable": sol.ok and not blown,  # what the map and the boundary use
        "undetected": sol.ok and blown,  # the library called a blow-up successful
        "peak_N": peak if math.isfinite(peak) else None,
        "peak_error": peak / ref_peak - 1 if math.isfinite(peak) else None,
        # largest finite roller speed over the save times, in pitch-line speeds ωR
        "max_speed_over_chain_speed": float(speed.max() / v_chain) if speed.size else None,
        "all_finite": finite,
    }


def boundary(scene, solver, h_guess, horizon, max_steps, span, n_bisect, ref_peak):
    """Runs on a geometric grid h_guess·2^(k/2), |k| ≤ span, widened until it holds a
    stable and a divergent step, then ``n_bisect`` log-bisections between the largest
    stable step below the smallest divergent one and that step."""
    runs, at = step_runs(lambda h: fixed_run(scene, solver, h, horizon, max_steps, ref_peak))
    ks = list(range(-span, span + 1))
    for k in ks:
        at(h_guess * 2 ** (k / 2))
    lo_k, hi_k = ks[0], ks[-1]
    while all(not r["stable"] for r in runs.values()) and lo_k > -LOWEST:
        lo_k -= 1
        at(h_guess * 2 ** (lo_k / 2))
    while all(r["stable"] for r in runs.values()) and hi_k < 8:
        hi_k += 1
        at(h_guess * 2 ** (hi_k / 2))
    div = [h for h, r in runs.items() if not r["stable"]]
    if not div or all(not r["stable"] for r in runs.values()):
        return None, None, runs
    h_div = min(div)
    below = [h for h, r in runs.items() if r["stable"] and h < h_div]
    if not below:
        return None, h_div, runs
    h_ok, h_div = log_bisect(lambda h: at(h)["stable"], max(below), h_div, n_bisect)
    return h_ok, h_div, runs


def stability_map(scales, methods, horizon_periods, n_entry, span, n_bisect):
    # the engagement from its layout, settled by stiffened()
    base = engagement_scene(
        tension=TENSION, n_entry=n_entry, model=jc.scenes.ChainModel(settle=False)
    )
    horizon = horizon_periods * PERIOD
    solvers = {m: getattr(diffrax, m)() for m in methods}
    beta = {
        m: {"real": axis_limit(s, -1.0), "imag": axis_limit(s, 1j, 4.0)} for m, s in solvers.items()
    }
    rows, scenes = [], {}
    lin = {}
    for s in scales:
        t = time.perf_counter()
        sc = stiffened(base, s)
        scenes[s] = sc
        eigs, contact_frac = linearization(sc)
        ref = jc.simulate(sc, horizon, rtol=1e-8, atol=1e-11, n_save=41, throw=False)
        est = stiffest_element(sc)
        omega = float(np.abs(eigs).max())
        top = eigs[np.argmax(np.abs(eigs))]
        lin[s] = {
            "omega_max": omega,
            "zeta_top_mode": float(-top.real / abs(top)),
            "eigs": eigs,
            "contact_frac": contact_frac,
            "reference_peak_N": float(ref.peak_contact_force),
            "reference_ok": ref.ok,
            **est,
        }
        print(
            f"scale {s:6.3g}: ω_max {omega:9.4g} rad/s (ζ {lin[s]['zeta_top_mode']:.3f}), "
            f"√(k_max/m_min) {est['omega_estimate']:9.4g} rad/s, reference peak "
            f"{float(ref.peak_contact_force):7.1f} N ({time.perf_counter() - t:.1f} s)"
        )
    for m, solver in solvers.items():
        preds = {
            s: {
                "rule": beta[m]["real"] / lin[s]["omega_max"],
                "linear": predicted_step(solver, lin[s]["eigs"]),
                "horizon": predicted_step(solver, lin[s]["eigs"], horizon),
                "horizon_G1e4": predicted_step(solver, lin[s]["eigs"], horizon, 1e4),
                "horizon_G1e12": predicted_step(solver, lin[s]["eigs"], horizon, 1e12),
                # modes mostly in the bilateral springs (links, anchors): contact-dominated
                # modes can only rattle (a unilateral contact lets go), not blow up
                "horizon_bilateral": predicted_step(
                    solver, lin[s]["eigs"][lin[s]["contact_frac"] < 0.5], horizon
                ),
            }
            for s in scales
        }
        # one max_steps for every run of a method (a static argument: no recompiles)
        h_min = min(p["horizon"] for p in preds.values()) * 2 ** (-LOWEST / 2)
        max_steps = int(math.ceil(horizon / h_min)) + 10
        for s in scales:
            t = time.perf_counter()
            p = preds[s]
            ref_peak = lin[s]["reference_peak_N"]
            h_ok, h_div, runs = boundary(
                scenes[s], solver, p["horizon"], horizon, max_steps, span, n_bisect, ref_peak
            )
            measured = math.sqrt(h_ok * h_div) if h_ok and h_div else None
            accurate = [
                r["dt"]
                for r in runs.values()
                if r["stable"] and r["peak_error"] is not None and abs(r["peak_error"]) <= 0.1
            ]
            row = {
                "method": m,
                "scale": s,
                "omega_max": lin[s]["omega_max"],
                "predicted": p,
                "measured_stable_dt": h_ok,
                "measured_divergent_dt": h_div,
                "measured_dt": measured,
                "measured_over_horizon_bound": measured / p["horizon"] if measured else None,
                "measured_over_rule": measured / p["rule"] if measured else None,
                "measured_h_omega": measured * lin[s]["omega_max"] if measured else None,
                "largest_accurate_dt": max(accurate) if accurate else None,
                "measured_over_bilateral_bound": measured / p["horizon_bilateral"]
                if measured
                else None,
                "limiting_modes": limiting_modes(
                    solver, lin[s]["eigs"], lin[s]["contact_frac"], horizon
                ),
                "runs": sorted(runs.values(), key=lambda r: r["dt"]),
                "undetected_failures": sum(r["undetected"] for r in runs.values()),
            }
            rows.append(row)
            ratio = row["measured_over_horizon_bound"]
            print(
                f"  {m:6s} s={s:<6.3g} rule {p['rule']:.3g}  linear {p['linear']:.3g}  "
                f"horizon {p['horizon']:.3g}  bilateral {p['horizon_bilateral']:.3g}  "
                f"measured [{_f(h_ok)}, {_f(h_div)}] s "
                f"(×{_f(ratio)} of horizon bound, hω={_f(row['measured_h_omega'])}) "
                f"{len(runs)} runs, {time.perf_counter() - t:.1f} s"
            )
    axes = {m: beta[m] for m in methods}
    lin_out = {
        str(s): {k: v for k, v in d.items() if k not in ("eigs", "contact_frac")}
        | {"eigs": [[float(x.real), float(x.imag)] for x in d["eigs"] if x.imag >= 0]}
        for s, d in lin.items()
    }
    return {"rows": rows, "axis_limits": axes, "linearization": lin_out}, lin, scenes


def _g(x, width):
    return f"{'—':>{width}s}" if x is None else f"{x:{width}.2f}"


def _f(x):
    return "—" if x is None else f"{x:.3g}"


# --------------------------------------------------------------- implicit (optional)
def implicit_check(scene, h_explicit, horizon, ref_peak):
    """Kvaerno3 (L-stable ESDIRK) at fixed steps far above the explicit bound: stable
    while its Newton iteration converges; a failing Newton is reported."""
    solver = diffrax.Kvaerno3(
        root_finder=diffrax.VeryChord(rtol=1e-8, atol=1e-11, norm=optx.max_norm),
        root_find_max_steps=10,
    )
    out = []
    for f in (1, 4, 16):
        h = f * h_explicit
        t = time.perf_counter()
        r = fixed_run(scene, solver, h, horizon, int(horizon / h_explicit) + 10, ref_peak)
        r["factor_over_tsit5_bound"] = f
        out.append(r)
        print(
            f"  Kvaerno3 dt = {f:3d} × Tsit5 bound ({h:.3g} s): {r['result']}, peak "
            f"{_f(r['peak_N'])} N ({time.perf_counter() - t:.1f} s)"
        )
    return out


# ------------------------------------------------------------ gradient vs horizon
def gradient_study(scene, horizons, dt, fd_check):
    space = jc.design.DesignSpace.iso606(jc.ChainSpec.iso606("08B"), TEETH)
    u0 = space.coordinates(scene.sprockets[0].profile)
    ref = jc.simulate(scene, max(horizons) * PERIOD, rtol=1e-8, atol=1e-11, throw=False)
    reference = float(ref.peak_contact_force)
    temperature = 0.02 * reference

    def objective(u, k):
        sc = eqx.tree_at(lambda s: s.sprockets[0].profile, scene, space.profile(u))
        out = jc.design.soft_peak_force(
            sc,
            k * PERIOD,
            t_start=(k - 1) * PERIOD,
            temperature=temperature,
            reference=reference,
            dt=dt,
        )
        return out.soft, out

    rows = []
    for k in horizons:
        t = time.perf_counter()
        (value, out), grad = jax.value_and_grad(objective, has_aux=True)(u0, k)
        g = np.asarray(grad)
        row = {
            "periods": k,
            "soft_peak_N": float(value),
            "result": jc.result_names(out.result)[0],
            "grad_N": g.tolist(),
            "grad_norm_N": float(np.linalg.norm(g)),
            "finite": bool(np.all(np.isfinite(g))),
            "wall_s": time.perf_counter() - t,
        }
        if fd_check:
            e = np.eye(4)[int(np.argmax(np.abs(g)))]
            fds = {}
            for eps in (1e-3, 1e-4):
                up = float(objective(u0 + eps * e, k)[0])
                dn = float(objective(u0 - eps * e, k)[0])
                fds[str(eps)] = (up - dn) / (2 * eps)
            row["fd_direction"] = e.tolist()
            row["fd_N"] = fds
            row["ad_along_direction_N"] = float(g @ e)
        rows.append(row)
        fd = "  FD " + ", ".join(f"{v:.4g}" for v in row["fd_N"].values()) if fd_check else ""
        print(
            f"  {k:2d} periods: soft peak {row['soft_peak_N']:7.1f} N, |∂P/∂u| "
            f"{row['grad_norm_N']:9.4g} N, ∂P/∂u = {np.array2string(g, precision=3)}"
            f"{fd} ({row['wall_s']:.0f} s)"
        )
    ks = np.asarray([r["periods"] for r in rows], dtype=float)
    gn = np.asarray([r["grad_norm_N"] for r in rows])
    growth = None
    if len(ks) >= 2 and np.all(gn > 0):
        slope = np.polyfit(ks, np.log(gn), 1)[0]
        growth = float(math.exp(slope))
        print(f"  gradient norm grows ×{growth:.3g} per tooth period (log-linear fit)")
    return {
        "dt": dt,
        "temperature_N": temperature,
        "reference_N": reference,
        "rows": rows,
        "growth_per_period": growth,
    }


# ------------------------------------------------------------------------- main
def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument(
        "--gradient", action="store_true", help="with --quick: also the gradient study (1, 2)"
    )
    args = parse(ap, argv)
    quick = args.quick
    t_start = time.perf_counter()
    if quick:
        scales, horizon_periods, span, n_bisect = (0.25, 1.0, 4.0), 1, 1, 2
        grad_horizons, n_entry = (1, 2), 3
    else:
        scales, horizon_periods, span, n_bisect = (1 / 16, 0.25, 1.0, 4.0, 16.0), 2, 2, 4
        grad_horizons, n_entry = (1, 2, 4, 8), 9
    results = {
        "machine": {"platform": platform.platform(), "cpu_count": os.cpu_count()},
        "versions": {"jax": jax.__version__, "diffrax": diffrax.__version__},
        "quick": quick,
        "scene": {
            "chain": "08B",
            "teeth": TEETH,
            "speed_rpm": RPM,
            "tension_N": TENSION,
            "n_entry": n_entry,
            "tooth_period_s": PERIOD,
            "horizon_periods": horizon_periods,
        },
        "growth_threshold": GROWTH,
    }
    print(f"stability map: {', '.join(METHODS)} × stiffness scales {scales}")
    smap, lin, scenes = stability_map(scales, METHODS, horizon_periods, n_entry, span, n_bisect)
    results["map"] = smap
    if not quick:
        print("implicit (optional): Kvaerno3 far above the explicit bound, scale 1")
        tsit = next(r for r in smap["rows"] if r["method"] == "Tsit5" and r["scale"] == 1.0)
        results["implicit"] = implicit_check(
            scenes[1.0],
            tsit["predicted"]["horizon"],
            horizon_periods * PERIOD,
            lin[1.0]["reference_peak_N"],
        )
    results["timing_s"] = {"map": time.perf_counter() - t_start}
    if quick and not args.gradient:
        results["gradient"] = None  # the full run (or --gradient) measures it
    else:
        print(f"gradient of the soft peak against horizon ({grad_horizons} tooth periods):")
        t = time.perf_counter()
        grad_scene = scenes[1.0]
        results["gradient"] = gradient_study(grad_scene, grad_horizons, 4e-6, fd_check=not quick)
        results["timing_s"]["gradient"] = time.perf_counter() - t
    results["wall_s"] = time.perf_counter() - t_start
    summary(results)
    (args.out / "stability.json").write_text(json.dumps(results, indent=1))
    chart(results, args.out / "stability.png")
    print(f"wrote {args.out / 'stability.json'} and stability.png ({results['wall_s']:.0f} s)")
    return results


def summary(results):
    print("\nmeasured boundary vs predicted (fixed step [s]):")
    print(
        f"{'method':7s} {'scale':>6s} {'ω_max':>9s} {'rule β/ω':>9s} {'linear':>9s} "
        f"{'horizon':>9s} {'bilat.':>9s} {'measured':>9s} {'hω':>5s} {'/hor':>5s} "
        f"{'/bilat':>6s} {'/rule':>5s} {'accurate':>9s}"
    )
    for r in results["map"]["rows"]:
        p = r["predicted"]
        print(
            f"{r['method']:7s} {r['scale']:6.3g} {r['omega_max']:9.4g} {p['rule']:9.3g} "
            f"{p['linear']:9.3g} {p['horizon']:9.3g} {p['horizon_bilateral']:9.3g} "
            f"{_f(r['measured_dt']):>9s} {_g(r['measured_h_omega'], 5)} "
            f"{_g(r['measured_over_horizon_bound'], 5)} "
            f"{_g(r['measured_over_bilateral_bound'], 6)} {_g(r['measured_over_rule'], 5)} "
            f"{_f(r['largest_accurate_dt']):>9s}"
        )
    bad = sum(r["undetected_failures"] for r in results["map"]["rows"])
    print(f"undetected failures (successful but non-finite or blown up): {bad}")


# ------------------------------------------------------------------------ chart
def chart(results, path=None):
    """The figure (a matplotlib ``Figure``, no pyplot state touched); saved if ``path``.

    Without a gradient study (``results["gradient"]`` missing, ``None`` or without rows)
    only the map's panels are drawn: one stability map per method above, the stability
    regions and the measured/predicted ratios below."""
    from matplotlib.figure import Figure

    rows = results["map"]["rows"]
    methods = list(dict.fromkeys(r["method"] for r in rows))
    g = results.get("gradient")
    if g and g["rows"]:
        fig = Figure(figsize=(16, 9.5))
        axes = fig.subplots(2, 3)
        maps, (ax_regions, ax_ratio, ax_gradient) = axes[0], axes[1]
    else:  # the map's panels only, each of the same size, rows centred
        n = max(len(methods), 2)
        fig = Figure(figsize=(16 * n / 3, 9.5))
        grid = fig.add_gridspec(2, 2 * n)
        off = n - len(methods)
        maps = [
            fig.add_subplot(grid[0, off + 2 * i : off + 2 * i + 2]) for i in range(len(methods))
        ]
        ax_regions = fig.add_subplot(grid[1, n - 2 : n])
        ax_ratio = fig.add_subplot(grid[1, n : n + 2])
        ax_gradient = None
    styles = {
        "stable": dict(marker="o", color="tab:green", ms=5, label="stable, peak within 10 %"),
        "inaccurate": dict(
            marker="o", mfc="none", color="tab:orange", ms=6, label="stable, peak off > 10 %"
        ),
        "diverged": dict(marker="x", color="tab:red", ms=6, label="diverged (reported)"),
        "undetected": dict(marker="*", color="k", ms=10, label="blew up, reported successful"),
    }
    for ax, m in zip(maps, methods, strict=False):
        mr = [r for r in rows if r["method"] == m]
        s = np.asarray([r["scale"] for r in mr])
        seen = set()
        for r in mr:
            for run in r["runs"]:
                if run["undetected"]:
                    kind = "undetected"
                elif not run["stable"]:
                    kind = "diverged"
                elif run["peak_error"] is not None and abs(run["peak_error"]) > 0.1:
                    kind = "inaccurate"
                else:
                    kind = "stable"
                st = dict(styles[kind])
                if kind in seen:
                    st.pop("label")
                seen.add(kind)
                ax.plot(r["scale"], run["dt"], ls="none", **st)
        keys = ("rule", "linear", "horizon", "horizon_bilateral")
        pred = {k: np.asarray([r["predicted"][k] for r in mr]) for k in keys}
        ax.plot(s, pred["rule"], "--", color="tab:gray", label="rule β_real/ω_max")
        ax.plot(s, pred["linear"], ":", color="tab:purple", label="|R(hλ)| ≤ 1, every mode")
        ax.plot(s, pred["horizon"], "-", color="tab:blue", label="growth ≤ 1e8 over horizon")
        ax.plot(s, pred["horizon_bilateral"], "-.", color="tab:cyan", label="same, bilateral modes")
        meas = [(r["scale"], r["measured_dt"]) for r in mr if r["measured_dt"]]
        plot_points(ax.plot, meas, "s-", color="k", ms=4, lw=1, label="measured")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(s, [f"{v:g}" for v in s])
        ax.minorticks_off()
        ax.set_xlabel("stiffness scale s (contact, links, anchors)")
        ax.set_ylabel("fixed step dt [s]")
        ax.set_title(f"{m}: stability map")
        ax.legend(fontsize=8, loc="lower left")
    # stability regions, with every mode's hλ at the measured boundary (scale 1)
    ax = ax_regions
    xs, ys = np.meshgrid(np.linspace(-4.2, 0.6, 400), np.linspace(-4, 4, 500))
    lin = results["map"]["linearization"]
    key = "1.0" if "1.0" in lin else next(iter(lin))
    eigs = np.asarray(lin[key]["eigs"])
    eigs = eigs[:, 0] + 1j * eigs[:, 1]
    colors = dict(Euler="tab:red", Heun="tab:orange", Tsit5="tab:blue")
    for m in methods:
        r = stability_function(getattr(diffrax, m)())
        ax.contour(xs, ys, np.abs(r(xs + 1j * ys)), levels=[1.0], colors=colors.get(m, "k"))
        row = next(
            (x for x in rows if x["method"] == m and str(x["scale"]) == key and x["measured_dt"]),
            None,
        )
        if row is not None:
            z = row["measured_dt"] * eigs
            ax.plot(z.real, z.imag, ".", color=colors.get(m, "k"), ms=3, label=f"{m}: h·λ")
    ax.axhline(0, color="k", lw=0.5)
    ax.axvline(0, color="k", lw=0.5)
    ax.set_xlim(-4.2, 0.6)
    ax.set_ylim(-4, 4)
    ax.set_xlabel("Re(hλ)")
    ax.set_ylabel("Im(hλ)")
    ax.set_title(f"|R(z)| = 1; modes at the measured dt (s = {float(key):g})")
    ax.legend(fontsize=8, loc="lower left")
    ax.set_aspect("equal")
    # measured over predicted
    ax = ax_ratio
    width = 0.8 / max(len(methods), 1)
    scales = sorted({r["scale"] for r in rows})

    def ratio(m, sc, key):
        row = next((r for r in rows if r["method"] == m and r["scale"] == sc), None)
        return np.nan if row is None or row[key] is None else row[key]

    for i, m in enumerate(methods):
        x = np.arange(len(scales)) + i * width
        bil = [ratio(m, sc, "measured_over_bilateral_bound") for sc in scales]
        allm = [ratio(m, sc, "measured_over_horizon_bound") for sc in scales]
        ax.bar(x, bil, width, label=f"{m}: / bilateral-mode bound", color=colors.get(m))
        ax.plot(x, allm, "v", color="k", ms=5, label="/ all-mode bound" if i == 0 else None)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xticks(np.arange(len(scales)) + 0.4 - width / 2, [f"s = {v:g}" for v in scales])
    ax.set_ylabel("measured / predicted step (growth ≤ 1e8 over horizon)")
    ax.set_title("measured boundary over the linearized prediction")
    ax.legend(fontsize=8)
    if ax_gradient is not None:
        ax = ax_gradient
        k = [r["periods"] for r in g["rows"]]
        ax.semilogy(k, [r["grad_norm_N"] for r in g["rows"]], "o-", label="|∂P/∂u| (AD)")
        fd = [(r["periods"], abs(r["fd_N"]["0.0001"])) for r in g["rows"] if "fd_N" in r]
        ad = [(r["periods"], abs(r["ad_along_direction_N"])) for r in g["rows"] if "fd_N" in r]
        if fd:
            fd3 = [(r["periods"], abs(r["fd_N"]["0.001"])) for r in g["rows"] if "fd_N" in r]
            ax.semilogy(*zip(*ad, strict=True), "s", mfc="none", label="|AD| along e_i")
            ax.semilogy(*zip(*fd, strict=True), "x", color="k", label="|central FD|, ε = 1e-4")
            ax.semilogy(
                *zip(*fd3, strict=True), "+", color="tab:red", label="|central FD|, ε = 1e-3"
            )
        ax.set_xlabel("horizon [tooth periods] (window: the last period)")
        ax.set_ylabel("gradient [N per unit u]")
        ax.set_title(f"soft-peak gradient vs horizon (fixed dt = {g['dt'] * 1e6:.0f} µs)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


if __name__ == "__main__":
    main()
