"""The span-level chain (``fidelity="spans"``) against the lumped chain on the same drive,
and its design gradient over many revolutions against central differences.

    python -m benchmarks.spans            # 1000 and 2000 rpm; gradient over 20 revolutions
    python -m benchmarks.spans --quick    # 1000 rpm; gradient over 6 revolutions

Writes ``benchmarks/results/spans.json`` and ``spans.png``.

The drive: 08B, an 18-tooth crank sprocket, round or with a 2nd-order pitch-curve
harmonic of 0.2 mm (``FreeformProfile.noncircular``), driving a round 36-tooth
sprocket (20 N·m, 200 N pretension), 80 links; the span model at the lumped drive's
centre distance. Both from their static equilibrium, four driver revolutions, the last
three analysed (whole revolutions): mean tight- and slack-span tension, the 2nd driver
order of the tight span's tension and of the driven sprocket's speed (amplitudes of the
Fourier component over the window), the lumped chain's 18th (tooth) order beside them,
and the warm time per revolution (lumped at rtol 1e-4, spans at rtol 1e-6). Span tensions
are ``Solution.span_tension`` (the lumped chain's: the mean over the links in the span).

Gradient: d/dA of the squared 2nd-order amplitude of the tight span's tension over the
second half of the horizon (A the crank's 2nd-order amplitude, traced through the pitch
polygon, the pitch-curve fit and the span element), fixed Tsit5 steps of 20, 10 and 5 µs
(``dt=``, exact discrete adjoint) against central differences (h = 1 µm) of the same
fixed-step solve.
"""

from __future__ import annotations

import time

import jax

jax.config.update("jax_enable_x64", True)

import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402

CHAIN = "08B"
TEETH = (18, 36)
AMPLITUDES = (0.0, 0.2e-3)  # m, the crank's 2nd-order pitch-curve harmonic, compared
AMPLITUDE = 1e-3  # m, where the gradient is taken
LOAD, PRETENSION, LINKS = 20.0, 200.0, 80


_CHAIN = jc.ChainSpec.iso606(CHAIN)
_CRANK = jc.ToothProfile.iso606(_CHAIN, TEETH[0])
_ROUND = jc.ToothProfile.iso606(_CHAIN, TEETH[1])


def profiles(amplitude):
    """The crank sprocket with ``amplitude`` [m] of 2nd order (may be traced) and the round
    driven one."""
    return jc.FreeformProfile.noncircular(_CRANK, ((2, amplitude, 0.0),)), _ROUND


def order_amplitude(signal, angle, order):
    """Amplitude of the ``order``-th driver order of ``signal`` sampled at driver angles
    ``angle`` spanning whole revolutions uniformly (end excluded)."""
    n = signal.shape[0]
    return 2 / n * jnp.abs(jnp.sum(signal * jnp.exp(-1j * order * angle)))


def compare(rpm: float, amplitude: float, revolutions: int = 4) -> dict:
    oval, round36 = profiles(amplitude)
    rev = 60.0 / rpm
    lumped = jc.scenes.drive(
        CHAIN, teeth=TEETH, n_links=LINKS, speed_rpm=rpm, load_torque=LOAD,
        pretension=PRETENSION, profiles=(oval, round36),
    )  # fmt: skip
    spans = jc.scenes.drive(
        CHAIN, teeth=TEETH, centre_distance=float(lumped.sprockets[1].centre[0]), speed_rpm=rpm,
        load_torque=LOAD, pretension=PRETENSION, profiles=(oval, round36), fidelity="spans",
    )  # fmt: skip
    n_per = 360
    ts = np.arange(n_per * revolutions + 1) * rev / n_per
    win = slice(n_per, n_per * revolutions)  # revolutions 2 … N, whole, end excluded
    out = {}
    for name, scene, kw in (
        ("lumped", lumped, dict(rtol=1e-4, max_steps=2_000_000)),
        ("spans", spans, dict()),
    ):
        sol = jc.simulate(scene, ts[-1], ts=ts, **kw)
        wall = time.perf_counter()
        sol = jc.simulate(scene, ts[-1], ts=ts, **kw)
        jax.block_until_ready(sol.ts)
        wall = (time.perf_counter() - wall) / revolutions
        tension = np.asarray(sol.span_tension)  # (T, 2): slack (span 0), tight (span 1)
        angle = np.asarray(sol.sprocket_angle)[:, 0]  # the crank body's angle
        a = angle[win]
        speed = np.asarray(sol.sprocket_speed)[:, 1]
        out[name] = {
            "ok": bool(sol.ok),
            "slack_mean_N": float(tension[win, 0].mean()),
            "tight_mean_N": float(tension[win, 1].mean()),
            "tight_order2_N": float(order_amplitude(tension[win, 1], a, 2)),
            "tight_order18_N": float(order_amplitude(tension[win, 1], a, TEETH[0])),
            "driven_speed_order2_rad_s": float(order_amplitude(speed[win], a, 2)),
            "driven_speed_mean_rad_s": float(speed[win].mean()),
            "wall_per_revolution_s": wall,
            "series": {
                "crank_deg": np.degrees(np.mod(a, 2 * np.pi)).tolist(),
                "tight_N": tension[win, 1].tolist(),
                "driven_speed": speed[win].tolist(),
            },
        }
        print(
            f"{rpm:.0f} rpm, {1e3 * amplitude:g} mm {name:6s}: tight "
            f"{out[name]['tight_mean_N']:7.1f} N, slack "
            f"{out[name]['slack_mean_N']:6.1f} N, tight 2nd order "
            f"{out[name]['tight_order2_N']:6.1f} N, driven speed 2nd order "
            f"{out[name]['driven_speed_order2_rad_s']:.3f} rad/s, {1e3 * wall:.1f} ms/rev"
        )
    return out


