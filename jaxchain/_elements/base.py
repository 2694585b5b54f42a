"""The force-element protocol: what every element of a drive (link springs, joints and
their friction, roller/tooth and roller/shoe contacts, tensioner springs, anchors,
gravity, and a user's own) tells the equations of motion.

The vector field sums the elements' :class:`Effect` s; the energy sums their stored
energies; the saved outputs, the stable-step estimate of the statics and the solve's
contact-slot check ask each element in turn. A new element is one subclass.
"""

from __future__ import annotations

import abc
from typing import Any, NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._kinematics import rot

__all__ = ["AbstractElement", "Effect", "ElementState"]


class ElementState(NamedTuple):
    """What an element with coordinates of its own (``n_dofs > 0``) receives as ``state``:
    its coordinates, their rates and its first-order states.

    Attributes:
        position: (D,) its coordinates (``DriveState.dof``'s slice of it) [m or rad].
        rate: (D,) their rates [m/s or rad/s] (zeros in the statics).
        states: (K,) its first-order states (``n_states`` of them), or None.
    """

    position: Float[Array, " D"]
    rate: Float[Array, " D"]
    states: Float[Array, " K"] | None = None


class Effect(NamedTuple):
    """What one force element does at one instant.

    Attributes:
        body: (N, 3) generalized forces on the chain's bodies: force (fx, fy) [N] at the
            body's origin and torque [N·m] about it.
        sprocket_torque: (S,) torque on each sprocket about its axis [N·m],
            counter-clockwise positive; None: none.
        sprocket_force: (S, 2) force on each sprocket's axis [N]; None: none.
        arm_torque: (A,) torque on each tensioner arm about its pivot [N·m] (the scene's
            ``tensioners``' coordinates: a shoe riding on an arm); None: none.
        state_rate: d/dt of the element's own states (``n_states`` of them); None when it
            has none.
        dof_force: (D,) generalized forces on the element's own coordinates
            (``n_dofs`` of them) [N for a length, N·m for an angle]; None: none.
        tension: the tensions it carries along the chain [N] (link springs, pin/bush
            joints), reported as link tension; None: it carries none.
        report: named quantities for :class:`~jaxchain._dynamics.Forces` (for example
            ``"roller_normal"``); None: none.
    """

    body: Float[Array, "N 3"]
    sprocket_torque: Float[Array, " S"] | None = None
    sprocket_force: Float[Array, "S 2"] | None = None
    arm_torque: Float[Array, " A"] | None = None
    state_rate: Float[Array, " F"] | None = None
    tension: Float[Array, " E"] | None = None
    report: dict[str, Any] | None = None
    dof_force: Float[Array, " D"] | None = None


