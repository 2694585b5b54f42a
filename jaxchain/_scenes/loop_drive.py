"""A closed chain over several sprockets: the loop branch of :func:`~jaxchain.scenes.drive`
(arguments shared with the two-sprocket drive are checked there)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .. import _checks as checks
from .._elements.cushion import CushionContacts, as_cushions
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH
from .._scene import Scene, Sprocket
from .build import assemble, roller_law
from .common import (
    as_loads,
    as_profiles,
    check_below_strength,
    check_load_ramp,
    contact_slots,
    sprocket_inertias,
    worn,
)
from .fidelity import as_fidelity, chain_bodies
from .layout import chain_pitch_radius, transport_velocity
from .loop import Circles, as_centres, as_outside, loop_layout
from .model import ChainModel, DriveArgs
from .shoes import (
    Guide,
    Tensioner,
    assemble_shoes,
    idler_centre,
    place_guide,
    place_tensioner,
    shoe_law,
    shoe_teeth,
    span_ends,
)
from .statics import equilibrate

__all__ = ["loop_drive", "span_tensions"]


def span_tensions(
    loads: Sequence[float], radii: Sequence[float], pretension: float, take_up: int
) -> np.ndarray:
    """(N,) static tensions [N] of spans 0 … N − 1 of a loop (span j from sprocket j to
    j + 1): each driven sprocket k takes load_k/R_k out of the tension, T_k − T_{k−1} =
    load_k/R_k, and the take-up sprocket m's two spans share 2·pretension, T_{m−1} + T_m =
    2·pretension. ``loads``, ``radii``: (N,) with the driver's entries unused."""
    steps = _load_steps(loads, radii)
    t0 = pretension - 0.5 * (steps[take_up - 1] + steps[take_up])
    return t0 + steps


def tensioner_tensions(
    loads: Sequence[float], radii: Sequence[float], pretension: float, span: int
) -> np.ndarray:
    """(N,) static tensions [N] of spans 0 … N − 1 of a loop whose tensioner holds span
    ``span`` at ``pretension``; each driven sprocket k takes load_k/R_k out of the tension
    (:func:`span_tensions`)."""
    steps = _load_steps(loads, radii)
    return pretension + steps - steps[span]


