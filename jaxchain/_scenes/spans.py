"""The span-level drive (``drive(..., fidelity="spans")``): rigid sprockets on their pitch
curves and the free spans as axial springs between tangent points
(:class:`~jaxchain._elements.spans.Spans`); no rollers, no links."""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jax.typing import ArrayLike

from .. import _checks as checks
from .._elements.gravity import Gravity
from .._elements.rollers import RollerTeeth
from .._elements.spans import Spans, pitch_curve_coefficients, scaled_curve
from .._kinematics import tangent_normal
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH
from .._scene import Scene, Sprocket
from .build import link_stiffness, roller_law
from .common import as_loads, as_profiles, check_load_ramp, sprocket_inertias
from .fidelity import Lumped
from .loop import as_centres, as_outside
from .loop_drive import as_guides, span_tensions, tensioned_layout, tensioner_tensions
from .model import ChainModel, DriveArgs
from .shoes import place_tensioner

__all__ = ["spans_drive", "span_element", "SpanShoe", "SPAN_ORDER"]

#: harmonics of a pitch curve the span-level chain resolves (at most (z − 1)/2)
SPAN_ORDER = 6


class SpanShoe(NamedTuple):
    """A tensioner's shoe in the span-level chain: it presses on span ``span`` from the
    chain's back; ``radius`` [m] of the chain's pitch line round it, its ``centre`` (2,)
    [m] when its arm's angle is ``angle`` [rad], the arm turning about ``pivot`` (2,) [m]."""

    span: int
    radius: float
    centre: ArrayLike
    pivot: ArrayLike
    angle: float


