"""Two-point force elements: the lumped chain's link springs and the clearance chain's
revolute clearance joints (pin/bush, bush/roller), with the joints' contact friction."""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._contact.base import AbstractContactLaw
from .._contact.film_base import AbstractFilmLaw
from .._contact.friction_base import AbstractFrictionLaw, contact_states, flat_rate
from .._contact.stiffness import tangent_stiffness
from .._kinematics import perp, points, rot, scatter
from .._numerics import cross2, safe_norm, safe_normalize
from .base import AbstractElement, Effect, chain_tension

__all__ = ["LinkSprings", "ClearanceJoints", "PairGroup", "chain_tension"]


class LinkSprings(eqx.Module):
    """Bilateral spring-dampers (the elastic links of the lumped chain).

    Tension T = k·(ℓ − ℓ₀) + c·ℓ̇ [N] (> 0 pulls the two points together).
    """

    stiffness: Float[Array, ...]
    damping: Float[Array, ...]
    rest_length: Float[Array, ...]

    def tension(self, length, rate, impact_speed):
        del impact_speed
        return self.stiffness * (length - self.rest_length) + self.damping * rate

    def stored(self, length):
        """Elastic energy at ``length`` [J]."""
        return 0.5 * self.stiffness * (length - self.rest_length) ** 2

    def tangent(self, force):
        """Largest stiffness [N/m] (linear springs: at any force)."""
        del force
        return jnp.max(self.stiffness)


class ClearanceJoints(eqx.Module):
    """Revolute clearance joints: a pin (point a) inside a hole (point b).

    The eccentricity ℓ = |x_b − x_a| is the pin's offset from the hole centre; contact when
    ℓ exceeds the radial clearance, with ``law`` (e.g. Johnson's conformal law, whose
    ``clearance`` field is the radial clearance). Tension T = law(ℓ − c, ℓ̇) ≥ 0.

    With ``friction``, the contact also carries a tangential force at the contact point,
    against the sliding of the pin's surface (radius ``radius``) on the hole's (radius
    ``radius + clearance``): the joint's friction moment, about μ·T·radius while it
    articulates. A law with states of its own (``states_per_contact``; one pre-sliding
    deflection for a :class:`~jaxchain.contact.DahlFriction`) keeps them per joint in
    ``DriveState.bristle``.

    With ``film`` (a :class:`~jaxchain.contact.AbstractFilmLaw`, e.g.
    :class:`~jaxchain.contact.OilFilm`), the joint is lubricated: the film's pressure
    force and shear torque act beside the dry contact, which still takes the load where
    the film breaks down (mixed lubrication), with its friction on the contact force only
    (the boundary friction of the asperities); the film's own friction is its shear.
    ``length`` [m] is the film's axial length.
    """

    law: AbstractContactLaw
    clearance: Float[Array, ""]
    friction: AbstractFrictionLaw | None = None
    radius: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))
    film: AbstractFilmLaw | None = None
    length: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))

    def tension(self, length, rate, impact_speed):
        return self.law.normal_force(length - self.clearance, rate, impact_speed)

    def stored(self, length):
        """Elastic energy of the contact at eccentricity ``length`` [J]."""
        return self.law.potential(length - self.clearance)

    def tangent(self, force):
        """Contact stiffness [N/m] at ``force`` [N]."""
        return tangent_stiffness(self.law, force)


class _PairState(NamedTuple):
    tension: Array  # (P,) [N]
    u: Array  # (P, 2) unit direction a→b
    arm_a: Array  # (P, 2) point a from its body's origin
    arm_b: Array
    dv: Array  # (P, 2) velocity of point b minus point a
    film: Array | None = None  # (P, 2) a lubricated joint's film force on the journal a [N]
    film_torque: Array | None = None  # (P, 2) the film's torques on a and on b [N·m]

    @property
    def chain_tension(self) -> Array:
        """(P,) the force pulling a toward b [N]: the contact's, plus the film's part
        along a→b in a lubricated joint."""
        if self.film is None:
            return self.tension
        return self.tension + jnp.sum(self.film * self.u, -1)


