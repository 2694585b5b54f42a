"""Shoes the chain slides on (tensioner shoes riding on their arms, fixed guides) and
their contact with the rollers.

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

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._contact.base import AbstractContactLaw
from .._contact.friction_base import AbstractFrictionLaw
from .._contact.stiffness import tangent_stiffness
from .._kinematics import nearest, points, scatter
from .._numerics import cross2, safe_norm
from .base import AbstractElement, Effect
from .tensioners import arm_coordinates

__all__ = ["Shoes", "ShoeContacts", "shoe_contacts", "shoe_frames", "smoothstep"]


class Shoes(AbstractElement):
    """Shoes the chain slides on: tensioner shoes (the first ``n_tensioners``, shoe k on
    arm k, turning with it about its pivot) then fixed guides.

    Each shoe's working surface is a circular arc of curvature κ (a straight line for κ =
    0), given at the layout (arm at ``Tensioners.layout_angle``) by its middle point, the
    unit normal there (pointing from the shoe to the chain) and its half length along
    the surface. A roller of radius r whose centre lies at distance g from the surface
    (on the chain side) overlaps it by δ = r − g and is pushed by ``law`` along the
    surface normal, with ``friction`` against its sliding along the surface. The force
    is faded out smoothly (C¹) over ``edge`` [m] at the shoe's ends, and over a roller
    radius for centres deeper than two roller radii behind the surface (the shoe's back:
    no roller reaches it).

    Attributes:
        mid: (K, 2) middle point of the surface [m], world frame at the layout.
        normal: (K, 2) unit surface normal at the middle, toward the chain.
        curvature: (K,) κ [1/m], ≥ 0 (convex toward the chain; 0: straight).
        half_length: (K,) half the surface's length [m], measured along it.
        edge: (K,) fade-out length at the ends [m].
        law: normal contact law of roller and shoe (every shoe).
        friction: roller/shoe friction, its fields (K,) (one per shoe), or None.
        n_tensioners: how many of the shoes ride on tensioner arms (static).
        slots: rollers checked per shoe, the nearest to its middle; None: all (static).
            ``simulate`` reports ``Result.contact_slots_exceeded`` if the farthest slot
            ever comes within half a shoe's length + 1.05 roller radii of its middle.
    """

    role = "shoes"

    mid: Float[Array, "K 2"]
    normal: Float[Array, "K 2"]
    curvature: Float[Array, " K"]
    half_length: Float[Array, " K"]
    edge: Float[Array, " K"]
    law: AbstractContactLaw
    friction: AbstractFrictionLaw | None
    n_tensioners: int = eqx.field(static=True)
    slots: int | None = eqx.field(static=True)

    def __check_init__(self):
        k = self.slots
        if k is not None and (isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1):
            raise ValueError(
                f"Shoes: slots must be an integer >= 1 or None (check every roller), got {k!r}"
            )

    @property
    def count(self) -> int:
        return int(np.shape(self.mid)[0])

    def effect(self, t, y, scene, state) -> Effect:
        xr, vr, arm = points(y.q, y.v, scene.roller_body, scene.roller_offset)
        sc = shoe_contacts(y, scene, xr, vr, scene.roller_radius, self)
        return Effect(
            body=scatter(scene.n_bodies, scene.roller_body, arm, sc.force),
            arm_torque=sc.arm_torque if self.n_tensioners else None,
            report={
                "shoe_normal": sc.normal,
                "shoe_force": sc.resultant,
                "arm_torque": sc.arm_torque,
            },
        )

    def energy(self, t, y, scene) -> Array:
        xr, vr, _ = points(y.q, y.v, scene.roller_body, scene.roller_offset)
        sc = shoe_contacts(y, scene, xr, vr, scene.roller_radius, self)
        return jnp.sum(self.law.potential(sc.depth) * sc.gate)

    def outputs(self, t, y, scene, effect: Effect) -> dict[str, Array]:
        na = self.n_tensioners
        magnitude = safe_norm(effect.report["shoe_force"])
        out = {"roller_shoe_force": effect.report["shoe_normal"], "guide_force": magnitude[na:]}
        if na:
            out["tensioner_force"] = magnitude[:na]
        return out

    def max_stiffness(self, scene, force) -> Array:
        return tangent_stiffness(self.law, force)

    def slots_ok(self, y, scene) -> Array:
        """The farthest roller checked lies beyond half the shoe's length + 1.05 roller
        radii from its middle (a roller touching it lies within half its length of the
        middle along it, and within a roller radius of its face), or every roller is
        checked."""
        n_r = scene.n_rollers
        if self.slots is None or self.slots >= n_r:
            return jnp.asarray(True)
        xr, _, _ = points(y.q, y.v, scene.roller_body, scene.roller_offset)
        r = scene.roller_radius
        turn, pivot, _ = shoe_frames(y, scene)

        def one(mid, half, alpha, piv):
            c, s = jnp.cos(alpha), jnp.sin(alpha)
            rel = mid - piv
            mid_now = piv + jnp.stack([c * rel[0] - s * rel[1], s * rel[0] + c * rel[1]])
            return nearest(xr - mid_now, self.slots)[1] > (half + 1.05 * r) ** 2

        return jnp.all(jax.vmap(one)(self.mid, self.half_length, turn, pivot))


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
    angle, rate = arm_coordinates(y, sh.n_tensioners)
    turn = jnp.concatenate([angle - tn.layout_angle, zeros])
    pivot = jnp.concatenate([tn.pivot, jnp.zeros((n_guides, 2), sh.mid.dtype)])
    rate = jnp.concatenate([rate, zeros])
    return turn, pivot, rate


def shoe_contacts(y, scene, xr, vr, radius, shoes=None) -> ShoeContacts:
    """Forces of every shoe (``shoes``, default the scene's) on the rollers (centres
    ``xr`` (R, 2), velocities ``vr`` (R, 2), radius ``radius``) and their reactions on the
    shoes and arms."""
    sh = scene.shoes if shoes is None else shoes
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
        sel = jnp.arange(n_r) if sh.slots is None else nearest(xr - mid_w, sh.slots)[0]
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
            f = f + friction.traction(fn, slip, None)[:, None] * t_c
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
