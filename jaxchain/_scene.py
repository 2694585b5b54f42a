"""A chain-drive scene is data: bodies, force elements, sprockets, boundary conditions.

Array leaves are what can be differentiated (geometry, masses, stiffnesses, speeds);
index arrays are integer leaves (never differentiated); counts and kinds are static.

Bodies of the chain are planar rigid bodies with state (x, y, φ): links in the
``"clearance"`` fidelity, rollers (point masses; their φ carries no torque) in both.
"""

from __future__ import annotations

from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._contact.base import AbstractContactLaw
from ._contact.dahl import DahlFriction
from ._contact.friction import CoulombFriction
from ._loads import AbstractLoad, as_load
from ._numerics import is_concrete
from ._profile import AbstractProfile

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


class ClearanceJoints(eqx.Module):
    """Revolute clearance joints: a pin (point a) inside a hole (point b).

    The eccentricity ℓ = |x_b − x_a| is the pin's offset from the hole centre; contact when
    ℓ exceeds the radial clearance, with ``law`` (e.g. Johnson's conformal law, whose
    ``clearance`` field is the radial clearance). Tension T = law(ℓ − c, ℓ̇) ≥ 0.

    With ``friction``, the contact also carries a tangential force at the contact point,
    against the sliding of the pin's surface (radius ``radius``) on the hole's (radius
    ``radius + clearance``): the joint's friction moment, about μ·T·radius while it
    articulates. A :class:`~jaxchain.contact.DahlFriction` keeps one pre-sliding state per
    joint in ``DriveState.bristle``; a :class:`~jaxchain.contact.CoulombFriction` none.
    """

    law: AbstractContactLaw
    clearance: Float[Array, ""]
    friction: CoulombFriction | DahlFriction | None = None
    radius: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))

    def tension(self, length, rate, impact_speed):
        return self.law.normal_force(length - self.clearance, rate, impact_speed)


class PairGroup(eqx.Module):
    """Force elements between a point on body ``a`` and a point on body ``b``.

    Attributes:
        a, b: body indices (P,).
        ra, rb: the points in the bodies' own frames (P, 2) [m].
        element: the force law (LinkSprings or ClearanceJoints), fields scalar or (P,).
        carries_tension: whether these elements transmit the chain's tension (links and
            pin/bush joints), reported as link tension; False for bush/roller joints.
    """

    a: Int[Array, " P"]
    b: Int[Array, " P"]
    ra: Float[Array, "P 2"]
    rb: Float[Array, "P 2"]
    element: LinkSprings | ClearanceJoints
    carries_tension: bool = eqx.field(static=True, default=True)


class JointFriction(eqx.Module):
    """Friction in the articulating joints of the lumped chain (whose links have no
    rotational freedom of their own).

    Joint j sits at body ``joint[j]``, between the link from ``before[j]`` and the link
    to ``after[j]``; its pin (radius ``pin_radius``) turns in its bush at the links'
    relative rate Ω = φ̇_after − φ̇_before. The friction moment on the link after is
    M = ``law.force(N·r, r·Ω)`` = −μ·N·r·tanh(r·Ω/v_s), with −M on the link before: the
    pin/bush contact's Coulomb friction at the sliding speed r·Ω of the pin's surface
    (with a :class:`~jaxchain.contact.DahlFriction` law, M = −μ·N·r·z/x_s, z the joint's
    pre-sliding state in ``DriveState.bristle``, driven by the sliding speed r·Ω).
    N is the joint's load, the mean tension of the two links (``link_before``,
    ``link_after``: indices into the tension-carrying elements), its positive part
    smoothed over ±``load_width``. Each moment acts as a couple of forces ±M/ℓ across
    its link; the power −M·Ω is never positive. At rest (Ω = 0) it adds nothing, so the
    statics do not change.
    """

    before: Int[Array, " J"]
    joint: Int[Array, " J"]
    after: Int[Array, " J"]
    link_before: Int[Array, " J"]
    link_after: Int[Array, " J"]
    law: CoulombFriction | DahlFriction
    pin_radius: Float[Array, ""]
    load_width: Float[Array, ""]