class PairGroup(AbstractElement):
    """Force elements between a point on body ``a`` and a point on body ``b``.

    Attributes:
        a, b: body indices (P,).
        ra, rb: the points in the bodies' own frames (P, 2) [m].
        element: the force law (LinkSprings or ClearanceJoints), fields scalar or (P,).
        carries_tension: whether these elements transmit the chain's tension (links and
            pin/bush joints), reported as link tension; False for bush/roller joints.
    """

    role = "pairs"

    a: Int[Array, " P"]
    b: Int[Array, " P"]
    ra: Float[Array, "P 2"]
    rb: Float[Array, "P 2"]
    element: LinkSprings | ClearanceJoints
    carries_tension: bool = eqx.field(static=True, default=True)

    @property
    def count(self) -> int:
        return int(np.shape(self.a)[0])

    @property
    def lubricated(self) -> bool:
        """Whether these are clearance joints with an oil film."""
        return isinstance(self.element, ClearanceJoints) and self.element.film is not None

    def dry(self) -> PairGroup:
        """These elements without their joints' oil film (the same, if they have none)."""
        if not self.lubricated:
            return self
        return eqx.tree_at(lambda g: g.element.film, self, None)

    def state(self, q, v, impact_speed, cs=None) -> _PairState:
        """Tensions, unit directions a→b, lever arms and relative velocity."""
        xa, va, arm_a = points(q, v, self.a, self.ra, cs)
        xb, vb, arm_b = points(q, v, self.b, self.rb, cs)
        d = xb - xa
        u = safe_normalize(d, jnp.array([1.0, 0.0], dtype=q.dtype))
        rate = jnp.sum(u * (vb - va), axis=-1)
        tension = self.element.tension(safe_norm(d), rate, impact_speed)
        el = self.element
        if not isinstance(el, ClearanceJoints) or el.film is None:
            return _PairState(tension, u, arm_a, arm_b, vb - va)
        film, torque = self._film(el, -d, va - vb, v[self.a, 2], v[self.b, 2])
        return _PairState(tension, u, arm_a, arm_b, vb - va, film, torque)

    @staticmethod
    def _film(el: ClearanceJoints, e, e_rate, spin_a, spin_b):
        """Film force on the journal (P, 2) and the film's torques (P, 2) on the journal
        and on the bearing, from the journal's offset ``e`` from the bearing centre and its
        rate in world axes; the offset's rate seen from the bearing removes the bearing's
        turning (ė − ω_b·ẑ×e). The torques balance the pair's angular momentum
        (:class:`~jaxchain.contact.AbstractFilmLaw`)."""
        seen = e_rate - spin_b[:, None] * perp(e)
        spin = spin_a - spin_b
        film = el.film.force(e, seen, spin, el.clearance, el.radius, el.length)
        shear = el.film.friction_torque(e, spin, el.clearance, el.radius, el.length)
        half = 0.5 * cross2(e, film)
        return film, jnp.stack([shear - half, -shear - half], -1)

    def n_states(self, scene) -> int:
        el = self.element
        if not isinstance(el, ClearanceJoints) or el.friction is None:
            return 0
        return self.count * el.friction.states_per_contact

    def effect(self, t, y, scene, state) -> Effect:
        n = scene.n_bodies
        ps = self.state(y.q, y.v, scene.impact_speed, rot(y.q[:, 2]))
        f = ps.tension[:, None] * ps.u
        body = scatter(n, self.a, ps.arm_a, f) + scatter(n, self.b, ps.arm_b, -f)
        rate, report, losses = None, None, None
        el = self.element
        if isinstance(el, ClearanceJoints) and el.friction is not None:
            losses, rate = self.friction_forces(n, ps, y.v, state)
        if ps.film is not None:
            film = self.film_forces(n, ps)
            losses = film if losses is None else losses + film
        if losses is not None:
            body = body + losses
            report = {"friction_power": jnp.sum(losses * y.v)}
        return Effect(
            body=body,
            state_rate=rate,
            tension=ps.chain_tension if self.carries_tension else None,
            report=report,
        )

    def film_forces(self, n: int, ps: _PairState) -> Array:
        """(n, 3) generalized forces of a lubricated joint's film: its force through the
        journal's centre (point a) and the opposite through the bearing's (point b), and
        its torques on both."""
        on_a = scatter(n, self.a, ps.arm_a, ps.film)
        gen = on_a + scatter(n, self.b, ps.arm_b, -ps.film)
        torque = jax.ops.segment_sum(ps.film_torque[:, 0], self.a, num_segments=n)
        torque = torque + jax.ops.segment_sum(ps.film_torque[:, 1], self.b, num_segments=n)
        return gen.at[:, 2].add(torque)

    def friction_forces(self, n: int, ps: _PairState, v, bristle=None):
        """Generalized forces of a clearance joint's contact friction: the tangential force
        at the contact point (where the pin at a touches the hole around b, on the side
        −u), against the sliding of the pin's surface on the hole's; and the rate of its
        law's states ``bristle`` (None for a law without states)."""
        el = self.element
        r_pin, r_hole = el.radius, el.radius + el.clearance
        tang = perp(ps.u)
        slip = -jnp.sum(ps.dv * tang, -1) - v[self.a, 2] * r_pin + v[self.b, 2] * r_hole
        z = contact_states(el.friction, bristle, self.count)
        ft = el.friction.traction(ps.tension, slip, z)[:, None] * tang
        rate = flat_rate(el.friction.state_rate(z, slip))
        on_a = scatter(n, self.a, ps.arm_a - r_pin * ps.u, ft)
        return on_a + scatter(n, self.b, ps.arm_b - r_hole * ps.u, -ft), rate

    def energy(self, t, y, scene) -> Array:
        xa, _, _ = points(y.q, y.v, self.a, self.ra)
        xb, _, _ = points(y.q, y.v, self.b, self.rb)
        return jnp.sum(self.element.stored(safe_norm(xb - xa)))

    def max_stiffness(self, scene, force) -> Array:
        return self.element.tangent(force)

    def tensions(self, y, scene, cs=None) -> Array:
        """(P,) the force pulling each a toward its b [N] (``chain_tension`` reads the
        tension-carrying groups')."""
        return self.state(y.q, y.v, scene.impact_speed, cs).chain_tension
