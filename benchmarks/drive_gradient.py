"""How far a gradient through the solve reaches on a closed drive: the design gradient's size
against the horizon, and whether the mesh-order objective is differentiable over its window.

    python -m benchmarks.drive_gradient            # full study (~20 min on 2 cores)
    python -m benchmarks.drive_gradient --quick    # 2 and 4 tooth periods, drive only

Writes ``benchmarks/results/drive_gradient.json`` and ``drive_gradient.png``.
Notes: benchmarks/drive_gradient.md
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from benchmarks.common import (
    DRIVE_CHAIN as CHAIN,
    DRIVE_LOAD as LOAD,
    DRIVE_N_LINKS as N_LINKS,
    DRIVE_PRETENSION as PRETENSION,
    DRIVE_Z as Z,
    DRIVE_Z_DRIVEN as Z_DRIVEN,
    figure,
    finish,
    header,
    parse,
    parser,
    quiet_drive_scene as drive_scene,
    save_chart,
)

RPM = 1000.0
TAKE_UP = 2 * PRETENSION  # as jc.scenes.drive settles the drive
PERIOD = 60.0 / (RPM * Z)
DT = 4e-6
HORIZONS = (2, 4, 8)  # tooth periods
STEPS = (4e-6, 2e-6, 1e-6)  # fixed steps of the convergence rows (2 and 4 periods)
REVS = 1.2  # the band objective's solve [driver revolutions]
STEPS_H = (1e-1, 1e-2, 1e-3, 1e-4)


def _model():
    import jaxchain as jc

    chain = jc.ChainSpec.iso606(CHAIN)
    return chain, jc.scenes.roller_law(chain, 0.7, width=3e-6)


def joints(slip):
    """The chain joints' friction: the nominal coefficient, creep band ``slip`` [m/s]
    (None: frictionless)."""
    import jaxchain as jc

    if slip is None:
        return None
    return jc.contact.CoulombFriction(jc.scenes.JOINT_FRICTION.coefficient, slip)


def pattern_space():
    """36 coordinates: each gap's seating radius and clockwise seat angle, around the
    uniform ISO minimum form (u = 0)."""
    import jaxchain as jc
    from jaxchain.design import DesignSpace

    chain, _ = _model()
    iso = jc.ToothProfile.iso606(chain, Z, "min")
    tip = jc.iso606_limits(chain, Z)["tip_diameter"][0]
    tooth = jc.FreeformProfile.from_iso(iso, 2, tip_diameter=tip)
    ri, a = float(iso.seating_radius), float(tooth.cw.seat_angle)
    ones = np.ones(Z)
    return DesignSpace.select(
        tooth,
        {
            "seating_radius": (ri - 20e-6 * ones, ri + 20e-6 * ones),
            "cw.seat_angle": ((a - 0.05) * ones, (a + 0.05) * ones),
        },
    )


def builder(scene: str, slip=2e-2, periods: int = 2):
    """profile -> settled scene: the closed ``drive`` or the ``engagement`` strand (long
    enough for ``periods``)."""
    import jaxchain as jc

    chain, law = _model()
    if scene == "drive":
        return lambda p: drive_scene(p, RPM, roller_contact=law, joint_friction=joints(slip))
    return lambda p: jc.scenes.engagement(
        chain,
        Z,
        speed_rpm=RPM,
        profile=p,
        n_entry=periods + 1,
        model=jc.scenes.ChainModel(roller_contact=law, joint_friction=joints(slip)),
    )


def gradient_row(scene: str, periods: int, dt: float = DT, slip=2e-2) -> dict:
    """|∇J| of the soft peak over the last of ``periods`` tooth periods, at u = 0."""
    import jax
    import jax.numpy as jnp

    import jaxchain as jc
    from jaxchain.design import ProfileObjective

    space = pattern_space()
    t1 = periods * PERIOD
    obj = ProfileObjective(
        space,
        builder(scene, slip, periods),
        t1=t1,
        t_start=t1 - PERIOD,
        temperature=50.0,
        reference=2000.0,
        samples=8,
        dt=dt,
        take_up=TAKE_UP if scene == "drive" else 0.0,
        throw=False,  # a blown-up gradient is a row of the study, not an error
    )
    u = jnp.zeros(space.size)
    scenes = obj.scenes(u)
    t = time.perf_counter()
    value, grad, members = obj.value_and_grad_on(u, scenes)
    jax.block_until_ready(grad)
    row = {
        "scene": scene,
        "periods": periods,
        "dt": dt,
        "joint_slip": slip,
        "value_N": float(value),
        "grad_norm": float(jnp.linalg.norm(grad)),
        "result": jc.result_names(members.result)[0],
        "seconds": time.perf_counter() - t,
    }
    print(
        f"{scene:10s} {periods:2d} periods, {dt * 1e6:.0f} µs, slip {slip}: value "
        f"{row['value_N']:.1f} N, |grad| {row['grad_norm']:.3g} ({row['seconds']:.0f} s)",
        flush=True,
    )
    return row


def band_probe(revs: float = REVS, steps=STEPS_H, seed: int = 0) -> dict:
    """The mesh-order objective over ``revs`` revolutions: its reverse-mode gradient
    along a random direction against central differences of its value at ``steps``."""
    import jax
    import jax.numpy as jnp

    import jaxchain as jc
    from jaxchain.design import Penalized, ProfileObjective
    from jaxchain.observers import BandLevel, SoftPeak

    space = pattern_space()
    rev = 60.0 / RPM
    objective = Penalized(
        BandLevel.mesh_band(
            Z, 0.2, revs - 0.02, temperature=0.5, signal="bearing", sprocket=1, reference=0
        ),
        SoftPeak(t_start=0.2 * rev, rise=0.05 * rev, temperature=50.0, reference=2000.0),
        limit=3000.0,
        weight=0.01,
        width=20.0,
    )
    obj = ProfileObjective(
        space,
        builder("drive"),
        t1=revs * rev,
        objective=objective,
        dt=DT,
        take_up=TAKE_UP,
    )
    u = jnp.zeros(space.size)
    scenes = obj.scenes(u)

    def warm(call, i):  # compile, then time a warm call (done when its output ``i`` is)
        jax.block_until_ready(call()[i])
        t = time.perf_counter()
        out = call()
        jax.block_until_ready(out[i])
        return out, time.perf_counter() - t

    (value, _), t_value = warm(lambda: obj.value_on(u, scenes), 0)
    (value, grad, members), t_grad = warm(lambda: obj.value_and_grad_on(u, scenes), 1)
    d = np.random.default_rng(seed).normal(size=space.size)
    d /= np.linalg.norm(d)
    fd = []
    for h in steps:
        hi = float(obj.value_on(u + h * d, scenes)[0])
        lo = float(obj.value_on(u - h * d, scenes)[0])
        fd.append({"h": h, "central_difference": (hi - lo) / (2 * h), "plus": hi, "minus": lo})
        print(f"band level: h {h:g}: central difference {fd[-1]['central_difference']:+.4g} dB")
    row = {
        "revolutions": revs,
        "value_dB": float(value),
        "grad_norm": float(jnp.linalg.norm(grad)),
        "directional_ad": float(jnp.dot(grad, d)),
        "finite_differences": fd,
        "result": jc.result_names(members.result)[0],
        "value_s": t_value,
        "value_and_grad_s": t_grad,
    }
    print(
        f"band level over {revs} revolutions: {row['value_dB']:.2f} dB, |grad| "
        f"{row['grad_norm']:.3g}, along d {row['directional_ad']:.3g}; value {t_value:.1f} s, "
        f"value+gradient {t_grad:.1f} s",
        flush=True,
    )
    return row


def growth(rows: list[dict], scene: str) -> float | None:
    """The fitted growth of |∇J| per tooth period (factor) over the 4 µs rows of
    ``scene`` with the design's joint friction (log-linear least squares)."""
    pts = [
        (r["periods"], math.log(r["grad_norm"]))
        for r in rows
        if r["scene"] == scene and r["dt"] == DT and r["joint_slip"] == 2e-2
        and np.isfinite(r["grad_norm"]) and r["grad_norm"] > 0
    ]  # fmt: skip
    if len(pts) < 2:
        return None
    n, lg = np.array(pts).T
    return float(math.exp(np.polyfit(n, lg, 1)[0]))


