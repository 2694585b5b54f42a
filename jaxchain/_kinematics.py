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


def tangent_normal(ca, ra, sa, cb, rb, sb):
    """World angle [rad] of the outward unit normal n of the chain's straight run from
    circle a to circle b (centres (…, 2), radii, senses ±1: +1 inside the loop, wrapped
    counter-clockwise): n·(c_b − c_a) = s_a·r_a − s_b·r_b, n the right-hand normal of the
    travel direction a → b."""
    d = cb - ca
    ratio = (sa * ra - sb * rb) / jnp.sqrt(jnp.sum(d * d, -1))
    return jnp.arctan2(d[..., 1], d[..., 0]) - jnp.arccos(jnp.clip(ratio, -1.0, 1.0))


def span_segments(scene):
    """(J, 2, 2) the free spans of a closed drive as segments between the tangent points of
    consecutive pitch circles (span j from sprocket j to j + 1; a sprocket running
    clockwise lies outside the loop), or None for a scene that is not a closed drive."""
    n = len(scene.sprockets)
    if scene.anchors is not None or n < 2:
        return None
    c = jnp.stack([s.centre for s in scene.sprockets])
    r = jnp.stack([jnp.asarray(s.profile.pitch_radius) for s in scene.sprockets])
    sense = jnp.asarray([float(s.sense) for s in scene.sprockets])
    a = jnp.arange(n)
    b = (a + 1) % n
    beta = tangent_normal(c[a], r[a], sense[a], c[b], r[b], sense[b])
    normal = jnp.stack([jnp.cos(beta), jnp.sin(beta)], -1)
    ends = (c[a] + (sense[a] * r[a])[:, None] * normal, c[b] + (sense[b] * r[b])[:, None] * normal)
    return jnp.stack(ends, 1)


def span_tension(xr, link_tension, scene) -> Array | None:
    """(J,) the mean tension [N] of the links in each free span of a closed drive (links
    whose midpoints lie beyond every sprocket's reach, each given to the nearest span
    segment of :func:`span_segments`; a span with none of them: its link nearest the
    segment's middle), from roller centres ``xr`` (R, 2) and ``link_tension`` (L,), link
    l joining rollers l and l + 1; None for a scene that is not a closed drive."""
    seg = span_segments(scene)
    if seg is None or xr.shape[0] != link_tension.shape[0] or xr.shape[0] == 0:
        return None
    mid = 0.5 * (xr + jnp.roll(xr, -1, axis=0))
    pitch = scene.sprockets[0].profile.pitch
    reach = jnp.stack([s.profile.reach_radius for s in scene.sprockets]) + 0.5 * pitch
    c = jnp.stack([s.centre for s in scene.sprockets])
    free = jnp.all(jnp.sum((mid[:, None] - c[None]) ** 2, -1) > reach**2, axis=1)
    p, q = seg[:, 0], seg[:, 1]
    u = q - p
    s = jnp.clip(jnp.sum((mid[:, None] - p[None]) * u[None], -1) / jnp.sum(u * u, -1), 0.0, 1.0)
    near = p[None] + s[..., None] * u[None]
    dist = jnp.sum((mid[:, None] - near) ** 2, -1)  # (L, J)
    mine = (jnp.argmin(dist, axis=1)[:, None] == jnp.arange(seg.shape[0])[None]) & free[:, None]
    count = jnp.sum(mine, 0)
    middle = jnp.argmin(jnp.sum((mid[:, None] - 0.5 * (p + q)[None]) ** 2, -1), axis=0)
    mean = jnp.sum(mine * link_tension[:, None], 0) / jnp.maximum(count, 1)
    return jnp.where(count > 0, mean, link_tension[middle])
