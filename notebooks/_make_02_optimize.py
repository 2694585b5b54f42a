"""Generate notebooks/02_tooth_optimization.ipynb (run: python notebooks/_make_02_optimize.py)."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

cells = [
    new_markdown_cell(
        "# Designing a tooth profile by gradient descent\n\n"
        "The tooth-gap parameters (seating radius, seating angle, flank radius, tip diameter)\n"
        "are reshaped inside the ISO 606 limits to lower the peak roller/tooth contact force\n"
        "of a chain meshing with the sprocket. Gradients come from reverse-mode\n"
        "differentiation through the diffrax solve (and through the static equilibrium the\n"
        "scene starts from). This is what `python -m optimize` runs; here each step is shown.\n\n"
        "`JAXCHAIN_FAST=1` (set by the test suite) runs two iterations on one operating point."
    ),
    new_code_cell(
        "import os\n"
        "import jax\n\n"
        'jax.config.update("jax_enable_x64", True)  # jaxchain never changes JAX config itself\n'
        "import diffrax\n"
        "import equinox as eqx\n"
        "import jax.numpy as jnp\n"
        "import matplotlib.pyplot as plt\n"
        "import numpy as np\n"
        "import optax\n\n"
        "import jaxchain as jc\n"
        "from jaxchain.design import DesignSpace, ProfileObjective\n\n"
        'FAST = os.environ.get("JAXCHAIN_FAST") == "1"\n'
        "ITERATIONS = 2 if FAST else 15\n"
        "SPEEDS = (1.0,) if FAST else (0.9, 1.0, 1.1)"
    ),
    new_markdown_cell(
        "## 1. The design space\n"
        "`DesignSpace.iso606` maps an unconstrained coordinate `u ∈ ℝ⁴` smoothly into the\n"
        "standard's box (`x = lower + (upper − lower)·sigmoid(u)`): any optimizer step stays a\n"
        "standard-conforming profile, and `u = 0` is the middle of every range."
    ),
    new_code_cell(
        'chain = jc.ChainSpec.iso606("08B")\n'
        "z, rpm = 18, 1000.0\n"
        "space = DesignSpace.iso606(chain, z)\n"
        'forms = {f: jc.ToothProfile.iso606(chain, z, f) for f in ("min", "max", "mid")}\n'
        "for name, lo, hi in zip(jc.design.PARAMETERS, space.lower, space.upper):\n"
        '    print(f"{name:15s} {float(lo):.6g} … {float(hi):.6g}")\n'
        'jc.plot_profiles(chain, z, extra={"u = 0 (mid)": space.profile(jnp.zeros(4))});'
    ),
    new_markdown_cell(
        "## 2. The objective\n"
        "One roller meshing from a settled strand (window: the second tooth period), at\n"
        "each operating point (speeds), with a soft maximum of the roller/tooth force\n"
        "integrated by the solver (`soft_peak_force`). Fixed Tsit5 steps make it a smooth\n"
        "function of the profile; the ensemble mean makes it robust."
    ),
    new_code_cell(
        "period = 60.0 / (z * rpm)\n"
        "# contact onset regularized over 3 µm so that 4 µs steps resolve it: then the gradient\n"
        "# converges as the step shrinks (the nominal 10 nm onset is crossed inside one step)\n"
        "law = jc.scenes.roller_law(chain, 0.7)\n"
        "design_law = eqx.tree_at(lambda l: l.width, law, jnp.asarray(3e-6))\n\n"
        "def build(profile):\n"
        "    return [jc.scenes.engagement(chain, z, speed_rpm=rpm * f, profile=profile, n_entry=3,\n"
        "                                 roller_contact=design_law) for f in SPEEDS]\n\n"
        "objective = ProfileObjective(space, build, t1=2 * period, t_start=period,\n"
        "                             temperature=20.0, reference=1000.0, dt=4e-6)\n"
        "value, grad, members = objective.value_and_grad(jnp.zeros(4))\n"
        'print(f"objective at the mid form: {float(value):.1f} N, gradient {np.asarray(grad)}")'
    ),
    new_markdown_cell("## 3. An optax loop"),
    new_code_cell(
        "opt = optax.adam(0.3)\n"
        "u = jnp.zeros(4)\n"
        "state = opt.init(u)\n"
        "history = []\n"
        "for k in range(ITERATIONS):\n"
        "    value, grad, _ = objective.value_and_grad(u)\n"
        "    history.append((np.asarray(u), float(value)))\n"
        '    print(f"{k:3d}  objective {float(value):8.1f} N  |grad| {float(jnp.linalg.norm(grad)):9.3g}")\n'
        "    updates, state = opt.update(grad, state, u)\n"
        "    u = optax.apply_updates(u, updates)\n"
        "u_best, best = min(history, key=lambda h: h[1])\n"
        "optimized = space.profile(u_best)\n"
        "for name, frac in zip(jc.design.PARAMETERS, space.fraction(u_best)):\n"
        '    print(f"{name:15s} at {100 * float(frac):5.1f} % of its ISO range")'
    ),
    new_markdown_cell(
        "## 4. Before and after, re-measured independently\n"
        "A different solver (Dopri8), a tight tolerance, the *sharp* maximum and the nominal\n"
        "contact law: the win must survive outside the smoothed, regularized, fixed-step\n"
        "objective it was found with."
    ),
    new_code_cell(
        "def remeasure(profile):\n"
        "    scene = jc.scenes.engagement(chain, z, speed_rpm=rpm, profile=profile, n_entry=3)\n"
        "    return jc.simulate(scene, 2 * period, solver=diffrax.Dopri8(),\n"
        "                       rtol=1e-7 if FAST else 1e-9, atol=1e-10 if FAST else 1e-12,\n"
        "                       ts=np.linspace(period, 2 * period, 4001), max_steps=400_000)\n\n"
        "fig, ax = plt.subplots(figsize=(8, 4))\n"
        'for name, profile in [("ISO min form", forms["min"]), ("ISO max form", forms["max"]),\n'
        '                      ("optimized", optimized)]:\n'
        "    sol = remeasure(profile)\n"
        "    f = np.asarray(sol.roller_sprocket_force).max(axis=1)\n"
        '    ax.plot(np.asarray(sol.ts) * 1e3, f, label=f"{name}: peak {f.max():.0f} N")\n'
        'ax.set_xlabel("time [ms]"); ax.set_ylabel("largest roller/tooth force [N]")\n'
        "ax.legend();"
    ),
    new_code_cell('jc.plot_profiles(chain, z, extra={"optimized": optimized});'),
    new_markdown_cell(
        "## 5. What to read into it\n"
        "The meshing peak is a rough function of the seating radius at the micrometre scale\n"
        "(the roller rattles in its seat clearance; each rebound's timing moves with the\n"
        "geometry), so gradients are local: the main job averages over operating points, keeps\n"
        "the best iterate, re-measures with a second contact law, and compares with a\n"
        "gradient-free search on the same simulator. See `python -m optimize --help`."
    ),
]

nb = new_notebook(
    cells=cells,
    metadata={"kernelspec": {"name": "python3", "display_name": "Python 3", "language": "python"}},
)
path = Path(__file__).parent / "02_tooth_optimization.ipynb"
nbformat.write(nb, path)
print("wrote", path)
