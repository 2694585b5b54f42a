"""Dahl friction: Coulomb friction with an elastic pre-sliding state of bounded stiffness."""

from __future__ import annotations

from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike

from .._numerics import is_concrete
from .base import check_fields
from .friction_base import AbstractFrictionLaw

__all__ = ["DahlFriction"]


class DahlFriction(AbstractFrictionLaw):
    """Coulomb friction with a bristle state (Dahl's model, smoothed, with LuGre's bristle
    damping):

        F_t = −μ·F_n·(z + τ_b·ż)/x_s,    ż = v_t − √(v_t² + ε²)·z/x_s.

    z [m] is the contact's pre-sliding deflection: while the contact sticks it follows
    the tangential displacement (ż ≈ v_t), so the friction force is a spring of stiffness
    μ·F_n/x_s; once the contact has slid a few x_s one way, z settles at x_s·v_t/√(v_t² +
    ε²) and the force at −μ·F_n·sign(v_t), Coulomb's. |z| never exceeds x_s. The bristle
    damping τ_b damps the stick spring (undamped, a stuck roller would ring in its bush at
    √(μ·F_n/(x_s·m))); it vanishes in steady sliding (ż = 0), so it adds no viscous drag.

    Why a state: the velocity-regularized law −μ·F_n·tanh(v_t/v_s)
    (:class:`CoulombFriction`) acts near zero slip as a damper of rate μ·F_n/v_s, which on a
    chain roller of a few grams gives time constants of tens of nanoseconds
    (m/(μ·F_n/v_s)), the stiffest part of a clearance-joint chain by two orders of
    magnitude. Here the stiffness is bounded: the stick spring μ·F_n/x_s and the state's
    relaxation rate |v_t|/x_s, both set by a length x_s rather than a velocity. As x_s →
    0 the law tends to Coulomb's with true sticking (no creep: only ε/x_s, a slow drift).

    Everything is C^∞ in the state, the slip and the normal force; the force is exactly
    linear in F_n, so an unloaded contact carries no friction whatever z holds.

    Attributes:
        coefficient: μ [-].
        presliding: x_s [m], the pre-sliding displacement (steel contacts: 1–10 µm).
        creep_velocity: ε [m/s], the smoothing of |v_t| (C^∞ at zero slip; at rest z
            relaxes at the slow rate ε/x_s).
        damping: τ_b [s], the bristle damping time: the stick spring μ·F_n/x_s with the
            damper μ·F_n·τ_b/x_s beside it: damping ratio τ_b·√(μ·F_n/(x_s·m))/2, 0.4 for
            the default on an 08B roller in its bush at 1 kN (m ≈ 0.74 g, the contact's
            tangential effective mass).
    """

    coefficient: ArrayLike = 0.1
    presliding: ArrayLike = 5e-6
    creep_velocity: ArrayLike = 1e-4
    damping: ArrayLike = 5e-6

    states_per_contact: ClassVar[int] = 1

    def __check_init__(self):
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("coefficient", lambda v: v >= 0, ">= 0"),
                ("presliding", lambda v: v > 0, "> 0 m"),
                ("creep_velocity", lambda v: v > 0, "> 0 m/s"),
                ("damping", lambda v: v >= 0, ">= 0 s"),
            ],
        )

    def force(
        self, normal_force: ArrayLike, deflection: ArrayLike, slip_velocity: ArrayLike = 0.0
    ) -> Array:
        """Tangential force [N] of the contact with bristle ``deflection`` z [m] at slip
        velocity ``slip_velocity`` v_t [m/s] (same sign convention as the slip: it opposes
        a slip that has built z up)."""
        z = jnp.asarray(deflection)
        spring = z + jnp.asarray(self.damping) * self.rate(z, slip_velocity)
        return -self.coefficient * jnp.asarray(normal_force) * spring / self.presliding

    def rate(self, deflection: ArrayLike, slip_velocity: ArrayLike) -> Array:
        """ż [m/s] at slip velocity ``slip_velocity`` v_t [m/s]."""
        v = jnp.asarray(slip_velocity)
        speed = jnp.sqrt(v * v + jnp.asarray(self.creep_velocity) ** 2)
        return v - speed * jnp.asarray(deflection) / self.presliding

    def traction(self, normal_force, slip_velocity, state):
        return self.force(normal_force, state, slip_velocity)

    def state_rate(self, state, slip_velocity):
        return self.rate(state, slip_velocity)
