"""``engagement``: one driver sprocket meshing with an open chain strand under tension."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._elements.anchors import Anchors
from .._elements.cushion import CushionContacts
from .._profiles.base import AbstractProfile
from .._profiles.iso import ToothProfile
from .._scene import Scene, Sprocket
from .build import (
    assemble,
    link_stiffness,
    roller_law,
    rollers_on_bush_of,
)
from .common import (
    as_gravity,
    check_below_strength,
    check_profile,
    contact_slots,
    disc_inertia,
    worn,
)
from .fidelity import AbstractFidelity, as_fidelity, chain_bodies
from .layout import strand_layout
from .model import ChainModel, rad_per_s
from .statics import equilibrate

__all__ = ["build_engagement"]


def build_engagement(
    chain: ChainSpec | str,
    teeth: int,
    *,
    speed_rpm: float,
    tension: float,
    slack_tension: float,
    wrap: int | None,
    n_entry: int,
    n_exit: int,
    fidelity: str | AbstractFidelity,
    profile: AbstractProfile | None,
    span_stiffness: float | None,
    m: ChainModel,
) -> Scene:
    """The strand :func:`~jaxchain.scenes.engagement` describes, modelled by ``m`` (what
    :meth:`~jaxchain.scenes.StrandSpec.build` builds; its sprocket's teeth and profile and
    its cushion ring are checked by the spec)."""
    omega = rad_per_s(speed_rpm)
    chain = as_chain(chain)
    gravity = as_gravity(m.gravity)
    fidelity = as_fidelity(fidelity)
    fidelity.check(m)
    cushion, restitution = m.cushion, m.restitution
    rollers_on_bush = rollers_on_bush_of(chain, m.rollers_on_bush)
    if not fidelity.has_links:
        raise ValueError(
            f"fidelity={fidelity.name!r} has no rollers to mesh: the engagement strand needs "
            "'lumped' or 'clearance' (the span-level chain is a fidelity of jc.scenes.drive)"
        )
    tension = checks.real(
        "tension", tension, lo=0.0, lo_open=True, unit="N (a slack entry span does not mesh)"
    )
    slack_tension = checks.real("slack_tension", slack_tension, lo=0.0, unit="N")
    for name, value in (("tension", tension), ("slack_tension", slack_tension)):
        check_below_strength(chain, name, value, f"lower {name}, or choose a larger chain")
    if span_stiffness is not None:
        checks.real("span_stiffness", span_stiffness, lo=0.0, lo_open=True, unit="N/m")
    if profile is None:
        profile = ToothProfile.iso606(chain, teeth, m.form)
    check_profile(chain, profile)
    if wrap is None:
        wrap = teeth // 2
    sprocket_chain = chain  # the sprocket is cut for the unworn pitch
    chain = worn(chain, m.elongation)
    n_exit += fidelity.even_rollers(wrap + n_entry + n_exit) - (wrap + n_entry + n_exit)
    lay = strand_layout(
        sprocket_chain.pitch,
        teeth,
        wrap=wrap,
        n_entry=n_entry,
        n_exit=n_exit,
        link_pitch=chain.pitch + fidelity.stretch(chain, tension),
    )
    rollers = np.asarray(lay.rollers)
    # rigid transport: seated rollers turn with the sprocket; each span translates at the
    # speed of its seated end roller, along the span
    seated = np.asarray(lay.sprocket_of) == 0
    vel = omega * np.column_stack([-rollers[:, 1], rollers[:, 0]])
    # the sprocket takes in (and lets out) z·ω/2π rollers per second; on a span stretched
    # by its tension the rollers are p + stretch apart, so that span's mean speed is
    # (p + stretch)·z·ω/2π (the polygon's mean speed z·p·ω/2π, stretched). A guide moving
    # at the unstretched speed would lag by the stretch every tooth period and its spring
    # would pull the span's tension up by span_stiffness·stretch per period.
    rate = omega * teeth / (2 * math.pi)
    v_entry = rate * (chain.pitch + fidelity.stretch(chain, tension))
    v_exit = rate * (chain.pitch + fidelity.stretch(chain, slack_tension))
    first, last = np.nonzero(seated)[0][[0, -1]]
    entry_dir, exit_dir = np.asarray(lay.entry_dir), np.asarray(lay.exit_dir)
    vel[:first] = -v_entry * entry_dir
    vel[last + 1 :] = v_exit * exit_dir
    bodies = chain_bodies(
        chain,
        rollers,
        vel,
        closed=False,
        fidelity=fidelity,
        restitution=restitution,
        rollers_on_bush=rollers_on_bush,
        damping_ratio=m.link_damping,
        joint_friction=m.joint_friction,
        lubrication=m.lubrication,
        link_load=tension,
    )
    k_span = link_stiffness(chain, tension) / 50 if span_stiffness is None else span_stiffness
    ends = np.asarray(bodies.roller_body)[[0, -1]]
    m_end = np.asarray(bodies.mass)[ends]
    anchors = Anchors(
        body=jnp.asarray(ends),
        origin=jnp.asarray(np.asarray(bodies.q0)[ends, :2]),
        direction=jnp.asarray(np.stack([entry_dir, exit_dir])),
        speed=jnp.asarray([-v_entry, v_exit]),
        tension=jnp.asarray([tension, slack_tension]),
        stiffness=jnp.full(2, k_span),
        damping=jnp.asarray(2 * np.sqrt(k_span * m_end)),
    )
    sprocket = Sprocket(
        profile,
        [0.0, 0.0],
        omega,
        angle0=lay.theta,
        inertia=disc_inertia(sprocket_chain, profile),
        contact_slots=contact_slots(wrap, len(rollers), profile),
    )
    scene = assemble(
        bodies,
        sprockets=(sprocket,),
        anchors=anchors,
        roller_contact=m.roller_contact or roller_law(sprocket_chain, restitution),
        friction=m.friction,
        impact_speed=m.impact_speed,
        fidelity=fidelity,
        tensile_strength=sprocket_chain.tensile_strength,
        # one entry roller meshes per tooth period: the strand runs out after n_entry
        horizon=n_entry * 2 * math.pi / (teeth * omega),
        gravity=gravity,
    )
    scene = CushionContacts.attach(scene, (cushion,), chain)
    return equilibrate(scene) if m.settle else scene
