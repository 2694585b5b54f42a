"""Equations of motion: M q̈ = forces(q, q̇, t), diagonal M, one pure vector field.

No Python loop runs over links, rollers or contacts: each group of force elements is
evaluated by one vectorized call and scattered onto bodies with segment sums. The only
Python loops are over the (static, few) element groups and sprockets.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._contact.dahl import DahlFriction
from ._freeform import FreeShape
from ._gap import gap_contact, gap_shapes, with_table
from ._numerics import cross2, safe_norm, safe_normalize, smooth_ramp
from ._scene import ClearanceJoints, JointFriction, LinkSprings, Scene
from ._shoe import shoe_contacts, shoe_frames

__all__ = [
    "DriveState",
    "initial_state",
    "vector_field",
    "rates",
    "outputs",
    "Forces",
    "energy",
    "roller_contacts",
    "roller_kinematics",
    "contact_slots_ok",
    "bristle_layout",
]


class DriveState(NamedTuple):
    """ODE state. q, v: (N, 3) bodies' (x, y, φ) and rates; theta, omega: (S,) sprockets;
    arm, arm_rate: (A,) tensioner arm angles [rad] and rates [rad/s] (None without
    tensioners); bristle: (F,) pre-sliding deflections [m] of the joints with
    :class:`~jaxchain.contact.DahlFriction` (None without; order: :func:`bristle_layout`)."""

    q: Float[Array, "N 3"]
    v: Float[Array, "N 3"]
    theta: Float[Array, " S"]
    omega: Float[Array, " S"]
    arm: Float[Array, " A"] | None = None
    arm_rate: Float[Array, " A"] | None = None
    bristle: Float[Array, " F"] | None = None


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
    na = 0 if scene.tensioners is None else scene.tensioners.count
    if na:
        want.update(arm=(na,), arm_rate=(na,))
    for name in ("arm", "arm_rate"):
        if not na and getattr(y, name) is not None:
            raise ValueError(f"{caller}: y.{name} must be None for a scene without tensioners")
        if na and getattr(y, name) is None:
            raise ValueError(
                f"{caller}: y.{name} must have shape ({na},) for this scene ({na} tensioner "
                "arms), got None; start from jc.initial_state(scene)"
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
    tn = scene.tensioners
    return DriveState(
        q=scene.q0,
        v=scene.v0,
        theta=jnp.stack([s.angle0 for s in scene.sprockets]),
        omega=jnp.stack([s.speed for s in scene.sprockets]),
        arm=None if tn is None else tn.angle0,
        arm_rate=None if tn is None else tn.rate0,
        bristle=_zero_bristle(scene),
    )


def bristle_layout(scene: Scene) -> tuple[tuple[str, int, int, int], ...]:
    """Where each stateful (Dahl) joint friction keeps its states in ``DriveState.bristle``
    (static): (``"pairs"``, group index, start, count) for the clearance joints of
    ``scene.pairs[group]``, then (``"joints"``, 0, start, count) for the lumped chain's
    joint friction."""
    out, start = [], 0
    for g, grp in enumerate(scene.pairs):
        if isinstance(grp.element, ClearanceJoints) and isinstance(
            grp.element.friction, DahlFriction
        ):
            k = int(np.shape(grp.a)[0])
            out.append(("pairs", g, start, k))
            start += k
    jf = scene.joint_friction
    if jf is not None and isinstance(jf.law, DahlFriction):
        k = int(np.shape(jf.joint)[0])
        out.append(("joints", 0, start, k))
    return tuple(out)


def n_bristles(scene: Scene) -> int:
    """Length of ``DriveState.bristle`` for ``scene`` (0: None)."""
    return sum(k for *_, k in bristle_layout(scene))


def _zero_bristle(scene: Scene):
    nb = n_bristles(scene)
    return jnp.zeros((nb,), scene.q0.dtype) if nb else None


def _bristle_of(y: DriveState, scene: Scene, start: int, count: int):
    """The ``count`` bristle states from ``start`` (zeros where the state carries none, as
    in the statics, which hold every joint at rest)."""
    if y.bristle is None:
        return jnp.zeros((count,), y.q.dtype)
    return y.bristle[start : start + count]


def _rot(phi):
    return jnp.cos(phi), jnp.sin(phi)


def _points(q, v, body, offset, cs=None):
    """World position and velocity of body-fixed points; ``cs``: (cos, sin) of every
    body's angle when the caller has them (trig once per body, not once per point)."""
    c, s = _rot(q[body, 2]) if cs is None else (cs[0][body], cs[1][body])
    arm = jnp.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1]], -1)
    w = v[body, 2:3]
    x = q[body, :2] + arm
    xd = v[body, :2] + w * jnp.stack([-arm[:, 1], arm[:, 0]], -1)
    return x, xd, arm