class AbstractElement(eqx.Module):
    """A force element of a drive.

    Subclass it, implement :meth:`effect`, and add an instance to a scene with
    ``scene.add_elements(element)``. The other methods have defaults: an element with no
    stored energy (a damper, friction), no outputs, no states, no stiffness limit on the
    step.

    ``energy_kind`` names the energy its :meth:`energy` belongs to: ``"elastic"`` (the
    default) or ``"gravity"``; ``reads_tension`` asks for the chain's tensions (below).

    **Coordinates of its own.** An element that moves (a tensioner arm, an idler on a
    slide) declares its degrees of freedom: :meth:`n_dofs` of them, with
    :meth:`dof_inertia` (their mass or moment of inertia) and :meth:`dof_start` (where
    they start). They then ride in ``DriveState.dof``/``dof_rate``; the element reads
    them as ``state`` (an :class:`ElementState`) in :meth:`effect`, :meth:`energy` and
    :meth:`power`, and drives them through ``Effect.dof_force``. The equations of
    motion, the energy (their kinetic energy), the statics (they settle with the chain;
    :meth:`force_scale`) and the settled start (:meth:`with_dof_start`) take them from
    there.
    """

    energy_kind = "elastic"
    #: the part of a drive a built-in element plays (``Scene``'s views ``pairs``,
    #: ``joint_friction``, ``anchors``, ``roller_teeth``, ``shoes``, ``tensioners``,
    #: ``gravity`` find it by this); None for every other element, the user's among them
    role = None
    #: True: :meth:`effect` takes a keyword ``tension``, the (E,) tensions [N] that the
    #: elements before it in ``Scene.force_elements`` carry (their ``Effect.tension``,
    #: concatenated), so that it need not compute them again (joint friction loads its
    #: joints with them); called without it, the element computes them itself.
    reads_tension = False

    def prepared(self, scene) -> AbstractElement:
        """This element with what it computes once per solve, before the solver's loop
        (the roller contacts' tooth shapes); the default computes nothing."""
        return self

    def n_states(self, scene) -> int:
        """How many states of its own it carries in ``DriveState.bristle`` (static)."""
        del scene
        return 0

    def n_dofs(self, scene) -> int:
        """How many coordinates of its own it carries in ``DriveState.dof`` (static)."""
        del scene
        return 0

    def dof_inertia(self, scene) -> Array:
        """(D,) the mass [kg] or moment of inertia [kg·m²] of each of its coordinates."""
        del scene
        raise NotImplementedError(
            f"{type(self).__name__} declares coordinates of its own (n_dofs > 0) but no "
            "dof_inertia: implement dof_inertia(scene), their masses or inertias"
        )

    def dof_start(self, scene) -> tuple[Array, Array]:
        """((D,), (D,)) its coordinates and their rates at t = 0 (default: zeros)."""
        z = jnp.zeros((self.n_dofs(scene),), scene.q0.dtype)
        return z, z

    def with_dof_start(self, position) -> AbstractElement:
        """This element starting at coordinates ``position`` (D,) (where the statics
        settled it)."""
        del position
        raise NotImplementedError(
            f"{type(self).__name__} declares coordinates of its own (n_dofs > 0) but no "
            "with_dof_start: implement with_dof_start(position), the element starting "
            "there, so that jc.scenes.equilibrate can settle it"
        )

    def force_scale(self, scene) -> Array | None:
        """A force typical of what it applies at rest [N] (a preload): the statics' unit
        of force takes the largest of these; None: it sets none."""
        del scene
        return None

    @abc.abstractmethod
    def effect(self, t, y, scene, state) -> Effect:
        """Its forces at time ``t`` [s] in state ``y`` (a ``DriveState``) of ``scene``;
        ``state``: its own states (``n_states`` of them; zeros where ``y`` carries
        none, as in the statics), or None when it has none; an :class:`ElementState`
        when it has coordinates of its own."""

    def energy(self, t, y, scene, state=None) -> Array:
        """Energy it stores [J] (0: it stores none). ``state``: as in :meth:`effect` for an
        element with coordinates of its own, None for the others."""
        del t, scene, state
        return jnp.zeros((), y.q.dtype)

    def power(self, t, y, scene, state=None) -> Array:
        """Power of its forces on the bodies, sprockets, arms and its coordinates [W]."""
        e = self.effect(t, y, scene, state)
        p = jnp.sum(e.body * y.v)
        if e.sprocket_torque is not None:
            p = p + jnp.sum(e.sprocket_torque * y.omega)
        if e.arm_torque is not None:
            p = p + jnp.sum(e.arm_torque * y.dof_rate[: e.arm_torque.shape[0]])
        if e.dof_force is not None:
            p = p + jnp.sum(e.dof_force * state.rate)
        return p

    def outputs(self, t, y, scene, effect: Effect) -> dict[str, Array]:
        """Named quantities it adds to a solution's saved outputs."""
        del t, y, scene, effect
        return {}

    def max_stiffness(self, scene, force) -> Array | None:
        """Its stiffest tangent stiffness [N/m] at a contact force ``force`` [N]: its part of
        the statics' stable-step estimate; None: it sets no limit."""
        del scene, force
        return None

    def slots_ok(self, y, scene) -> Array:
        """Whether the rollers it checks cover every roller that can reach it (elements
        that check only the nearest rollers); True for the others."""
        del y, scene
        return jnp.asarray(True)


def chain_tension(y, scene) -> Array:
    """(E,) tensions of the scene's tension-carrying elements [N] (link springs, pin/bush
    joints: the pairs that ``carries_tension``), in the order of ``scene.pairs``."""
    cs = rot(y.q[:, 2])
    parts = [g.tensions(y, scene, cs) for g in scene.pairs if g.carries_tension]
    return jnp.concatenate(parts) if parts else jnp.zeros((0,), y.q.dtype)
