"""Shared test helpers."""

import jax
import jax.numpy as jnp
import numpy as np


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
    s = np.linspace(-1.0, 1.0, n).reshape((n,) + (1,) * fm.ndim)
    return (fm + 0.5 * (f1 - f0) * s + (0.5 * (f0 + f1) - fm) * s**2).max(axis=0)


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
    import jaxchain._solve as S

    return count_calls(monkeypatch, S, "forces")


def fixed_step_joints():
    """Joint friction for fixed-step solves of a few µs: the nominal μ, its creep band
    widened from 2 mm/s to 20 mm/s (the nominal band sticks over ~1 µs, which an explicit
    step of 4 µs does not follow: the joints chatter and gradients blow up)."""
    import jaxchain as jc

    return jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)


def tooth_period(rpm, z):
    """One tooth period [s] of a sprocket of ``z`` teeth at ``rpm``."""
    return 60.0 / rpm / z