def roller_kinematics(y: DriveState, scene: Scene) -> tuple[Array, Array]:
    """(R, 2) roller centres [m] and (R, 2) their velocities [m/s], world frame."""
    _check_state(y, scene, "roller_kinematics")
    x, xd, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
    return x, xd


def _scatter(n, body, arm, f):
    """Generalized forces (fx, fy, τ) of point forces f applied at arms, summed per body."""
    gen = jnp.concatenate([f, cross2(arm, f)[:, None]], axis=-1)
    return jax.ops.segment_sum(gen, body, num_segments=n)


class RollerContacts(NamedTuple):
    """The roller/tooth contacts of one instant (part of :class:`Forces`)."""

    force: Float[Array, "R 2"]  # total contact force on each roller (all sprockets) [N]
    arm: Float[Array, "R 2"]  # roller centre from its body's origin [m]
    normal: Float[Array, "S R"]  # normal force per sprocket and roller [N]
    sprocket_torque: Float[Array, " S"]
    sprocket_force: Float[Array, "S 2"]


def _contact_slots(scene: Scene, n_rollers: int) -> int | None:
    """Rollers checked per sprocket (static): the most any sprocket asks for, or None
    (every roller) when one asks for all."""
    slots = [s.contact_slots for s in scene.sprockets]
    if any(k is None or k >= n_rollers for k in slots):
        return None
    return max(slots)


def prepare(scene: Scene) -> Scene:
    """``scene`` with its sprockets' contact shapes computed once (a free-form profile's
    every gap outline: its :func:`~jaxchain._gap.gap_table`), for the steps of one solve to
    read: the shapes depend on the profiles alone, so computing them in every evaluation
    of the contact repeats the same work at every stage, and a gradient pulls back through
    them at every stage too (a 72-coordinate per-gap design objective's value + gradient:
    7 % less time)."""
    shapes = gap_shapes([s.profile for s in scene.sprockets])
    if isinstance(shapes, FreeShape):
        shapes = jax.vmap(with_table)(shapes)
    return eqx.tree_at(lambda s: s.prepared_shapes, scene, shapes, is_leaf=lambda x: x is None)


