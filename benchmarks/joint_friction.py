"""Joint friction in the clearance-joint chain: where its stiffness comes from, what the
Dahl (pre-sliding state) law costs against frictionless joints, and that it carries the
same physics as the velocity-regularized Coulomb law.

    python -m benchmarks.joint_friction            # full study (~40 min on 2 cores)
    python -m benchmarks.joint_friction --quick    # smoke run

Writes ``benchmarks/results/joint_friction.json`` and ``joint_friction.png``.

Three parts, all on the 08B chain meshing an 18-tooth driver under 1000 N
(``jc.scenes.engagement(..., fidelity="clearance")``, settled start, Tsit5 at
``simulate``'s default tolerances) and, for the cost, also on a closed 18/36 drive:

* **stiffness** — the eigenvalues of the vector field's Jacobian at the settled start,
  frictionless, with the velocity-regularized law (μ = 0.1, v_s = 2 mm/s,
  ``jc.scenes.JOINT_FRICTION``) and with the Dahl law (``CLEARANCE_JOINT_FRICTION``); the
  most negative one against the closed form of a roller sliding in its bush,
  λ = (μ·N/v_s)·(1/m + r²/J) summed over the two bodies of the contact.
* **cost** — steps and wall time (a second, compiled call) over two tooth periods, per
  law, from 100 to 3000 rpm on the strand and 300 to 3000 rpm on the closed drive; the
  velocity-regularized law is given a budget (``--budget`` steps, every law the same)
  and reported as not finished past it.
* **physics** — at 1250 rpm over ``--periods`` tooth periods (the first two discarded):
  the entry span's mean tension, the power lost in the joints (∫ Σ F_t·v_t dt over the
  window, an integral observer) and the per-engagement peak roller/tooth force (mean and
  95 % confidence interval), the velocity-regularized law against the Dahl law at
  pre-sliding displacements of 2, 5 and 10 µm.
"""

from __future__ import annotations

import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from jax.flatten_util import ravel_pytree  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402

CHAIN, TEETH, TENSION = "08B", 18, 1000.0
DAHL = jc.scenes.CLEARANCE_JOINT_FRICTION
TANH = jc.scenes.JOINT_FRICTION


def period(rpm: float) -> float:
    return 60.0 / (TEETH * rpm)


def strand(rpm: float, law, n_entry: int = 8):
    return jc.scenes.engagement(
        CHAIN,
        TEETH,
        speed_rpm=rpm,
        tension=TENSION,
        fidelity="clearance",
        n_entry=n_entry,
        model=jc.scenes.ChainModel(joint_friction=law),
    )


def drive(rpm: float, law):
    return jc.scenes.drive(
        CHAIN,
        teeth=(TEETH, 2 * TEETH),
        n_links=60,
        speed_rpm=rpm,
        load_torque=20.0,
        pretension=300.0,
        fidelity="clearance",
        model=jc.scenes.ChainModel(joint_friction=law),
    )


def laws(x_s=(5e-6,)) -> dict:
    out = {"frictionless": None, "tanh (v_s 2 mm/s)": TANH}
    for x in x_s:
        name = "Dahl" if x == DAHL.presliding else f"Dahl x_s {x * 1e6:g} µm"
        out[name] = jc.contact.DahlFriction(
            coefficient=DAHL.coefficient, presliding=x, creep_velocity=DAHL.creep_velocity,
            damping=DAHL.damping,
        )  # fmt: skip
    return out