def gradient(rpm: float, revolutions: int, steps_us=(20.0, 10.0, 5.0)) -> list[dict]:
    """AD against central differences of J(A) = (2nd-order amplitude of the tight span's
    tension over the second half)² at A = ``AMPLITUDE``, fixed steps."""
    oval, round36 = profiles(AMPLITUDE)
    base = jc.scenes.drive(
        CHAIN, teeth=TEETH, centre_distance=0.33, speed_rpm=rpm, load_torque=LOAD,
        pretension=PRETENSION, profiles=(oval, round36), fidelity="spans",
    )  # fmt: skip
    from jaxchain.scenes import span_element  # the element, rebuilt from traced profiles

    el = base.added[0]
    centres = jnp.stack([s.centre for s in base.sprockets])
    theta0 = jnp.zeros(2)
    tension0 = el.tensions(theta0, theta0, centres)[0]  # at rest: the statics' tensions
    length = el.geometry(theta0, centres)[0]
    ea, ca = float((el.stiffness * length)[0]), float((el.damping * length)[0])
    rev = 60.0 / rpm
    n_per = 72
    ts = np.arange(n_per * revolutions // 2, n_per * revolutions) * rev / n_per
    rows = []
    for dt_us in steps_us:

        def objective(amplitude, dt=dt_us * 1e-6):
            oval, _ = profiles(amplitude)
            spans = span_element((oval, round36), centres, el.sense, tension0, ea, ca)
            scene = eqx.tree_at(lambda s: s.added[0], base, spans)
            sol = jc.simulate(scene, rev * revolutions, ts=ts, dt=dt, throw=False)
            angle = sol.sprocket_angle[:, 0]
            return order_amplitude(sol.link_tension[:, 1], angle, 2) ** 2

        f = objective  # (not jitted: dt's step count needs a concrete time span)
        g = jax.grad(objective)
        wall = time.perf_counter()
        ad = float(g(AMPLITUDE))
        wall = time.perf_counter() - wall
        h = 1e-6
        fd = (float(f(AMPLITUDE + h)) - float(f(AMPLITUDE - h))) / (2 * h)
        value = float(f(AMPLITUDE))
        rows.append({"dt_us": dt_us, "value": value, "ad": ad, "fd": fd, "first_grad_s": wall})
        print(
            f"gradient over {revolutions} revolutions, dt {dt_us:g} µs: J {value:.6g}, AD "
            f"{ad:.6g}, FD {fd:.6g} (rel. {abs(ad - fd) / abs(fd):.1e})"
        )
    return rows


def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    cmp_ = results["compare"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for point, runs in cmp_.items():
        if point.endswith(" 0 mm"):
            continue  # round sprockets: the span model's lines are flat
        for name, style in (("lumped", "-"), ("spans", "--")):
            s = runs[name]["series"]
            order = np.argsort(s["crank_deg"])
            x = np.asarray(s["crank_deg"])[order]
            axes[0].plot(
                x, np.asarray(s["tight_N"])[order], style, lw=0.6, label=f"{name}, {point}"
            )
            axes[1].plot(
                x, np.asarray(s["driven_speed"])[order], style, lw=0.6, label=f"{name}, {point}"
            )
    axes[0].set(xlabel="crank sprocket angle [deg]", ylabel="tight span tension [N]")
    axes[1].set(xlabel="crank sprocket angle [deg]", ylabel="driven speed [rad/s]")
    axes[0].legend(fontsize=7)
    rows = results["gradient"]["rows"]
    dts = np.asarray([r["dt_us"] for r in rows])
    ad = np.asarray([r["ad"] for r in rows])
    fd = np.asarray([r["fd"] for r in rows])
    axes[2].plot(dts, np.abs(ad - fd) / np.abs(fd), "o-", label="|AD − central differences| / |CD|")
    axes[2].plot(dts[:-1], np.abs(ad[:-1] / ad[-1] - 1), "x--", label="AD against the finest step")
    axes[2].set(
        xscale="log", yscale="log", xlabel="fixed step [µs]", ylabel="relative difference",
        title=f"dJ/dA over {results['gradient']['revolutions']} revolutions",
    )  # fmt: skip
    axes[2].legend(fontsize=7)
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="1000 rpm; gradient over 6 revolutions")
    args = parse(ap, argv)
    start = time.perf_counter()
    res = header("spans", argv)
    speeds = (1000.0,) if args.quick else (1000.0, 2000.0)
    res["compare"] = {
        f"{rpm:.0f} rpm, {1e3 * a:g} mm": compare(rpm, a) for rpm in speeds for a in AMPLITUDES
    }
    revolutions = 6 if args.quick else 20
    res["gradient"] = {
        "rpm": 2000.0,
        "revolutions": revolutions,
        "rows": gradient(2000.0, revolutions),
    }
    return finish(res, args.out, "spans", chart, start)


if __name__ == "__main__":
    main()
