"""Shared test helpers."""

import jax
import jax.numpy as jnp
import numpy as np

# the chain model's fields into model=, as the studies gather a scene's keywords
from benchmarks.common import modelled  # noqa: F401  (tests import it from here)


def central_fd(f, x, h):
    """Central finite-difference gradient of scalar f at x (any shape), step h."""
    x = np.asarray(x, dtype=float)
    g = np.zeros_like(x)
    for i in np.ndindex(x.shape):
        e = np.zeros_like(x)
        e[i] = h
        g[i] = (float(f(jnp.asarray(x + e))) - float(f(jnp.asarray(x - e)))) / (2 * h)
    return g


def brute_parabola_max(f0, fm, f1, n=2001):
    """Max of the parabola through samples (f0, fm, f1) at s = −1, 0, 1 over s ∈ [−1, 1], by
    brute force on an ``n``-point grid; elementwise over arrays of any (equal) shape."""
    f0, fm, f1 = (np.asarray(x, dtype=float) for x in (f0, fm, f1))
    b, c = 0.5 * (f1 - f0), 0.5 * (f0 + f1) - fm
    grid = np.linspace(-1.0, 1.0, n)
    out = np.full(fm.shape, -np.inf)
    for i in range(0, n, 64):  # 64 grid points at a time: no (n, ...) temporary
        s = grid[i : i + 64].reshape((-1,) + (1,) * fm.ndim)
        np.maximum(out, (fm + b * s + c * s**2).max(axis=0), out=out)
    return out


def tree_allclose(a, b, rtol=1e-7, atol=0.0):
    la, lb = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    return len(la) == len(lb) and all(
        np.allclose(np.asarray(x), np.asarray(y), rtol=rtol, atol=atol)
        for x, y in zip(la, lb, strict=True)
    )


def count_calls(monkeypatch, module, name):
    """A list that grows by one each time ``module.name`` is called (traced, when jitted)."""
    calls = []
    real = getattr(module, name)

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, counting)
    return calls


def count_vector_field_calls(monkeypatch):
    """A list that grows by one each time the one solve (``simulate``, ensembles, design
    objectives) traces (calls) the drive's forces in its vector field."""
    import jaxchain._solve.solve as S

    return count_calls(monkeypatch, S, "forces")


def count_objective_traces(monkeypatch):
    """A list that grows by one each time a design objective's program traces a member
    (``_member``, which every objective program calls first): a retrace of the objective
    counts even where the solve inside it comes from JAX's cache of traces, which
    :func:`count_vector_field_calls` does not see."""
    import jaxchain._design.objective as O

    return count_calls(monkeypatch, O, "_member")


def own_program_store(monkeypatch, folder):
    """Point jaxchain's store of traced programs (jaxchain/_programs.py) at ``folder``, an
    empty folder of the test's own, for what the test calls next. The store conftest.py
    turns on is shared by every run: a program an earlier run wrote is read back there
    without tracing, so a call that should have reused this process's program but got a
    new one (a retrace) would go unseen from the second run on. With a store of its own
    such a call traces, and the trace counters see it; a call that reuses a program this
    process already holds (in memory, whichever folder) costs nothing."""
    monkeypatch.setenv("JAXCHAIN_PROGRAM_STORE", str(folder))


def fixed_step_joints():
    """Joint friction for fixed-step solves of a few µs: the nominal μ, its creep band
    widened from 2 mm/s to 20 mm/s (the nominal band sticks over ~1 µs, which an explicit
    step of 4 µs does not follow: the joints chatter and gradients blow up)."""
    import jaxchain as jc

    return jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)


def tooth_period(rpm, z):
    """One tooth period [s] of a sprocket of ``z`` teeth at ``rpm``."""
    return 60.0 / rpm / z


def energy_balance_error(scene, t1: float, n_save: int) -> tuple[float, float]:
    """Largest |Δ(stored energy) − driver work + load work| over [0, t1] relative to the
    largest driver work [J], and that work: a dissipation-free drive's mechanical energy
    (every component of ``jc.energy``) changes exactly by the driver's work ∫ −τ_chain·ω1 dt
    less the work the loads take out, ∫ Σ τ_load,k·ω_k dt (trapezoid rule over ``n_save``
    saves of a tight adaptive solve of ``jc.vector_field``)."""
    import diffrax

    import jaxchain as jc
    from jaxchain._dynamics import forces

    ts = jnp.linspace(0.0, t1, n_save)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(jc.vector_field),
        diffrax.Tsit5(),
        0.0,
        t1,
        None,
        jc.initial_state(scene),
        args=scene,
        saveat=diffrax.SaveAt(ts=ts),
        stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-13),
        max_steps=500_000,
    )

    # jitted: an eager vmap over the saved states dispatches (and batches) op by op
    def parts(t, y):
        sprockets = enumerate(scene.sprockets)
        load = sum(s.load(t, y.theta[k], y.omega[k]) * y.omega[k] for k, s in sprockets)
        return jc.energy(t, y, scene), forces(t, y, scene).sprocket_torque[0], load

    e, torque, load = jax.jit(jax.vmap(parts))(ts, sol.ys)
    total = np.asarray(sum(e.values()))
    power = -np.asarray(torque) * float(scene.sprockets[0].speed) - np.asarray(load)
    dt = float(ts[1] - ts[0])
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * dt)])
    scale = float(np.abs(work).max())
    return float(np.abs((total - total[0]) - work).max() / scale), scale


# a dissipation-free 9/18 drive (energy balances close on it)
FREE_DRIVE = dict(
    teeth=(9, 18),
    n_links=40,
    speed_rpm=600,
    pretension=300.0,
    restitution=1.0,
    link_damping=0.0,
    joint_friction=None,
)
