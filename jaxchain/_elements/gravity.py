"""Gravity on the chain's bodies."""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .base import AbstractElement, Effect

__all__ = ["Gravity"]


class Gravity(AbstractElement):
    """Uniform gravity ``acceleration`` (2,) [m/s²] on every chain body's mass; its energy
    is −Σ m·g·x."""

    role = "gravity"

    acceleration: Float[Array, 2]
    energy_kind = "gravity"

    def effect(self, t, y, scene, state) -> Effect:
        body = jnp.zeros_like(y.q).at[:, :2].add(scene.mass[:, None] * self.acceleration)
        return Effect(body=body)

    def energy(self, t, y, scene) -> Array:
        return -jnp.sum(scene.mass[:, None] * self.acceleration * y.q[:, :2])
