"""The span-level drive (``drive(..., fidelity="spans")``): rigid sprockets on their pitch
curves and the free spans as axial springs between tangent points
(:class:`~jaxchain._elements.spans.Spans`); no rollers, no links."""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec
from .._elements.spans import Spans, pitch_curve_coefficients, scaled_curve
from .._kinematics import tangent_normal
from .._loads import AbstractLoad
from .._profiles.base import MAX_TEETH
from .._scene import Scene, Sprocket
from .build import link_stiffness, roller_law
from .common import (
    as_loads,
    as_profiles,
    check_load_ramp,
    sprocket_inertias,
)
from .loop import as_centres, as_outside
from .loop_drive import span_tensions

__all__ = ["spans_drive", "span_element", "SPAN_ORDER"]

#: harmonics of a pitch curve the span-level chain resolves (at most (z − 1)/2)
SPAN_ORDER = 6


def span_element(profiles, centres, sense, tension, axial_stiffness, axial_damping) -> Spans:
    """The :class:`~jaxchain.elements.Spans` of sprockets with ``profiles`` at ``centres``
    (S, 2) [m], ``sense`` (S,) ±1, whose spans carry ``tension`` (S,) [N] at the sprockets'
    zero angles; ``axial_stiffness`` EA [N] and ``axial_damping`` [N·s] of the chain (a
    span of length L: EA/L, damping/L). Every step is an array operation: the element is
    differentiable in the profiles' leaves (a pitch curve's harmonics, say) and the
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
    # the outward normal of the tangent of the (effective) pitch circles: the line solve's start
    beta = tangent_normal(
        centres[start], arc_mean[start], sense[start], centres[end], arc_mean[end], sense[end]
    )
    probe = Spans(
        start=jnp.asarray(start), end=jnp.asarray(end), sense=sense, coefficients=coef,
        arc_mean=arc_mean, arc_cos=arc_cos, arc_sin=arc_sin, normal_angle=beta,
        base=jnp.zeros(n), stiffness=jnp.ones(n), damping=jnp.zeros(n),
    )  # fmt: skip
    length, u0, _, _ = probe.geometry(jnp.zeros(n), centres)
    stiffness = axial_stiffness / length
    # start stretch: the tension through the smooth ramp's inverse (ramp(e) = T/k)
    x, w = tension / stiffness, 1.0 / stiffness
    stretch = x - w * w / (4 * x)
    return dataclasses.replace(
        probe, base=length - stretch - u0, stiffness=stiffness, damping=axial_damping / length
    )


# one compiled program (eager, every operation would compile on its own)
_span_element = eqx.filter_jit(span_element)


def spans_drive(
    chain: ChainSpec,
    teeth,
    centres,
    *,
    outside,
    take_up_sprocket: int | None,
    speed_rpm: float,
    load_torque,
    pretension: float,
    form: str,
    profiles,
    driven_inertia,
    load_ramp: float | None,
    link_damping: float,
) -> Scene:
    """The span-level drive over N sprockets (see :func:`~jaxchain.scenes.drive`): the
    sprockets at ``centres`` (the driver first, the loop counter-clockwise, ``outside``
    ones on the chain's back), the spans' start tensions those of the statics with
    ``pretension`` shared by the take-up sprocket's two spans and every driven sprocket's
    load carried."""
    n = len(teeth)
    teeth = tuple(checks.integer(f"teeth[{k}]", z, lo=7, hi=MAX_TEETH) for k, z in enumerate(teeth))
    centres = as_centres(centres, n)
    sense = np.ones(n)
    sense[list(as_outside(outside, n))] = -1.0
    m = (
        n - 1
        if take_up_sprocket is None
        else checks.integer("take_up_sprocket", take_up_sprocket, lo=1, hi=n - 1)
    )
    speeds = [speed_rpm * math.pi / 30 * teeth[0] / z for z in teeth[1:]]
    driven_loads, held = as_loads("load_torque", load_torque, speeds)
    check_load_ramp(driven_loads, load_ramp)
    pretension = checks.real("pretension", pretension, lo=0.0, unit="N")
    profiles = as_profiles(chain, profiles, teeth, form)
    radii = [p.teeth * float(p.pitch) / (2 * math.pi) for p in profiles]  # z·p/2π
    tension = span_tensions((0.0, *held), radii, pretension, m)
    if tension.min() <= 0:
        raise ValueError(
            f"no static equilibrium: a span would carry {tension.min():.4g} N (the loads need "
            "more tension than pretension gives); raise pretension or lower load_torque"
        )
    inertias = sprocket_inertias(chain, profiles, driven_inertia)
    omega1 = speed_rpm * 2 * math.pi / 60
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
    c_link = 2 * link_damping * math.sqrt(k_link * m_link / 2)
    spans = _span_element(
        tuple(profiles), jnp.asarray(np.stack(centres)), jnp.asarray(sense),
        jnp.asarray(tension), k_link * chain.pitch, c_link * chain.pitch,
    )  # fmt: skip
    empty2, empty3 = jnp.zeros((0, 2)), jnp.zeros((0, 3))
    return Scene(
        mass=jnp.zeros(0),
        inertia=jnp.zeros(0),
        pairs=(),
        roller_body=jnp.zeros(0, dtype=int),
        roller_offset=empty2,
        roller_law=roller_law(chain, 0.7),
        friction=None,
        sprockets=sprockets,
        anchors=None,
        joint_friction=None,
        impact_speed=jnp.asarray(1.0),
        q0=empty3,
        v0=empty3,
        link_weights=jnp.eye(n),
        gravity=jnp.zeros(2),
        horizon=jnp.asarray(math.inf),
        tensile_strength=jnp.asarray(chain.tensile_strength, dtype=float),
        fidelity="spans",
        elements=(spans,),
    )
