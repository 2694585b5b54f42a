"""Contact of the rollers with shoes: tensioner shoes riding on their arms, fixed guides.

Every shoe is read in its own layout frame (a tensioner's turned back by its arm's
rotation about the pivot), where its surface is a circular arc of curvature κ through the
middle point ``mid`` with normal ``n`` there. In the frame (ξ along the surface, η along
n) the distance of a point from the arc is

    g = (κ(ξ² + η²) + 2η) / (1 + √((κξ)² + (1 + κη)²)),

exact for any κ ≥ 0 and smooth in κ (g = η for a straight shoe), and the arc length from
the middle to the point's foot is s = atan2(κξ, 1 + κη)/κ (s = ξ for κ = 0). One vmapped
evaluation over the shoes, each checking its ``slots`` nearest rollers.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._numerics import cross2, safe_norm

__all__ = ["ShoeContacts", "shoe_contacts", "shoe_frames", "smoothstep"]


class ShoeContacts(NamedTuple):
    """The roller/shoe contacts of one instant."""

    force: Float[Array, "R 2"]  # total shoe force on each roller [N]
    normal: Float[Array, " R"]  # normal force on each roller, summed over shoes [N]
    resultant: Float[Array, "K 2"]  # force of the chain on each shoe [N]
    arm_torque: Float[Array, " A"]  # torque of the chain on each tensioner arm [N·m]
    depth: Float[Array, "K R"]  # overlap of each roller with each shoe [m] (−1 unchecked)
    gate: Float[Array, "K R"]  # the fade-out factor of each of these contacts (0 unchecked)


def smoothstep(x):
    """C¹ step: 0 for x ≤ 0, 3x² − 2x³ on [0, 1], 1 for x ≥ 1."""
    x = jnp.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def shoe_frames(y, scene):
    """(K,) rotation of each shoe from its layout [rad], (K, 2) its centre of rotation [m]
    and (K,) its angular rate [rad/s] (zeros for the fixed guides)."""
    sh = scene.shoes
    n_guides = sh.count - sh.n_tensioners
    zeros = jnp.zeros(n_guides, sh.mid.dtype)
    if sh.n_tensioners == 0:
        return zeros, jnp.zeros((n_guides, 2), sh.mid.dtype), zeros
    tn = scene.tensioners
    turn = jnp.concatenate([y.arm - tn.layout_angle, zeros])
    pivot = jnp.concatenate([tn.pivot, jnp.zeros((n_guides, 2), sh.mid.dtype)])
    rate = jnp.concatenate([y.arm_rate, zeros])
    return turn, pivot, rate


def _nearest(rel, slots: int):
    d2 = jax.lax.stop_gradient(jnp.sum(rel * rel, -1))
    return jax.lax.top_k(-d2, slots)[1]


def shoe_contacts(y, scene, xr, vr, radius) -> ShoeContacts:
    """Forces of every shoe on the rollers (centres ``xr`` (R, 2), velocities ``vr`` (R,
    2), radius ``radius``) and their reactions on the shoes and arms."""
    sh = scene.shoes
    n_r = xr.shape[0]
    turn, pivot, rate = shoe_frames(y, scene)
    r = radius

    def one(mid, nrm, kappa, half, edge, alpha, piv, omega, friction):
        c, s = jnp.cos(alpha), jnp.sin(alpha)
        # the shoe's middle and normal now (turned by alpha about the pivot)
        mrel = mid - piv
        mid_w = piv + jnp.stack([c * mrel[0] - s * mrel[1], s * mrel[0] + c * mrel[1]])
        n_w = jnp.stack([c * nrm[0] - s * nrm[1], s * nrm[0] + c * nrm[1]])
        t_w = jnp.stack([n_w[1], -n_w[0]])
        sel = jnp.arange(n_r) if sh.slots is None else _nearest(xr - mid_w, sh.slots)
        d = xr[sel] - mid_w
        xi, eta = d @ t_w, d @ n_w
        root = safe_norm(jnp.stack([kappa * xi, 1.0 + kappa * eta], -1))
        g = (kappa * (xi * xi + eta * eta) + 2.0 * eta) / (1.0 + root)
        depth = r - g
        # surface normal at the foot, in (ξ, η), then world
        a_xi, a_eta = kappa * xi / root, (1.0 + kappa * eta) / root
        n_c = a_xi[:, None] * t_w + a_eta[:, None] * n_w
        t_c = jnp.stack([n_c[:, 1], -n_c[:, 0]], -1)
        ang = jnp.arctan2(kappa * xi, 1.0 + kappa * eta)
        k_safe = jnp.where(kappa > 0, kappa, 1.0)
        arc = jnp.where(kappa > 0, ang / k_safe, xi)
        gate = smoothstep((half - jnp.abs(arc)) / edge) * smoothstep((3.0 * r - depth) / r)
        # the contact point on the shoe and its velocity (turning with the arm)
        xc = xr[sel] - r * n_c
        arm_c = xc - piv
        v_surf = omega * jnp.stack([-arm_c[:, 1], arm_c[:, 0]], -1)
        vrel = vr[sel] - v_surf
        approach = -jnp.sum(n_c * vrel, -1)
        fn = sh.law.normal_force(depth, approach, scene.impact_speed) * gate
        f = fn[:, None] * n_c
        if friction is not None:
            slip = jnp.sum(t_c * vrel, -1)
            f = f + friction.force(fn, slip)[:, None] * t_c
        return (
            jnp.zeros_like(xr).at[sel].add(f),
            jnp.zeros(n_r, fn.dtype).at[sel].add(fn),
            -jnp.sum(f, axis=0),
            jnp.sum(cross2(arm_c, -f)),
            jnp.full(n_r, -1.0, fn.dtype).at[sel].set(depth),
            jnp.zeros(n_r, fn.dtype).at[sel].set(gate),
        )

    f, fn, pull, torque, depth, gate = jax.vmap(one)(
        sh.mid, sh.normal, sh.curvature, sh.half_length, sh.edge, turn, pivot, rate, sh.friction
    )
    return ShoeContacts(
        force=jnp.sum(f, axis=0),
        normal=jnp.sum(fn, axis=0),
        resultant=pull,
        arm_torque=torque[: sh.n_tensioners],
        depth=depth,
        gate=gate,
    )
