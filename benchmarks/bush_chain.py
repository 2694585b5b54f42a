"""Roller chain against bush chain of the same pitch (ISO 606 06B and 06C, 9.525 mm): the
bush chain has no roller, so its bush slides on the tooth (Dahl friction, μ = 0.1, the
builders' default for bush chains) where the roller rolls.

1. Lumped drive, 18/36 teeth, 10 N·m on the driven sprocket, 200 N pretension, at 500,
   1000 and 2000 rpm, over the driver's second and third revolutions: the efficiency
   (load work over driver work), the power lost at the teeth and in the joints (as
   fractions of the driver's work), and the mesh-order lines of the driven sprocket's
   speed and of the tight span's tension (amplitude at z1 × the driver's frequency).
2. Clearance-joint chain, an 18-tooth sprocket meshing a strand at 1000 N and 1000 rpm:
   the distribution of the per-engagement meshing peaks (mean, p95, 95 % intervals) and
   their difference, bush − roller.

    python -m benchmarks.bush_chain            # ~15 min on 2 cores
    python -m benchmarks.bush_chain --quick    # one speed, 6 engagements
"""

from __future__ import annotations

import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402

CHAINS = {"roller (06B)": "06B", "bush (06C)": "06C"}
TEETH = (18, 36)
LOAD, PRETENSION = 10.0, 200.0  # N·m, N
SPEEDS = (500.0, 1000.0, 2000.0)  # rpm
REVS = (1.0, 3.0)  # the measured window, driver revolutions
SAVES_PER_TOOTH = 24
TENSION, RPM_MESH, DISCARD = 1000.0, 1000.0, 2  # the engagement strand


class Losses(jc.observers.AbstractIntegralObserver):
    """∫ over t ≥ ``start`` of: the driver's power, the load's, and the power lost to the
    joints' and the teeth's friction [J] (4,)."""

    start: jax.Array

    def integrand(self, t, y, scene, forces):
        drive = -forces.sprocket_torque[0] * y.omega[0]
        load = scene.sprockets[1].load(t, y.theta[1], y.omega[1]) * y.omega[1]
        lost = jnp.stack([-forces.joint_friction_power, -forces.tooth_friction_power])
        return jnp.where(t >= self.start, jnp.concatenate([jnp.stack([drive, load]), lost]), 0.0)

    def value(self, state, t0, t1):
        return state


def _line(t, x, freq):
    """Amplitude of the component at ``freq`` [Hz] of samples ``x`` at times ``t`` (a
    whole number of its periods; mean removed)."""
    x = x - x.mean()
    w = 2 * np.pi * freq * t
    return float(2 * np.hypot(np.mean(x * np.cos(w)), np.mean(x * np.sin(w))))


def drive_row(chain: str, rpm: float) -> dict:
    scene = jc.scenes.drive(
        chain, teeth=TEETH, speed_rpm=rpm, load_torque=LOAD, pretension=PRETENSION
    )
    rev = 60.0 / rpm
    t1 = REVS[1] * rev
    n_save = int(REVS[1] * TEETH[0] * SAVES_PER_TOOTH) + 1
    t = time.perf_counter()
    sol = jc.simulate(
        scene,
        t1,
        n_save=n_save,
        observers=(Losses(jnp.asarray(REVS[0] * rev)),),
        max_steps=int(t1 / 1e-6),  # steps of ~2 µs: room for twice as many
    )
    wall = time.perf_counter() - t
    drive, load, joints, teeth = (float(v) for v in sol.observed[0])
    ts = np.asarray(sol.ts)
    win = (ts >= REVS[0] * rev) & (ts < t1 - 0.5 * (ts[1] - ts[0]))
    mesh = TEETH[0] / rev  # Hz
    speed = np.asarray(sol.sprocket_speed)[win, 1]
    tight = np.asarray(sol.span_tension)[win, 0]
    return {
        "chain": chain,
        "rpm": rpm,
        "ok": bool(sol.ok),
        "message": sol.message,
        "efficiency": load / drive,
        "teeth_loss": teeth / drive,
        "joint_loss": joints / drive,
        "speed_mesh_line_pct": 100 * _line(ts[win], speed, mesh) / float(np.mean(speed)),
        "tension_mesh_line_N": _line(ts[win], tight, mesh),
        "mean_tight_tension_N": float(np.mean(tight)),
        "wall_s": wall,
    }