def roller_contacts(y: DriveState, scene: Scene, cs=None) -> RollerContacts:
    """Rollers against every sprocket (each roller sees its nearest gap: O(1) per pair);
    all the chain's elements but these are skipped (what the per-step peak record needs).

    One vmapped evaluation over the sprockets (their tooth shapes stacked): the contact
    appears once in the traced program, so its size and the gradient's compile time do
    not grow with the number of sprockets."""
    xr, vr, arm_r = _points(y.q, y.v, scene.roller_body, scene.roller_offset, cs)
    r = scene.roller_radius
    n_r = xr.shape[0]
    slots = _contact_slots(scene, n_r)
    shapes = scene.prepared_shapes
    if shapes is None:
        shapes = gap_shapes([s.profile for s in scene.sprockets])
    centres = jnp.stack([s.centre for s in scene.sprockets])

    def one(shape, centre, theta, omega):
        c, s = jnp.cos(theta), jnp.sin(theta)
        rel_all = xr - centre
        sel = jnp.arange(n_r) if slots is None else _nearest(rel_all, slots)[0]
        rel, vsel = rel_all[sel], vr[sel]
        local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
        depth, nl = jax.vmap(gap_contact, in_axes=(None, 0))(shape, local)
        nrm = jnp.stack([c * nl[:, 0] - s * nl[:, 1], s * nl[:, 0] + c * nl[:, 1]], -1)
        arm_s = rel - r * nrm  # contact point on the roller surface, from the axis
        vsurf = omega * jnp.stack([-arm_s[:, 1], arm_s[:, 0]], -1)
        vrel = vsel - vsurf
        approach = -jnp.sum(nrm * vrel, -1)
        fn = scene.roller_law.normal_force(depth, approach, scene.impact_speed)
        f = fn[:, None] * nrm
        if scene.friction is not None:
            tang = jnp.stack([-nrm[:, 1], nrm[:, 0]], -1)
            slip = jnp.sum(tang * vrel, -1)
            f = f + scene.friction.force(fn, slip)[:, None] * tang
        return (
            jnp.zeros_like(xr).at[sel].add(f),
            jnp.zeros(n_r, fn.dtype).at[sel].add(fn),
            jnp.sum(cross2(arm_s, -f)),
            -jnp.sum(f, axis=0),
        )

    f, normal, torque, pull = jax.vmap(one)(shapes, centres, y.theta, y.omega)
    return RollerContacts(jnp.sum(f, axis=0), arm_r, normal, torque, pull)


def _nearest(rel, slots: int):
    """Indices of the ``slots`` rollers nearest the axis (``rel``: centres from the axis),
    and the squared distance of the farthest of them (no gradient: a selection)."""
    d2 = jax.lax.stop_gradient(jnp.sum(rel * rel, -1))
    neg, sel = jax.lax.top_k(-d2, slots)
    return sel, -jnp.min(neg)


def contact_slots_ok(y: DriveState, scene: Scene) -> Array:
    """Whether the contact slots of every sprocket and shoe cover every roller within
    reach: for a sprocket, the farthest roller checked lies beyond the tip radius + 1.05
    roller radii (all tooth material lies inside the tip circle); for a shoe, beyond half
    its length + 1.05 roller radii from its middle (a roller touching it lies within half
    its length of the middle along it, and within a roller radius of its face). So no
    roller left out can touch a tooth or a shoe. True when every roller is checked."""
    xr, _, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
    r = scene.roller_radius
    ok = jnp.asarray(True)
    slots = _contact_slots(scene, xr.shape[0])
    if slots is not None:
        reach = jnp.stack([s.profile.reach_radius for s in scene.sprockets])
        centres = jnp.stack([s.centre for s in scene.sprockets])

        def one(reach, centre):
            return _nearest(xr - centre, slots)[1] > reach**2

        ok = jnp.all(jax.vmap(one)(reach, centres))
    sh = scene.shoes
    if sh is not None and sh.slots is not None and sh.slots < xr.shape[0]:
        turn, pivot, _ = shoe_frames(y, scene)

        def shoe(mid, half, alpha, piv):
            c, s = jnp.cos(alpha), jnp.sin(alpha)
            rel = mid - piv
            mid_now = piv + jnp.stack([c * rel[0] - s * rel[1], s * rel[0] + c * rel[1]])
            return _nearest(xr - mid_now, sh.slots)[1] > (half + 1.05 * r) ** 2

        ok = ok & jnp.all(jax.vmap(shoe)(sh.mid, sh.half_length, turn, pivot))
    return ok


class _PairState(NamedTuple):
    tension: Array  # (P,) [N]
    u: Array  # (P, 2) unit direction a→b
    arm_a: Array  # (P, 2) point a from its body's origin
    arm_b: Array
    dv: Array  # (P, 2) velocity of point b minus point a


