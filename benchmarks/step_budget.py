"""What sets a lumped drive's step: the error control's components, the stiffest link mode
and the joints' friction, measured.

1. At the state after two tooth periods of the 08B 18/36 and 06B 21/42 drives (1000 rpm,
   20 N·m, 200 N pretension, ``simulate``'s defaults: Tsit5, rtol 1e-6, atol 1e-9, max
   norm), the largest step the error control accepts and, at that step, each state
   field's scaled error (|error| / (atol + rtol·|y|), 1 = the limit); beside it the
   explicit limit of the stiffest link mode (2.8/√(4k/m)).
2. Steps over three tooth periods with each field's error counted in full, and with the
   velocities' error weighted 1e-3 (what the step would be if velocities did not set it),
   for the default joint friction (μ 0.1 regularized over 2 mm/s), a band of 2 cm/s, and
   frictionless joints.
3. Accuracy for the step budget (08B): the peak contact force, the driven speed and the
   span tensions against an rtol 1e-10 solve, for a looser rtol against a smaller weight
   on the velocities' error.

    python -m benchmarks.step_budget            # ~3 min on 2 cores
"""

from __future__ import annotations

import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import optimistix as optx  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402

DRIVES = {"08B 18/36": ("08B", (18, 36)), "06B 21/42": ("06B", (21, 42))}
RPM, LOAD, PRETENSION = 1000.0, 20.0, 200.0
RTOL, ATOL = 1e-6, 1e-9  # simulate's defaults
FRICTION = {
    "default (2 mm/s)": "default",
    "2 cm/s band": jc.contact.CoulombFriction(0.1, slip_velocity=2e-2),
    "frictionless": None,
}


def scene(name, joint_friction="default"):
    chain, teeth = DRIVES[name]
    return jc.scenes.drive(
        chain,
        teeth=teeth,
        speed_rpm=RPM,
        load_torque=LOAD,
        pretension=PRETENSION,
        model=jc.scenes.ChainModel(joint_friction=joint_friction),
    )


def period(name) -> float:
    return 60.0 / (RPM * DRIVES[name][1][0])


def weighted(w: float):
    """The max norm with the velocities' scaled error weighted by ``w``."""

    def norm(x):
        if isinstance(x, jc.DriveState):
            parts = [x.q, w * x.v, x.theta, x.omega, x.dof, x.bristle]
            return jnp.max(jnp.stack([optx.max_norm(p) for p in parts if p is not None]))
        return optx.max_norm(x)

    return norm


def controller(rtol=RTOL, w=1.0):
    norm = optx.max_norm if w == 1.0 else weighted(w)
    return diffrax.PIDController(rtol=rtol, atol=rtol * 1e-3, norm=norm, pcoeff=0.2, icoeff=0.4)


def error_fields(name) -> dict:
    sc = scene(name)
    sol = jc.simulate(sc, 2 * period(name), n_save=2)
    y0, term, solver = sol.y1, diffrax.ODETerm(jc.vector_field), diffrax.Tsit5()

    @jax.jit
    def scaled(dt):
        st = solver.init(term, 0.0, dt, y0, sc)
        y1, err, _, _, _ = solver.step(term, 0.0, dt, y0, sc, st, made_jump=False)
        return jax.tree.map(
            lambda e, a, b: jnp.abs(e) / (ATOL + RTOL * jnp.maximum(jnp.abs(a), jnp.abs(b))),
            err, y0, y1,
        )  # fmt: skip

    lo, hi = 1e-9, 1e-4  # the largest step whose max-norm error is at most 1
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        worst = max(float(jnp.max(x)) for x in jax.tree.leaves(scaled(mid)))
        lo, hi = (mid, hi) if worst <= 1.0 else (lo, mid)
    s = scaled(lo)
    fields = {"positions": s.q[:, :2], "velocities": s.v[:, :2], "sprocket angles": s.theta}
    fields["sprocket speeds"] = s.omega
    k = float(jnp.max(sc.pairs[0].element.stiffness))
    m = float(jnp.min(sc.mass))
    return {
        "drive": name,
        "accepted_dt_us": lo * 1e6,
        "mean_dt_us": 2 * period(name) / int(sol.stats["num_accepted_steps"]) * 1e6,
        "link_mode_limit_us": 2.8 / math.sqrt(4 * k / m) * 1e6,
        "scaled_error": {f: float(jnp.max(v)) for f, v in fields.items()},
    }


def steps(name, friction, w) -> dict:
    sol = jc.simulate(
        scene(name, friction), 3 * period(name), n_save=2, stepsize_controller=controller(w=w)
    )
    n = int(sol.stats["num_accepted_steps"])
    return {"steps": n, "rejected": int(sol.stats["num_rejected_steps"]),
            "mean_dt_us": 3 * period(name) / n * 1e6}  # fmt: skip


