"""Generate ``notebooks/01_drive_walkthrough.ipynb`` (run from anywhere):

    .venv/bin/python notebooks/_make_01_drive_walkthrough.py

The notebook builds an ISO 606 chain and its sprockets, simulates the engagement scene and
a complete two-sprocket drive (short runs with ``JAXCHAIN_FAST=1``, as the test suite sets
it), plots forces, tensions (spans, and the lumped links' compression explained), speeds and
snapshots, shows a failed solve and an animation inline. This script writes it without
outputs;

    .venv/bin/python notebooks/_make_all.py --execute

regenerates all four notebooks and executes them in full mode, storing the outputs (the
form they are committed in).
"""

from nbformat.v4 import new_code_cell, new_markdown_cell

from _write import CACHE, PLAYER, STAMP, X64, write

CELLS = [
    new_markdown_cell(
        """# Building, running and plotting a chain drive

This walkthrough builds an ISO 606 chain and its sprockets, simulates the meshing of a chain strand
with a sprocket (the scene used for tooth design) and a complete two-sprocket drive, and plots
what a drive engineer looks at: contact forces, tensions, speeds and snapshots.

`JAXCHAIN_FAST=1` (set by the test suite) shortens every simulation so the notebook executes
in CI in well under a minute of solver time; unset it for the real thing."""
    ),
    new_code_cell(
        """import os
from pathlib import Path
import jax

"""
        + X64
        + """import equinox as eqx
import jax.numpy as jnp
import numpy as np
import matplotlib.pyplot as plt
import jaxchain as jc
"""
        + CACHE
        + STAMP
        + """
FAST = os.environ.get("JAXCHAIN_FAST") == "1"
"""
    ),
    new_markdown_cell(
        """## 1. Chain and tooth profiles
ISO 606 gives the chain's dimensions and the limits of the tooth-gap form; the minimum and
maximum forms bracket every standard sprocket."""
    ),
    new_code_cell(
        """chain = jc.ChainSpec.iso606("08B")
print(
    f"pitch {chain.pitch * 1e3} mm, roller {chain.roller_diameter * 1e3} mm, "
    f"{chain.mass_per_length:.3f} kg/m (derived)"
)
for form in ("min", "max"):
    p = jc.ToothProfile.iso606(chain, 18, form)
    print(
        f"{form} form: ri = {float(p.seating_radius) * 1e3:.3f} mm, "
        f"α = {np.degrees(float(p.seating_angle)):.1f}°, re = {float(p.flank_radius) * 1e3:.2f} mm, "
        f"seat clearance {float(p.seat_clearance) * 1e6:.0f} µm"
    )
jc.plot_profiles(chain, 18);"""
    ),
    new_markdown_cell(
        """## 2. The engagement scene
A driver sprocket (1000 rpm) draws a strand in from a tight span held at 1000 N; one roller meshes
per tooth period. The scene starts from its static equilibrium, so the first engagement is not
drowned in a start-up transient."""
    ),
    new_code_cell(
        """rpm, z = 1000, 18
tooth_period = 60 / rpm / z
scene = jc.scenes.engagement(chain, z, speed_rpm=rpm, tension=1000.0, n_entry=8)
sol = jc.simulate(scene, (1.5 if FAST else 5) * tooth_period)  # 501 saves
print(
    f"{int(sol.stats['num_steps'])} steps; peak roller–sprocket force {float(sol.peak_contact_force):.0f} N"
)
fig, ax = plt.subplots(1, 2, figsize=(13, 4))
jc.plot_forces(sol, ax=ax[0])
jc.plot_snapshot(scene, sol, index=-1, ax=ax[1]);"""
    ),
    new_markdown_cell(
        """The dashed line is the peak over *every solver step*; the saved curves are sampled at the
save times and can miss the top of a short impact."""
    ),
    new_markdown_cell(
        """## 3. A complete drive
18/36 teeth, 100 links, 1000 rpm at the driver, 20 N·m on the driven sprocket. The builder
closes the loop with rollers seated, then finds the static equilibrium: the driven axis is
taken up until each span carries the 200 N pretension, and the driven sprocket turns until
the tight span carries the load."""
    ),
    new_code_cell(
        """drive = jc.scenes.drive(
    chain,
    teeth=(18, 36),
    n_links=60 if FAST else 100,
    speed_rpm=rpm,
    load_torque=20.0,
    pretension=200.0,
    fidelity="lumped",
)
c = float(drive.sprockets[1].centre[0])
print(f"centre distance {c * 1e3:.2f} mm, {drive.n_links} links")
t1 = (2 if FAST else 18) * tooth_period  # 18 tooth periods = one driver revolution
dsol = jc.simulate(drive, t1, n_save=1001)
w = np.asarray(dsol.sprocket_speed)
print(f"mean speed ratio {w[:, 1].mean() / w[:, 0].mean():.4f} (18/36 = 0.5)")
fig, ax = plt.subplots(1, 2, figsize=(13, 4))
jc.plot_speed(dsol, ax=ax[0], scene=drive)
jc.plot_tensions(dsol, ax=ax[1]);"""
    ),
    new_markdown_cell(
        """The right panel is what a drive engineer reads: `Solution.span_tension`, the mean
tension of the links in each free span (span 0 runs from the driver to the driven
sprocket, the slack side; span 1 back, the tight side, carrying the 20 N·m on the
driven sprocket's pitch radius on top of the pretension).

The lumped chain's links themselves (`Solution.link_tension`, one column per link) are
**two-way springs**: a link whose two rollers are pushed together is in compression and
reports a *negative* tension. A real chain's link cannot push (its joints fold); in the
model a seated link can be squeezed between its rollers as they settle in neighbouring
tooth gaps. `plot_tensions(sol, links=...)` draws links on request; here the five that
are squeezed the hardest, and where the compressed ones are:"""
    ),
    new_code_cell(
        """tension = np.asarray(dsol.link_tension)  # (T, L): link j joins rollers j and j + 1
squeezed = np.argsort(tension.min(axis=0))[:5]
pos = np.asarray(dsol.roller_position)
middle = 0.5 * (pos + np.roll(pos, -1, axis=1))  # each link's centre
on_sprocket = np.zeros(tension.shape, bool)  # within 2 mm of a sprocket's pitch circle
for s in drive.sprockets:
    gap = np.linalg.norm(middle - np.asarray(s.centre), axis=-1) - float(s.profile.pitch_radius)
    on_sprocket |= np.abs(gap) < 2e-3
compressed = tension < -10.0
print(
    f"link tensions {tension.min():.0f} … {tension.max():.0f} N; span tensions "
    f"{np.asarray(dsol.span_tension).min():.0f} … {np.asarray(dsol.span_tension).max():.0f} N"
)
print(
    f"{100 * compressed.mean():.2f} % of the link samples below −10 N, "
    f"{100 * on_sprocket[compressed].mean():.0f} % of them on a sprocket"
)
jc.plot_tensions(dsol, links=sorted(squeezed.tolist()));"""
    ),
    new_markdown_cell(
        """Single links reach −276 N, and up to 971 N, where the spans stay between 59 and
553 N: the links' extremes are brief spikes, down and up, as rollers seat on the
sprockets. Below −10 N are 0.18 % of the link samples, and 99 % of those are links on a
sprocket; the free spans, which `span_tension` averages, stay in tension (the slack
span's 59 N is its least). A link's compression is the lumped model seating its
rollers, not a load a chain carries: read the spans for the drive's tensions, and the
clearance-joint chain (`fidelity="clearance"`) for the forces inside a link."""
    ),
    new_code_cell("jc.plot_snapshot(drive, dsol, index=-1);"),
    new_markdown_cell(
        """## 4. Failures are values
A solve that cannot finish, or whose result is not physical, reports what happened and
what to change, instead of returning NaNs. `throw=True` (the default) raises with the same
message. Here the same strand as a chain of 500 N tensile strength under its 1000 N span:"""
    ),
    new_code_cell(
        """weak = eqx.tree_at(lambda s: s.tensile_strength, scene, jnp.asarray(500.0))
bad = jc.simulate(weak, tooth_period, throw=False)
print(bad.result == jc.Result.chain_overloaded)
print(bad.message)"""
    ),
    new_markdown_cell(
        """## 5. Animation
`jc.animate` writes a GIF (or MP4 where ffmpeg is installed), each frame a
`plot_snapshot` coloured on the whole run's force scale. `player` (defined here) shows
it inline with matplotlib's JavaScript controls (play, step, scrub with the slider): the
strand of section 2 over its five tooth periods, every 8th save."""
    ),
    new_code_cell(
        PLAYER
        + """


path = jc.animate(scene, sol, "engagement.gif", stride=50 if FAST else 8, fps=12, dpi=60)
player(path, fps=12)"""
    ),
    new_markdown_cell(
        """## 6. Bush chains
A bush chain (ISO 606 04C and 06C, ANSI 25 and 35) has no roller: the bush, pressed into
the inner link's plates, engages the tooth, so it slides on the tooth as the link
articulates, where a roller would roll. Every builder takes it by name; its teeth carry
Dahl friction by default (`jc.scenes.BUSH_TOOTH_FRICTION`, μ = 0.1), and a roller
chain's none."""
    ),
    new_code_cell(
        """bush = jc.ChainSpec.iso606("06C")
roller = jc.ChainSpec.iso606("06B")
for c in (roller, bush):
    print(
        f"{c.name}: pitch {c.pitch * 1e3:.3f} mm, engaging diameter d1 "
        f"{c.roller_diameter * 1e3:.2f} mm, has a roller: {c.has_roller}, "
        f"{c.mass_per_length:.3f} kg/m"
    )
print(jc.scenes.BUSH_TOOTH_FRICTION)"""
    ),
    new_markdown_cell(
        """The study `python -m benchmarks.bush_chain` runs both chains of the same pitch on the
same 18/36 drive (10 N·m, 200 N pretension) and meshes both with an 18-tooth sprocket in
the clearance-joint chain (1000 N, 1000 rpm). Its committed results:"""
    ),
    new_code_cell(
        """import json

ROOT = Path(jc.__file__).resolve().parents[1]  # the repository: the studies' results
study = json.loads((ROOT / "benchmarks" / "results" / "bush_chain.json").read_text())
print("chain  rpm  efficiency  teeth   joints  speed line  tension line")
for r in study["drive"]:
    print(
        f"{r['chain']}  {r['rpm']:4.0f}  {100 * r['efficiency']:8.2f} %  "
        f"{100 * r['teeth_loss']:5.2f} %  {100 * r['joint_loss']:5.2f} %  "
        f"{r['speed_mesh_line_pct']:8.3f} %  {r['tension_mesh_line_N']:9.1f} N"
    )
for p in study["peaks"]:
    lo, hi = p["ci95_N"]
    print(
        f"{p['chain']} meshing peaks: mean {p['mean_N']:.0f} N [{lo:.0f}, {hi:.0f}], "
        f"p95 {p['p95_N']:.0f} N over {len(p['peaks_N'])} engagements"
    )
d = study["bush_minus_roller"]
print(
    f"bush - roller: {d['difference']:+.0f} N ({100 * d['relative']:+.1f} %), "
    f"95 % interval [{d['ci_low']:+.0f}, {d['ci_high']:+.0f}] N"
)"""
    ),
    new_code_cell(
        """from IPython.display import Image

Image(str(ROOT / "benchmarks" / "results" / "bush_chain.png"))"""
    ),
    new_markdown_cell(
        """The bush chain loses 0.6–0.8 points of efficiency, half a percent of the driver's
work to its bushes sliding on the teeth; its driven speed carries a 2–5× stronger
mesh-order line; and in the clearance-joint chain its meshing peaks are 14 % higher on
average (an interval clear of zero). The main job designs a bush chain's tooth with
`python -m optimize --chain 06C`: there the ISO minimum form stays the choice, the
designed tooth's −5.6 % under its own contact law not surviving the Hertz law or the
clearance-joint chain (`benchmarks/results/optimize_bush`)."""
    ),
]


def main():
    return write(CELLS, "01_drive_walkthrough.ipynb", runs_from=RUNS_FROM)


RUNS_FROM = """**Runs from** any installation of jaxchain, from any directory, but for section 6:
it reads a study's committed results from `benchmarks/results/`, which needs a checkout of
the repository with jaxchain installed from it (`pip install -e .` in the clone)."""


if __name__ == "__main__":
    main()
