"""A chain-drive scene is data: bodies, force elements, sprockets, boundary conditions.

Array leaves are what can be differentiated (geometry, masses, stiffnesses, speeds);
index arrays are integer leaves (never differentiated); counts and kinds are static.

Bodies of the chain are planar rigid bodies with state (x, y, φ): links in the
``"clearance"`` fidelity, rollers (point masses; their φ carries no torque) in both.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._contact.base import AbstractContactLaw
from ._contact.friction_base import AbstractFrictionLaw
from ._elements.anchors import Anchors
from ._elements.base import AbstractElement
from ._elements.gravity import Gravity
from ._elements.joint_friction import JointFriction
from ._elements.pairs import ClearanceJoints, LinkSprings, PairGroup
from ._elements.rollers import RollerTeeth
from ._elements.shoes import Shoes
from ._elements.tensioners import Tensioners
from ._loads import AbstractLoad, as_load
from ._numerics import is_concrete
from ._profiles.base import AbstractProfile

__all__ = [
    "Sprocket",
    "LinkSprings",
    "ClearanceJoints",
    "PairGroup",
    "JointFriction",
    "Anchors",
    "Tensioners",
    "Shoes",
    "Scene",
]


class Sprocket(eqx.Module):
    """A sprocket: tooth profile, axis position, and how it turns.

    Attributes:
        profile: its tooth profile (teeth, pitch, gap form).
        centre: axis position (2,) [m], world frame.
        speed: driver: prescribed angular speed [rad/s] (positive counter-clockwise);
            driven: initial angular speed.
        inertia: polar moment of inertia [kg·m²] (driven sprockets).
        torque_load: the load on its shaft (driven sprockets), a
            :class:`jc.loads.AbstractLoad <jaxchain.loads.AbstractLoad>` resisting the
            sprocket's rotation in its running direction ``sense``; built from the
            arguments ``load_torque`` (a number [N·m] or a load) and ``load_ramp`` (a
            number's smooth rise from 0 over this time [s]; 0: applied at once).
        angle0: rotation angle at t = 0 [rad]: gap k centred at angle0 + 2πk/z.
        driven: False for a driver (speed prescribed), True for a free sprocket
            (static).
        sense: +1 if the sprocket runs counter-clockwise, −1 clockwise (a sprocket the
            chain wraps clockwise): the direction its load's angle and speed count in
            (static).
        contact_slots: how many rollers (the nearest to the axis) are checked against
            this sprocket; None: all. Only rollers within the tip radius plus a roller
            radius can touch it, so wrap + a few is exact; ``simulate`` reports
            ``Result.contact_slots_exceeded`` if the farthest slot ever comes within reach
            (static).
        take_up_vector: (2,) force on the axis per newton of the statics' take-up
            (:func:`~jaxchain.scenes.equilibrate`); the axis moves along it while the scene
            settles, and (0, 0) holds it. None (the default): a driven axis is pushed by
            the whole take-up away from the first sprocket's axis, along their centre line.
    """

    profile: AbstractProfile
    centre: Float[Array, 2]
    speed: Float[Array, ""]
    inertia: Float[Array, ""]
    torque_load: AbstractLoad
    angle0: Float[Array, ""]
    driven: bool = eqx.field(static=True)
    contact_slots: int | None = eqx.field(static=True)
    take_up_vector: Float[Array, 2] | None
    sense: int = eqx.field(static=True)

    def __init__(
        self,
        profile,
        centre,
        speed,
        *,
        inertia=1.0,
        load_torque=0.0,
        angle0=0.0,
        load_ramp=0.0,
        driven=False,
        contact_slots=None,
        take_up_vector=None,
        sense=1,
        torque_load=None,
    ):
        self.profile = profile
        self.centre = jnp.asarray(centre, dtype=float)
        self.speed = jnp.asarray(speed, dtype=float)
        self.inertia = jnp.asarray(inertia, dtype=float)
        if torque_load is not None:  # the field itself (dataclasses.replace passes it)
            load_torque = torque_load
        if isinstance(load_torque, AbstractLoad) and not (
            is_concrete(load_ramp) and not np.any(np.asarray(load_ramp))
        ):
            raise ValueError(
                "Sprocket: load_ramp applies to a number load_torque; a jc.loads load carries "
                "its own time dependence (jc.loads.Ramped(value, duration) ramps one in): "
                "leave load_ramp at 0"
            )
        if is_concrete(load_ramp) and np.any(np.asarray(load_ramp) < 0):
            raise ValueError(f"Sprocket: load_ramp must be >= 0 s, got {load_ramp}")
        self.torque_load = as_load(load_torque, "Sprocket: load_torque", ramp=load_ramp)
        self.angle0 = jnp.asarray(angle0, dtype=float)
        if sense not in (1, -1):
            raise ValueError(f"Sprocket: sense must be +1 or -1, got {sense!r}")
        self.sense = int(sense)
        self.driven = bool(driven)
        self.contact_slots = None if contact_slots is None else int(contact_slots)
        self.take_up_vector = (
            None if take_up_vector is None else jnp.asarray(take_up_vector, dtype=float)
        )

    def load(self, t, theta=None, omega=None):
        """The load's torque at time ``t`` [s], counted positive against counter-clockwise
        rotation [N·m], with the sprocket at angle ``theta`` [rad] turning at ``omega``
        [rad/s] (world sense; default its start: ``angle0``, ``speed``)."""
        theta = self.angle0 if theta is None else theta
        omega = self.speed if omega is None else omega
        s = self.sense
        return s * self.torque_load.torque(t, s * (theta - self.angle0), s * omega)

    @property
    def load_torque(self) -> Array:
        """The load's mean torque, positive against counter-clockwise rotation [N·m]."""
        return self.sense * self.torque_load.mean_torque

    @property
    def load_ramp(self) -> Array:
        """The rise time of a ramped load [s]; 0 for any other load."""
        return getattr(self.torque_load, "duration", jnp.zeros(()))

    def __check_init__(self):
        if not isinstance(self.profile, AbstractProfile):
            raise TypeError(
                "Sprocket: profile must be a jc.ToothProfile, jc.FreeformProfile or another "
                "jc.AbstractProfile, got "
                f"{type(self.profile).__name__}"
            )
        if np.shape(self.centre)[-1:] != (2,):
            raise ValueError(f"Sprocket: centre must be (x, y), got shape {np.shape(self.centre)}")
        if self.take_up_vector is not None and np.shape(self.take_up_vector)[-1:] != (2,):
            raise ValueError(
                "Sprocket: take_up_vector must be (x, y) or None, got shape "
                f"{np.shape(self.take_up_vector)}"
            )
        if self.contact_slots is not None and self.contact_slots < 1:
            raise ValueError(
                f"Sprocket: contact_slots must be an integer >= 1 or None (check every "
                f"roller), got {self.contact_slots}"
            )
        if not is_concrete(self):
            return
        for name in ("centre", "speed", "inertia", "angle0"):
            if not np.all(np.isfinite(np.asarray(getattr(self, name)))):
                raise ValueError(f"Sprocket: {name} must be finite, got {getattr(self, name)}")
        if self.take_up_vector is not None and not np.all(
            np.isfinite(np.asarray(self.take_up_vector))
        ):
            raise ValueError(f"Sprocket: take_up_vector must be finite, got {self.take_up_vector}")
        if self.driven and not np.all(np.asarray(self.inertia) > 0):
            raise ValueError(f"a driven sprocket needs inertia > 0 kg·m², got {self.inertia}")


class Scene(eqx.Module):
    """Everything the vector field needs. Built by :mod:`jaxchain.scenes`.

    Attributes:
        mass: (N,) body masses [kg].
        inertia: (N,) body polar inertias [kg·m²].
        pairs: groups of two-point force elements.
        roller_body: (R,) body carrying each roller's centre.
        roller_offset: (R, 2) roller centre in that body's frame [m].
        roller_law: roller/tooth normal contact law.
        friction: roller/tooth friction or None.
        sprockets: the sprockets (static count).
        anchors: tension anchors of an open strand, or None.
        joint_friction: friction in the lumped chain's joints, or None (the clearance
            fidelity carries it in its :class:`ClearanceJoints`).
        impact_speed: reference impact speed of the history-free contact damping [m/s]
            (a law with restitution e gives e at this impact speed; see docs).
        q0, v0: (N, 3) initial positions (x, y, φ) and velocities.
        link_weights: (n_links, n_tension_elements) maps element tensions to links.
        horizon: the time up to which the scene models its drive [s] (an open strand runs
            out of chain: the engagement's entry span meshes ``n_entry`` tooth periods;
            ``inf`` for a closed drive). A solve past it is reported as ``past_horizon``.
        tensile_strength: the chain's minimum tensile strength [N] (ISO 606); a link
            tension beyond it is reported as ``chain_overloaded``.
        fidelity: "lumped" or "clearance" (static).
        gravity: (2,) [m/s²].
        tensioners: tensioner arms, or None.
        shoes: tensioner shoes and fixed guides, or None.
        prepared_shapes: None, except inside a solve: the sprockets' contact shapes
            computed once before its loop (``jaxchain._elements.rollers.prepare``).
        elements: force elements added to the drive's own
            (:class:`jc.elements.AbstractElement <jaxchain.elements.AbstractElement>`;
            :meth:`add_elements`).
        bush_link: a bush chain's (R, 2) roller indices of the two bushes of the inner
            link each bush is part of: the bush turns with that link, so it slides on the
            tooth (the contact's slip includes the link's rotation, and the friction's
            moment about the bush centre acts on the link); None for a roller chain
            (the slip is the roller centre's; the roller's own spin is not modelled).
    """

    mass: Float[Array, " N"]
    inertia: Float[Array, " N"]
    pairs: tuple[PairGroup, ...]
    roller_body: Int[Array, " R"]
    roller_offset: Float[Array, "R 2"]
    roller_law: AbstractContactLaw
    friction: AbstractFrictionLaw | None
    sprockets: tuple[Sprocket, ...]
    anchors: Anchors | None
    joint_friction: JointFriction | None
    impact_speed: Float[Array, ""]
    q0: Float[Array, "N 3"]
    v0: Float[Array, "N 3"]
    link_weights: Float[Array, "L E"]
    gravity: Float[Array, 2]
    horizon: Float[Array, ""]
    tensile_strength: Float[Array, ""]
    fidelity: str = eqx.field(static=True)
    tensioners: Tensioners | None = None
    shoes: Shoes | None = None
    prepared_shapes: Any = None
    elements: tuple[AbstractElement, ...] = ()
    bush_link: Int[Array, "R 2"] | None = None

    def __check_init__(self):
        for el in self.elements:
            if not isinstance(el, AbstractElement):
                raise TypeError(
                    "Scene: elements must be jc.elements.AbstractElement instances, got "
                    f"{type(el).__name__}"
                )

    @property
    def force_elements(self) -> tuple[AbstractElement, ...]:
        """Every force element of the drive, in the order the equations of motion sum
        them: the two-point groups (links or joints), the lumped chain's joint friction,
        the anchors, the roller/tooth contacts, the shoes, the tensioner springs, gravity,
        then :attr:`elements`."""
        own = [*self.pairs, self.joint_friction, self.anchors]
        own += [RollerTeeth(self.roller_law, self.friction), self.shoes, self.tensioners]
        own.append(Gravity(self.gravity))
        return tuple(e for e in own if e is not None) + tuple(self.elements)

    def with_force_element(self, index: int, element: AbstractElement) -> Scene:
        """This scene with ``force_elements[index]`` replaced by ``element`` (an element
        the scene holds: a two-point group, a named one or an added one)."""
        held = self.force_elements
        own = len(held) - len(self.elements)
        if index < len(self.pairs):
            pairs = list(self.pairs)
            pairs[index] = element
            return dataclasses.replace(self, pairs=tuple(pairs))
        if index >= own:
            added = list(self.elements)
            added[index - own] = element
            return dataclasses.replace(self, elements=tuple(added))
        for name in ("joint_friction", "anchors", "shoes", "tensioners"):
            if getattr(self, name) is held[index]:
                return dataclasses.replace(self, **{name: element})
        raise ValueError(
            f"Scene.with_force_element: force element {index} "
            f"({type(held[index]).__name__}) is made from the scene's other fields"
        )

    def add_elements(self, *elements: AbstractElement) -> Scene:
        """This scene with ``elements`` added to its force elements."""
        return dataclasses.replace(self, elements=tuple(self.elements) + tuple(elements))

    @property
    def n_bodies(self) -> int:
        return int(np.shape(self.mass)[0])

    @property
    def n_rollers(self) -> int:
        return int(np.shape(self.roller_body)[0])

    @property
    def n_links(self) -> int:
        return int(np.shape(self.link_weights)[0])

    @property
    def roller_radius(self):
        return self.sprockets[0].profile.roller_radius