def chart(results: dict, path: Path) -> None:
    band = results.get("band")
    fig, axes = figure(1, 2 if band else 1, figsize=(12 if band else 6.5, 4.5))
    ax = axes[0] if band else axes
    rows = results["rows"]
    styles = {
        ("drive", DT, 2e-2): ("C3", "o-", "closed drive, 4 µs"),
        ("drive", 2e-6, 2e-2): ("C4", "s--", "closed drive, 2 µs"),
        ("drive", 1e-6, 2e-2): ("C5", "D:", "closed drive, 1 µs"),
        ("drive", DT, None): ("C0", "^", "closed drive, frictionless joints"),
        ("drive", DT, 0.1): ("C1", "v", "closed drive, creep band 100 mm/s"),
        ("engagement", DT, 2e-2): ("C2", "o-", "engagement strand, 4 µs"),
    }
    for (scene, dt, slip), (colour, marker, label) in styles.items():
        pts = sorted(
            (r["periods"], r["grad_norm"])
            for r in rows
            if r["scene"] == scene and r["dt"] == dt and r["joint_slip"] == slip
        )
        if pts:
            n, g = zip(*pts, strict=True)
            ax.semilogy(n, g, marker, color=colour, label=label)
    ax.set_xlabel("solve horizon [tooth periods]")
    ax.set_ylabel("|∇J| of the soft peak [N per unit u]")
    ax.set_title("Design gradient against horizon (36 per-gap coordinates)")
    if band:
        ax = axes[1]
        h = [f["h"] for f in band["finite_differences"]]
        cd = [abs(f["central_difference"]) for f in band["finite_differences"]]
        ax.loglog(h, cd, "o-", color="C0", label="|central difference| of the value")
        ax.axhline(abs(band["directional_ad"]), color="C3", ls="--", label="|reverse mode|")
        ax.set_xlabel("finite-difference step h (u units)")
        ax.set_ylabel("|dJ/dh| along a random direction [dB per unit u]")
        ax.set_title(f"Band level over {band['revolutions']} revolutions")
    for ax in np.atleast_1d(axes):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="2 and 4 tooth periods on the drive only, no band probe")
    args = parse(ap, argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    start = time.perf_counter()
    horizons = (2, 4) if args.quick else HORIZONS
    rows = [gradient_row("drive", n) for n in horizons]
    band = None
    if not args.quick:
        rows += [gradient_row("drive", n, dt=dt) for n in (2, 4) for dt in STEPS[1:]]
        rows += [gradient_row("drive", 4, slip=slip) for slip in (None, 0.1)]
        rows += [gradient_row("engagement", n) for n in horizons[:3]]
        band = band_probe()
    results = {
        **header("drive_gradient", argv),
        "scene": f"{CHAIN}, {N_LINKS} links, {Z}/{Z_DRIVEN} teeth, {RPM:g} rpm, {LOAD:g} N·m, "
        f"{PRETENSION:g} N pretension; design law (onset 3 µm), joint creep band 20 mm/s",
        "space": "36 per-gap coordinates (seating radius ±20 µm, cw seat angle ±0.05 rad)",
        "rows": rows,
        "growth_per_period": {s: growth(rows, s) for s in ("drive", "engagement")},
        "band": band,
    }
    for s, g in results["growth_per_period"].items():
        if g is not None:
            print(f"{s}: |grad| grows ×{g:.3g} per tooth period (4 µs)")
    return finish(results, args.out, "drive_gradient", chart, start)


if __name__ == "__main__":
    main()
