"""Tensioners and guides of a closed drive: what the user asks for (:class:`Tensioner`,
:class:`Guide`, placed on a span of the loop) and their placement on the laid-out chain
(set-up code: NumPy, not traced).

The layout treats a tensioner's shoe as an idler on the chain's back whose pitch circle
is the circle of the roller centres resting on the shoe (radius shoe radius + roller
radius, rounded so a whole number of link pitches fits round it): the exact loop layout
(:func:`~jaxchain.scenes.loop_layout`) then closes the loop by moving that idler along
the bisector of its spans, and the rollers it wraps rest on the shoe. Guides are placed
on the laid-out spans.
"""

from __future__ import annotations

import math
from typing import Literal

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._contact.flores import Flores
from .._contact.friction import CoulombFriction
from .._elements.shoes import Shoes
from .._elements.tensioners import Tensioners
from .._materials import STEEL, Material, effective_modulus
from .._profiles.base import MAX_TEETH, MIN_TEETH

__all__ = ["Tensioner", "Guide", "SHOE_FRICTION", "POLYAMIDE", "shoe_law"]

#: Polyamide 46, the usual face of tensioner and guide shoes (E = 3 GPa, ν = 0.4).
POLYAMIDE = Material(youngs_modulus=3.0e9, poisson_ratio=0.4, density=1180.0)

#: Friction of the chain on a shoe: lubricated steel on polyamide, μ = 0.08, regularized
#: over a sliding speed of 1 cm/s (the chain slides on a shoe at its running speed).
SHOE_FRICTION = CoulombFriction(coefficient=0.08, slip_velocity=1e-2)


def shoe_law(chain: ChainSpec | str, restitution: float, material: Material = POLYAMIDE) -> Flores:
    """Roller/shoe contact: a line contact along the roller (0.95·b1 long) on the shoe's
    face, linear in the overlap, K = (π/4)·E*·ℓ [N/m] (the line contact's compliance up
    to its logarithm), Flores hysteresis damping for ``restitution``. ``chain``: an ISO
    606 designation or a :class:`~jaxchain.ChainSpec`."""
    chain = as_chain(chain)
    checks.real("restitution", restitution, lo=0.0, hi=1.0, lo_open=True)
    estar = effective_modulus(material, STEEL)
    stiffness = 0.25 * math.pi * estar * 0.95 * chain.inner_width
    return Flores(
        stiffness=jnp.asarray(stiffness),
        exponent=jnp.asarray(1.0),
        restitution=jnp.asarray(restitution),
    )


def _optional(name, value, *, lo, unit, lo_open=True):
    return None if value is None else checks.real(name, value, lo=lo, lo_open=lo_open, unit=unit)


