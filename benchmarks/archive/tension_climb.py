"""The closed drive's tension climb: what joint friction changes.

    python -m benchmarks.archive.tension_climb            # full study (~8 min on 2 cores)
    python -m benchmarks.archive.tension_climb --quick    # smoke run (CI-sized)

Writes ``benchmarks/archive/results/tension_climb.json`` and ``tension_climb.png``.

The drive is ``jc.scenes.drive("10A", (13, 26), n_links=60, speed_rpm=600,
load_torque=30, pretension=300)``, lumped, settled, Tsit5 at rtol 1e-6. Its independent
anchors are the statics: at rest the spans' mean tension is the pretension and the tight
and slack spans differ by the load torque over the driven pitch radius; in motion the
mean driven speed is the driver's times z1/z2.

Measured, with frictionless joints and with the default joint friction
(``jc.scenes.JOINT_FRICTION``, μ = 0.1):

* the history over two driver revolutions: mean link tension, tight- and slack-span
  tension, driven speed;
* per run, over the last driver revolution: tight- and slack-span tension, mean and
  largest link tension, the driven speed's mean against the closed-form ratio and its
  swing, steps and wall time;
* a sweep of the friction coefficient at the nominal speed (any friction removes the
  climb, or only enough of it?);
* a sweep of the driver speed, with and without friction (does the climb scale with the
  speed, as a kinematic excitation of the spans would?).
"""

from __future__ import annotations

import datetime
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import ARCHIVE, finish, machine_info, parse, parser  # noqa: E402

SCENE = dict(chain="10A", teeth=(13, 26), n_links=60, load_torque=30.0, pretension=300.0)
NOMINAL_RPM = 600.0
SAVES_PER_REV = 400


def build(speed_rpm: float, mu: float | None):
    friction = (
        None
        if mu is None
        else jc.contact.CoulombFriction(mu, jc.scenes.JOINT_FRICTION.slip_velocity)
    )
    return jc.scenes.drive(
        **SCENE, speed_rpm=speed_rpm, model=jc.scenes.ChainModel(joint_friction=friction)
    )


def spans(sol, scene) -> tuple[np.ndarray, np.ndarray]:
    """Mean tension of the links in the tight (upper) and the slack (lower) span at every
    save: the links whose roller lies between the driver's pitch circle and the driven
    wrap's leftmost point."""
    x = np.asarray(sol.roller_position)  # (T, R, 2); link k starts at roller k
    tension = np.asarray(sol.link_tension)
    r1 = float(scene.sprockets[0].profile.pitch_radius)
    r2 = float(scene.sprockets[1].profile.pitch_radius)
    c2 = float(scene.sprockets[1].centre[0])
    span = (x[..., 0] > r1) & (x[..., 0] < c2 - r2)
    top, bottom = span & (x[..., 1] > 0), span & (x[..., 1] < 0)
    mean = lambda m: np.sum(tension * m, axis=1) / np.maximum(m.sum(axis=1), 1)
    return mean(top), mean(bottom)


def statics(tight0: float, slack0: float) -> dict:
    """Closed-form span tensions against the settled layout's (t = 0)."""
    z1, z2 = SCENE["teeth"]
    r2 = jc.ChainSpec.iso606(SCENE["chain"]).pitch / (2 * np.sin(np.pi / z2))
    return {
        "pretension_N": SCENE["pretension"],
        "load_over_driven_radius_N": SCENE["load_torque"] / r2,
        "settled_tight_N": tight0,
        "settled_slack_N": slack0,
        "settled_span_mean_N": 0.5 * (tight0 + slack0),
        "settled_difference_N": tight0 - slack0,
        "speed_ratio": z1 / z2,
    }


