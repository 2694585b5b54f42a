"""Generate ``notebooks/02_tooth_optimization.ipynb`` (run from anywhere):

    .venv/bin/python notebooks/_make_02_tooth_optimization.py

The notebook shows, step by step, what ``python -m optimize --problem iso`` runs: the
ISO 606 design space, the smooth peak-force objective and its gradient, an optax loop (two iterations on
one operating point with ``JAXCHAIN_FAST=1``, as the test suite sets it) and an independent
re-measurement of the result. This script writes it without outputs;

    .venv/bin/python notebooks/_make_all.py --execute

regenerates all four notebooks and executes them in full mode, storing the outputs (the
form they are committed in).
"""

from nbformat.v4 import new_code_cell, new_markdown_cell

from _write import CACHE, STAMP, X64, write

CELLS = [
    new_markdown_cell(
        """# Designing a tooth profile by gradient descent

The tooth-gap parameters (seating radius, seating angle, flank radius, tip diameter)
are reshaped inside the ISO 606 limits to lower the peak roller/tooth contact force
of a chain meshing with the sprocket. Gradients come from reverse-mode
differentiation through the diffrax solve (and through the static equilibrium the
scene starts from). This is what `python -m optimize --problem iso` runs; here each step
is shown. (The main job's default problem designs a free-form asymmetric tooth over a
band of speeds and chain wear, the same way.)

**What it finds.** Inside the ISO 606 box the best tooth is the box's own minimum form:
the loop below walks towards it (the seating angle to its largest value, the only
parameter the meshing peak feels here), stops after 15 iterations short of it, and its
result re-measures no better than the minimum form (section 4). The main job's measured
runs say the same (section 6): of 70 designs across the box none beats its minimum
form by more than 0.6 %, while the free-form tooth of `python -m optimize`, outside the
box, lowers the worst meshing peak by 20.5 %.

`JAXCHAIN_FAST=1` (set by the test suite) runs two iterations on one operating point."""
    ),
    new_code_cell(
        """import math
import os
from pathlib import Path
import jax

"""
        + X64
        + """import diffrax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
import optax

import jaxchain as jc
"""
        + CACHE
        + STAMP
        + """from jaxchain.design import DesignSpace, ProfileObjective

FAST = os.environ.get("JAXCHAIN_FAST") == "1"
ITERATIONS = 2 if FAST else 15
SPEEDS = (1.0,) if FAST else (0.9, 1.0, 1.1)"""
    ),
    new_markdown_cell(
        """## 1. The design space
`DesignSpace.iso606` maps an unconstrained coordinate `u ∈ ℝ⁴` smoothly into the
standard's box (`x = lower + (upper − lower)·sigmoid(u)`): any optimizer step stays a
standard-conforming profile, and `u = 0` is the middle of every range."""
    ),
    new_code_cell(
        """chain = jc.ChainSpec.iso606("08B")
z, rpm = 18, 1000.0
space = DesignSpace.iso606(chain, z)
forms = {f: jc.ToothProfile.iso606(chain, z, f) for f in ("min", "max", "mid")}
for name, lo, hi in zip(jc.design.PARAMETERS, space.lower, space.upper):
    print(f"{name:15s} {float(lo):.6g} … {float(hi):.6g}")
jc.plot_profiles(chain, z, extra={"u = 0 (mid)": space.profile(jnp.zeros(4))});"""
    ),
    new_markdown_cell(
        """## 2. The objective
One roller meshing from a settled strand (window: the second tooth period), at
each operating point (speeds), with a soft maximum of the roller/tooth force
integrated inside the solve (`soft_peak_force`). Fixed Tsit5 steps make it a smooth
function of the profile; `samples=8` takes the soft maximum's integral by the trapezoid
rule on 8 parts of each step — near an impact's top its integrand is a spike narrower
than the 4 µs step, and sampled this way the gradient converges as the step shrinks. The
ensemble mean makes it robust."""
    ),
    new_code_cell(
        """period = 60.0 / (z * rpm)
# The design model, made for 4 µs fixed steps: the contact onset regularized over 3 µm
# (the nominal 10 nm onset is crossed inside one step) and the joints' friction creep band
# widened to 2 cm/s (the nominal 2 mm/s band sticks within about 1 µs: at 4 µs steps the
# value looks plausible and the gradient is useless). The re-measurement below uses the
# nominal model.
design_law = jc.scenes.roller_law(chain, 0.7, width=3e-6)
nominal_joints = jc.scenes.JOINT_FRICTION
design_joints = jc.contact.CoulombFriction(nominal_joints.coefficient, 2e-2)


def build(profile):
    return [
        jc.scenes.engagement(
            chain,
            z,
            speed_rpm=rpm * f,
            profile=profile,
            n_entry=3,
            model=jc.scenes.ChainModel(roller_contact=design_law, joint_friction=design_joints),
        )
        for f in SPEEDS
    ]


objective = ProfileObjective(
    space,
    build,
    t1=2 * period,
    t_start=period,
    temperature=20.0,
    reference=1000.0,
    dt=4e-6,
    samples=8,
)
value, grad, members = objective.value_and_grad(jnp.zeros(4))
print(f"objective at the mid form: {float(value):.1f} N, gradient {np.asarray(grad)}")"""
    ),
    new_markdown_cell("## 3. An optax loop"),
    new_code_cell(
        """opt = optax.adam(0.3)
u = jnp.zeros(4)
state = opt.init(u)
history = []
for k in range(ITERATIONS):
    value, grad, _ = objective.value_and_grad(u)
    history.append((np.asarray(u), float(value)))
    print(f"{k:3d}  objective {float(value):8.1f} N  |grad| {float(jnp.linalg.norm(grad)):9.3g}")
    updates, state = opt.update(grad, state, u)
    u = optax.apply_updates(u, updates)
u_best, best = min(history, key=lambda h: h[1])
optimized = space.profile(u_best)
u_min = space.coordinates(forms["min"])  # the minimum form (a millionth of each range inside)
at_min = float(objective.value_and_grad(u_min)[0])
print(f"objective at the ISO minimum form: {at_min:.1f} N")
for name, frac, end in zip(jc.design.PARAMETERS, space.fraction(u_best), space.fraction(u_min)):
    print(
        f"{name:15s} at {100 * float(frac):5.1f} % of its ISO range (minimum form: {100 * float(end):.0f} %)"
    )

fig, ax = plt.subplots(1, 2, figsize=(12, 3.8))
ax[0].plot([h[1] for h in history], "o-", label="Adam")
ax[0].axhline(at_min, color="k", ls="--", label=f"ISO minimum form: {at_min:.0f} N")
ax[0].set(xlabel="iteration", ylabel="design objective [N]", title="the objective")
ax[0].legend()
fractions = np.array([np.asarray(space.fraction(u)) for u, _ in history])
for name, f in zip(jc.design.PARAMETERS, fractions.T):
    ax[1].plot(f, "o-", ms=3, label=name)
ax[1].set(
    xlabel="iteration", ylabel="fraction of its ISO range", ylim=(-0.03, 1.03),
    title="the design (minimum form: 0, 1, 1, 1)",
)
ax[1].legend(fontsize=8);"""
    ),
    new_markdown_cell(
        """**What the loop shows.** The objective falls from 1061 N at the middle of the box to
922 N in 15 iterations and is still falling (1.5 N in the last, |grad| 7 N): the loop
stops unconverged. It is walking into the corner of the box that is the ISO minimum
form, where the objective is lower still, 915 N: the seating angle (97.5 % of its range)
and the flank radius (96.6 %) towards their largest, the seating radius (11 %) towards
its smallest. Only the seating angle has a sizeable gradient (−73 N per unit of `u` at
the start, against 0.41 and −0.34 for the two radii); Adam scales each coordinate's step by its own
gradient history, so the radii move as fast, whichever way their small gradients point.
The tip diameter's gradient is exactly zero (the roller never reaches the tip here): it
stays at 50 %. The corner lies at `u = ±∞` on the sigmoid map, so run on, the loop would
keep approaching the minimum form without arriving."""
    ),
    new_markdown_cell(
        """## 4. The ISO forms and the optimized profile, re-measured independently
A different solver (Dopri8), a tight tolerance, the *sharp* maximum and the nominal
contact law: the win must survive outside the smoothed, regularized, fixed-step
objective it was found with."""
    ),
    new_code_cell(
        """def remeasure(profile):
    scene = jc.scenes.engagement(chain, z, speed_rpm=rpm, profile=profile, n_entry=3)
    return jc.simulate(
        scene,
        2 * period,
        solver=diffrax.Dopri8(),
        rtol=1e-6 if FAST else 1e-9,
        atol=1e-9 if FAST else 1e-12,
        ts=np.linspace(period, 2 * period, math.ceil(period / 0.5e-6) + 1),  # every ≤ 0.5 µs
        max_steps=1_000_000,
    )


fig, ax = plt.subplots(figsize=(8, 4))
peaks = {}
for name, profile, style in [
    ("ISO min form", forms["min"], "-"),
    ("ISO max form", forms["max"], "-"),
    ("optimized", optimized, "--"),
]:
    sol = remeasure(profile)
    f = np.asarray(sol.roller_sprocket_force).max(axis=1)
    peaks[name] = f.max()
    ax.plot(np.asarray(sol.ts) * 1e3, f, style, label=f"{name}: peak {f.max():.0f} N")
ax.set_xlabel("time [ms]")
ax.set_ylabel("largest roller/tooth force [N]")
ax.legend()
change = peaks["optimized"] / peaks["ISO min form"] - 1
print(f"optimized against the ISO minimum form: {100 * change:+.1f} % ({rpm:.0f} rpm)")"""
    ),
    new_code_cell('jc.plot_profiles(chain, z, extra={"optimized": optimized});'),
    new_markdown_cell(
        """**What the re-measurement shows.** At 1000 rpm the optimized profile peaks at 1325 N, 0.7 %
*above* the ISO minimum form's 1316 N: its curve (dashed) lies on the minimum form's
over the whole window, apart from a spike of the minimum form's at the window's last
instant (below both peaks), and both stay far below the maximum form's 1657 N. The loop
has found the minimum form's neighbourhood, not a better tooth: its 13 % fall in the
objective is the way from the middle of the box to that corner, and the 0.7 % left is
an unfinished walk measured on a peak that is rough at the micrometre scale (section 6).
In the drawing, the optimized gap follows the minimum form's seat and flanks; only its
tooth tips are lower (the tip diameter left at mid-range), where the roller never goes."""
    ),
    new_markdown_cell(
        """## 5. Beyond the ISO box: free-form flanks and per-gap patterns
`jc.FreeformProfile` gives each side of a gap its own seat angle and a chain of tangent
flank arcs (curvature, break radius), and lets every leaf vary from gap to gap. The ISO
forms are special cases (`from_iso`); here an asymmetric tooth, then a per-gap pattern
of seating radius and gap phase, drawn against the ISO min…max band and as a whole
sprocket (the pattern exaggerated so that it shows)."""
    ),
    new_code_cell(
        """iso = forms["mid"]
a, k = float(iso.seating_angle) / 2, 1 / float(iso.flank_radius)
asym = jc.FreeformProfile.from_iso(
    iso,
    3,
    cw=jc.Flank(a - 0.05, [1.2 * k, k, 0.9 * k], [0.3, 0.6]),
    ccw=jc.Flank(a + 0.03, [0.9 * k, k, k], [0.3, 0.6]),
)
rng = np.random.default_rng(0)
pattern = jc.FreeformProfile.from_iso(  # the same flanks, seats and phases per gap
    iso,
    3,
    cw=asym.cw,
    ccw=asym.ccw,
    seating_radius=float(iso.seating_radius) + rng.uniform(0, 60e-6, z),
    phase=rng.uniform(-1e-3, 1e-3, z),
)
fig, axs = plt.subplots(1, 2, figsize=(12, 5.5))
jc.plot_profiles(chain, z, extra={"asymmetric, 3 arcs per flank": asym}, ax=axs[0])
jc.plot_sprocket(pattern, ax=axs[1]);"""
    ),
    new_markdown_cell(
        """The pattern meshes like any sprocket: the contact reads each roller's two
neighbouring gaps, whatever their shapes. One tooth period of the engagement on it:"""
    ),
    new_code_cell(
        """mesh = jc.scenes.engagement(chain, z, speed_rpm=rpm, profile=pattern)
sol = jc.simulate(mesh, 2 * period)
print(sol.message or "successful", f"peak roller/tooth force {float(sol.peak_contact_force):.0f} N")
jc.plot_forces(sol);"""
    ),
    new_markdown_cell(
        """## 6. What to read into it
Inside the ISO 606 box there is nothing to gain on this scene: the minimum form is the
box's optimum, and an optimizer that starts in the middle of the box can only walk
towards it. The committed runs (`benchmarks/results/`, read below when this notebook
runs from a checkout) re-measured every design with Dopri8 at rtol 1e-9:

* `python -m optimize --problem iso` (`optimize_iso/results.json`; the worst of six
  operating points, 500–1500 rpm, chain new and worn 2 %): the gradient result
  re-measures 1.2 % *above* the minimum form's worst peak (2281 against 2255 N),
  the gradient-free search's 0.2 % above (2258 N): neither beats the minimum form.
* `python -m benchmarks.design_space` (`design_space.json`; this notebook's three
  speeds, 900–1100 rpm): over 70 designs in the box the best is 0.6 % below the minimum
  form (1615 against 1625 N); the seating angle is the parameter that counts (115° →
  135°: 2062 → 1625 N), and the minimum form has the largest.
* `python -m optimize`, the main job's default (`optimize_default/results.json`; the
  same six operating points as `--problem iso`): a free-form asymmetric tooth
  (`jc.FreeformProfile`, section 5's kind, its seat angles and flank curvatures free of
  the ISO box) lowers the worst peak by 20.5 % (2255 →
  1793 N), by 3.1 % under a second contact law, and by 3.3 % in the clearance-joint
  chain, inside that chain's scatter (95 % interval of the difference −152 to +35 N).

The meshing peak is also a rough function of the seating radius at the micrometre scale
(the roller rattles in its seat clearance; each rebound's timing moves with the
geometry), so gradients are local: the main job averages over operating points, keeps
the best iterate, re-measures with a second contact law, and compares with a
gradient-free search on the same simulator. See `python -m optimize --help`."""
    ),
    new_code_cell(
        """import json

RESULTS = Path(jc.__file__).resolve().parents[1] / "benchmarks" / "results"
if not (RESULTS / "optimize_iso" / "results.json").exists():
    print("the committed results are in a checkout of the repository (benchmarks/results/)")
else:
    for run in ("optimize_iso", "optimize_default"):
        s = json.loads((RESULTS / run / "results.json").read_text())["summary"]
        print(
            f"{run}: {s['baseline']} {s['baseline_value']:.0f} N, design "
            f"{s['optimized_value']:.0f} N "
            f"({100 * (s['optimized_value'] / s['baseline_value'] - 1):+.1f} %; {s['method']})"
        )
    iso = json.loads((RESULTS / "optimize_iso" / "results.json").read_text())
    g, m = iso["remeasured"]["gradient"]["johnson"]["peak_N"], iso["summary"]["baseline_value"]
    print(f"optimize_iso, gradient result: {g:.0f} N ({100 * (g / m - 1):+.1f} %)")
    c = json.loads((RESULTS / "optimize_default" / "results.json").read_text())
    c = c["summary"]["clearance"]["members"][0]
    lo, hi = c["difference_ci95_N"]
    print(
        f"optimize_default, clearance-joint chain: {100 * c['improvement']:.1f} % lower, "
        f"difference 95 % interval {lo:+.0f} … {hi:+.0f} N"
    )
    a = json.loads((RESULTS / "design_space.json").read_text())["analysis"]
    print(
        f"design_space: best in the box {a['best']['peak_N']:.0f} N against the minimum "
        f"form's {a['baseline_min_form_N']:.0f} N ({100 * a['best']['reduction_vs_min_form']:.1f} % lower)"
    )"""
    ),
]


def main():
    return write(CELLS, "02_tooth_optimization.ipynb", runs_from=RUNS_FROM)


RUNS_FROM = """**Runs from** any installation of jaxchain with its `optimize` extra (optax; `pip install
-e ".[optimize]"` in a clone), from any directory. Section 6 prints the committed runs'
numbers when jaxchain is installed from a checkout of the repository, and says so
otherwise."""


if __name__ == "__main__":
    main()