def engagement_peaks(chain: str, engagements: int) -> dict:
    n_entry = engagements + DISCARD + 1
    scene = jc.scenes.engagement(
        chain, TEETH[0], speed_rpm=RPM_MESH, tension=TENSION, fidelity="clearance",
        n_entry=n_entry,
    )  # fmt: skip
    period = 60.0 / (RPM_MESH * TEETH[0])
    obs = jc.observers.EngagementPeaks.for_solve(scene, n_entry * period)
    t = time.perf_counter()
    sol = jc.simulate(
        scene, n_entry * period, n_save=2, observers=(obs,), max_steps=25_000 * n_entry
    )  # a step budget of 25 k per tooth period (the clearance chain takes ~5 k)
    ev = jc.engagement_peaks(sol, t_start=DISCARD * period)
    st = jc.peak_statistics(ev)
    return {
        "chain": chain,
        "ok": bool(sol.ok),
        "peaks_N": ev.peak.tolist(),
        "mean_N": st.mean,
        "p95_N": st.p95,
        "ci95_N": [st.ci_low, st.ci_high],
        "wall_s": time.perf_counter() - t,
    }


def chart(res: dict, path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 4), dpi=120)
    every = np.concatenate([p["peaks_N"] for p in res["peaks"]])
    bins = np.linspace(every.min(), every.max(), 16)  # one set of bins for both chains
    for name, chain in CHAINS.items():
        rows = [r for r in res["drive"] if r["chain"] == chain]
        rpm = [r["rpm"] for r in rows]
        ax[0].plot(rpm, [100 * r["teeth_loss"] for r in rows], "o-", label=f"{name}: teeth")
        ax[0].plot(rpm, [100 * r["joint_loss"] for r in rows], "s--", label=f"{name}: joints")
        ax[1].plot(rpm, [r["tension_mesh_line_N"] for r in rows], "o-", label=name)
        peaks = next(p for p in res["peaks"] if p["chain"] == chain)["peaks_N"]
        ax[2].hist(peaks, bins=bins, alpha=0.6, label=name)
    ax[0].set(xlabel="driver speed [rpm]", ylabel="power lost [% of driver work]")
    ax[0].set_title("friction losses, lumped drive 18/36", fontsize=10)
    ax[1].set(xlabel="driver speed [rpm]", ylabel="tight-span tension at mesh order [N]")
    ax[1].set_title("mesh-order tension line", fontsize=10)
    ax[2].set(xlabel="meshing peak [N]", ylabel="engagements")
    ax[2].set_title(f"clearance chain, {RPM_MESH:g} rpm, {TENSION:g} N", fontsize=10)
    for a in ax:
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    save_chart(fig, res, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--engagements", type=int, default=48)
    args = parse(ap, argv)
    speeds = (1000.0,) if args.quick else SPEEDS
    engagements = 6 if args.quick else args.engagements
    start = time.perf_counter()
    res = header("bush_chain", argv)
    res["drive"] = [drive_row(c, rpm) for c in CHAINS.values() for rpm in speeds]
    for r in res["drive"]:
        print(
            f"{r['chain']} {r['rpm']:5.0f} rpm: efficiency {100 * r['efficiency']:.2f} %, "
            f"teeth {100 * r['teeth_loss']:.3f} %, joints {100 * r['joint_loss']:.3f} %, "
            f"speed line {r['speed_mesh_line_pct']:.3f} %, tension line "
            f"{r['tension_mesh_line_N']:.1f} N ({r['wall_s']:.0f} s)"
        )
    res["peaks"] = [engagement_peaks(c, engagements) for c in CHAINS.values()]
    for p in res["peaks"]:
        print(
            f"{p['chain']} meshing peaks: mean {p['mean_N']:.0f} N "
            f"[{p['ci95_N'][0]:.0f}, {p['ci95_N'][1]:.0f}], p95 {p['p95_N']:.0f} N "
            f"({len(p['peaks_N'])} engagements, {p['wall_s']:.0f} s)"
        )
    roller, bush = (p["peaks_N"] for p in res["peaks"])
    c = jc.compare_peaks(roller, bush)
    res["bush_minus_roller"] = {k: v for k, v in c._asdict().items() if k not in ("a", "b")}
    print(
        f"bush − roller: mean {c.difference:+.0f} N ({100 * c.relative:+.1f} %) "
        f"[{c.ci_low:+.0f}, {c.ci_high:+.0f}], p95 {c.p95_difference:+.0f} N "
        f"[{c.p95_ci_low:+.0f}, {c.p95_ci_high:+.0f}]"
    )
    return finish(res, args.out, "bush_chain", chart, start)


if __name__ == "__main__":
    main()