def _load_steps(loads, radii) -> np.ndarray:
    """(N,) Σ_{k ≤ j} load_k/R_k: what span j gains over span 0."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(loads[1:]) / np.asarray(radii[1:]))])


def tensioned_layout(pitch, lp, r_roller, teeth, centres, outside, profiles, n_links, m, tensioner):
    """The loop's layout (:func:`loop_layout`) for links of pitch ``lp``, rollers of radius
    ``r_roller``, on sprockets cut for ``pitch``, with take-up sprocket ``m``; with a
    ``tensioner`` its shoe is laid out as an idler on the chain's back inserted after
    sprocket ``tensioner.span``, and is the take-up. Returns (layout, each sprocket's index
    in the layout, the shoe's index or None, the tensioner's straight span's length or
    None)."""
    n = len(teeth)
    tips = [float(p.tip_diameter) / 2 for p in profiles]
    real = list(range(n))  # index of each sprocket in the layout
    lay_teeth, lay_centres, lay_outside = teeth, centres, outside
    iv = span_length = None
    if tensioner is not None:
        jt = int(tensioner.span)
        # the shoe laid out as an idler on the chain's back, inserted after sprocket jt
        sense = np.array([-1 if k in as_outside(outside, n) else 1 for k in range(n)])
        circ = Circles(centres, np.array([chain_pitch_radius(lp, z) for z in teeth]), sense)
        if not circ.ok:
            raise ValueError("centres: two consecutive sprockets have no common tangent")
        z_v = shoe_teeth(tensioner, lp, r_roller)
        r_v = chain_pitch_radius(lp, z_v)
        c_v, span_length = idler_centre(tensioner, circ.t_out[jt], circ.t_in[(jt + 1) % n], r_v)
        iv = jt + 1
        real = [k if k <= jt else k + 1 for k in range(n)]
        lay_teeth = (*teeth[:iv], z_v, *teeth[iv:])
        lay_centres = np.insert(centres, iv, c_v, axis=0)
        lay_outside = (*[real[k] for k in as_outside(outside, n)], iv)
        tips = [*tips[:iv], r_v - r_roller, *tips[iv:]]
        m = iv
    try:
        lay = loop_layout(
            pitch,
            lay_teeth,
            lay_centres,
            lay_outside,
            n_links=n_links,
            link_pitch=lp,
            take_up_sprocket=m,
            tip_radii=tips,
            roller_radius=r_roller,
        )
    except ValueError as err:
        if tensioner is None:
            raise
        raise ValueError(
            f"with the tensioner's shoe laid out as idler {iv} on the chain's back (the "
            f"sprockets after it numbered one up): {err}; a larger Tensioner.deflection "
            "wraps the chain further round the shoe"
        ) from None
    return lay, real, iv, span_length


def loop_drive(a: DriveArgs, model: ChainModel) -> Scene:
    """The drive over N sprockets (see :func:`~jaxchain.scenes.drive`): ``a`` with its
    ``centres``, modelled by ``model``."""
    chain, teeth, centres, fidelity = a.chain, a.teeth, a.centres, as_fidelity(a.fidelity)
    outside, take_up_sprocket, n_links = a.outside, a.take_up_sprocket, a.n_links
    load_torque, pretension, profiles = a.load_torque, a.pretension, a.profiles
    tensioner, guides, settle, load_ramp = a.tensioner, a.guides, model.settle, model.load_ramp
    if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
        raise TypeError(f"teeth must be a sequence of tooth counts, got {teeth!r}")
    n = len(teeth)
    if n < 2:
        raise ValueError(f"teeth must hold at least 2 tooth counts (driver first), got {n}")
    teeth = tuple(checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth))
    centres = as_centres(centres, n)
    rings = as_cushions(model.cushion, n)
    speeds = [a.omega * teeth[0] / z for z in teeth[1:]]
    driven_loads, held = as_loads("load_torque", load_torque, speeds)
    check_load_ramp(driven_loads, load_ramp)
    loads = (0.0, *held)  # the torques the statics hold at the start [N·m]
    pretension = checks.real("pretension", pretension, lo=0.0, unit="N")
    if load_ramp is not None:
        load_ramp = checks.real("load_ramp", load_ramp, lo=0.0, unit="s")
    profiles = as_profiles(chain, profiles, teeth, model.form)
    radii = [float(p.pitch_radius) for p in profiles]
    guides = as_guides(guides, n, tensioner)
    if tensioner is not None:
        if take_up_sprocket is not None:
            raise ValueError(
                "take_up_sprocket: a drive with a tensioner needs no take-up sprocket (the "
                "tensioner sets the tension and the sprockets stay where given); give one "
                "or the other"
            )
        jt = checks.integer("Tensioner.span", tensioner.span, lo=0, hi=n - 1)
        pretension = checks.real("pretension", pretension, lo=0.0, lo_open=True, unit="N")
        tension = tensioner_tensions(loads, radii, pretension, jt)
        m = None  # the shoe is the take-up
    else:
        m = n - 1 if take_up_sprocket is None else take_up_sprocket
        m = checks.integer("take_up_sprocket", m, lo=1, hi=n - 1)
        tension = span_tensions(loads, radii, pretension, m)
    check_below_strength(
        chain,
        "the tight span's static tension",
        float(tension.max()),
        "lower load_torque or pretension, or choose a larger chain",
    )
    if settle and tension.min() < 0:
        need = pretension - float(tension.min())
        where = (
            f"the tensioner's span {tensioner.span} carries the pretension"
            if tensioner is not None
            else f"the take-up sprocket {m}'s spans share 2·pretension = {2 * pretension:.4g} N"
        )
        raise ValueError(
            f"no static equilibrium: {where}, and the loads (Σ load_k/R_k = "
            f"{float(tension[-1] - tension[0]):.4g} N between the tight and the slack span) "
            f"would leave span {int(np.argmin(tension))} pushing with "
            f"{-float(tension.min()):.4g} N; use pretension >= {need:.4g} N, a smaller "
            "load_torque, a take-up on the slack side (take_up_sprocket=1, or the tensioner "
            "on span 0), or settle=False (start from the layout, load ramped in)"
        )
    pitch = chain.pitch  # the sprockets are cut for the unworn pitch
    chain = worn(chain, model.elongation)
    stretch = fidelity.stretch(chain, pretension)
    lp = chain.pitch + stretch
    r_roller = chain.roller_diameter / 2
    lay, real, iv, span_length = tensioned_layout(
        pitch, lp, r_roller, teeth, centres, outside, profiles, n_links, m, tensioner
    )
    inertias = sprocket_inertias(chain, profiles, a.driven_inertia)
    omega1 = a.omega
    bodies = chain_bodies(
        chain,
        lay.rollers,
        transport_velocity(lay, omega1),
        closed=True,
        fidelity=fidelity,
        restitution=model.restitution,
        rollers_on_bush=model.rollers_on_bush,
        damping_ratio=model.link_damping,
        joint_friction=model.joint_friction,
        lubrication=model.lubrication,
        link_load=float(tension.max()),
    )
    if load_ramp is None:  # a settled start carries the full load already
        load_ramp = 0.0 if settle else 2 * math.pi / omega1
    sprockets = tuple(
        Sprocket(
            profiles[k],
            lay.centres[real[k]],
            omega1 * teeth[0] / teeth[k] * int(lay.sense[real[k]]),
            inertia=inertias[k],
            load_torque=driven_loads[k - 1] if k else 0.0,  # opposes its own turning
            angle0=lay.theta[real[k]],
            load_ramp=load_ramp if k and not isinstance(driven_loads[k - 1], AbstractLoad) else 0.0,
            sense=int(lay.sense[real[k]]),
            driven=k > 0,
            contact_slots=contact_slots(lay.wrap[real[k]], lay.n_links, profiles[k]),
            take_up_vector=(lay.take_up_vector if k == m and tensioner is None else np.zeros(2)),
        )
        for k in range(n)
    )
    arms, placed = None, []
    if tensioner is not None:
        arms, shoe = place_tensioner(tensioner, lay, iv, span_length, float(tension[jt]), chain)
        placed.append(shoe)
    for g in guides:
        placed.append(place_guide(g, *span_ends(lay, real[g.span]), chain))
    shoes = None
    if placed:
        law = model.shoe_contact or shoe_law(chain, model.restitution)
        shoes = assemble_shoes(
            placed, 0 if arms is None else 1, law, lp, lay.rollers[:, :2], r_roller
        )
    scene = assemble(
        bodies,
        sprockets=sprockets,
        anchors=None,
        roller_contact=model.roller_contact or roller_law(chain, model.restitution),
        friction=model.friction,
        impact_speed=model.impact_speed,
        fidelity=fidelity,
        tensile_strength=chain.tensile_strength,
        gravity=model.gravity,
        tensioners=arms,
        shoes=shoes,
    )
    scene = CushionContacts.attach(scene, rings, chain)
    if not settle:
        return scene
    return equilibrate(scene, take_up=0.0 if tensioner is not None else 2 * pretension)


def as_guides(guides, n: int, tensioner) -> tuple[Guide, ...]:
    """``guides`` checked: a sequence of :class:`Guide` on spans in [0, N − 1], none on the
    tensioner's span."""
    if isinstance(guides, Guide):
        guides = (guides,)
    if not isinstance(guides, Sequence) or not all(isinstance(g, Guide) for g in guides):
        raise TypeError(f"guides must be a sequence of jc.scenes.Guide, got {guides!r}")
    for g in guides:
        checks.integer("Guide.span", g.span, lo=0, hi=n - 1)
        if tensioner is not None and g.span == tensioner.span:
            raise ValueError(
                f"Guide.span={g.span} is the tensioner's span: put the guide on another span"
            )
    if tensioner is not None and not isinstance(tensioner, Tensioner):
        raise TypeError(f"tensioner must be a jc.scenes.Tensioner or None, got {tensioner!r}")
    return tuple(guides)
