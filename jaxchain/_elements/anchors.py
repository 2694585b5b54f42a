"""Tension anchors holding the free ends of an open strand."""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from .base import AbstractElement, Effect

__all__ = ["Anchors"]


class Anchors(AbstractElement):
    """Tension anchors holding the free ends of an open strand.

    Each anchored body is pulled along the unit direction ``direction`` (pointing away
    from the sprocket) by ``tension`` plus a soft spring toward a guide point that moves
    at ``speed`` along that direction (the chain's mean speed there), and is held on the
    span's line by the same spring across it — a span end running on a guide. The guide
    moves, so the springs store no energy of a conserved total (:meth:`energy` is 0).
    """

    role = "anchors"

    body: Int[Array, " A"]
    origin: Float[Array, "A 2"]
    direction: Float[Array, "A 2"]
    speed: Float[Array, " A"]
    tension: Float[Array, " A"]
    stiffness: Float[Array, " A"]
    damping: Float[Array, " A"]

    def effect(self, t, y, scene, state) -> Effect:
        x, xd = y.q[self.body, :2], y.v[self.body, :2]
        guide = self.origin + (self.speed * t)[:, None] * self.direction
        rel = guide - x
        s = jnp.sum(rel * self.direction, -1)
        across = rel - s[:, None] * self.direction
        relv = self.speed[:, None] * self.direction - xd
        f = (self.tension + self.stiffness * s)[:, None] * self.direction
        f = f + self.stiffness[:, None] * across + self.damping[:, None] * relv
        return Effect(body=jnp.zeros_like(y.q).at[self.body, :2].add(f))