def _pair(grp, q, v, cs, impact_speed) -> _PairState:
    """A pair group's tensions, unit directions a→b, lever arms and relative velocity."""
    xa, va, arm_a = _points(q, v, grp.a, grp.ra, cs)
    xb, vb, arm_b = _points(q, v, grp.b, grp.rb, cs)
    d = xb - xa
    u = safe_normalize(d, jnp.array([1.0, 0.0], dtype=q.dtype))
    rate = jnp.sum(u * (vb - va), axis=-1)
    tension = grp.element.tension(safe_norm(d), rate, impact_speed)
    return _PairState(tension, u, arm_a, arm_b, vb - va)


def _perp(d):
    return jnp.stack([-d[..., 1], d[..., 0]], -1)


def _clearance_friction(n, grp, ps: _PairState, v, bristle=None):
    """Generalized forces of a clearance joint's contact friction: the tangential force at
    the contact point (where the pin at a touches the hole around b, on the side −u),
    against the sliding of the pin's surface on the hole's; and, for a Dahl law, the rate
    of its states ``bristle`` (else None)."""
    el = grp.element
    r_pin, r_hole = el.radius, el.radius + el.clearance
    t = _perp(ps.u)
    slip = -jnp.sum(ps.dv * t, -1) - v[grp.a, 2] * r_pin + v[grp.b, 2] * r_hole
    if isinstance(el.friction, DahlFriction):
        ft = el.friction.force(ps.tension, bristle, slip)[:, None] * t
        rate = el.friction.rate(bristle, slip)
    else:
        ft = el.friction.force(ps.tension, slip)[:, None] * t
        rate = None
    on_a = _scatter(n, grp.a, ps.arm_a - r_pin * ps.u, ft)
    return on_a + _scatter(n, grp.b, ps.arm_b - r_hole * ps.u, -ft), rate


def _joint_friction(n, jf: JointFriction, q, v, tension, bristle=None):
    """Generalized forces of the lumped chain's joint friction (see :class:`JointFriction`):
    each moment as a couple ±M/ℓ² · perp(d) at its link's ends; and, for a Dahl law, the
    rate of its states ``bristle`` (else None)."""
    xa, xj, xb = q[jf.before, :2], q[jf.joint, :2], q[jf.after, :2]
    va, vj, vb = v[jf.before, :2], v[jf.joint, :2], v[jf.after, :2]
    d1, d2 = xj - xa, xb - xj
    l1, l2 = jnp.sum(d1 * d1, -1), jnp.sum(d2 * d2, -1)
    rel_rate = cross2(d2, vb - vj) / l2 - cross2(d1, vj - va) / l1
    load = smooth_ramp(0.5 * (tension[jf.link_before] + tension[jf.link_after]), jf.load_width)
    r = jf.pin_radius
    if isinstance(jf.law, DahlFriction):  # on the link after; −moment before
        moment = jf.law.force(load * r, bristle, r * rel_rate)
        rate = jf.law.rate(bristle, r * rel_rate)
    else:
        moment = jf.law.force(load * r, r * rel_rate)
        rate = None
    f2 = (moment / l2)[:, None] * _perp(d2)
    f1 = (moment / l1)[:, None] * _perp(d1)
    gen = jnp.zeros((n, 2), q.dtype)
    gen = gen.at[jf.after].add(f2).at[jf.joint].add(-f2 - f1).at[jf.before].add(f1)
    return jnp.concatenate([gen, jnp.zeros((n, 1), q.dtype)], axis=-1), rate


def peak_tension(y: DriveState, scene: Scene) -> Array:
    """The largest tension of any tension-carrying element (link spring or pin/bush joint)
    [N]; cheap beside the contacts (what the solve's health compares with the chain's
    tensile strength)."""
    cs = _rot(y.q[:, 2])
    tensions = [
        _pair(grp, y.q, y.v, cs, scene.impact_speed).tension
        for grp in scene.pairs
        if grp.carries_tension
    ]
    if not tensions:
        return jnp.zeros((), y.q.dtype)
    return jnp.max(jnp.concatenate(tensions))