def span_element(
    profiles, centres, sense, tension, axial_stiffness, axial_damping, *, shoe=None
) -> Spans:
    """The :class:`~jaxchain.elements.Spans` of sprockets with ``profiles`` at ``centres``
    (S, 2) [m], ``sense`` (S,) ±1, whose spans carry ``tension`` (S,) [N] at the sprockets'
    zero angles (and a tensioner's arm at its ``shoe.angle``); ``axial_stiffness`` EA [N]
    and ``axial_damping`` [N·s] of the chain (a span of length L: EA/L, damping/L);
    ``shoe``: a :class:`SpanShoe`, or None. Every step is an array operation: the element
    is differentiable in the profiles' leaves (a pitch curve's harmonics, say) and the
    tensions, and can be rebuilt inside a traced design objective."""
    n = len(profiles)
    coef = []
    for p in profiles:
        radius, angle = p.pitch_polar()
        coef.append(pitch_curve_coefficients(radius, angle, min(SPAN_ORDER, (p.teeth - 1) // 2)))
    width = max(c.shape[0] for c in coef)
    curves = [
        scaled_curve(jnp.pad(c, (0, width - c.shape[0])), p.teeth * p.pitch)
        for c, p in zip(coef, profiles, strict=True)
    ]
    coef = jnp.stack([c for c, _ in curves])
    arc_mean, arc_cos, arc_sin = (jnp.stack(x) for x in zip(*(a for _, a in curves), strict=True))
    start = np.arange(n)
    end = (start + 1) % n
    # straight segments between nodes (sprocket k is node k, the shoe node n)
    seg = []
    for j in range(n):
        if shoe is not None and j == shoe.span:
            seg += [(j, n, j), (n, end[j], j)]
        else:
            seg.append((j, end[j], j))
    seg_from, seg_to, seg_span = (np.asarray(x) for x in zip(*seg, strict=True))
    node_c, node_r, node_s = jnp.asarray(centres), arc_mean, jnp.asarray(sense, dtype=float)
    if shoe is not None:
        node_c = jnp.concatenate([node_c, jnp.asarray(shoe.centre, dtype=float)[None]])
        node_r = jnp.concatenate([node_r, jnp.asarray([shoe.radius], dtype=float)])
        node_s = jnp.concatenate([node_s, -jnp.ones(1)])
        shoe_fields = dict(
            shoe_radius=jnp.asarray([shoe.radius], dtype=float),
            shoe_pivot=jnp.asarray(shoe.pivot, dtype=float)[None],
            shoe_offset=(jnp.asarray(shoe.centre, dtype=float) - jnp.asarray(shoe.pivot))[None],
            shoe_angle=jnp.asarray([shoe.angle], dtype=float),
        )
        arm = shoe_fields["shoe_angle"]
    else:
        shoe_fields = dict(
            shoe_radius=jnp.zeros(0), shoe_pivot=jnp.zeros((0, 2)),
            shoe_offset=jnp.zeros((0, 2)), shoe_angle=jnp.zeros(0),
        )  # fmt: skip
        arm = None
    # the outward normal of the tangent of the (effective) pitch circles: the line solve's start
    beta = tangent_normal(
        node_c[seg_from], node_r[seg_from], node_s[seg_from],
        node_c[seg_to], node_r[seg_to], node_s[seg_to],
    )  # fmt: skip
    probe = Spans(
        start=jnp.asarray(start), end=jnp.asarray(end), sense=jnp.asarray(sense, dtype=float),
        coefficients=coef, arc_mean=arc_mean, arc_cos=arc_cos, arc_sin=arc_sin,
        normal_angle=beta, base=jnp.zeros(n), stiffness=jnp.ones(n), damping=jnp.zeros(n),
        segment_from=jnp.asarray(seg_from), segment_to=jnp.asarray(seg_to),
        segment_span=jnp.asarray(seg_span), **shoe_fields,
    )  # fmt: skip
    geo = probe.geometry(jnp.zeros(n), jnp.asarray(centres), arm)
    stiffness = axial_stiffness / geo.length
    # start stretch: the tension through the smooth ramp's inverse (ramp(e) = T/k)
    x, w = tension / stiffness, 1.0 / stiffness
    stretch = x - w * w / (4 * x)
    return dataclasses.replace(
        probe,
        base=geo.length - stretch - geo.unstretched,
        stiffness=stiffness,
        damping=axial_damping / geo.length,
    )


# one compiled program (eager, every operation would compile on its own)
_span_element = eqx.filter_jit(span_element)


def spans_drive(a: DriveArgs, model: ChainModel) -> Scene:
    """The span-level drive over N sprockets (see :func:`~jaxchain.scenes.drive`): the
    sprockets at ``centres`` (the driver first, the loop counter-clockwise, ``outside``
    ones on the chain's back), the spans' start tensions those of the statics with
    ``pretension`` shared by the take-up sprocket's two spans (or carried by the
    ``tensioner``'s span) and every driven sprocket's load carried. ``guides`` are checked
    as the lumped chain checks them and change nothing: a guide's face lies along its
    straight span (at the rollers or ``offset`` beyond), and the span model's spans do not
    move across to meet it."""
    chain, teeth, centres, outside = a.chain, a.teeth, a.centres, a.outside
    take_up_sprocket, load_torque, pretension = a.take_up_sprocket, a.load_torque, a.pretension
    profiles, tensioner, n_links, guides = a.profiles, a.tensioner, a.n_links, a.guides
    load_ramp = model.load_ramp
    n = len(teeth)
    teeth = tuple(checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth))
    centres = as_centres(centres, n)
    sense = np.ones(n)
    sense[list(as_outside(outside, n))] = -1.0
    as_guides(() if guides is None else guides, n, tensioner)
    if tensioner is not None and take_up_sprocket is not None:
        raise ValueError(
            "take_up_sprocket: a drive with a tensioner needs no take-up sprocket (the "
            "tensioner sets the tension and the sprockets stay where given); give one or the "
            "other"
        )
    m = (
        n - 1
        if take_up_sprocket is None
        else checks.integer("take_up_sprocket", take_up_sprocket, lo=1, hi=n - 1)
    )
    speeds = [a.omega * teeth[0] / z for z in teeth[1:]]
    driven_loads, held = as_loads("load_torque", load_torque, speeds)
    check_load_ramp(driven_loads, load_ramp)
    pretension = checks.real("pretension", pretension, lo=0.0, unit="N")
    profiles = as_profiles(chain, profiles, teeth, model.form)
    radii = [p.teeth * float(p.pitch) / (2 * math.pi) for p in profiles]  # z·p/2π
    if tensioner is None:
        tension = span_tensions((0.0, *held), radii, pretension, m)
    else:
        jt = checks.integer("Tensioner.span", tensioner.span, lo=0, hi=n - 1)
        pretension = checks.real("pretension", pretension, lo=0.0, lo_open=True, unit="N")
        tension = tensioner_tensions((0.0, *held), radii, pretension, jt)
    if tension.min() <= 0:
        raise ValueError(
            f"no static equilibrium: a span would carry {tension.min():.4g} N (the loads need "
            "more tension than pretension gives); raise pretension or lower load_torque"
        )
    inertias = sprocket_inertias(chain, profiles, a.driven_inertia)
    omega1 = a.omega
    if load_ramp is None:
        load_ramp = 0.0  # the spans start with the statics' tensions
    sprockets = tuple(
        Sprocket(
            profiles[k],
            centres[k],
            omega1 * teeth[0] / teeth[k] * sense[k],
            inertia=inertias[k],
            load_torque=driven_loads[k - 1] if k else 0.0,
            angle0=0.0,
            load_ramp=load_ramp if k and not isinstance(driven_loads[k - 1], AbstractLoad) else 0.0,
            sense=int(sense[k]),
            driven=k > 0,
        )
        for k in range(n)
    )
    reach = [float(p.reach_radius) for p in profiles]
    for a in range(n):
        for b in range(a + 1, n):
            if math.dist(centres[a], centres[b]) <= reach[a] + reach[b]:
                raise ValueError(
                    f"sprockets {a} and {b} overlap: their axes are "
                    f"{math.dist(centres[a], centres[b]):.4g} m apart, their tips reach "
                    f"{reach[a] + reach[b]:.4g} m; move them apart"
                )
    k_link = link_stiffness(chain, float(tension.max()))
    m_link = chain.roller_mass + 0.5 * (chain.roller_link_mass + chain.pin_link_mass)
    c_link = 2 * model.link_damping * math.sqrt(k_link * m_link / 2)
    shoe = arms = None
    if tensioner is not None:
        shoe, arms = _place_shoe(
            tensioner, chain, centres, teeth, outside, profiles, n_links, tension
        )
    spans = _span_element(
        tuple(profiles), jnp.asarray(np.stack(centres)), jnp.asarray(sense),
        jnp.asarray(tension), k_link * chain.pitch, c_link * chain.pitch, shoe=shoe,
    )  # fmt: skip
    empty2, empty3 = jnp.zeros((0, 2)), jnp.zeros((0, 3))
    return Scene(
        mass=jnp.zeros(0),
        inertia=jnp.zeros(0),
        roller_body=jnp.zeros(0, dtype=int),
        roller_offset=empty2,
        sprockets=sprockets,
        impact_speed=jnp.asarray(1.0),
        q0=empty3,
        v0=empty3,
        link_weights=jnp.eye(n),
        horizon=jnp.asarray(math.inf),
        tensile_strength=jnp.asarray(chain.tensile_strength, dtype=float),
        fidelity="spans",
        elements=(RollerTeeth(roller_law(chain, 0.7), None), arms, Gravity(jnp.zeros(2)), spans),
    )


def _place_shoe(tensioner, chain, centres, teeth, outside, profiles, n_links, tension):
    """(SpanShoe, Tensioners) of ``tensioner`` laid out as in the lumped chain
    (:func:`.loop_drive.tensioned_layout`, ``n_links`` setting how far it pushes), its arm
    at the layout's angle."""
    stretch = Lumped().stretch(chain, float(tension[int(tensioner.span)]))
    lp = chain.pitch + stretch
    lay, _, iv, span_length = tensioned_layout(
        chain.pitch, lp, chain.roller_diameter / 2, teeth, np.asarray(centres), outside,
        profiles, n_links, None, tensioner,
    )  # fmt: skip
    arms, _ = place_tensioner(
        tensioner, lay, iv, span_length, float(tension[int(tensioner.span)]), chain
    )
    r_v = lay.link_pitch / (2 * math.sin(math.pi / int(lay.teeth[iv])))
    shoe = SpanShoe(
        int(tensioner.span), r_v, lay.centres[iv], np.asarray(arms.pivot[0]),
        float(arms.angle0[0]),
    )  # fmt: skip
    return shoe, arms
