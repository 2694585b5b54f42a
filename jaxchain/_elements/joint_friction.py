"""Friction in the articulating joints of the lumped chain."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._contact.friction_base import AbstractFrictionLaw, contact_states, flat_rate
from .._kinematics import perp
from .._numerics import cross2, smooth_ramp
from .base import AbstractElement, Effect
from .pairs import chain_tension

__all__ = ["JointFriction"]


class JointFriction(AbstractElement):
    """Friction in the articulating joints of the lumped chain (whose links have no
    rotational freedom of their own).

    Joint j sits at body ``joint[j]``, between the link from ``before[j]`` and the link
    to ``after[j]``; its pin (radius ``pin_radius``) turns in its bush at the links'
    relative rate Ω = φ̇_after − φ̇_before. The friction moment on the link after is
    M = ``law.force(N·r, r·Ω)`` = −μ·N·r·tanh(r·Ω/v_s), with −M on the link before: the
    pin/bush contact's Coulomb friction at the sliding speed r·Ω of the pin's surface
    (any :class:`~jaxchain.contact.AbstractFrictionLaw`: with a
    :class:`~jaxchain.contact.DahlFriction`, M = −μ·N·r·z/x_s, z the joint's pre-sliding
    state in ``DriveState.bristle``, driven by the sliding speed r·Ω).
    N is the joint's load, the mean tension of the two links (``link_before``,
    ``link_after``: indices into the tension-carrying elements), its positive part
    smoothed over ±``load_width``. Each moment acts as a couple of forces ±M/ℓ across
    its link; the power −M·Ω is never positive. At rest (Ω = 0) it adds nothing, so the
    statics do not change.
    """

    role = "joint_friction"

    before: Int[Array, " J"]
    joint: Int[Array, " J"]
    after: Int[Array, " J"]
    link_before: Int[Array, " J"]
    link_after: Int[Array, " J"]
    law: AbstractFrictionLaw
    pin_radius: Float[Array, ""]
    load_width: Float[Array, ""]

    def n_states(self, scene) -> int:
        return int(np.shape(self.joint)[0]) * self.law.states_per_contact

    reads_tension = True  # the link springs' tensions, as the pair elements carry them

    def effect(self, t, y, scene, state, tension=None) -> Effect:
        if tension is None:
            tension = chain_tension(y, scene)
        body, rate = self.moments(scene.n_bodies, y.q, y.v, tension, state)
        return Effect(body=body, state_rate=rate, report={"friction_power": jnp.sum(body * y.v)})

    def moments(self, n: int, q, v, tension, state=None):
        """(n, 3) generalized forces of the joints' friction moments, each a couple
        ±M/ℓ²·perp(d) at its link's ends, for the tension-carrying elements' tensions
        ``tension`` (E,) [N]; and the rate of its law's states ``state`` (None for a law
        without states)."""
        xa, xj, xb = q[self.before, :2], q[self.joint, :2], q[self.after, :2]
        va, vj, vb = v[self.before, :2], v[self.joint, :2], v[self.after, :2]
        d1, d2 = xj - xa, xb - xj
        l1, l2 = jnp.sum(d1 * d1, -1), jnp.sum(d2 * d2, -1)
        rel_rate = cross2(d2, vb - vj) / l2 - cross2(d1, vj - va) / l1
        mean = 0.5 * (tension[self.link_before] + tension[self.link_after])
        load = smooth_ramp(mean, self.load_width)
        r = self.pin_radius
        z = contact_states(self.law, state, int(np.shape(self.joint)[0]))
        moment = self.law.traction(load * r, r * rel_rate, z)  # on the link after; − before
        rate = flat_rate(self.law.state_rate(z, r * rel_rate))
        f2 = (moment / l2)[:, None] * perp(d2)
        f1 = (moment / l1)[:, None] * perp(d1)
        gen = jnp.zeros((n, 2), q.dtype)
        gen = gen.at[self.after].add(f2).at[self.joint].add(-f2 - f1).at[self.before].add(f1)
        return jnp.concatenate([gen, jnp.zeros((n, 1), q.dtype)], axis=-1), rate