# ------------------------------------------------------------------------------ stiffness
def stiffness(rpm: float = 1250.0) -> dict:
    out = {}
    for name, law in laws().items():
        sc = strand(rpm, law)
        y = jc.initial_state(sc)
        flat, unravel = ravel_pytree(y)
        field = lambda x, sc=sc, unravel=unravel: ravel_pytree(  # noqa: E731
            jc.vector_field(0.0, unravel(x), sc)
        )[0]
        ev = np.linalg.eigvals(np.asarray(jax.jacfwd(field)(flat)))
        out[name] = {
            "most_negative_real_per_s": float(ev.real.min()),
            "largest_modulus_per_s": float(np.abs(ev).max()),
        }
    # closed form: the most loaded bush/roller joint, its roller and roller link
    ch = jc.ChainSpec.iso606(CHAIN)
    sc = strand(rpm, None)
    y = jc.initial_state(sc)
    grp = sc.pairs[1]  # bush (a point of the roller link) / roller (its body's origin)
    c, s = jnp.cos(y.q[grp.a, 2]), jnp.sin(y.q[grp.a, 2])
    ra = grp.ra
    xa = y.q[grp.a, :2] + jnp.stack([c * ra[:, 0] - s * ra[:, 1], s * ra[:, 0] + c * ra[:, 1]], -1)
    xb = y.q[grp.b, :2]
    load = grp.element.tension(jnp.linalg.norm(xb - xa, axis=-1), 0.0, sc.impact_speed)
    n_max = float(load.max())
    r_hole = float(grp.element.radius + grp.element.clearance)
    inv = 1 / ch.roller_mass + r_hole**2 / ch.roller_inertia
    inv += 1 / ch.roller_link_mass + (ch.pitch / 2) ** 2 / ch.roller_link_inertia
    out["closed_form"] = {
        "joint_load_N": n_max,
        "lambda_per_s": -TANH.coefficient * n_max / TANH.slip_velocity * inv,
        "formula": "-(mu N / v_s)(1/m_r + r_h^2/J_r + 1/m_link + (p/2)^2/J_link)",
    }
    return out


# ----------------------------------------------------------------------------------- cost
def timed(sc, t1, max_steps):
    run = lambda: jc.simulate(sc, t1, n_save=2, throw=False, max_steps=max_steps)  # noqa: E731
    t = time.perf_counter()
    sol = run()
    jax.block_until_ready(sol.peak_contact_force)
    if sol.ok:  # time a second, compiled call (a failed one: the first, compile included)
        t = time.perf_counter()
        sol = run()
        jax.block_until_ready(sol.peak_contact_force)
    return {
        "ok": bool(sol.ok),
        "result": jc.result_names(sol.result)[0] if not sol.ok else "successful",
        "steps": int(sol.stats["num_steps"]),
        "wall_s": time.perf_counter() - t,  # compile included where not ok
        "peak_N": float(sol.peak_contact_force),
    }


def cost(speeds, drive_speeds, budget, periods=2.0) -> dict:
    out = {"strand": {}, "drive": {}}
    for kind, rpms, build in (("strand", speeds, strand), ("drive", drive_speeds, drive)):
        for rpm in rpms:
            row = {}
            for name, law in laws().items():
                row[name] = timed(build(rpm, law), periods * period(rpm), budget)
                print(f"  {kind} {rpm:6.0f} rpm {name:20s} {row[name]}", flush=True)
            base = row["frictionless"]
            for r in row.values():
                r["steps_ratio"] = r["steps"] / base["steps"]
                r["time_ratio"] = r["wall_s"] / base["wall_s"]
            out[kind][f"{rpm:g}"] = row
    return out


# -------------------------------------------------------------------------------- physics
class JointLoss(jc.observers.AbstractIntegralObserver):
    """∫ power of the joints' friction dt [J] after ``t_start`` (negative: power lost)."""

    t_start: float

    def integrand(self, t, y, scene, forces):
        return jnp.where(t >= self.t_start, forces.joint_friction_power, 0.0)

    def value(self, state, t0, t1):
        return state


def physics(rpm: float, periods: int, x_s, save_dt: float = 1e-6) -> dict:
    per = period(rpm)
    t1 = periods * per
    t_start = 2 * per
    ts = np.linspace(0.0, t1, int(round(t1 / save_dt)) + 1)
    out = {}
    for name, law in laws(x_s).items():
        sc = strand(rpm, law, n_entry=periods)
        t = time.perf_counter()
        sol = jc.simulate(
            sc, t1, ts=ts, throw=False, max_steps=4_000_000, observers=(JointLoss(t_start),)
        )
        wall = time.perf_counter() - t
        f = np.asarray(sol.roller_sprocket_force).max(axis=1)
        peaks = [float(f[(ts >= k * per) & (ts < (k + 1) * per)].max()) for k in range(2, periods)]
        tension = np.asarray(sol.link_tension)[ts >= t_start, 0]
        loss = float(sol.observed[0])
        n = len(peaks)
        mean, sd = float(np.mean(peaks)), float(np.std(peaks, ddof=1))
        half = 1.96 * sd / math.sqrt(n)
        out[name] = {
            "ok": bool(sol.ok),
            "steps": int(sol.stats["num_steps"]),
            "wall_s_with_compile": wall,
            "entry_span_mean_tension_N": float(tension.mean()),
            "joint_power_lost_W": -loss / (t1 - t_start),
            "engagement_peaks_N": peaks,
            "peak_mean_N": mean,
            "peak_ci95_N": [mean - half, mean + half],
        }
        print(
            f"  {name:20s} steps {out[name]['steps']:8d} tension "
            f"{out[name]['entry_span_mean_tension_N']:.1f} N, joints lose "
            f"{out[name]['joint_power_lost_W']:.2f} W, peaks {mean:.0f} ± {half:.0f} N (n={n})",
            flush=True,
        )
    return out