class Anchors(eqx.Module):
    """Tension anchors holding the free ends of an open strand.

    Each anchored body is pulled along the unit direction ``direction`` (pointing away
    from the sprocket) by ``tension`` plus a soft spring toward a guide point that moves
    at ``speed`` along that direction (the chain's mean speed there), and is held on the
    span's line by the same spring across it — a span end running on a guide.
    """

    body: Int[Array, " A"]
    origin: Float[Array, "A 2"]
    direction: Float[Array, "A 2"]
    speed: Float[Array, " A"]
    tension: Float[Array, " A"]
    stiffness: Float[Array, " A"]
    damping: Float[Array, " A"]


class Tensioners(eqx.Module):
    """Pivoting tensioner arms: rigid arms turning about fixed pivots, each pressed onto
    the chain by a preloaded torsional spring with a linear (hydraulic-style) damper.

    The arm's angle ψ is part of the ODE state (``DriveState.arm``). Its rotation toward
    the chain is φ = s·(ψ − ψ_ref) (s = ``sense``, ψ_ref = ``layout_angle``), and the
    spring and damper turn it toward the chain by τ = preload − stiffness·φ −
    damping·φ̇ [N·m]. Its shoe is the matching entry of the scene's :class:`Shoes`.

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


class Shoes(eqx.Module):
    """Shoes the chain slides on: tensioner shoes (the first ``n_tensioners``, shoe k on
    arm k, turning with it about its pivot) then fixed guides.

    Each shoe's working surface is a circular arc of curvature κ (a straight line for κ =
    0), given at the layout (arm at ``Tensioners.layout_angle``) by its middle point, the
    unit normal there (pointing from the shoe to the chain) and its half length along
    the surface. A roller of radius r whose centre lies at distance g from the surface
    (on the chain side) overlaps it by δ = r − g and is pushed by ``law`` along the
    surface normal, with ``friction`` against its sliding along the surface. The force
    is faded out smoothly (C¹) over ``edge`` [m] at the shoe's ends, and over a roller
    radius for centres deeper than two roller radii behind the surface (the shoe's back:
    no roller reaches it).

    Attributes:
        mid: (K, 2) middle point of the surface [m], world frame at the layout.
        normal: (K, 2) unit surface normal at the middle, toward the chain.
        curvature: (K,) κ [1/m], ≥ 0 (convex toward the chain; 0: straight).
        half_length: (K,) half the surface's length [m], measured along it.
        edge: (K,) fade-out length at the ends [m].
        law: normal contact law of roller and shoe (every shoe).
        friction: roller/shoe friction, its fields (K,) (one per shoe), or None.
        n_tensioners: how many of the shoes ride on tensioner arms (static).
        slots: rollers checked per shoe, the nearest to its middle; None: all (static).
            ``simulate`` reports ``Result.contact_slots_exceeded`` if the farthest slot
            ever comes within half a shoe's length + 1.05 roller radii of its middle.
    """

    mid: Float[Array, "K 2"]
    normal: Float[Array, "K 2"]
    curvature: Float[Array, " K"]
    half_length: Float[Array, " K"]
    edge: Float[Array, " K"]
    law: AbstractContactLaw
    friction: CoulombFriction | None
    n_tensioners: int = eqx.field(static=True)
    slots: int | None = eqx.field(static=True)

    def __check_init__(self):
        k = self.slots
        if k is not None and (isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1):
            raise ValueError(
                f"Shoes: slots must be an integer >= 1 or None (check every roller), got {k!r}"
            )

    @property
    def count(self) -> int:
        return int(np.shape(self.mid)[0])


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
            computed once before its loop (``jaxchain._dynamics.prepare``).
    """

    mass: Float[Array, " N"]
    inertia: Float[Array, " N"]
    pairs: tuple[PairGroup, ...]
    roller_body: Int[Array, " R"]
    roller_offset: Float[Array, "R 2"]
    roller_law: AbstractContactLaw
    friction: CoulombFriction | None
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
