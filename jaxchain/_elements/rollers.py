"""Contact of the rollers (in a bush chain: the bushes) with the sprockets' teeth.

The friction at a contact opposes the slip of the engaging circle's surface over the
tooth's. A roller chain's slip is the roller centre's velocity relative to the tooth
surface (the roller's own spin is not modelled). A bush is fixed to its inner link
(``Scene.bush_link``), so its surface also moves with that link's rotation ω: the slip is
t·(v_c − v_tooth) − r·ω (t the contact tangent, r the bush radius), and the friction's
moment −r·F_t about the bush centre acts on the link as a couple on its two bushes,
±M·d⊥/|d|² (d from one bush to the other): a pure moment M on a rigid link, and on the
lumped chain's points a pair whose power is exactly M·ω. The link's ω is that of d,
(d × ḋ)/|d|², in both fidelities.

A friction law with states of its own (:class:`~jaxchain.contact.DahlFriction`) keeps
them per sprocket and roller (``DriveState.bristle``). They move only while their contact
carries load: their rate is the law's times F_n/(F_n + ``STATE_GATE``), so a roller away
from the teeth (whose slip over the nearest gap is meaningless and fast) holds its state
instead of relaxing it at |v_t|/x_s, which would be the stiffest rate of the drive.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._contact.base import AbstractContactLaw
from .._contact.friction_base import AbstractFrictionLaw
from .._contact.stiffness import tangent_stiffness
from .._kinematics import nearest, perp, points, scatter
from .._numerics import cross2
from .._profiles.contact import gap_contact, gap_shapes, prepare_shapes
from .base import AbstractElement, Effect

__all__ = ["RollerTeeth", "RollerContacts", "roller_contacts", "STATE_GATE"]

#: normal force [N] at which a roller/tooth contact's friction states move at half their
#: law's rate (they hold still while it carries no load)
STATE_GATE = 1.0


class RollerContacts(NamedTuple):
    """The roller/tooth contacts of one instant."""

    # total contact force on each roller (all sprockets; a bush chain's with the couples
    # that carry the friction's moments to the links) [N]
    force: Float[Array, "R 2"]
    arm: Float[Array, "R 2"]  # roller centre from its body's origin [m]
    normal: Float[Array, "S R"]  # normal force per sprocket and roller [N]
    sprocket_torque: Float[Array, " S"]
    sprocket_force: Float[Array, "S 2"]
    state_rate: Array | None = None  # (S, R[, k]) rates of the friction's states, or None
    # (S,) power of the friction on chain and sprocket [W] (Σ F_t·slip, ≤ 0 in sliding)
    friction_power: Array | None = None


def _contact_slots(scene, n_rollers: int) -> int | None:
    """Rollers checked per sprocket (static): the most any sprocket asks for, or None
    (every roller) when one asks for all."""
    slots = [s.contact_slots for s in scene.sprockets]
    if any(k is None or k >= n_rollers for k in slots):
        return None
    return max(slots)


def roller_contacts(y, scene, law, friction, cs=None, states=None) -> RollerContacts:
    """Rollers against every sprocket (each roller sees its nearest gap: O(1) per pair).
    ``states``: (S, R[, k]) the friction law's states per sprocket and roller (a law with
    states of its own), else None.

    One vmapped evaluation over the sprockets (their tooth shapes stacked): the contact
    appears once in the traced program, so its size and the gradient's compile time do
    not grow with the number of sprockets."""
    xr, vr, arm_r = points(y.q, y.v, scene.roller_body, scene.roller_offset, cs)
    r = scene.roller_radius
    n_r = xr.shape[0]
    bush = scene.bush_link is not None
    if bush:  # each bush turns with its inner link: ω of the line between its two bushes
        ia, ib = scene.bush_link[:, 0], scene.bush_link[:, 1]
        d, dv = xr[ib] - xr[ia], vr[ib] - vr[ia]
        spin_all = cross2(d, dv) / jnp.sum(d * d, -1)
    slots = _contact_slots(scene, n_r)
    shapes = scene.prepared_shapes
    if shapes is None:
        shapes = gap_shapes([s.profile for s in scene.sprockets])
    centres = jnp.stack([s.centre for s in scene.sprockets])

    stateful = friction is not None and friction.states_per_contact > 0
    if stateful and states is None:
        raise ValueError(
            f"roller_contacts: {type(friction).__name__} keeps states per contact; pass "
            "them (states=, per sprocket and roller)"
        )

    def one(shape, centre, theta, omega, z):
        c, s = jnp.cos(theta), jnp.sin(theta)
        rel_all = xr - centre
        if slots is None:  # every roller: no gather, no scatter (each ~30 ns per roller)
            sel, rel, vsel = None, rel_all, vr
            spin = spin_all if bush else None
        else:
            sel = nearest(rel_all, slots)[0]
            rel, vsel = rel_all[sel], vr[sel]
            spin = spin_all[sel] if bush else None
            z = None if z is None else z[sel]
        local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
        depth, nl = jax.vmap(gap_contact, in_axes=(None, 0))(shape, local)
        nrm = jnp.stack([c * nl[:, 0] - s * nl[:, 1], s * nl[:, 0] + c * nl[:, 1]], -1)
        arm_s = rel - r * nrm  # contact point on the roller surface, from the axis
        vsurf = omega * jnp.stack([-arm_s[:, 1], arm_s[:, 0]], -1)
        vrel = vsel - vsurf
        approach = -jnp.sum(nrm * vrel, -1)
        fn = law.normal_force(depth, approach, scene.impact_speed)
        f = fn[:, None] * nrm
        moment = rate = power = None
        if friction is not None:
            tang = jnp.stack([-nrm[:, 1], nrm[:, 0]], -1)
            slip = jnp.sum(tang * vrel, -1)
            if bush:  # the bush surface at the contact moves by ω × (−r·n) = −r·ω·t too
                slip = slip - r * spin
            ft = friction.traction(fn, slip, z)
            if stateful:  # the states move while the contact carries load (docstring)
                gate = fn / (fn + STATE_GATE)
                rate = friction.state_rate(z, slip)
                rate = rate * gate.reshape(gate.shape + (1,) * (rate.ndim - 1))
            f = f + ft[:, None] * tang
            power = jnp.sum(ft * slip)
            if bush:
                moment = -r * ft  # about the bush centre: (−r·n) × (F_t·t)
        torque, pull = jnp.sum(cross2(arm_s, -f)), -jnp.sum(f, axis=0)
        if sel is not None:  # back onto every roller
            f = jnp.zeros_like(xr).at[sel].add(f)
            fn = jnp.zeros(n_r, fn.dtype).at[sel].add(fn)
            if moment is not None:
                moment = jnp.zeros(n_r, moment.dtype).at[sel].add(moment)
            if rate is not None:  # the rollers left out hold their states
                rate = jnp.zeros((n_r,) + rate.shape[1:], rate.dtype).at[sel].set(rate)
        if moment is not None:  # the moment onto the bush's link: a couple on its bushes
            couple = moment[:, None] * perp(d) / jnp.sum(d * d, -1)[:, None]
            f = f.at[ib].add(couple).at[ia].add(-couple)
        return f, fn, torque, pull, rate, power

    ns = centres.shape[0]
    zs = [None] * ns if states is None else list(states)
    if isinstance(shapes, tuple):  # sprockets of kinds that do not stack: one by one
        each = [one(*a) for a in zip(shapes, centres, y.theta, y.omega, zs, strict=True)]
        f, normal, torque, pull = (jnp.stack(x) for x in list(zip(*each, strict=True))[:4])
        rate = None if states is None else jnp.stack([e[4] for e in each])
        power = None if friction is None else jnp.stack([e[5] for e in each])
    else:
        f, normal, torque, pull, rate, power = jax.vmap(one)(
            shapes, centres, y.theta, y.omega, states
        )
    return RollerContacts(jnp.sum(f, axis=0), arm_r, normal, torque, pull, rate, power)


class RollerTeeth(AbstractElement):
    """The rollers against every sprocket's teeth: normal contact ``law`` and
    ``friction`` (None: frictionless). Each roller sees its sprocket's nearest gap.
    ``shapes``: None, except inside a solve: the sprockets' contact shapes computed once
    before its loop (:meth:`prepared`)."""

    role = "roller_teeth"

    law: AbstractContactLaw
    friction: AbstractFrictionLaw | None
    shapes: Any = None

    def prepared(self, scene) -> RollerTeeth:
        """The sprockets' contact shapes computed once (with what each shape computes
        ahead: a free-form profile's every gap outline), for the steps of one solve to
        read: the shapes depend on the profiles alone, so computing them in every
        evaluation of the contact would repeat the same work at every stage, and a
        gradient would pull back through them at every stage too."""
        shapes = prepare_shapes(gap_shapes([s.profile for s in scene.sprockets]))
        return eqx.tree_at(lambda e: e.shapes, self, shapes, is_leaf=lambda x: x is None)

    def n_states(self, scene) -> int:
        """A friction law's states, per sprocket and roller (module docstring)."""
        if self.friction is None:
            return 0
        return len(scene.sprockets) * scene.n_rollers * self.friction.states_per_contact

    def contacts(self, y, scene, cs=None, state=None, friction=True) -> RollerContacts:
        """The rollers against every sprocket's teeth (:func:`roller_contacts`), with this
        element's slice of the drive's states ``state``; ``friction=False``: the normal law
        alone (no friction law, none of its states)."""
        if not friction:
            return roller_contacts(y, scene, self.law, None, cs, None)
        states = self.contact_states(scene, state)
        return roller_contacts(y, scene, self.law, self.friction, cs, states)

    def contact_states(self, scene, state):
        """``state`` (this element's slice of the drive state) as (S, R[, k]), or None."""
        if state is None or not self.n_states(scene):
            return None
        k = self.friction.states_per_contact
        shape = (len(scene.sprockets), scene.n_rollers) + ((k,) if k > 1 else ())
        return state.reshape(shape)

    def effect(self, t, y, scene, state) -> Effect:
        zs = self.contact_states(scene, state)
        rc = roller_contacts(y, scene, self.law, self.friction, states=zs)
        return Effect(
            body=scatter(scene.n_bodies, scene.roller_body, rc.arm, rc.force),
            sprocket_torque=rc.sprocket_torque,
            sprocket_force=rc.sprocket_force,
            state_rate=None if rc.state_rate is None else rc.state_rate.reshape(-1),
            report={"roller_normal": rc.normal}
            | ({} if rc.friction_power is None else {"tooth_friction_power": rc.friction_power}),
        )

    def outputs(self, t, y, scene, effect: Effect) -> dict[str, Array]:
        """With friction at the teeth: ``tooth_friction_power`` (S,), its power on chain
        and sprockets at each sprocket [W] (≤ 0 in sliding)."""
        power = effect.report.get("tooth_friction_power")
        return {} if power is None else {"tooth_friction_power": power}

    def energy(self, t, y, scene) -> Array:
        xr, _, _ = points(y.q, y.v, scene.roller_body, scene.roller_offset)
        total = jnp.zeros((), y.q.dtype)
        for k, spr in enumerate(scene.sprockets):
            c, s = jnp.cos(y.theta[k]), jnp.sin(y.theta[k])
            rel = xr - spr.centre
            local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
            depth, _ = jax.vmap(gap_contact, in_axes=(None, 0))(spr.profile, local)
            total = total + jnp.sum(self.law.potential(depth))
        return total

    def max_stiffness(self, scene, force) -> Array:
        return tangent_stiffness(self.law, force)

    def slots_ok(self, y, scene) -> Array:
        """The farthest roller checked lies beyond the tip radius + 1.05 roller radii
        (all tooth material lies inside the tip circle), or every roller is checked."""
        xr, _, _ = points(y.q, y.v, scene.roller_body, scene.roller_offset)
        slots = _contact_slots(scene, xr.shape[0])
        if slots is None:
            return jnp.asarray(True)
        reach = jnp.stack([s.profile.reach_radius for s in scene.sprockets])
        centres = jnp.stack([s.centre for s in scene.sprockets])

        def one(reach, centre):
            return nearest(xr - centre, slots)[1] > reach**2

        return jnp.all(jax.vmap(one)(reach, centres))