class Tensioner(eqx.Module):
    """A pivoting-arm tensioner: a rigid arm turning about a fixed pivot, pressed onto a
    span from the chain's back by a preloaded torsional spring with a linear
    (hydraulic-style) damper on the arm's rate; its shoe is a circular arc (convex toward
    the chain) that the rollers slide on (normal contact :func:`shoe_law`, regularized
    Coulomb friction). The arm type is built; a sprung idler on a slider is not.

    Placed by :func:`~jaxchain.scenes.drive` on span ``span`` (span j runs from sprocket
    j to sprocket j + 1; span 0 leaves the driver: the slack side). It sets the chain's
    tension: the drive needs no take-up and its sprockets stay where given.

    Attributes:
        span: index of the span it presses on, in [0, N − 1] (default 0).
        at: where the shoe's middle sits along the span, a fraction of its length in
            (0, 1) (default 0.5).
        shoe_radius: radius of the shoe's face [m], > 0 (default 0.1); rounded so that a
            whole number of link pitches fits round the circle of the roller centres
            resting on it (by about radius/z, z that number).
        deflection: how far the shoe pushes the span in from its straight line [m], > 0
            (default 8 % of the span's length): it sets the wrap angle θ on the shoe and
            its force 2·T·sin(θ/2).
        shoe_length: length of the shoe's face [m] (default: the wrapped arc plus four
            pitches); it must cover the wrapped arc.
        pivot: (along, out) [m]: the pivot from the shoe's middle, ``along`` the span's
            direction of travel (negative: upstream) and ``out`` away from the chain
            (default (−0.4·span length, 0.02)).
        preload: spring torque pressing the shoe onto the chain at the laid-out arm angle
            [N·m], > 0 (default: what holds the span at the drive's ``pretension``).
        stiffness: torsional spring rate [N·m/rad], ≥ 0 (default preload/(π/2): the spring
            wound a quarter turn at its preload).
        damping: damper rate on the arm's angular rate [N·m·s/rad], ≥ 0 (default 0).
        inertia: the arm's moment of inertia about its pivot [kg·m²], > 0 (default a
            0.1 kg rod from the pivot to the shoe's middle).
        friction: roller/shoe friction (default :data:`SHOE_FRICTION`, μ = 0.08), or None.
    """

    span: int = eqx.field(static=True, default=0)
    at: float = 0.5
    shoe_radius: float = 0.1
    deflection: float | None = None
    shoe_length: float | None = None
    pivot: tuple[float, float] | None = None
    preload: float | None = None
    stiffness: float | None = None
    damping: float = 0.0
    inertia: float | None = None
    friction: CoulombFriction | None = SHOE_FRICTION

    def __check_init__(self):
        checks.integer("Tensioner.span", self.span, lo=0)
        checks.real("Tensioner.at", self.at, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
        checks.real("Tensioner.shoe_radius", self.shoe_radius, lo=0.0, lo_open=True, unit="m")
        _optional("Tensioner.deflection", self.deflection, lo=0.0, unit="m")
        _optional("Tensioner.shoe_length", self.shoe_length, lo=0.0, unit="m")
        _optional("Tensioner.preload", self.preload, lo=0.0, unit="N·m")
        _optional("Tensioner.stiffness", self.stiffness, lo=0.0, lo_open=False, unit="N·m/rad")
        checks.real("Tensioner.damping", self.damping, lo=0.0, unit="N·m·s/rad")
        _optional("Tensioner.inertia", self.inertia, lo=0.0, unit="kg·m²")
        if self.pivot is not None:
            along, out = checks.pair("Tensioner.pivot", self.pivot, 2, "(along, out) [m]")
            checks.real("Tensioner.pivot[0]", along, unit="m")
            checks.real("Tensioner.pivot[1]", out, lo=0.0, lo_open=True, unit="m")
        if self.friction is not None:
            checks.instance(
                "Tensioner.friction", self.friction, CoulombFriction,
                "a jc.contact.CoulombFriction or None",
            )  # fmt: skip


class Guide(eqx.Module):
    """A fixed guide: a straight or circular-arc shoe (convex toward the chain) along a
    span that the rollers slide on (normal contact :func:`shoe_law`, regularized Coulomb
    friction).

    Placed by :func:`~jaxchain.scenes.drive` along span ``span`` of the laid-out chain,
    its face ``offset`` off the rollers on the chain's back (``side="outside"``) or
    inside the loop (``"inside"``); an arc guide touches the span at its middle.

    Attributes:
        span: index of the span it guides, in [0, N − 1] (span j runs from sprocket j to
            j + 1).
        at: where its middle sits along the span, a fraction of the span's length in
            (0, 1) (default 0.5).
        length: length of its face [m], > 0 (default 0.06); it must fit within the span.
        radius: radius of its face [m], > 0; ``math.inf`` (the default) for a straight
            guide.
        offset: gap between its face and the rollers at the layout [m], ≥ 0 (default 0).
        side: "outside" (on the chain's back, the default) or "inside" the loop.
        friction: roller/guide friction (default :data:`SHOE_FRICTION`), or None.
    """

    span: int = eqx.field(static=True, default=0)
    at: float = 0.5
    length: float = 0.06
    radius: float = math.inf
    offset: float = 0.0
    side: Literal["outside", "inside"] = eqx.field(static=True, default="outside")
    friction: CoulombFriction | None = SHOE_FRICTION

    def __check_init__(self):
        checks.integer("Guide.span", self.span, lo=0)
        checks.real("Guide.at", self.at, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
        checks.real("Guide.length", self.length, lo=0.0, lo_open=True, unit="m")
        r = float(self.radius)
        if not (r > 0):
            raise ValueError(f"Guide.radius must be > 0 m (math.inf: straight), got {r}")
        checks.real("Guide.offset", self.offset, lo=0.0, unit="m")
        checks.choice("Guide.side", self.side, ("outside", "inside"))
        if self.friction is not None:
            checks.instance(
                "Guide.friction", self.friction, CoulombFriction,
                "a jc.contact.CoulombFriction or None",
            )  # fmt: skip


def _unit(v):
    return np.asarray(v, float) / float(np.linalg.norm(v))


def _left(u):
    return np.array([-u[1], u[0]])


def shoe_teeth(tensioner: Tensioner, link_pitch: float, roller_radius: float) -> int:
    """Link pitches round the circle of the roller centres resting on the shoe (the
    idler standing in for the shoe in the layout)."""
    r_v = float(tensioner.shoe_radius) + roller_radius
    z = math.pi / math.asin(min(1.0, link_pitch / (2 * r_v)))
    z = round(z)
    if not MIN_TEETH <= z <= MAX_TEETH:
        lo = link_pitch / (2 * math.sin(math.pi / MIN_TEETH)) - roller_radius
        hi = link_pitch / (2 * math.sin(math.pi / MAX_TEETH)) - roller_radius
        raise ValueError(
            f"Tensioner.shoe_radius must be in [{lo * 1e3:.4g}, {hi * 1e3:.4g}] mm for this "
            f"chain (between {MIN_TEETH} and {MAX_TEETH} pitches round the shoe), got "
            f"{float(tensioner.shoe_radius) * 1e3:.4g} mm"
        )
    return z


def idler_centre(tensioner, start, end, r_v) -> tuple[np.ndarray, float]:
    """Centre of the idler standing in for the shoe, pushing the straight span from
    ``start`` to ``end`` (roller centres) in by the deflection, and the span's length."""
    length = float(np.linalg.norm(end - start))
    u = _unit(end - start)
    deflection = 0.08 * length if tensioner.deflection is None else float(tensioner.deflection)
    q = start + float(tensioner.at) * (end - start)
    return q - _left(u) * (r_v - deflection), length


def span_ends(lay, j):
    """(start, end) roller centres of laid-out span j: the last roller of sprocket j's
    wrap and the first of sprocket j + 1's (sprocket 0's wrap opens the roller list)."""
    n = len(lay.teeth)
    i0 = int(np.max(np.nonzero(lay.sprocket_of == j)[0]))
    i1 = int(np.min(np.nonzero(lay.sprocket_of == (j + 1) % n)[0]))
    return lay.rollers[i0], lay.rollers[i1]


def place_tensioner(
    tensioner: Tensioner, lay, iv: int, span_length: float, tension: float, chain: ChainSpec
):
    """(Tensioners, shoe dict) of the tensioner whose shoe stands in as idler ``iv`` of
    layout ``lay``; ``tension`` [N]: its span's static tension (for the default
    preload)."""
    p, r = chain.pitch, chain.roller_diameter / 2
    lp = lay.link_pitch
    z = int(lay.teeth[iv])
    r_v = lp / (2 * math.sin(math.pi / z))
    r_s = r_v - r
    c = lay.centres[iv]
    wrapped = lay.rollers[lay.sprocket_of == iv] - c
    dirs = wrapped / np.linalg.norm(wrapped, axis=-1, keepdims=True)
    n = _unit(dirs.sum(axis=0))
    half_angle = float(np.max(np.arccos(np.clip(dirs @ n, -1.0, 1.0))))
    wrapped_half = r_s * half_angle
    if tensioner.shoe_length is None:
        half = wrapped_half + 2 * p
    else:
        half = 0.5 * float(tensioner.shoe_length)
        if half < wrapped_half + 0.5 * p:
            raise ValueError(
                f"Tensioner.shoe_length must cover the chain's wrap on the shoe and half a "
                f"pitch each side, >= {2 * (wrapped_half + 0.5 * p) * 1e3:.4g} mm, got "
                f"{2 * half * 1e3:.4g} mm"
            )
    if half / r_s >= 0.5 * math.pi:
        raise ValueError(
            f"Tensioner.shoe_length: the shoe's face spans {math.degrees(2 * half / r_s):.0f}° "
            "of its circle; it must span less than 180°: shorten it or use a larger "
            "shoe_radius"
        )
    mid = c + r_s * n
    # the direction of travel along the span at the shoe
    u = _unit(_left(n) * -1.0)  # chain runs clockwise round the shoe: travel = −left(n)
    along, out = (
        (-0.4 * span_length, 0.02) if tensioner.pivot is None else map(float, tensioner.pivot)
    )
    pivot = mid + along * u - out * n
    lever_vec = mid - pivot
    ell = float(np.linalg.norm(lever_vec))
    press = float(lever_vec[0] * n[1] - lever_vec[1] * n[0])  # cross(mid − pivot, n)
    if abs(press) < 0.2 * ell:
        raise ValueError(
            f"Tensioner.pivot={tensioner.pivot!r} lies almost on the shoe's normal line "
            f"(the arm turns the shoe along the chain, not onto it: lever {abs(press) / ell:.2f}"
            " of the arm's length, needs >= 0.2): move the pivot along the span"
        )
    sense = 1.0 if press > 0 else -1.0
    if tensioner.preload is None:
        # resultant of the two span tensions on the shoe, through the arc's centre
        i_in = np.nonzero(lay.sprocket_of == iv)[0]
        first, last = lay.rollers[i_in[0]], lay.rollers[i_in[-1]]
        prev = lay.rollers[(i_in[0] - 1) % len(lay.rollers)]
        nxt = lay.rollers[(i_in[-1] + 1) % len(lay.rollers)]
        u_in, u_out = _unit(first - prev), _unit(nxt - last)
        force = tension * (u_out - u_in)
        arm_c = c - pivot
        torque = float(arm_c[0] * force[1] - arm_c[1] * force[0])
        preload = -sense * torque
        if not preload > 0:  # pragma: no cover - a shoe on the chain's back pushes in
            raise ValueError("the tensioner's arm cannot press the shoe onto the chain")
    else:
        preload = float(tensioner.preload)
    stiffness = preload / (0.5 * math.pi) if tensioner.stiffness is None else tensioner.stiffness
    inertia = 0.1 * ell**2 / 3 if tensioner.inertia is None else tensioner.inertia
    angle = math.atan2(lever_vec[1], lever_vec[0])
    arms = Tensioners(
        pivot=jnp.asarray(pivot[None]),
        layout_angle=jnp.asarray([angle]),
        angle0=jnp.asarray([angle]),
        rate0=jnp.zeros(1),
        inertia=jnp.asarray([float(inertia)]),
        stiffness=jnp.asarray([float(stiffness)]),
        damping=jnp.asarray([float(tensioner.damping)]),
        preload=jnp.asarray([float(preload)]),
        sense=jnp.asarray([sense]),
    )
    shoe = dict(
        mid=mid,
        normal=n,
        curvature=1.0 / r_s,
        half_length=half,
        edge=p,
        friction=tensioner.friction,
    )
    return arms, shoe


def place_guide(guide: Guide, start, end, chain: ChainSpec) -> dict:
    """Shoe arrays of ``guide`` on the laid-out straight span from ``start`` to ``end``."""
    p, r = chain.pitch, chain.roller_diameter / 2
    length = float(np.linalg.norm(end - start))
    u = _unit(end - start)
    at, half = float(guide.at), 0.5 * float(guide.length)
    if at * length - half < -1e-12 or at * length + half > length + 1e-12:
        raise ValueError(
            f"Guide on span {guide.span}: its face runs from {(at * length - half) * 1e3:.4g} "
            f"to {(at * length + half) * 1e3:.4g} mm along a span of {length * 1e3:.4g} mm; "
            "shorten it (length) or move it (at) so it lies within the span"
        )
    normal = _left(u) if guide.side == "outside" else -_left(u)
    q = start + at * (end - start)
    mid = q - normal * (r + float(guide.offset))
    curvature = 0.0 if math.isinf(float(guide.radius)) else 1.0 / float(guide.radius)
    if curvature * half >= 0.5 * math.pi:
        raise ValueError(
            f"Guide.length: the face spans {math.degrees(2 * half * curvature):.0f}° of its "
            "circle; it must span less than 180°: shorten it or use a larger radius"
        )
    return dict(
        mid=mid,
        normal=normal,
        curvature=curvature,
        half_length=half,
        edge=min(p, 0.25 * float(guide.length)),
        friction=guide.friction,
    )


#: Shoes check every roller unless the chain has more rollers than this per contact slot:
#: up to there, picking a shoe's nearest rollers (a top-k, gathers and scatters) costs
#: more than its contact with every roller.
SHOE_ROLLERS_PER_SLOT = 24


def assemble_shoes(shoes: list[dict], n_tensioners: int, law, lp, rollers, radius: float):
    """The scene's :class:`Shoes` from placed shoes (tensioners' first); each shoe's
    friction stacked into one law (μ = 0 for a shoe without). ``rollers``: (R, 2) the laid
    out roller centres [m]. The contact slots cover a shoe's length in pitches and every
    roller of the layout within its reach (half its length plus a roller radius from its
    middle: other parts of the chain may pass close), with a margin of 6."""
    rollers = np.asarray(rollers, dtype=float)
    half = max(s["half_length"] + s["edge"] for s in shoes)
    near = max(
        int(np.sum(np.linalg.norm(rollers - s["mid"], axis=-1) <= s["half_length"] + 1.05 * radius))
        for s in shoes
    )
    slots = max(math.ceil(2 * half / lp), near) + 6
    mu = [0.0 if s["friction"] is None else float(s["friction"].coefficient) for s in shoes]
    vs = [1.0 if s["friction"] is None else float(s["friction"].slip_velocity) for s in shoes]
    friction = CoulombFriction(coefficient=jnp.asarray(mu), slip_velocity=jnp.asarray(vs))
    return Shoes(
        mid=jnp.asarray(np.stack([s["mid"] for s in shoes])),
        normal=jnp.asarray(np.stack([s["normal"] for s in shoes])),
        curvature=jnp.asarray([float(s["curvature"]) for s in shoes]),
        half_length=jnp.asarray([float(s["half_length"]) for s in shoes]),
        edge=jnp.asarray([float(s["edge"]) for s in shoes]),
        law=law,
        friction=None if not any(mu) else friction,
        n_tensioners=n_tensioners,
        slots=None if SHOE_ROLLERS_PER_SLOT * slots > len(rollers) else slots,
    )
