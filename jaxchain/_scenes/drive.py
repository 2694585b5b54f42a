"""The closed chain drive a :class:`~jaxchain.scenes.DriveSpec` describes (what
:func:`~jaxchain.scenes.drive` builds through its spec): over a driver and one driven
sprocket, or over several sprockets (:mod:`.loop_drive`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import _checks as checks
from .._elements.cushion import CushionContacts, as_cushions
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH
from .._scene import Scene, Sprocket
from .build import assemble, roller_law, rollers_on_bush_of
from .common import (
    as_gravity,
    as_load,
    as_profiles,
    check_below_strength,
    check_load_ramp,
    contact_slots,
    disc_inertia,
    worn,
)
from .fidelity import as_fidelity, chain_bodies
from .layout import closed_drive_layout, transport_velocity
from .loop_drive import loop_drive
from .model import ChainModel, DriveArgs
from .shoes import Guide, Tensioner
from .spans import spans_drive
from .statics import equilibrate

__all__ = ["build_drive", "two_sprockets"]


def two_sprockets(teeth, outside=(), take_up_sprocket=None) -> tuple[int, int]:
    """The (driver, driven) tooth counts of a drive given no ``centres``, checked: the
    sprockets' placement (``outside``, ``take_up_sprocket``) needs centres, and more than
    two tooth counts do too."""
    given = {"outside": np.size(outside) > 0, "take_up_sprocket": take_up_sprocket is not None}
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
    return tuple(
        checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate((z1, z2))
    )


def build_drive(a: DriveArgs, m: ChainModel) -> Scene:
    """The drive ``a`` modelled by ``m`` (what :meth:`~jaxchain.scenes.DriveSpec.build`
    builds, and so :func:`~jaxchain.scenes.drive`)."""
    fidelity = as_fidelity(a.fidelity)
    fidelity.check(m)
    a = a._replace(fidelity=fidelity)
    if not fidelity.has_links:  # the span-level chain: its own builder
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
    z1, z2 = two_sprockets(teeth, a.outside, a.take_up_sprocket)
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
    stretch = fidelity.stretch(chain, pretension)
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