# jitted: a solve calls the forces at every stage of its step, in its observers and in its
# outputs; as a jitted function they are traced once per program instead of at every call
# (measured on the design gradient: tracing 11.9 s -> 6.6 s, the same values)
@jax.jit
def forces(t, y: DriveState, scene: Scene) -> Forces:
    n = scene.n_bodies
    q, v = y.q, y.v
    total = jnp.zeros((n, 3), q.dtype)
    tensions = []
    cs = _rot(q[:, 2])
    slots = {(kind, g): (start, k) for kind, g, start, k in bristle_layout(scene)}
    bristle_rates = []
    friction = jnp.zeros((n, 3), q.dtype)  # generalized forces of the joints' friction
    for g, grp in enumerate(scene.pairs):
        ps = _pair(grp, q, v, cs, scene.impact_speed)
        f = ps.tension[:, None] * ps.u
        total = total + _scatter(n, grp.a, ps.arm_a, f) + _scatter(n, grp.b, ps.arm_b, -f)
        if isinstance(grp.element, ClearanceJoints) and grp.element.friction is not None:
            z = _bristle_of(y, scene, *slots[("pairs", g)]) if ("pairs", g) in slots else None
            gen, rate = _clearance_friction(n, grp, ps, v, z)
            friction = friction + gen
            if rate is not None:
                bristle_rates.append(rate)
        if grp.carries_tension:
            tensions.append(ps.tension)
    element_tension = jnp.concatenate(tensions) if tensions else jnp.zeros((0,), q.dtype)
    if scene.joint_friction is not None:
        z = _bristle_of(y, scene, *slots[("joints", 0)]) if ("joints", 0) in slots else None
        gen, rate = _joint_friction(n, scene.joint_friction, q, v, element_tension, z)
        friction = friction + gen
        if rate is not None:
            bristle_rates.append(rate)
    total = total + friction

    if scene.anchors is not None:
        an = scene.anchors
        x, xd = q[an.body, :2], v[an.body, :2]
        guide = an.origin + (an.speed * t)[:, None] * an.direction
        rel = guide - x
        s = jnp.sum(rel * an.direction, -1)
        perp = rel - s[:, None] * an.direction
        relv = an.speed[:, None] * an.direction - xd
        f = (an.tension + an.stiffness * s)[:, None] * an.direction
        f = f + an.stiffness[:, None] * perp + an.damping[:, None] * relv
        total = total.at[an.body, :2].add(f)

    rc = roller_contacts(y, scene, cs)
    total = total + _scatter(n, scene.roller_body, rc.arm, rc.force)
    shoe = None
    if scene.shoes is not None:
        xr, vr, _ = _points(q, v, scene.roller_body, scene.roller_offset, cs)
        shoe = shoe_contacts(y, scene, xr, vr, scene.roller_radius)
        total = total + _scatter(n, scene.roller_body, rc.arm, shoe.force)
    total = total.at[:, :2].add(scene.mass[:, None] * scene.gravity)
    return Forces(
        body=total,
        roller_normal=rc.normal,
        sprocket_torque=rc.sprocket_torque,
        sprocket_force=rc.sprocket_force,
        element_tension=element_tension,
        shoe_normal=None if shoe is None else shoe.normal,
        shoe_force=None if shoe is None else shoe.resultant,
        arm_torque=None if scene.tensioners is None else shoe.arm_torque,
        bristle_rate=jnp.concatenate(bristle_rates) if bristle_rates else None,
        joint_friction_power=jnp.sum(friction * v),
    )


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
    tn = scene.tensioners
    arm = arm_acc = None
    if tn is not None:
        arm = y.arm_rate
        arm_acc = (fr.arm_torque + tn.spring_torque(y.arm, y.arm_rate)) / tn.inertia
    return DriveState(
        q=y.v,
        v=acc,
        theta=jnp.stack(dtheta),
        omega=jnp.stack(domega),
        arm=arm,
        arm_rate=arm_acc,
        bristle=None if y.bristle is None else fr.bristle_rate,
    )


