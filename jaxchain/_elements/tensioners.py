"""Pivoting tensioner arms: their preloaded spring and damper."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .base import AbstractElement, Effect

__all__ = ["Tensioners", "arm_coordinates"]


def arm_coordinates(y, count: int):
    """The tensioner arms' angles [rad] and rates [rad/s], (count,) each: the first
    ``count`` of ``y``'s element coordinates (the arms precede every element added to a
    scene); (None, None) for no arm."""
    if not count:
        return None, None
    return y.dof[:count], y.dof_rate[:count]


class Tensioners(AbstractElement):
    """Pivoting tensioner arms: rigid arms turning about fixed pivots, each pressed onto
    the chain by a preloaded torsional spring with a linear (hydraulic-style) damper.

    The arms' angles ψ are the element's own coordinates (``DriveState.dof``, first).
    Its rotation toward the chain is φ = s·(ψ − ψ_ref) (s = ``sense``, ψ_ref =
    ``layout_angle``), and the spring and damper turn it toward the chain by τ = preload
    − stiffness·φ − damping·φ̇ [N·m]. Its shoe is the matching entry of the scene's
    :class:`Shoes`.

    Attributes:
        pivot: (A, 2) pivot positions [m], world frame.
        layout_angle: (A,) the reference angle ψ_ref [rad]: world angle of the line from
            the pivot to the shoe's middle where the shoe geometry is given.
        angle0: (A,) the arm angle at t = 0 [rad] (same convention as ``layout_angle``).
        rate0: (A,) the arm's angular rate at t = 0 [rad/s].
        inertia: (A,) polar moment of inertia about the pivot [kg·m²], > 0.
        stiffness: (A,) torsional spring rate [N·m/rad], ≥ 0.
        damping: (A,) damper rate [N·m·s/rad], ≥ 0.
        preload: (A,) spring torque toward the chain at ψ_ref [N·m].
        sense: (A,) +1 if a counter-clockwise turn moves the shoe toward the chain, −1 if
            a clockwise one does.
    """

    role = "tensioners"

    pivot: Float[Array, "A 2"]
    layout_angle: Float[Array, " A"]
    angle0: Float[Array, " A"]
    rate0: Float[Array, " A"]
    inertia: Float[Array, " A"]
    stiffness: Float[Array, " A"]
    damping: Float[Array, " A"]
    preload: Float[Array, " A"]
    sense: Float[Array, " A"]

    @property
    def count(self) -> int:
        return int(np.shape(self.pivot)[0])

    def spring_torque(self, angle, rate):
        """(A,) torque of spring and damper on each arm [N·m], world sense."""
        phi = self.sense * (angle - self.layout_angle)
        press = self.preload - self.stiffness * phi - self.damping * self.sense * rate
        return self.sense * press

    def n_dofs(self, scene) -> int:
        return self.count

    def dof_inertia(self, scene) -> Array:
        return self.inertia

    def dof_start(self, scene) -> tuple[Array, Array]:
        return self.angle0, self.rate0

    def with_dof_start(self, position) -> Tensioners:
        return eqx.tree_at(lambda tn: tn.angle0, self, position)

    def force_scale(self, scene) -> Array:
        """The largest preload over the distance from its pivot to its shoe [N]."""
        lever = jnp.sqrt(jnp.sum((scene.shoes.mid[: self.count] - self.pivot) ** 2, -1))
        return jnp.max(jnp.abs(self.preload) / lever)

    def effect(self, t, y, scene, state) -> Effect:
        torque = self.spring_torque(state.position, state.rate)
        return Effect(body=jnp.zeros_like(y.q), dof_force=torque)

    def energy(self, t, y, scene, state=None) -> Array:
        phi = self.sense * (state.position - self.layout_angle)
        return jnp.sum(0.5 * self.stiffness * phi**2 - self.preload * phi)

    def outputs(self, t, y, scene, effect: Effect) -> dict[str, Array]:
        angle, _ = arm_coordinates(y, self.count)
        return {"tensioner_angle": angle, "tensioner_torque": effect.dof_force}