def run(speed_rpm: float, mu: float | None, revs: float) -> tuple[dict, dict]:
    """One solve over ``revs`` driver revolutions: its row of figures (over the last
    revolution) and its history."""
    scene = build(speed_rpm, mu)
    rev = 60.0 / speed_rpm
    n_save = int(SAVES_PER_REV * revs) + 1
    t = time.perf_counter()
    sol = jc.simulate(scene, revs * rev, n_save=n_save, throw=False)
    tension = np.asarray(sol.link_tension)
    wall = time.perf_counter() - t
    tight, slack = spans(sol, scene)
    ts = np.asarray(sol.ts)
    last = ts >= ts[-1] - min(rev, ts[-1] / 2)
    omega = np.asarray(sol.sprocket_speed)
    ratio = omega[last, 1].mean() / omega[last, 0].mean()
    row = {
        "speed_rpm": speed_rpm,
        "mu": mu,
        "revolutions": revs,
        "result": sol.message or "successful",
        "steps": int(sol.stats["num_steps"]),
        "wall_s": wall,
        "mean_tension_N": float(tension[last].mean()),
        "max_tension_N": float(tension[last].max()),
        "min_tension_N": float(tension[last].min()),
        "tight_span_N": float(tight[last].mean()),
        "slack_span_N": float(slack[last].mean()),
        "span_mean_N": float(0.5 * (tight[last].mean() + slack[last].mean())),
        "speed_ratio": float(ratio),
        "driven_speed_swing": float(np.ptp(omega[last, 1]) / omega[last, 1].mean()),
    }
    print(
        f"  {speed_rpm:6.0f} rpm  μ = {'none' if mu is None else mu:<5}  links: mean "
        f"{row['mean_tension_N']:6.0f} N  max {row['max_tension_N']:6.0f} N  spans "
        f"{row['tight_span_N']:5.0f} / {row['slack_span_N']:4.0f} N  ratio "
        f"{row['speed_ratio']:.4f}  swing {row['driven_speed_swing']:.1%}  "
        f"{row['steps']:6d} steps  {wall:5.1f} s",
        flush=True,
    )
    history = {
        "t_rev": (ts / rev).tolist(),
        "mean_N": tension.mean(axis=1).tolist(),
        "max_N": tension.max(axis=1).tolist(),
        "min_N": tension.min(axis=1).tolist(),
        "tight_N": tight.tolist(),
        "slack_N": slack.tolist(),
        "settled_spans_N": [float(tight[0]), float(slack[0])],
        "driven_over_nominal": (
            omega[:, 1] / (omega[0, 0] * SCENE["teeth"][0] / SCENE["teeth"][1])
        ).tolist(),
    }
    return row, history