def outputs(t, y: DriveState, scene: Scene) -> dict[str, Array]:
    """Named quantities at one instant (what ``simulate`` saves)."""
    fr = forces(t, y, scene)
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
    if scene.shoes is not None:
        na = scene.shoes.n_tensioners
        magnitude = safe_norm(fr.shoe_force)
        out["roller_shoe_force"] = fr.shoe_normal
        out["guide_force"] = magnitude[na:]
        if na:
            out["tensioner_angle"] = y.arm
            out["tensioner_force"] = magnitude[:na]
            out["tensioner_torque"] = scene.tensioners.spring_torque(y.arm, y.arm_rate)
    return out


def _potential(law, depth, n_nodes: int = 24):
    """∫ elastic force d(depth) from the onset (−width) to ``depth`` [J] (Gauss–Legendre)."""
    x, w = np.polynomial.legendre.leggauss(n_nodes)
    lo = -law.width
    hi = jnp.maximum(depth, lo)
    half = 0.5 * (hi - lo)
    pts = lo + half[..., None] * (x + 1.0)
    return half * jnp.sum(w * law.elastic_force(pts), axis=-1)


def energy(t, y: DriveState, scene: Scene) -> dict[str, Array]:
    """Mechanical energy [J]: kinetic (chain bodies, driven sprockets, tensioner arms),
    elastic (link springs, joint contacts, roller/tooth and roller/shoe contacts,
    tensioner springs) and gravity's (−Σ m·g·x of the chain bodies, 0 without gravity).
    The anchors' guide springs are not included."""
    del t
    _check_state(y, scene, "energy")
    inertia = jnp.stack([scene.mass, scene.mass, scene.inertia], -1)
    kinetic = 0.5 * jnp.sum(inertia * y.v**2)
    for k, spr in enumerate(scene.sprockets):
        if spr.driven:
            kinetic = kinetic + 0.5 * spr.inertia * y.omega[k] ** 2
    elastic = jnp.zeros((), y.q.dtype)
    for grp in scene.pairs:
        xa, _, _ = _points(y.q, y.v, grp.a, grp.ra)
        xb, _, _ = _points(y.q, y.v, grp.b, grp.rb)
        length = safe_norm(xb - xa)
        el = grp.element
        if isinstance(el, LinkSprings):
            elastic = elastic + jnp.sum(0.5 * el.stiffness * (length - el.rest_length) ** 2)
        else:
            elastic = elastic + jnp.sum(_potential(el.law, length - el.clearance))
    xr, _, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
    for k, spr in enumerate(scene.sprockets):
        c, s = jnp.cos(y.theta[k]), jnp.sin(y.theta[k])
        rel = xr - spr.centre
        local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
        depth, _ = jax.vmap(gap_contact, in_axes=(None, 0))(spr.profile, local)
        elastic = elastic + jnp.sum(_potential(scene.roller_law, depth))
    tn = scene.tensioners
    if tn is not None:
        kinetic = kinetic + 0.5 * jnp.sum(tn.inertia * y.arm_rate**2)
        phi = tn.sense * (y.arm - tn.layout_angle)
        elastic = elastic + jnp.sum(0.5 * tn.stiffness * phi**2 - tn.preload * phi)
    if scene.shoes is not None:
        _, vr, _ = _points(y.q, y.v, scene.roller_body, scene.roller_offset)
        sc = shoe_contacts(y, scene, xr, vr, scene.roller_radius)
        elastic = elastic + jnp.sum(_potential(scene.shoes.law, sc.depth) * sc.gate)
    weight = -jnp.sum(scene.mass[:, None] * scene.gravity * y.q[:, :2])
    return {"kinetic": kinetic, "elastic": elastic, "gravity": weight}
