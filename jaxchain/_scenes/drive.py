"""``drive``: a closed chain over a driver and one driven sprocket, or over several
sprockets (:mod:`.loop_drive`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._elements.cushion import CushionContacts, as_cushions
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH, AbstractProfile
from .._scene import Scene, Sprocket
from .build import assemble, chain_bodies, roller_law, rollers_on_bush_of
from .common import (
    as_gravity,
    as_load,
    as_profiles,
    check_below_strength,
    check_load_ramp,
    contact_slots,
    disc_inertia,
    stretch_of,
    worn,
)
from .layout import closed_drive_layout, transport_velocity
from .loop_drive import loop_drive
from .model import _DEFAULTS, ChainModel, DriveArgs, _is_default, model_of, rad_per_s
from .shoes import Guide, Tensioner
from .spans import spans_drive
from .statics import equilibrate

__all__ = ["drive"]


def drive(
    chain: ChainSpec | str = "08B",
    teeth: Sequence[int] = (18, 36),
    *,
    centres: Sequence[tuple[float, float]] | None = None,
    outside: Sequence[int] = (),
    take_up_sprocket: int | None = None,
    centre_distance: float | None = None,
    n_links: int | None = None,
    speed_rpm: float = 1000.0,
    load_torque: float | AbstractLoad | Sequence[float | AbstractLoad] = 20.0,
    pretension: float = 200.0,
    fidelity: Literal["lumped", "clearance", "spans"] = "lumped",
    profiles: Sequence[AbstractProfile] | None = None,
    tensioner: Tensioner | None = None,
    guides: Sequence[Guide] = (),
    model: ChainModel | None = None,
    **older,
) -> Scene:
    """A closed roller chain over a driver (axis at the origin, turning counter-clockwise at
    ``speed_rpm``) and a driven sprocket (axis at (C, 0)) loaded by ``load_torque``; or,
    with ``centres``, over any number of sprockets (below).

    The initial configuration is consistent: rollers seated at the pitch points of the
    wrap arcs, straight spans of whole pitches, the centre distance C adjusted (by less
    than a pitch) so the loop closes with an even link count (give ``centre_distance`` or
    ``n_links``; default 40 pitches), the chain laid out stretched by ``pretension``, and
    velocities of rigid transport at the driver speed; then (``settle``, the default) the
    static equilibrium of that layout with the driver held: rollers in their seats, joints
    closed, the driven axis moved by a take-up of 2·pretension and the full load carried.
    What remains is a small start-up transient: the polygonal mismatch of the spans' end
    velocities. From the raw layout (``settle=False``) the seat and joint clearances are
    open and the load is ramped in smoothly over ``load_ramp`` (default: one driver
    revolution) so the tight span stretches without a shock.

    Several sprockets: give ``teeth=(z1, …, zN)`` and their axes ``centres=((x1, y1), …)``
    [m]. The first (index 0) drives; the chain passes the sprockets in the order given as one
    counter-clockwise loop, wrapping counter-clockwise the ones inside it and clockwise
    the ``outside`` ones (idlers on the chain's back, turning clockwise). A driven
    sprocket with zero load torque is an idler. The layout closes exactly
    (:func:`~jaxchain.scenes.loop_layout`): the take-up sprocket moves along the outward
    bisector of its spans by what closes the loop with ``n_links`` (default: the even
    count nearest the belt length), and while the scene settles it is pushed along that
    bisector so that its two spans carry 2·pretension between them; the other axes stay
    where given. Every sprocket k starts at ±ω1·z1/zk.

    A ``tensioner`` (:class:`~jaxchain.scenes.Tensioner`, a sprung arm with a shoe)
    presses on one span from the chain's back and sets the tension: its span carries
    ``pretension`` at rest, and no sprocket moves (no take-up). The layout wraps the chain
    round the shoe, pushed in by ``Tensioner.deflection``; the loop closes by moving the
    shoe along the bisector of its spans, and the settled start turns the arm until its
    spring balances the chain. ``guides`` (:class:`~jaxchain.scenes.Guide`) are fixed
    shoes along spans. Both work with two sprockets and no ``centres`` too (the driven
    axis at (``centre_distance``, 0), default 40 pitches).

    Args:
        chain: an ISO 606 designation or a :class:`ChainSpec`.
        teeth: tooth counts, driver first: (driver, driven), or N of them with ``centres``.
        centres: (N, 2) axis positions [m] in the order the chain passes them (None: the
            two-sprocket drive on the x axis).
        outside: indices in [1, N − 1] of sprockets outside the loop (needs ``centres``).
        take_up_sprocket: the sprocket that closes the loop and takes up the pretension,
            in [1, N − 1] (default N − 1; needs ``centres``).
        centre_distance: two-sprocket drive: C [m] (adjusted by less than a pitch to close).
        n_links: even number of links.
        speed_rpm: driver speed [rpm], > 0; every scene built with the defaults runs with
            ``simulate``'s defaults from 100 to 3000 rpm, in both fidelities.
        load_torque: the torque resisting each driven sprocket's rotation: a number [N·m],
            ≥ 0, or a load (``jc.loads.Harmonic(...)``, any ``jc.loads.AbstractLoad``), for
            every driven sprocket, or one per driven sprocket. The statics hold a load at its
            value at the start; a number is ramped in over ``load_ramp``.
        pretension: chain tension at rest [N], ≥ 0.
        fidelity: "lumped" (rollers + elastic links), "clearance" (rigid links,
            pin/bush and bush/roller clearance joints) or "spans" (no rollers: the free
            spans as axial springs between the sprockets' pitch curves, for the drive's
            tensions and speeds over many revolutions; fixed axes, a tensioner's shoe as a
            frictionless circle the chain slides over, guides checked but without effect
            (they lie along the straight spans, which do not move across), no gravity; see
            :class:`jc.elements.Spans <jaxchain.elements.Spans>`).
        profiles: one tooth profile per sprocket (default ISO 606 of ``model.form``).
        tensioner: a :class:`~jaxchain.scenes.Tensioner` on one span, or None.
        guides: fixed :class:`~jaxchain.scenes.Guide` shoes, each on a span (not the
            tensioner's).
        model: how the chain and its contacts are modelled, a
            :class:`~jaxchain.scenes.ChainModel` (form, wear, restitution, friction, joint
            friction, oil, contact laws, damping, gravity, settled start, load ramp, cushion
            rings); default ``ChainModel()``.

    Older keywords: each field of :class:`~jaxchain.scenes.ChainModel` is still taken as
    a keyword (``restitution=0.5`` for ``model=ChainModel(restitution=0.5)``), with a
    ``DeprecationWarning`` naming that spelling; and
    ``driven_inertia`` [kg·m²], of every driven sprocket or one per driven sprocket
    (default a steel disc of the pitch diameter; ``SprocketSpec.inertia`` in a
    :class:`~jaxchain.scenes.DriveSpec`).
    """
    driven_inertia = older.pop("driven_inertia", None)
    m = model_of("drive", model, older)
    a = DriveArgs(
        chain=as_chain(chain), teeth=teeth, centres=centres, outside=outside,
        take_up_sprocket=take_up_sprocket, centre_distance=centre_distance, n_links=n_links,
        omega=rad_per_s(speed_rpm), load_torque=load_torque, pretension=pretension,
        fidelity=fidelity, profiles=profiles, driven_inertia=driven_inertia,
        tensioner=tensioner, guides=guides,
    )  # fmt: skip
    return build_drive(a, m)


def build_drive(a: DriveArgs, m: ChainModel) -> Scene:
    """The drive ``a`` modelled by ``m`` (what :func:`drive` and
    :meth:`~jaxchain.scenes.DriveSpec.build` build)."""
    m.check_fidelity(a.fidelity)
    if a.fidelity == "spans":  # what only a chain of links and rollers uses: refused
        given = [
            name
            for name in (
                "restitution", "friction", "joint_friction", "impact_speed",
                "rollers_on_bush", "roller_contact", "settle", "shoe_contact",
            )
            if not _is_default(getattr(m, name), _DEFAULTS[name])
        ]  # fmt: skip
        if given:
            raise ValueError(
                f"fidelity='spans' has no rollers, links or joints and does not use "
                f"{', '.join(given)} (its spans are axial springs between the sprockets' "
                "pitch curves, its start always settled, its shoes frictionless circles): "
                "leave them at their defaults, or use fidelity='lumped' or 'clearance'"
            )
        if m.cushion is not None:
            raise ValueError(
                "cushion: fidelity='spans' has no links for a cushion ring's plates to press "
                "on; use fidelity='lumped' or 'clearance' with cushion rings (or cushion=None)"
            )
        return _spans(a, m)
    chain, teeth, centres, fidelity = a.chain, a.teeth, a.centres, a.fidelity
    tensioner, guides, pretension = a.tensioner, a.guides, a.pretension
    centre_distance, n_links, load_torque = a.centre_distance, a.n_links, a.load_torque
    settle, load_ramp, profiles = m.settle, m.load_ramp, a.profiles
    gravity = as_gravity(m.gravity)
    rollers_on_bush = rollers_on_bush_of(chain, m.rollers_on_bush)
    if tensioner is not None and not isinstance(tensioner, Tensioner):
        raise TypeError(f"tensioner must be a jc.scenes.Tensioner or None, got {tensioner!r}")
    if isinstance(guides, Guide):  # one guide, as the loop's builder takes it
        guides = (guides,)
    if centres is None and (tensioner is not None or (guides is not None and len(guides))):
        if n_links is not None and centre_distance is None:
            raise ValueError(
                "a two-sprocket drive with a tensioner or guides needs centre_distance (the "
                "sprockets stay where given; n_links sets how far the tensioner pushes)"
            )
        z = checks.pair("teeth", teeth, 2, "tooth counts (driver, driven)")
        c = 40 * chain.pitch if centre_distance is None else centre_distance
        c = checks.real("centre_distance", c, lo=0.0, lo_open=True, unit="m")
        centres, centre_distance, teeth = ((0.0, 0.0), (c, 0.0)), None, tuple(z)
    if centres is not None:
        if centre_distance is not None:
            raise ValueError(
                "give centres (the axes of every sprocket) or centre_distance (two sprockets "
                "on the x axis), not both"
            )
        return loop_drive(
            a._replace(centres=centres, centre_distance=None, teeth=teeth, guides=guides),
            m.replace(rollers_on_bush=rollers_on_bush, gravity=gravity),
        )
    given = {"outside": np.size(a.outside) > 0, "take_up_sprocket": a.take_up_sprocket is not None}
    for name, value in given.items():
        if value:
            raise ValueError(
                f"{name} needs centres: give the axis (x, y) of every sprocket in centres"
            )
    if (
        isinstance(teeth, Sequence | np.ndarray)
        and not isinstance(teeth, (str, bytes))
        and len(teeth) != 2
    ):
        raise ValueError(
            f"teeth must hold 2 tooth counts (driver, driven), got {len(teeth)}: {teeth!r}; "
            "for a drive over more sprockets give their axes in centres=((x1, y1), ...)"
        )
    z1, z2 = checks.pair("teeth", teeth, 2, "tooth counts (driver, driven)")
    for k, z in enumerate((z1, z2)):
        checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH)
    rings = as_cushions(m.cushion, 2)
    load, load_torque = as_load("load_torque", load_torque, a.omega * z1 / z2)
    check_load_ramp((load,), load_ramp)
    pretension = checks.real("pretension", pretension, lo=0.0, unit="N")
    if centre_distance is not None:
        centre_distance = checks.real(
            "centre_distance", centre_distance, lo=0.0, lo_open=True, unit="m"
        )
    if load_ramp is not None:
        load_ramp = checks.real("load_ramp", load_ramp, lo=0.0, unit="s")
    profiles = as_profiles(chain, profiles, (z1, z2), m.form)
    check_below_strength(
        chain,
        "the tight span's static tension pretension + load_torque/R2",
        pretension + load_torque / float(profiles[1].pitch_radius),
        "lower load_torque or pretension, or choose a larger chain",
    )
    if centre_distance is None and n_links is None:
        centre_distance = 40 * chain.pitch
    pitch = chain.pitch  # the sprockets are cut for the unworn pitch
    chain = worn(chain, m.elongation)
    stretch = stretch_of(chain, fidelity, pretension)
    lay = closed_drive_layout(
        pitch,
        z1,
        z2,
        centre_distance=centre_distance,
        n_links=n_links,
        link_pitch=chain.pitch + stretch,
    )
    if settle:
        # statics: the take-up 2·pretension along the centre line is shared by the spans,
        # tight − slack = load/R2; a slack span cannot push, so the load must not exceed it
        r1, r2 = float(profiles[0].pitch_radius), float(profiles[1].pitch_radius)
        cos_b = math.sqrt(max(0.0, 1 - ((r2 - r1) / lay.centre_distance) ** 2))
        carried = load_torque / r2
        if carried > 2 * pretension * cos_b:
            raise ValueError(
                f"no static equilibrium: the load needs a tension difference load_torque/R2 = "
                f"{carried:.4g} N but the spans share only the take-up 2·pretension·cos β = "
                f"{2 * pretension * cos_b:.4g} N (the slack span would have to push); use "
                f"pretension >= {carried / (2 * cos_b):.4g} N, a smaller load_torque, or "
                "settle=False (start from the layout, load ramped in)"
            )
    omega1 = a.omega
    vel = transport_velocity(lay, omega1, z1, z2)
    bodies = chain_bodies(
        chain,
        lay.rollers,
        vel,
        closed=True,
        fidelity=fidelity,
        restitution=m.restitution,
        rollers_on_bush=rollers_on_bush,
        damping_ratio=m.link_damping,
        joint_friction=m.joint_friction,
        lubrication=m.lubrication,
        link_load=pretension + load_torque / float(profiles[1].pitch_radius),
    )
    driven_inertia = a.driven_inertia
    if driven_inertia is None:
        driven_inertia = disc_inertia(chain, profiles[1])
    checks.real("driven_inertia", driven_inertia, lo=0.0, lo_open=True, unit="kg·m²")
    if load_ramp is None:  # a settled start carries the full load already
        load_ramp = 0.0 if settle else 2 * math.pi / omega1
    sprockets = (
        Sprocket(
            profiles[0],
            [0.0, 0.0],
            omega1,
            angle0=lay.theta[0],
            inertia=disc_inertia(chain, profiles[0]),
            contact_slots=contact_slots(lay.wrap[0], lay.n_links, profiles[0]),
        ),
        Sprocket(
            profiles[1],
            [lay.centre_distance, 0.0],
            omega1 * z1 / z2,
            inertia=driven_inertia,
            load_torque=load,
            angle0=lay.theta[1],
            load_ramp=0.0 if isinstance(load, AbstractLoad) else load_ramp,
            driven=True,
            contact_slots=contact_slots(lay.wrap[1], lay.n_links, profiles[1]),
        ),
    )
    scene = assemble(
        bodies,
        sprockets=sprockets,
        anchors=None,
        roller_contact=m.roller_contact or roller_law(chain, m.restitution),
        friction=m.friction,
        impact_speed=m.impact_speed,
        fidelity=fidelity,
        tensile_strength=chain.tensile_strength,
        gravity=gravity,
    )
    scene = CushionContacts.attach(scene, rings, chain)
    return equilibrate(scene, take_up=2 * pretension) if settle else scene


def _spans(a: DriveArgs, m: ChainModel) -> Scene:
    """``fidelity="spans"``: what it models, checked, then :func:`.spans.spans_drive`."""
    unsupported = {
        "gravity": m.gravity is not None,
        "elongation": m.elongation != 0.0,
        "n_links without a tensioner": a.n_links is not None and a.tensioner is None,
    }
    given = [name for name, is_given in unsupported.items() if is_given]
    if given:
        raise ValueError(
            f"fidelity='spans' does not model {', '.join(given)}: the span-level chain has "
            "fixed sprocket axes and massless spans whose length follows from the axes (give "
            "centre_distance or centres); use fidelity='lumped' for them"
        )
    teeth, centres = a.teeth, a.centres
    if centres is None:
        given = {
            "outside": np.size(a.outside) > 0,
            "take_up_sprocket": a.take_up_sprocket is not None,
        }
        for name, value in given.items():
            if value:
                raise ValueError(
                    f"{name} needs centres: give the axis (x, y) of every sprocket in centres"
                )
        z = checks.pair("teeth", teeth, 2, "tooth counts (driver, driven)")
        c = 40 * a.chain.pitch if a.centre_distance is None else a.centre_distance
        c = checks.real("centre_distance", c, lo=0.0, lo_open=True, unit="m")
        centres, teeth = ((0.0, 0.0), (c, 0.0)), tuple(z)
    elif a.centre_distance is not None:
        raise ValueError(
            "give centres (the axes of every sprocket) or centre_distance (two sprockets on "
            "the x axis), not both"
        )
    if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
        raise TypeError(f"teeth must be a sequence of tooth counts, got {teeth!r}")
    return spans_drive(a._replace(teeth=tuple(teeth), centres=centres), m)
