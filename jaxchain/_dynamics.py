"""Equations of motion: M q̈ = forces(q, q̇, t), diagonal M, one pure vector field.

The forces are the sum of the scene's force elements (``Scene.force_elements``, each a
:class:`~jaxchain.elements.AbstractElement`); this module knows the bodies, the
sprockets and the elements' own coordinates (``DriveState.dof``), not the elements. No
Python loop runs over links, rollers or contacts: each element is one vectorized call
scattered onto bodies with segment sums. The only Python loops are over the (static,
few) elements and sprockets.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from . import _checks as checks
from ._elements.base import Effect, ElementState, chain_tension
from ._kinematics import points as _points, span_tension as _span_tension
from ._scene import Scene

if TYPE_CHECKING:
    from ._elements.rollers import RollerContacts

__all__ = [
    "DriveState",
    "initial_state",
    "vector_field",
    "rates",
    "outputs",
    "CHAIN_OUTPUTS",
    "Forces",
    "energy",
    "roller_contacts",
    "roller_normal_forces",
    "roller_kinematics",
    "contact_slots_ok",
    "bristle_layout",
    "dof_layout",
    "dof_start",
    "effects",
    "element_effects",
]


class _State(NamedTuple):
    q: Float[Array, "N 3"]
    v: Float[Array, "N 3"]
    theta: Float[Array, " S"]
    omega: Float[Array, " S"]
    dof: Float[Array, " D"] | None = None
    dof_rate: Float[Array, " D"] | None = None
    bristle: Float[Array, " F"] | None = None


class DriveState(_State):
    """ODE state. q, v: (N, 3) bodies' (x, y, φ) and rates; theta, omega: (S,) sprockets;
    dof, dof_rate: (D,) the force elements' own coordinates and their rates (None when no
    element has any; order: :func:`dof_layout`): the tensioner arms' angles [rad] first,
    then those of the elements added to the scene; bristle: (F,) pre-sliding deflections
    [m] of the joints with :class:`~jaxchain.contact.DahlFriction` (None without; order:
    :func:`bristle_layout`).

    ``arm``/``arm_rate`` (the tensioner arms' angles and rates) are the former names of
    ``dof``/``dof_rate``: still accepted and read, with a deprecation warning."""

    __slots__ = ()

    def __new__(cls, q, v, theta, omega, dof=None, dof_rate=None, bristle=None, **old):
        for name, new in (("arm", "dof"), ("arm_rate", "dof_rate")):
            if name in old:
                _renamed(name, new)
                if (dof if new == "dof" else dof_rate) is not None:
                    raise TypeError(f"DriveState: give {new} only, not both {new} and {name}")
                if new == "dof":
                    dof = old.pop(name)
                else:
                    dof_rate = old.pop(name)
        if old:
            raise TypeError(f"DriveState: unexpected arguments {sorted(old)}")
        return super().__new__(cls, q, v, theta, omega, dof, dof_rate, bristle)

    @property
    def arm(self):
        """Former name of :attr:`dof` (deprecated)."""
        _renamed("arm", "dof")
        return self.dof

    @property
    def arm_rate(self):
        """Former name of :attr:`dof_rate` (deprecated)."""
        _renamed("arm_rate", "dof_rate")
        return self.dof_rate


def _renamed(old: str, new: str) -> None:
    warnings.warn(
        f"DriveState.{old} is now DriveState.{new} (the force elements' own coordinates, "
        "tensioner arms first); use the new name",
        DeprecationWarning,
        stacklevel=3,
    )


class Forces(NamedTuple):
    """Everything the vector field computes, for outputs and diagnostics."""

    body: Float[Array, "N 3"]  # total force (fx, fy) and torque on each body
    roller_normal: Float[Array, "S R"]  # roller/tooth normal force per sprocket [N]
    sprocket_torque: Float[Array, " S"]  # torque of the chain on each sprocket [N·m]
    sprocket_force: Float[Array, "S 2"]  # force of the chain on each sprocket's axis [N]
    element_tension: Float[Array, " E"]  # tensions of tension-carrying elements [N]
    shoe_normal: Float[Array, " R"] | None = None  # roller/shoe normal force per roller [N]
    shoe_force: Float[Array, "K 2"] | None = None  # force of the chain on each shoe [N]
    arm_torque: Float[Array, " A"] | None = None  # torque of the chain on each arm [N·m]
    bristle_rate: Float[Array, " F"] | None = None  # d/dt of DriveState.bristle [m/s]
    joint_friction_power: Float[Array, ""] | None = None  # power of the joints' friction [W]
    dof_force: Float[Array, " D"] | None = None  # every element's on the elements' coordinates
    tooth_friction_power: Float[Array, ""] | None = None  # of the roller/tooth friction [W]


def _check_scene(scene, caller: str) -> None:
    if not isinstance(scene, Scene):
        raise TypeError(
            f"{caller}: scene must be a jaxchain Scene (built by jc.scenes.*), got "
            f"{type(scene).__name__}"
        )
    if np.ndim(scene.q0) != 2:
        raise ValueError(
            f"{caller}: the scene is stacked (q0 has shape {np.shape(scene.q0)}, members "
            f"first); for an ensemble use jax.vmap(lambda s: jc.{caller}(..., s))(scenes)"
        )


def _check_state(y, scene, caller: str) -> None:
    """``y`` must be one state of ``scene`` (a :class:`DriveState` of its shapes)."""
    _check_scene(scene, caller)
    if not isinstance(y, DriveState):
        raise TypeError(
            f"{caller}: y must be a jc.DriveState (e.g. jc.initial_state(scene)), got "
            f"{type(y).__name__}"
        )
    n, ns = scene.n_bodies, len(scene.sprockets)
    want = {"q": (n, 3), "v": (n, 3), "theta": (ns,), "omega": (ns,)}
    nd = n_dofs(scene)
    if nd:
        want.update(dof=(nd,), dof_rate=(nd,))
    for name in ("dof", "dof_rate"):
        if not nd and getattr(y, name) is not None:
            raise ValueError(
                f"{caller}: y.{name} must be None for a scene whose elements have no "
                "coordinates of their own (no tensioner arm)"
            )
        if nd and getattr(y, name) is None:
            raise ValueError(
                f"{caller}: y.{name} must have shape ({nd},) for this scene (its elements' "
                "own coordinates: tensioner arms and the like), got None; start from "
                "jc.initial_state(scene)"
            )
    nb = n_bristles(scene)
    if nb:
        want["bristle"] = (nb,)
    elif y.bristle is not None:
        raise ValueError(
            f"{caller}: y.bristle must be None for a scene without Dahl joint friction"
        )
    if nb and y.bristle is None:
        raise ValueError(
            f"{caller}: y.bristle must have shape ({nb},) for this scene (its joints' Dahl "
            "friction states), got None; start from jc.initial_state(scene)"
        )
    for name, shape in want.items():
        got = np.shape(getattr(y, name))
        if got != shape:
            batched = got[1:] == shape
            raise ValueError(
                f"{caller}: y.{name} must have shape {shape} for this scene ({n} bodies, "
                f"{ns} sprockets), got {got}"
                + ("; for a batch of states use jax.vmap over y" if batched else "")
            )


def initial_state(scene: Scene) -> DriveState:
    """The state the scene starts from (its bodies' q0, v0; the sprockets' angle0 and
    speed): what :func:`vector_field` takes as ``y`` at t0."""
    _check_scene(scene, "initial_state")
    checks.element_coordinates(scene, "initial_state")
    dof, dof_rate = dof_start(scene)
    return DriveState(
        q=scene.q0,
        v=scene.v0,
        theta=jnp.stack([s.angle0 for s in scene.sprockets]),
        omega=jnp.stack([s.speed for s in scene.sprockets]),
        dof=dof,
        dof_rate=dof_rate,
        bristle=_zero_bristle(scene),
    )


def dof_layout(scene: Scene) -> tuple[tuple[int, int, int], ...]:
    """Where each force element with coordinates of its own keeps them in
    ``DriveState.dof`` (static): (index in ``scene.force_elements``, start, count). The
    tensioner arms come first (they precede every added element)."""
    out, start = [], 0
    for i, el in enumerate(scene.force_elements):
        k = el.n_dofs(scene)
        if k:
            out.append((i, start, k))
            start += k
    return tuple(out)


def n_dofs(scene: Scene) -> int:
    """Length of ``DriveState.dof`` for ``scene`` (0: None)."""
    return sum(k for *_, k in dof_layout(scene))


def _dof_owners(scene: Scene):
    return [scene.force_elements[i] for i, _, _ in dof_layout(scene)]


def dof_start(scene: Scene) -> tuple[Array | None, Array | None]:
    """((D,), (D,)) every element coordinate and its rate at t = 0, in
    :func:`dof_layout`'s order; (None, None) when there are none."""
    starts = [el.dof_start(scene) for el in _dof_owners(scene)]
    if not starts:
        return None, None
    dtype = scene.q0.dtype
    return tuple(
        jnp.concatenate([jnp.reshape(jnp.asarray(s[j], dtype), -1) for s in starts]) for j in (0, 1)
    )


def dof_inertia(scene: Scene) -> Array | None:
    """(D,) the mass or inertia of each element coordinate (None: there are none)."""
    parts = [jnp.reshape(jnp.asarray(el.dof_inertia(scene)), -1) for el in _dof_owners(scene)]
    return jnp.concatenate(parts) if parts else None


def bristle_layout(scene: Scene) -> tuple[tuple[str, int, int, int], ...]:
    """Where each force element with states of its own (a Dahl joint friction, a user's
    element) keeps them in ``DriveState.bristle`` (static): (kind, index, start, count),
    kind ``"pairs"`` for ``scene.pairs[index]``, ``"joints"`` for the lumped chain's
    joint friction, ``"elements"`` for ``scene.added[index]``."""
    out, start = [], 0
    for kind, i, el in _labelled(scene):
        k = el.n_states(scene)
        if k:
            out.append((kind, i, start, k))
            start += k
    return tuple(out)


def _labelled(scene: Scene):
    """(kind, index, element) of every force element, in ``scene.force_elements`` order:
    ``"pairs"`` and its index among the pairs, ``"joints"`` for the lumped chain's joint
    friction, ``"elements"`` and its index among the added ones, else the class name."""
    counts = {"pairs": 0, None: 0}
    for el in scene.force_elements:
        if el.role in counts:
            kind = "pairs" if el.role == "pairs" else "elements"
            yield kind, counts[el.role], el
            counts[el.role] += 1
        elif el.role == "joint_friction":
            yield "joints", 0, el
        else:
            yield type(el).__name__, 0, el


def _element_states(y, scene: Scene):
    """Each force element's own states (None for those with none): slices of
    ``y.bristle`` (zeros where ``y`` carries none, as in the statics); an
    :class:`~jaxchain.elements.ElementState` for an element with coordinates of its own
    (slices of ``y.dof``/``y.dof_rate``)."""
    out, start, at = [], 0, 0
    for el in scene.force_elements:
        k = el.n_states(scene)
        if not k:
            z = None
        elif y.bristle is None:
            z = jnp.zeros((k,), y.q.dtype)
        else:
            z = y.bristle[start : start + k]
        start += k
        d = el.n_dofs(scene)
        if d:
            z = ElementState(y.dof[at : at + d], y.dof_rate[at : at + d], z)
            at += d
        out.append(z)
    return out


def n_bristles(scene: Scene) -> int:
    """Length of ``DriveState.bristle`` for ``scene`` (0: None)."""
    return sum(k for *_, k in bristle_layout(scene))


def _zero_bristle(scene: Scene):
    nb = n_bristles(scene)
    return jnp.zeros((nb,), scene.q0.dtype) if nb else None


def roller_kinematics(y: DriveState, scene: Scene) -> tuple[Array, Array]:
    """(R, 2) roller centres [m] and (R, 2) their velocities [m/s], world frame."""
    _check_state(y, scene, "roller_kinematics")
    x, xd, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
    return x, xd


def roller_contacts(y: DriveState, scene: Scene, cs=None) -> RollerContacts:
    """The scene's rollers against every sprocket's teeth; all the chain's other elements
    are skipped (what the per-step peak record needs)."""
    teeth = scene.roller_teeth
    state = None
    if teeth.n_states(scene):  # a friction law with states: this element's slice of them
        at = next(i for i, el in enumerate(scene.force_elements) if el is teeth)
        state = _element_states(y, scene)[at]
    return teeth.contacts(y, scene, cs, state)


def roller_normal_forces(y: DriveState, scene: Scene) -> Float[Array, "S R"]:
    """(S, R) each roller's normal force against each sprocket's teeth [N]: the normal law
    alone (it reads depth and approach, not the friction), so no friction law and none of
    its states are evaluated — what the per-step peak record samples."""
    _check_state(y, scene, "roller_normal_forces")
    return scene.roller_teeth.contacts(y, scene, friction=False).normal


def contact_slots_ok(y: DriveState, scene: Scene) -> Array:
    """Whether every element that checks only the rollers nearest to it (sprockets, shoes)
    covers every roller that can reach it, so no roller left out can touch a tooth or a
    shoe. True when every roller is checked."""
    ok = jnp.asarray(True)
    for el in scene.force_elements:
        ok = ok & el.slots_ok(y, scene)
    return ok


def peak_tension(y: DriveState, scene: Scene) -> Array:
    """The largest tension of any tension-carrying element (link spring or pin/bush joint)
    [N]; cheap beside the contacts (what the solve's health compares with the chain's
    tensile strength)."""
    tension = chain_tension(y, scene)
    if tension.shape[0] == 0:
        return jnp.zeros((), y.q.dtype)
    return jnp.max(tension)


def _sum(parts, shape, dtype):
    parts = [p for p in parts if p is not None]
    return sum(parts[1:], parts[0]) if parts else jnp.zeros(shape, dtype)


def _reported(effects, name):
    got = [e.report[name] for e in effects if e.report is not None and name in e.report]
    return got


def effects(t, y: DriveState, scene: Scene) -> list[Effect]:
    """Every force element's :class:`~jaxchain.elements.Effect` at one instant, in
    ``scene.force_elements`` order."""
    out, carried = [], []
    for el, z in zip(scene.force_elements, _element_states(y, scene), strict=True):
        if el.reads_tension:
            e = el.effect(t, y, scene, z, tension=_tensions(carried, y.q.dtype))
        else:
            e = el.effect(t, y, scene, z)
        if e.tension is not None:
            carried.append(e.tension)
        out.append(e)
    return out


#: the public name of :func:`effects` (``jc.element_effects``)
element_effects = effects


def _tensions(parts, dtype):
    return jnp.concatenate(parts) if parts else jnp.zeros((0,), dtype)


# jitted: a solve calls the forces at every stage of its step, in its observers and in its
# outputs; as a jitted function they are traced once per program instead of at every call
@jax.jit
def forces(t, y: DriveState, scene: Scene) -> Forces:
    """The sum of the scene's force elements at one instant."""
    return _combine(effects(t, y, scene), y, scene)


def _combine(eff: list[Effect], y: DriveState, scene: Scene) -> Forces:
    dtype = y.q.dtype
    ns, nr = len(scene.sprockets), scene.n_rollers
    rates_ = [e.state_rate for e in eff if e.state_rate is not None]
    shoe_normal = _reported(eff, "shoe_normal")
    shoe_force = _reported(eff, "shoe_force")
    chain_arm = _reported(eff, "arm_torque")
    return Forces(
        body=_sum([e.body for e in eff], y.q.shape, dtype),
        roller_normal=_sum(_reported(eff, "roller_normal"), (ns, nr), dtype),
        sprocket_torque=_sum([e.sprocket_torque for e in eff], (ns,), dtype),
        sprocket_force=_sum([e.sprocket_force for e in eff], (ns, 2), dtype),
        element_tension=_tensions([e.tension for e in eff if e.tension is not None], dtype),
        shoe_normal=shoe_normal[0] if shoe_normal else None,
        shoe_force=shoe_force[0] if shoe_force else None,
        arm_torque=chain_arm[0] if (chain_arm and chain_arm[0].shape[0]) else None,
        bristle_rate=jnp.concatenate(rates_) if rates_ else None,
        joint_friction_power=_sum(_reported(eff, "friction_power"), (), dtype),
        dof_force=_dof_force(eff, y, scene),
        tooth_friction_power=_sum(
            [jnp.sum(p) for p in _reported(eff, "tooth_friction_power")], (), dtype
        ),
    )


def _dof_force(eff: list[Effect], y: DriveState, scene: Scene):
    """(D,) the generalized force on every element coordinate: each owner's own
    ``dof_force``, plus every element's ``arm_torque`` on the tensioner arms (the first
    coordinates); None without coordinates."""
    if y.dof is None:
        return None
    parts = []
    for i, _, k in dof_layout(scene):
        own = eff[i].dof_force
        parts.append(jnp.zeros((k,), y.q.dtype) if own is None else own)
    total = jnp.concatenate(parts)
    for e in eff:
        if e.arm_torque is not None:
            total = total.at[: e.arm_torque.shape[0]].add(e.arm_torque)
    return total


def vector_field(t, y: DriveState, scene: Scene) -> DriveState:
    """dy/dt: the equations of motion of the drive (pure; diffrax's ``ODETerm`` target)."""
    _check_state(y, scene, "vector_field")
    return rates(t, y, scene, forces(t, y, scene))


def rates(t, y: DriveState, scene: Scene, fr: Forces) -> DriveState:
    """dy/dt from already computed forces (for fields that also use the forces)."""
    inv = jnp.stack([1 / scene.mass, 1 / scene.mass, 1 / scene.inertia], -1)
    acc = fr.body * inv
    dtheta, domega = [], []
    for k, spr in enumerate(scene.sprockets):
        if spr.driven:
            dtheta.append(y.omega[k])
            load = spr.load(t, y.theta[k], y.omega[k])
            domega.append((fr.sprocket_torque[k] - load) / spr.inertia)
        else:  # driver: prescribed constant speed
            dtheta.append(spr.speed)
            domega.append(jnp.zeros_like(spr.speed))
    dof = dof_acc = None
    if y.dof is not None:
        dof = y.dof_rate
        dof_acc = fr.dof_force / dof_inertia(scene)
    return DriveState(
        q=y.v,
        v=acc,
        theta=jnp.stack(dtheta),
        omega=jnp.stack(domega),
        dof=dof,
        dof_rate=dof_acc,
        bristle=None if y.bristle is None else fr.bristle_rate,
    )


#: the names :func:`outputs` gives the chain's and the sprockets' own quantities; every
#: other output is a force element's (``AbstractElement.outputs``)
CHAIN_OUTPUTS = (
    "roller_position", "roller_velocity", "roller_sprocket_force", "link_tension",
    "sprocket_speed", "sprocket_angle", "sprocket_torque", "span_tension",
)  # fmt: skip


def outputs(t, y: DriveState, scene: Scene) -> dict[str, Array]:
    """Named quantities at one instant (what ``simulate`` saves): the chain's and the
    sprockets', then each force element's own."""
    eff = effects(t, y, scene)
    fr = _combine(eff, y, scene)
    xr, vr, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
    out = {
        "roller_position": xr,
        "roller_velocity": vr,
        "roller_sprocket_force": jnp.sum(fr.roller_normal, axis=0),
        "link_tension": scene.link_weights @ fr.element_tension,
        "sprocket_speed": y.omega,
        "sprocket_angle": y.theta,
        "sprocket_torque": fr.sprocket_torque,
    }
    spans = _span_tension(xr, out["link_tension"], scene)
    if spans is not None:
        out["span_tension"] = spans
    for el, e in zip(scene.force_elements, eff, strict=True):
        out.update(el.outputs(t, y, scene, e))
    return out


def energy(t, y: DriveState, scene: Scene) -> dict[str, Array]:
    """Mechanical energy [J]: kinetic (chain bodies, driven sprockets, the elements' own
    coordinates: tensioner arms and the like) and
    the energies the force elements store, by kind: elastic (link springs, joint contacts,
    roller/tooth and roller/shoe contacts, tensioner springs) and gravity's (−Σ m·g·x of
    the chain bodies, 0 without gravity). The anchors' guide springs are not included."""
    _check_state(y, scene, "energy")
    inertia = jnp.stack([scene.mass, scene.mass, scene.inertia], -1)
    kinetic = 0.5 * jnp.sum(inertia * y.v**2)
    for k, spr in enumerate(scene.sprockets):
        if spr.driven:
            kinetic = kinetic + 0.5 * spr.inertia * y.omega[k] ** 2
    if y.dof is not None:
        kinetic = kinetic + 0.5 * jnp.sum(dof_inertia(scene) * y.dof_rate**2)
    out = {"kinetic": kinetic, "elastic": jnp.zeros((), y.q.dtype)}
    out["gravity"] = jnp.zeros((), y.q.dtype)
    for el, z in zip(scene.force_elements, _element_states(y, scene), strict=True):
        kind = el.energy_kind
        # an element with coordinates of its own reads them from its state
        stored = el.energy(t, y, scene, z) if el.n_dofs(scene) else el.energy(t, y, scene)
        out[kind] = out.get(kind, jnp.zeros((), y.q.dtype)) + stored
    return out
