"""A chain-drive scene is data: bodies, force elements, sprockets, boundary conditions.

Array leaves are what can be differentiated (geometry, masses, stiffnesses, speeds);
index arrays are integer leaves (never differentiated); counts and kinds are static.

Bodies of the chain are planar rigid bodies with state (x, y, φ): links in the
``"clearance"`` fidelity, rollers (point masses; their φ carries no torque) in both.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._elements.base import AbstractElement
from ._loads import AbstractLoad, as_load
from ._numerics import is_concrete
from ._profiles.base import AbstractProfile

if TYPE_CHECKING:  # the views' types
    from ._contact.base import AbstractContactLaw
    from ._contact.friction_base import AbstractFrictionLaw
    from ._elements.anchors import Anchors
    from ._elements.joint_friction import JointFriction
    from ._elements.pairs import PairGroup
    from ._elements.rollers import RollerTeeth
    from ._elements.shoes import Shoes
    from ._elements.tensioners import Tensioners

__all__ = ["Sprocket", "Scene", "ROLES"]


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


#: the parts of a drive its built-in force elements play (``AbstractElement.role``), in
#: the order the equations of motion sum their forces; the other elements follow
ROLES = ("pairs", "joint_friction", "anchors", "roller_teeth", "shoes", "tensioners", "gravity")
#: the views a Scene keeps of its built-in elements, and (for the keyword of the same
#: name) what giving one changes: a role's element(s), or a field of one
_NAMED = {
    "pairs": "pairs",
    "joint_friction": "joint_friction",
    "anchors": "anchors",
    "shoes": "shoes",
    "tensioners": "tensioners",
    "roller_law": ("roller_teeth", "law"),
    "friction": ("roller_teeth", "friction"),
    "gravity": ("gravity", "acceleration"),
}


def _arranged(elements, named: dict) -> tuple[AbstractElement, ...]:
    """``elements`` with the built-in parts ``named`` gives (Scene's view names) put in
    place, ordered by :data:`ROLES` then the rest in their order."""
    by_role: dict[str, list] = {r: [] for r in ROLES}
    rest = []
    for el in elements:
        if el is None:
            continue
        if not isinstance(el, AbstractElement):
            raise TypeError(
                "Scene: elements must be jc.elements.AbstractElement instances, got "
                f"{type(el).__name__}"
            )
        if el.role is not None and el.role not in by_role:
            raise ValueError(f"Scene: {type(el).__name__}.role {el.role!r} is none of {ROLES}")
        (rest if el.role is None else by_role[el.role]).append(el)
    for name, value in named.items():
        target = _NAMED[name]
        if isinstance(target, str):
            given = tuple(value) if name == "pairs" else (() if value is None else (value,))
            for el in given:
                if not isinstance(el, AbstractElement) or el.role != target:
                    raise TypeError(
                        f"Scene: {name} must hold elements whose role is {target!r}, got "
                        f"{type(el).__name__}"
                    )
            by_role[target] = list(given)
        else:
            role, field = target
            if not by_role[role]:
                raise TypeError(
                    f"Scene: {name} is a field of the scene's {role!r} element, which it does "
                    "not hold: give that element in elements"
                )
            by_role[role] = [dataclasses.replace(by_role[role][0], **{field: value})]
    for role, found in by_role.items():
        if role != "pairs" and len(found) > 1:
            raise ValueError(f"Scene: {len(found)} elements play {role!r}; a scene holds one")
    return tuple(el for role in ROLES for el in by_role[role]) + tuple(rest)


class Scene(eqx.Module):
    """Everything the vector field needs. Built by :mod:`jaxchain.scenes`.

    A scene is its bodies, its sprockets and its force elements. The built-in elements
    play the parts :data:`ROLES` names (``AbstractElement.role``), and the scene keeps a
    view of each under that name, read-only: ``pairs`` (the two-point groups: links or
    joints), ``joint_friction`` (the lumped chain's joint friction, or None: the
    clearance fidelity carries it in its :class:`ClearanceJoints`), ``anchors`` (tension
    anchors of an open strand, or None), ``roller_law`` and ``friction`` (the roller/tooth
    contact's normal law and friction, or None), ``shoes`` (tensioner shoes and fixed
    guides, or None), ``tensioners`` (tensioner arms, or None) and ``gravity`` ((2,)
    [m/s²]). Giving one of these names as a keyword (``dataclasses.replace(scene,
    friction=law)``) puts that part in place; :meth:`add_elements` adds elements of your
    own.

    Attributes:
        mass: (N,) body masses [kg].
        inertia: (N,) body polar inertias [kg·m²].
        roller_body: (R,) body carrying each roller's centre.
        roller_offset: (R, 2) roller centre in that body's frame [m].
        sprockets: the sprockets (static count).
        impact_speed: reference impact speed of the history-free contact damping [m/s]
            (a law with restitution e gives e at this impact speed; see docs).
        q0, v0: (N, 3) initial positions (x, y, φ) and velocities.
        link_weights: (n_links, n_tension_elements) maps element tensions to links.
        horizon: the time up to which the scene models its drive [s] (an open strand runs
            out of chain: the engagement's entry span meshes ``n_entry`` tooth periods;
            ``inf`` for a closed drive). A solve past it is reported as ``past_horizon``.
        tensile_strength: the chain's minimum tensile strength [N] (ISO 606); a link
            tension beyond it is reported as ``chain_overloaded``.
        fidelity: "lumped", "clearance" or "spans" (static).
        elements: every force element, in the order the equations of motion sum them:
            the built-in parts in :data:`ROLES` order, then the others
            (:class:`jc.elements.AbstractElement <jaxchain.elements.AbstractElement>`).
        bush_link: a bush chain's (R, 2) roller indices of the two bushes of the inner
            link each bush is part of: the bush turns with that link, so it slides on the
            tooth (the contact's slip includes the link's rotation, and the friction's
            moment about the bush centre acts on the link); None for a roller chain
            (the slip is the roller centre's; the roller's own spin is not modelled).
    """

    mass: Float[Array, " N"]
    inertia: Float[Array, " N"]
    roller_body: Int[Array, " R"]
    roller_offset: Float[Array, "R 2"]
    sprockets: tuple[Sprocket, ...]
    impact_speed: Float[Array, ""]
    q0: Float[Array, "N 3"]
    v0: Float[Array, "N 3"]
    link_weights: Float[Array, "L E"]
    horizon: Float[Array, ""]
    tensile_strength: Float[Array, ""]
    fidelity: str = eqx.field(static=True)
    elements: tuple[AbstractElement, ...] = ()
    bush_link: Int[Array, "R 2"] | None = None

    def __init__(self, *, elements=(), bush_link=None, **fields):
        named = {k: fields.pop(k) for k in list(fields) if k in _NAMED}
        own = {f.name for f in dataclasses.fields(type(self))} - {"elements", "bush_link"}
        if set(fields) != own:
            raise TypeError(
                f"Scene: missing field(s) {sorted(own - set(fields))}, unexpected keyword(s) "
                f"{sorted(set(fields) - own)} (the elements' views: {sorted(_NAMED)})"
            )
        for name, value in fields.items():
            setattr(self, name, value)
        self.elements = _arranged(tuple(elements), named)
        self.bush_link = bush_link

    def _role(self, role: str):
        found = [el for el in self.elements if el is not None and el.role == role]
        return found[0] if found else None

    @property
    def pairs(self) -> tuple[PairGroup, ...]:
        """The two-point groups (links or joints)."""
        return tuple(el for el in self.elements if el is not None and el.role == "pairs")

    @property
    def joint_friction(self) -> JointFriction | None:
        return self._role("joint_friction")

    @property
    def anchors(self) -> Anchors | None:
        return self._role("anchors")

    @property
    def shoes(self) -> Shoes | None:
        return self._role("shoes")

    @property
    def tensioners(self) -> Tensioners | None:
        return self._role("tensioners")

    @property
    def roller_teeth(self) -> RollerTeeth:
        """The roller/tooth contact element (its ``law`` and ``friction``)."""
        return self._role("roller_teeth")

    @property
    def roller_law(self) -> AbstractContactLaw:
        return self.roller_teeth.law

    @property
    def friction(self) -> AbstractFrictionLaw | None:
        return self.roller_teeth.friction

    @property
    def gravity(self) -> Float[Array, 2]:
        el = self._role("gravity")
        return jnp.zeros(2) if el is None else el.acceleration

    @property
    def prepared_shapes(self):
        """None, except inside a solve: the sprockets' contact shapes computed once before
        its loop (:meth:`prepared`)."""
        teeth = self.roller_teeth
        return None if teeth is None else teeth.shapes

    @property
    def added(self) -> tuple[AbstractElement, ...]:
        """The elements that play no built-in part (:meth:`add_elements`'s)."""
        return tuple(el for el in self.elements if el is not None and el.role is None)

    @property
    def force_elements(self) -> tuple[AbstractElement, ...]:
        """Every force element of the drive, in the order the equations of motion sum
        them (:attr:`elements`)."""
        return tuple(el for el in self.elements if el is not None)

    def prepared(self) -> Scene:
        """This scene with what each element computes once per solve
        (``AbstractElement.prepared``)."""
        return dataclasses.replace(
            self, elements=tuple(el.prepared(self) for el in self.force_elements)
        )

    def with_force_element(self, index: int, element: AbstractElement) -> Scene:
        """This scene with ``force_elements[index]`` replaced by ``element``."""
        held = list(self.force_elements)
        held[index] = element
        return dataclasses.replace(self, elements=tuple(held))

    def add_elements(self, *elements: AbstractElement) -> Scene:
        """This scene with ``elements`` added to its force elements."""
        return dataclasses.replace(self, elements=self.force_elements + tuple(elements))

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
