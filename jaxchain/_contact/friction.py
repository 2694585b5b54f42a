"""Regularized Coulomb friction."""

from __future__ import annotations

from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, ArrayLike

from .._numerics import is_concrete
from .base import check_fields
from .friction_base import AbstractFrictionLaw

__all__ = ["CoulombFriction"]


class CoulombFriction(AbstractFrictionLaw):
    """Regularized Coulomb friction, F_t = −μ·F_n·tanh(v_t / v_s).

    Smooth (C^∞) through zero slip; within |v_t| ≲ v_s it behaves like viscous damping
    of coefficient μF_n/v_s, so sticking is approximated by a slow creep of about v_s.
    Reaches 0.76 μF_n at v_t = v_s and 0.995 μF_n at 3v_s.

    Attributes:
        coefficient: μ [-].
        slip_velocity: v_s [m/s], the regularization velocity.
    """

    coefficient: ArrayLike = 0.1
    slip_velocity: ArrayLike = 1e-3

    states_per_contact: ClassVar[int] = 0

    def __check_init__(self):
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("coefficient", lambda v: v >= 0, ">= 0"),
                ("slip_velocity", lambda v: v > 0, "> 0 m/s"),
            ],
        )

    def force(self, normal_force: ArrayLike, slip_velocity: ArrayLike) -> Array:
        """Tangential force [N] opposing ``slip_velocity`` [m/s] (same sign convention)."""
        return (
            -self.coefficient
            * jnp.asarray(normal_force)
            * jnp.tanh(jnp.asarray(slip_velocity) / self.slip_velocity)
        )

    def traction(self, normal_force, slip_velocity, state=None):
        del state
        return self.force(normal_force, slip_velocity)
