"""Generate ``notebooks/05_timing_drive.ipynb`` (run from anywhere):

    .venv/bin/python notebooks/_make_05_timing_drive.py

The notebook builds an engine timing drive (06B chain, crank 21 teeth at 3000 rpm, two
42-tooth cams, a pivoting-arm tensioner on the slack span, a fixed guide on the tight
span), shows its settled statics, simulates it (one tenth of a crank revolution with
``JAXCHAIN_FAST=1``, as the test suite sets it; three revolutions otherwise) and plots the
drive with its tensioner and guide, the tensioner's arm angle and force, the span tensions
and the sprocket speeds. The scene and the solve match ``tests/test_timing_drive.py``'s,
so the compiled solve is shared through the persistent compilation cache. This script
writes it without outputs;

    .venv/bin/python notebooks/_make_all.py --execute 05

executes it in full mode, storing the outputs (the form it is committed in).
"""

from nbformat.v4 import new_code_cell, new_markdown_cell

from _write import CACHE, PLAYER, STAMP, X64, write

CELLS = [
    new_markdown_cell(
        """# An engine timing drive: crank, two cams, a tensioner and a guide

A timing drive as engines carry it: the crank sprocket (21 teeth) drives two camshaft
sprockets (42 teeth each) through an 06B roller chain. The span leaving the crank is the
slack side; a pivoting arm pressed by a preloaded torsional spring (with a damper) holds
it in tension through a polyamide shoe. The span returning to the crank is the tight side;
a fixed straight guide steadies it.

The notebook builds the drive, looks at its settled statics, simulates it at 3000 rpm and
plots what a timing-drive engineer looks at: the drive with its tensioner and guide, the
tensioner's arm angle and shoe force, the span tensions and the sprocket speeds.

`JAXCHAIN_FAST=1` (set by the test suite) simulates one tenth of a crank revolution from
the layout as built (not settled); unset, three revolutions from the settled start."""
    ),
    new_code_cell(
        """import os
import time
from pathlib import Path
import jax

"""
        + X64
        + """import numpy as np
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
        """## 1. The drive
The drive is described as data, a `jc.scenes.DriveSpec`: one `SprocketSpec` per sprocket
(its teeth, its axis, its load), in the order the chain passes them as one
counter-clockwise loop; the first drives. `spec.build()` gives the scene (what
`jc.scenes.drive(chain, teeth=..., centres=..., ...)` gives from the same data as
keywords), and `spec.replace(...)` or `spec.with_sprocket(k, ...)` the next variant.
Span j runs from sprocket j to
sprocket j + 1: span 0 (crank to first cam) leaves the driver, the slack side, and carries
the tensioner; span 2 (second cam back to the crank) is the tight side and carries the
guide. The tensioner sets the chain's tension (its span carries `pretension` at rest), so
no sprocket needs to move to take up the chain. The layout wraps the chain round the
tensioner's shoe (pushed in by `deflection`), closes the loop with an even link count, and
the settled start turns the arm until its spring balances the chain."""
    ),
    new_code_cell(
        """chain = jc.ChainSpec.iso606("06B")
rpm = 3000.0
revolution = 60 / rpm  # one crank revolution [s]
start = time.perf_counter()
spec = jc.scenes.DriveSpec(
    chain=chain,
    sprockets=(
        jc.scenes.SprocketSpec(21, centre=(0.0, 0.0), load=None),  # the crank drives
        jc.scenes.SprocketSpec(42, centre=(0.05, 0.18), load=2.0),  # first cam [m, N·m]
        jc.scenes.SprocketSpec(42, centre=(-0.09, 0.18), load=2.0),  # second cam
    ),
    speed_rpm=rpm,
    pretension=150.0,  # the tensioner's span at rest [N]
    tensioner=jc.scenes.Tensioner(span=0, shoe_radius=0.12, deflection=0.015, damping=0.02),
    guides=(jc.scenes.Guide(span=2, length=0.12),),
    settle=not FAST,  # fast mode: the layout as built (settling takes ~10 s)
)
timing = spec.build()
print(
    f"built{'' if FAST else ' and settled'} in {time.perf_counter() - start:.1f} s: {timing.n_links} links"
)
centres = np.array([np.asarray(s.centre) for s in timing.sprockets])
radii = np.array([float(s.profile.pitch_radius) for s in timing.sprockets])
teeth = [s.profile.teeth for s in timing.sprockets]
for k, (c, r, z) in enumerate(zip(centres, radii, teeth)):
    print(
        f"sprocket {k}: z = {z}, axis ({c[0] * 1e3:.1f}, {c[1] * 1e3:.1f}) mm, pitch radius {r * 1e3:.2f} mm"
    )
arm = timing.tensioners
pivot = np.asarray(arm.pivot[0]) * 1e3
print(
    f"tensioner pivot ({pivot[0]:.1f}, {pivot[1]:.1f}) mm, settled arm angle "
    f"{np.degrees(float(arm.angle0[0])):.2f}° (laid out at {np.degrees(float(arm.layout_angle[0])):.2f}°)"
)"""
    ),
    new_markdown_cell(
        """At rest every cam takes its load torque over its pitch radius out of the tension: the
slack span carries the pretension, the span between the cams one cam's load more, the
tight span both."""
    ),
    new_code_cell(
        """pretension, load = 150.0, 2.0
static = pretension + np.array([0.0, load / radii[1], load / radii[1] + load / radii[2]])
for j, t in enumerate(static):
    print(f"span {j}: {t:6.1f} N at rest")"""
    ),
    new_markdown_cell(
        """## 2. Simulation
Tsit5 with adaptive steps (rtol 1e-6) from the settled start. The solution carries the
tensioner's arm angle, the chain's force on its shoe and the spring's torque, and the
chain's force on the guide, beside the usual roller, link and sprocket outputs."""
    ),
    new_code_cell(
        """t1 = (0.1 if FAST else 3.0) * revolution
start = time.perf_counter()
sol = jc.simulate(timing, t1, n_save=601)
print(
    f"{t1 * 1e3:.0f} ms simulated ({t1 / revolution:.1f} crank revolutions) in "
    f"{time.perf_counter() - start:.1f} s, {int(sol.stats['num_steps'])} steps: {sol.result_name}"
)
print(
    "outputs:",
    sol.tensioner_angle.shape,
    sol.tensioner_force.shape,
    sol.guide_force.shape,
    sol.roller_shoe_force.shape,
)"""
    ),
    new_markdown_cell(
        """`plot_snapshot` draws the sprockets (turned to their angles), the chain, the
tensioner's shoe on its arm (the pivot marked) and the guide; the rollers are coloured by
their force on the sprockets."""
    ),
    new_code_cell("jc.plot_snapshot(timing, sol, index=-1);"),
    new_markdown_cell(
        """## 3. The tensioner and the guide
The rollers run over the shoe at 10 m/s, each a point contact on its face: the chain's force
on the shoe is a train of short pulses, one set per roller passing (thin lines, as saved).
Averaged over a crank tooth period (thick lines) it follows the span tension across the
shoe's wrap, 2·T·sin(θ/2). The arm itself, with its inertia, spring and damper, turns by
hundredths of a degree once the start-up transient has died out."""
    ),
    new_code_cell(
        """t_ms = np.asarray(sol.ts) * 1e3
tooth_period = revolution / teeth[0]  # of the crank [s]


def running_mean(values, window=tooth_period):
    \"\"\"Mean over ``window`` seconds around each save time (shorter at the ends).\"\"\"
    kernel = np.ones(max(1, int(round(window / (t1 / (len(t_ms) - 1))))))
    counts = np.convolve(np.ones_like(values), kernel, mode="same")
    return np.convolve(values, kernel, mode="same") / counts


fig, ax = plt.subplots(1, 3, figsize=(15, 3.8))
angle = np.degrees(np.asarray(sol.tensioner_angle[:, 0] - sol.tensioner_angle[0, 0]))
ax[0].plot(t_ms, angle)
ax[0].set(xlabel="time [ms]", ylabel="arm angle from the settled start [°]", title="tensioner arm")
shoe = np.asarray(sol.tensioner_force[:, 0])
ax[1].plot(t_ms, shoe, lw=0.4, color="tab:blue", alpha=0.5)
ax[1].plot(t_ms, running_mean(shoe), lw=2, color="tab:blue", label="chain on the shoe [N]")
ax[1].plot(
    t_ms,
    np.asarray(sol.tensioner_torque[:, 0]) * 100,
    color="tab:orange",
    label="spring + damper torque [N·cm]",
)
ax[1].set(xlabel="time [ms]", title="tensioner forces")
ax[1].legend(fontsize=8)
guide = np.asarray(sol.guide_force[:, 0])
ax[2].plot(t_ms, guide, lw=0.4, color="tab:green", alpha=0.5)
ax[2].plot(t_ms, running_mean(guide), lw=2, color="tab:green")
ax[2].set(xlabel="time [ms]", ylabel="force [N]", title="chain on the guide")
for a in ax:
    a.grid(True, lw=0.4, alpha=0.5)
fig.tight_layout()"""
    ),
    new_markdown_cell(
        """## 4. Span tensions and sprocket speeds
A span's tension is read where a strain gauge would sit: at a fixed point on the span
(here near its middle, a quarter of the way along the tensioner's span, clear of the
shoe), from the link passing it at each save time. The cams' speeds are shown relative to
ω₁·z₁/z_k, the speed the tooth counts give them."""
    ),
    new_code_cell(
        """x = np.asarray(sol.roller_position)  # (T, R, 2) [m]
middle = 0.5 * (x + np.roll(x, -1, axis=1))  # link k joins rollers k and k + 1
tension = np.asarray(sol.link_tension)  # (T, L) [N]


def probe(j, along):
    \"\"\"A point on span j, ``along`` of the way from sprocket j to sprocket j + 1: on the
    tangent between the pitch circles (right of the travel: outside the loop).\"\"\"
    a, b = centres[j], centres[(j + 1) % 3]
    d = (b - a) / np.linalg.norm(b - a)
    return a + along * (b - a) + np.array([d[1], -d[0]]) * 0.5 * (radii[j] + radii[(j + 1) % 3])


spans = {}
for j, along in ((0, 0.25), (1, 0.5), (2, 0.5)):
    nearest = np.argmin(np.linalg.norm(middle - probe(j, along), axis=-1), axis=1)
    spans[j] = tension[np.arange(len(t_ms)), nearest]
fig, ax = plt.subplots(1, 2, figsize=(14, 4))
for j, name in ((0, "slack (tensioner)"), (1, "between the cams"), (2, "tight (guide)")):
    (line,) = ax[0].plot(t_ms, spans[j], lw=0.4, alpha=0.5)
    ax[0].plot(
        t_ms, running_mean(spans[j]), lw=2, color=line.get_color(), label=f"span {j}: {name}"
    )
    ax[0].axhline(static[j], color=line.get_color(), ls="--", lw=0.8)
ax[0].set(
    xlabel="time [ms]",
    ylabel="tension [N]",
    title="span tensions (thick: mean over a crank tooth period; dashed: at rest)",
)
ax[0].legend(fontsize=8)
w = np.asarray(sol.sprocket_speed)
for k in (1, 2):
    nominal = w[:, 0] * teeth[0] / teeth[k]
    ax[1].plot(t_ms, (w[:, k] / nominal - 1) * 100, lw=1, label=f"cam {k} (z = {teeth[k]})")
ax[1].set(xlabel="time [ms]", ylabel="speed / (ω₁·z₁/z_k) − 1 [%]", title="cam speeds")
ax[1].legend(fontsize=8)
for a in ax:
    a.grid(True, lw=0.4, alpha=0.5)
fig.tight_layout()"""
    ),
    new_markdown_cell(
        """Over whole revolutions each sprocket turns at ω₁·z₁/z_k on average, and the tight
and slack spans differ by the cams' load (here over the last crank revolution, or the whole
run in fast mode):"""
    ),
    new_code_cell(
        """ts = np.asarray(sol.ts)
last = ts >= ts[-1] - min(revolution, ts[-1] / 2)
for k in (1, 2):
    ratio = w[last, k].mean() / w[last, 0].mean()
    print(f"cam {k}: mean speed / crank speed {ratio:.4f} (z1/zk = {teeth[0] / teeth[k]:.4f})")
for j in range(3):
    print(
        f"span {j}: mean {spans[j][last].mean():6.1f} N (at rest {static[j]:6.1f} N), "
        f"swing {spans[j][last].min():6.1f} to {spans[j][last].max():6.1f} N"
    )
print(
    f"shoe force: mean {float(np.mean(np.asarray(sol.tensioner_force)[last])):.1f} N, "
    f"arm swing {np.ptp(angle[last]):.3f}°"
)"""
    ),
    new_markdown_cell(
        """## 5. Animation
`jc.animate` draws the same frames as `plot_snapshot` (coloured on the whole run's force
scale), the tensioner's arm turning; `player` (defined here) shows the GIF inline with
matplotlib's JavaScript controls (play, step, scrub with the slider). Every 15th save of
the three revolutions: 1.5 ms apart, the crank turning 27° (1.6 teeth) between frames, so
the teeth seem to creep; watch the arm and the rollers' colours."""
    ),
    new_code_cell(
        PLAYER
        + """


path = jc.animate(timing, sol, "timing_drive.gif", stride=100 if FAST else 15, fps=10, dpi=60)
player(path, fps=10)"""
    ),
    new_markdown_cell(
        """## 6. Designing on this drive
Every array in the scene can be differentiated through the solve, and the design objectives
take any sprocket of it: `sprocket=1` designs the first cam's tooth form, the drive
rebuilt and resettled for each profile. On fixed steps (with the widened contact onset
and joint-friction band that fixed steps need) the gradient matches central differences
of the same discrete solve (`tests/test_timing_drive.py`; about a minute and a half on a
2-core CPU, most of it compiling):

```python
import jax.numpy as jnp
from jaxchain.design import DesignSpace, ProfileObjective

law = jc.scenes.roller_law(chain, 0.7, width=3e-6)
joints = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)
design = spec.replace(settle=True, roller_contact=law, joint_friction=joints)
build = lambda p: design.with_sprocket(1, profile=p).build()  # the first cam's tooth
objective = ProfileObjective(
    DesignSpace.iso606(chain, 42), build, t1=1e-4, temperature=20.0, reference=300.0,
    sprocket=1, dt=1e-6,
)
value, grad, members = objective.value_and_grad(jnp.zeros(4))  # N, N per unit u
```

`jc.simulate_ensemble` runs the drive at several crank speeds as one vmapped solve, the
outputs of the tensioner and the guide per member."""
    ),
]


def main():
    return write(CELLS, "05_timing_drive.ipynb")


if __name__ == "__main__":
    main()