# ---------------------------------------------------------------------------------- chart
def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    for kind, style in (("strand", "-"), ("drive", "--")):
        rows = results["cost"][kind]
        rpms = [float(k) for k in rows]
        for name, colour in (("Dahl", "C0"), ("tanh (v_s 2 mm/s)", "C3")):
            ratio = [rows[k][name]["steps_ratio"] if rows[k][name]["ok"] else np.nan for k in rows]
            ax[0].plot(rpms, ratio, style, marker="o", color=colour, label=f"{name}, {kind}")
    ax[0].axhline(2.0, color="k", lw=0.8, ls=":")
    ax[0].set_xscale("log")
    ax[0].set_yscale("log")
    ax[0].set_xlabel("driver speed [rpm]")
    ax[0].set_ylabel("steps / frictionless steps (2 tooth periods)")
    ax[0].set_title("cost of joint friction (dotted: 2×)")
    ax[0].legend(fontsize=7)

    st = results["stiffness"]
    names = [k for k in st if k != "closed_form"]
    ax[1].bar(names, [-st[k]["most_negative_real_per_s"] for k in names], color="C2")
    ax[1].axhline(-st["closed_form"]["lambda_per_s"], color="k", ls=":", label="closed form")
    ax[1].set_yscale("log")
    ax[1].set_ylabel("−min Re λ of the Jacobian [1/s]")
    ax[1].set_title("stiffest eigenvalue at the settled start")
    ax[1].legend(fontsize=7)
    ax[1].tick_params(axis="x", labelsize=7)

    ph = results["physics"]
    names = list(ph)
    for i, k in enumerate(names):
        pk = ph[k]["engagement_peaks_N"]
        ax[2].plot(np.full(len(pk), i), pk, ".", color="0.6")
        lo, hi = ph[k]["peak_ci95_N"]
        ax[2].errorbar(i, ph[k]["peak_mean_N"], yerr=[[ph[k]["peak_mean_N"] - lo]], fmt="o",
                       color="C0", capsize=4)  # fmt: skip
    ax[2].set_xticks(range(len(names)), names, fontsize=7, rotation=20)
    ax[2].set_ylabel("peak roller/tooth force per engagement [N]")
    ax[2].set_title(f"{results['physics_rpm']:g} rpm: peaks, mean ± 95 % CI")
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--budget", type=int, default=400_000, help="step budget of the tanh law")
    ap.add_argument("--periods", type=int, default=22, help="tooth periods of the physics part")
    args = parse(ap, argv)
    start = time.perf_counter()
    results = header("joint_friction", argv)
    if args.quick:
        speeds, drive_speeds, periods, x_s, budget = (1000.0,), (), 4, (5e-6,), 100_000
    else:
        speeds, drive_speeds = (100.0, 300.0, 1000.0, 3000.0), (300.0, 1000.0, 3000.0)
        periods, x_s, budget = args.periods, (2e-6, 5e-6, 10e-6), args.budget
    print("stiffness", flush=True)
    results["stiffness"] = stiffness()
    print(results["stiffness"], flush=True)
    print("cost", flush=True)
    results["cost"] = cost(speeds, drive_speeds, budget)
    results["physics_rpm"] = 1250.0
    print("physics", flush=True)
    results["physics"] = physics(1250.0, periods, x_s)
    return finish(results, args.out, "joint_friction", chart, start)


if __name__ == "__main__":
    main()