def accuracy(rtol, w, ref) -> dict:
    sc = scene("08B 18/36")
    t1 = 3 * period("08B 18/36")
    args = dict(n_save=201, stepsize_controller=controller(rtol, w), max_steps=2_000_000)
    jc.simulate(sc, t1, **args)  # compiled
    t = time.perf_counter()
    sol = jc.simulate(sc, t1, **args)
    wall = time.perf_counter() - t
    speed = np.asarray(sol.sprocket_speed)[:, 1]
    ref_speed = np.asarray(ref.sprocket_speed)[:, 1]
    return {
        "rtol": rtol,
        "velocity_weight": w,
        "steps": int(sol.stats["num_accepted_steps"]),
        "warm_s": wall,
        "peak_error_pct": 100 * (float(sol.peak_contact_force) / float(ref.peak_contact_force) - 1),
        "speed_error": float(np.max(np.abs(speed - ref_speed)) / np.mean(ref_speed)),
        "tension_error_N": float(np.max(np.abs(sol.span_tension - ref.span_tension))),
    }


def chart(res: dict, path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.2), dpi=120)
    rows = res["steps"]
    labels = [f"{r['friction']}\n{r['drive']}" for r in rows if r["velocity_weight"] == 1.0]
    x = np.arange(len(labels))
    for i, w in enumerate((1.0, 1e-3)):
        dt = [r["mean_dt_us"] for r in rows if r["velocity_weight"] == w]
        ax[0].bar(x + (i - 0.5) * 0.38, dt, 0.38, label=f"velocities' error × {w:g}")
    lim = {r["drive"]: r["link_mode_limit_us"] for r in res["errors"]}
    for j, r in enumerate(r for r in rows if r["velocity_weight"] == 1.0):
        ax[0].plot([j - 0.4, j + 0.4], [lim[r["drive"]]] * 2, "k:", lw=1)
    ax[0].set_xticks(x, labels, fontsize=7)
    ax[0].set_ylabel("mean step [µs]")
    ax[0].set_title("steps over 3 tooth periods (dotted: stiffest link mode)", fontsize=10)
    ax[0].legend(fontsize=8)
    for w, mark in ((1.0, "o-"), (0.1, "s--"), (0.01, "^:")):
        pts = [a for a in res["accuracy"] if a["velocity_weight"] == w]
        ax[1].plot([a["steps"] for a in pts], [abs(a["tension_error_N"]) for a in pts], mark,
                   label=f"velocity weight {w:g}")  # fmt: skip
    ax[1].set(xlabel="steps over 3 tooth periods", ylabel="largest span tension error [N]")
    ax[1].set_title("08B 18/36: accuracy against steps", fontsize=10)
    ax[1].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    save_chart(fig, res, path)


def main(argv=None) -> dict:
    args = parse(parser(__doc__), argv)
    start = time.perf_counter()
    res = header("step_budget", argv)
    res["errors"] = [error_fields(name) for name in DRIVES]
    for e in res["errors"]:
        errs = ", ".join(f"{k} {v:.2g}" for k, v in e["scaled_error"].items())
        print(
            f"{e['drive']}: accepted step {e['accepted_dt_us']:.2f} µs (mean "
            f"{e['mean_dt_us']:.2f}), link-mode limit {e['link_mode_limit_us']:.1f} µs; "
            f"scaled errors: {errs}"
        )
    drives = list(DRIVES)[:1] if args.quick else list(DRIVES)
    res["steps"] = [
        {"drive": d, "friction": f, "velocity_weight": w} | steps(d, law, w)
        for d in drives for f, law in FRICTION.items() for w in (1.0, 1e-3)
    ]  # fmt: skip
    for r in res["steps"]:
        print(f"{r['drive']} {r['friction']:17s} × {r['velocity_weight']:g}: "
              f"{r['steps']} steps, mean {r['mean_dt_us']:.2f} µs")  # fmt: skip
    sc = scene("08B 18/36")
    ref = jc.simulate(
        sc, 3 * period("08B 18/36"), n_save=201, stepsize_controller=controller(1e-10),
        max_steps=2_000_000,
    )  # fmt: skip
    grid = [(r, 1.0) for r in (1e-6, 3e-6, 1e-5, 3e-5)] + [(1e-6, w) for w in (0.1, 0.01)]
    res["accuracy"] = [accuracy(r, w, ref) for r, w in ([] if args.quick else grid)]
    for a in res["accuracy"]:
        print(
            f"rtol {a['rtol']:g} × {a['velocity_weight']:g}: {a['steps']} steps, peak "
            f"{a['peak_error_pct']:+.3f} %, speed {a['speed_error']:.1e}, tension "
            f"{a['tension_error_N']:.2f} N"
        )
    return finish(res, args.out, "step_budget", chart, start)


if __name__ == "__main__":
    main()