def chart(res: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 7.5))
    colours = {"frictionless": "tab:red", "friction": "tab:blue"}
    for key, h in res["history"].items():
        c = colours[key]
        ax[0, 0].plot(h["t_rev"], h["tight_N"], c, lw=1, label=f"{key}: tight span")
        ax[0, 0].plot(h["t_rev"], h["slack_N"], c, lw=1, ls="--", label=f"{key}: slack span")
        ax[1, 0].plot(h["t_rev"], h["driven_over_nominal"], c, lw=0.8, label=key)
    s = res["statics"]
    for v in (s["settled_tight_N"], s["settled_slack_N"]):
        ax[0, 0].axhline(v, color="k", lw=0.6)
    ax[0, 0].set(
        xlabel="driver revolutions",
        ylabel="mean link tension in the span [N]",
        title="span tensions (thin black: the settled statics)",
    )
    ax[0, 0].legend(fontsize=8)
    ax[1, 0].axhline(1.0, color="k", ls="--", lw=0.8)
    ax[1, 0].set(
        xlabel="driver revolutions",
        ylabel="driven speed / (z1/z2 · driver speed)",
        title="driven speed",
    )
    ax[1, 0].legend(fontsize=8)
    mu = res["mu_sweep"]
    xs = [r["mu"] if r["mu"] else 1e-4 for r in mu]
    ax[0, 1].semilogx(xs, [r["span_mean_N"] for r in mu], "o-", label="spans' mean")
    ax[0, 1].semilogx(xs, [r["tight_span_N"] for r in mu], "^-", label="tight span")
    ax[0, 1].semilogx(xs, [r["max_tension_N"] for r in mu], "s--", label="largest link")
    ax[0, 1].axhline(s["settled_span_mean_N"], color="k", ls="--", lw=0.8)
    ax[0, 1].set(
        xlabel="joint friction coefficient μ (frictionless plotted at 1e-4)",
        ylabel="link tension, last revolution [N]",
        title=f"friction sweep at {NOMINAL_RPM:.0f} rpm",
    )
    ax[0, 1].legend(fontsize=8)
    for key, c in colours.items():
        rows = [r for r in res["speed_sweep"] if (r["mu"] is None) == (key == "frictionless")]
        ax[1, 1].plot(
            [r["speed_rpm"] for r in rows],
            [r["span_mean_N"] for r in rows],
            "o-",
            color=c,
            label=f"{key}: spans' mean",
        )
        ax[1, 1].plot(
            [r["speed_rpm"] for r in rows],
            [r["max_tension_N"] for r in rows],
            "s--",
            color=c,
            alpha=0.6,
            label=f"{key}: largest link",
        )
    ax[1, 1].axhline(s["settled_span_mean_N"], color="k", ls="--", lw=0.8)
    ax[1, 1].set(
        xlabel="driver speed [rpm]", ylabel="link tension, last revolution [N]", title="speed sweep"
    )
    ax[1, 1].legend(fontsize=8)
    fig.suptitle(
        "10A 13/26 drive, 60 links, 30 N·m, 300 N pretension — "
        f"python -m benchmarks.archive.tension_climb{' --quick' if res['quick'] else ''}, "
        f"{res['date']}, {res['machine']['cpu_count']}-core CPU",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    args = parse(parser(__doc__, out=ARCHIVE), argv)
    p = (
        dict(revs=0.3, mus=(None, 0.1), speeds=(600.0,))
        if args.quick
        else dict(revs=2.0, mus=(None, 0.003, 0.01, 0.03, 0.1), speeds=(300.0, 600.0, 1000.0))
    )
    start = time.perf_counter()
    res = {
        "machine": machine_info(),
        "date": datetime.date.today().isoformat(),
        "quick": args.quick,
        "plan": p,
        "scene": {**SCENE, "speed_rpm": NOMINAL_RPM},
    }
    print(f"friction sweep at {NOMINAL_RPM:.0f} rpm, {p['revs']} revolutions:", flush=True)
    res["history"] = {}
    res["mu_sweep"] = []
    default_mu = jc.scenes.JOINT_FRICTION.coefficient
    for mu in p["mus"]:
        row, hist = run(NOMINAL_RPM, mu, p["revs"])
        res["mu_sweep"].append(row)
        if mu is None:
            res["history"]["frictionless"] = hist
        elif mu == default_mu:
            res["history"]["friction"] = hist
    res["statics"] = s = statics(*res["history"]["frictionless"].pop("settled_spans_N"))
    res["history"]["friction"].pop("settled_spans_N")
    print(
        f"statics: spans {s['settled_tight_N']:.0f} / {s['settled_slack_N']:.0f} N, their mean "
        f"{s['settled_span_mean_N']:.0f} N (pretension {s['pretension_N']:.0f} N), their "
        f"difference {s['settled_difference_N']:.0f} N (T/r2 = "
        f"{s['load_over_driven_radius_N']:.0f} N)",
        flush=True,
    )
    print("speed sweep:", flush=True)
    res["speed_sweep"] = []
    for rpm in p["speeds"]:
        for mu in (None, default_mu):
            if rpm == NOMINAL_RPM:
                row = next(r for r in res["mu_sweep"] if r["mu"] == mu)
            else:
                row, _ = run(rpm, mu, p["revs"])
            res["speed_sweep"].append(row)
    return finish(res, args.out, "tension_climb", chart, start)


if __name__ == "__main__":
    main()
