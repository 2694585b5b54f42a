"""Foundation demo (the main job until the optimizer lands): ISO 606 tooth forms, contact
laws, and a roller impacting its seat, solved with diffrax.

Writes ``<out>/demo.json`` and ``<out>/tooth_forms.png``, ``<out>/seat_impact.png``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxchain as jc


def _impact(profile: jc.ToothProfile, law, mass: float, speed: float):
    """A free roller (point mass) moving radially inwards at ``speed`` into the seat of
    gap 0 of a fixed sprocket; returns (ts, force history, rebound speed / speed)."""
    c = profile.geometry().seat_centre
    start = c - jnp.array([profile.seat_clearance * 0.5, 0.0])  # in the gap, not touching
    y0 = (start, jnp.array([-speed, 0.0]))

    def field(t, y, args):
        x, v = y
        depth, n = jc.gap_contact(profile, x)
        rate = -(v @ n)  # approach speed along the normal
        f = law.normal_force(depth, rate, speed)
        return v, f * n / mass

    t1 = 4 * profile.seat_clearance / speed
    ts = jnp.linspace(0.0, t1, 8001)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Tsit5(),
        0.0,
        t1,
        1e-8,
        y0,
        stepsize_controller=diffrax.PIDController(rtol=1e-9, atol=1e-14, dtmin=1e-14),
        saveat=diffrax.SaveAt(ts=ts),
        max_steps=200_000,
    )
    xs, vs = sol.ys
    force = jax.vmap(
        lambda x, v: law.normal_force(
            jc.gap_contact(profile, x)[0], -(v @ jc.gap_contact(profile, x)[1]), speed
        )
    )(xs, vs)
    return ts, force, vs[-1, 0] / speed  # outward after the rebound


def run(out: Path, chain_name: str = "08B", teeth: int = 18, speed: float = 0.5) -> dict:
    jax.config.update("jax_enable_x64", True)
    out.mkdir(parents=True, exist_ok=True)
    chain = jc.ChainSpec.iso606(chain_name)
    print(f"jaxchain foundation demo — chain {chain.name}, z = {teeth}")
    print(
        f"  pitch {chain.pitch * 1e3:.3f} mm, roller Ø {chain.roller_diameter * 1e3:.2f} mm, "
        f"{chain.mass_per_length:.3f} kg/m (derived), tensile {chain.tensile_strength / 1e3:.1f} kN"
    )
    lim = jc.iso606_limits(chain, teeth)
    forms = {f: jc.ToothProfile.iso606(chain, teeth, f) for f in ("min", "mid", "max")}
    print("\n  ISO 606 tooth-gap forms        min form   mid form   max form")
    rows = [
        ("seating radius ri [mm]", lambda p: p.seating_radius * 1e3),
        ("seating angle α [deg]", lambda p: np.degrees(p.seating_angle)),
        ("flank radius re [mm]", lambda p: p.flank_radius * 1e3),
        ("tip diameter da [mm]", lambda p: p.tip_diameter * 1e3),
        ("seat clearance [µm]", lambda p: p.seat_clearance * 1e6),
    ]
    for label, get in rows:
        print(f"  {label:28s}" + "".join(f"{float(get(p)):11.3f}" for p in forms.values()))

    print("\n  contact laws: restitution actually produced (closed form), nominal e = 0.5 / 0.9")
    laws = {}
    for cls in (
        jc.contact.LankaraniNikravesh,
        jc.contact.HuntCrossley,
        jc.contact.Flores,
        jc.contact.Gonthier,
    ):
        e5 = cls(stiffness=1.0, restitution=0.5).effective_restitution()
        e9 = cls(stiffness=1.0, restitution=0.9).effective_restitution()
        laws[cls.__name__] = {"e=0.5": e5, "e=0.9": e9}
        print(f"  {cls.__name__:20s} e*(0.5) = {e5:.3f}   e*(0.9) = {e9:.3f}")

    # roller impact into the seat: Johnson (conformal) vs Hertz with internal R*
    estar = jc.effective_modulus(jc.STEEL, jc.STEEL)
    mass = chain.roller_mass + 0.5 * (chain.roller_link_mass + chain.pin_link_mass)
    length = 0.95 * chain.inner_width
    impacts = {}
    curves = {}
    print(
        f"\n  roller (+ half a link pair, {mass * 1e3:.1f} g) hits its seat at {speed} m/s, e = 0.8"
    )
    t0 = time.perf_counter()
    for form in ("min", "max"):
        p = forms[form]
        # array fields: one compile per law type, not per value
        johnson = jc.contact.JohnsonCylinder(
            clearance=p.seat_clearance,
            length=jnp.asarray(length),
            modulus=jnp.asarray(estar),
            restitution=jnp.asarray(0.8),
        )
        hertz = jc.contact.Flores(
            stiffness=jc.contact.hertz_stiffness(
                estar, p.roller_radius, p.seating_radius, internal=True
            ),
            restitution=jnp.asarray(0.8),
        )
        for name, law in (("Johnson", johnson), ("Hertz-internal", hertz)):
            ts, f, reb = eqx.filter_jit(_impact)(p, law, mass, speed)
            impacts[f"{form}/{name}"] = {
                "peak_force_N": float(jnp.max(f)),
                "rebound_ratio": float(reb),
            }
            curves[f"{form} form, {name}"] = (np.asarray(ts), np.asarray(f))
            print(
                f"  {form} form, {name:15s} peak force {float(jnp.max(f)):8.1f} N, "
                f"rebound speed / impact speed {float(reb):.3f}"
            )
    print(f"  (4 impacts solved with diffrax in {time.perf_counter() - t0:.1f} s incl. compile)")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = jc.plot_profiles(chain, teeth)
    ax.figure.savefig(out / "tooth_forms.png", dpi=120, bbox_inches="tight")
    fig, ax = plt.subplots(figsize=(7, 4))
    span = 0.0
    for label, (ts, f) in curves.items():
        on = np.nonzero(f > 0)[0]
        t_on, t_off = ts[on[0]], ts[on[-1]]
        span = max(span, t_off - t_on)
        ax.plot((ts - t_on) * 1e6, f, label=label)
    ax.set_xlim(-0.2 * span * 1e6, 1.3 * span * 1e6)
    ax.set_xlabel("time from contact onset [µs]")
    ax.set_ylabel("roller–seat normal force [N]")
    ax.set_title(f"{chain.name}, z = {teeth}: roller hits its seat at {speed} m/s")
    ax.legend(fontsize=8)
    fig.savefig(out / "seat_impact.png", dpi=120, bbox_inches="tight")
    plt.close("all")

    result = {
        "chain": chain.name,
        "teeth": teeth,
        "impact_speed_m_s": speed,
        "iso606_limits": lim,
        "forms": {
            f: {
                k: float(getattr(p, k))
                for k in ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")
            }
            for f, p in forms.items()
        },
        "law_restitution": laws,
        "seat_impact": impacts,
        "versions": {
            "jax": jax.__version__,
            "diffrax": diffrax.__version__,
            "jaxchain": jc.__version__,
        },
    }
    tmp = out / "demo.json.tmp"
    tmp.write_text(json.dumps(result, indent=2))
    tmp.replace(out / "demo.json")
    print(f"\n  wrote {out / 'demo.json'}, {out / 'tooth_forms.png'}, {out / 'seat_impact.png'}")
    return result


if __name__ == "__main__":  # pragma: no cover
    run(Path("results/demo"))
