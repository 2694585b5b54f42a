"""Points on the chain's bodies and forces applied at them: the kinematics every force
element shares (positions and velocities of body-fixed points, forces scattered back onto
bodies as generalized forces)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array

from ._numerics import cross2

__all__ = ["rot", "points", "scatter", "perp", "nearest"]


def rot(phi):
    """(cos φ, sin φ) of the bodies' angles."""
    return jnp.cos(phi), jnp.sin(phi)


def points(q, v, body, offset, cs=None):
    """World position, velocity and arm (from the body's origin) of body-fixed points
    ``offset`` (P, 2) on bodies ``body`` (P,); ``cs``: (cos, sin) of every body's angle
    when the caller has them (trig once per body, not once per point)."""
    c, s = rot(q[body, 2]) if cs is None else (cs[0][body], cs[1][body])
    arm = jnp.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1]], -1)
    w = v[body, 2:3]
    x = q[body, :2] + arm
    xd = v[body, :2] + w * jnp.stack([-arm[:, 1], arm[:, 0]], -1)
    return x, xd, arm


def scatter(n: int, body, arm, f) -> Array:
    """(n, 3) generalized forces (fx, fy, τ) of point forces ``f`` (P, 2) applied at arms
    ``arm`` (P, 2) from the origins of bodies ``body`` (P,), summed per body."""
    gen = jnp.concatenate([f, cross2(arm, f)[:, None]], axis=-1)
    return jax.ops.segment_sum(gen, body, num_segments=n)


def perp(d):
    """``d`` turned by +90°."""
    return jnp.stack([-d[..., 1], d[..., 0]], -1)


def nearest(rel, slots: int):
    """Indices of the ``slots`` points nearest the origin (``rel``: (P, 2) from it), and
    the squared distance of the farthest of them (no gradient: a selection)."""
    d2 = jax.lax.stop_gradient(jnp.sum(rel * rel, -1))
    neg, sel = jax.lax.top_k(-d2, slots)
    return sel, -jnp.min(neg)
