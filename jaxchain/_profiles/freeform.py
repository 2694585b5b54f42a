"""Free-form sprocket tooth profiles: asymmetric arc-spline flanks and per-tooth patterns.

Frame conventions as in :mod:`.iso`: sprocket frame, SI units, origin on
the sprocket axis. Gap ``k`` is centred on the ray at angle ``2πk/z + phase[k]``; its seat
centre lies on that ray at radius ``R + seat_offset[k]`` (R = p / (2 sin(π/z)), the pitch
radius).

Outline of gap k, in its own frame (gap axis along +x), on each side of the axis — the
counter-clockwise side (``ccw``, y > 0) and the clockwise side (``cw``, y < 0), each with
its own :class:`Flank` — from the gap bottom outwards:

* **seat** — one arc of radius ``seating_radius`` about the seat centre c, spanning
  ``seat_angle`` on that side of the axis (the ISO seating angle α is the sum of the two
  sides), up to the junction J;
* **flank** — K convex circular arcs, tangent to the seat at J and to each other (a G1
  arc spline): arc i has curvature ``curvature[i]`` and runs until the flank reaches the
  radius ``|J| + breaks[i]·(ra − |J|)``; the last arc runs to the tip circle (ra = da/2),
  where it meets it at the tip corner;
* **tip** — the tip circle, out to the nominal tooth centre line at angle (k ± ½)·2π/z,
  where the next gap's outline takes over.

The radial break points make every parameter set of the box a closed outline that
reaches the tip circle monotonically (no arc length to tune against the tip). An ISO 606
profile is the special case K = 1, curvature 1/re, seat angle α/2 on both sides, no
offsets (:meth:`FreeformProfile.from_iso`); splitting its flank into K arcs of the same
curvature leaves the outline unchanged.

Every shape leaf is a scalar (uniform sprocket) or has a leading axis of length z, one
value per gap (the flanks' ``curvature`` (K,) and ``breaks`` (K−1,) become (z, K) and
(z, K−1)). Chordal pitch reduction (a sprocket pitch p' a fraction shorter than the
chain's) is the uniform ``seat_offset = (p' − p) / (2 sin(π/z))``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _checks as checks
from .._numerics import is_concrete, stack
from .base import AbstractProfile, check_teeth
from .freeform_shape import Flank, FreeShape, HalfGap, gap_table, half_gap, split_between
from .pitch_polygon import pitch_polygon

__all__ = ["Flank", "FreeformProfile", "stack_shapes"]


class FreeformProfile(AbstractProfile):
    """A sprocket's tooth profile with free-form asymmetric flanks and per-tooth patterns.

    All geometric fields are array leaves (differentiable); ``teeth`` and
    ``min_tip_width`` are static. See the module docstring for the outline.

    Attributes:
        teeth: number of teeth z (static).
        pitch: chain pitch p [m].
        roller_diameter: d1 of the roller that engages it [m].
        seating_radius: ri [m] (> d1/2), scalar or (z,).
        seat_offset: radial offset [m] of the seat centre from the pitch circle, scalar
            or (z,) (0: on the pitch circle, as ISO 606).
        phase: angular offset [rad] of each gap from 2πk/z, scalar or (z,).
        tip_diameter: da [m], one tip circle for every tooth.
        cw: the clockwise side of every gap (y < 0 in the gap's frame).
        ccw: the counter-clockwise side.
        min_tip_width: smallest tooth width on the tip circle (arc length) [m] the
            construction accepts (static, default 0).
    """

    teeth: int = eqx.field(static=True)
    pitch: Float[Array, ""]
    roller_diameter: Float[Array, ""]
    seating_radius: Float[Array, "*z"]
    seat_offset: Float[Array, "*z"]
    phase: Float[Array, "*z"]
    tip_diameter: Float[Array, ""]
    cw: Flank
    ccw: Flank
    min_tip_width: float = eqx.field(static=True)

    def __init__(
        self,
        *,
        teeth: int,
        pitch: ArrayLike,
        roller_diameter: ArrayLike,
        seating_radius: ArrayLike,
        tip_diameter: ArrayLike,
        cw: Flank,
        ccw: Flank,
        seat_offset: ArrayLike = 0.0,
        phase: ArrayLike = 0.0,
        min_tip_width: float = 0.0,
    ):
        check_teeth(teeth)
        self.teeth = int(teeth)
        self.pitch = jnp.asarray(pitch, dtype=float)
        self.roller_diameter = jnp.asarray(roller_diameter, dtype=float)
        self.seating_radius = jnp.asarray(seating_radius, dtype=float)
        self.seat_offset = jnp.asarray(seat_offset, dtype=float)
        self.phase = jnp.asarray(phase, dtype=float)
        self.tip_diameter = jnp.asarray(tip_diameter, dtype=float)
        for name, flank in (("cw", cw), ("ccw", ccw)):
            if not isinstance(flank, Flank):
                raise TypeError(
                    f"FreeformProfile: {name} must be a jc.Flank, got {type(flank).__name__}"
                )
        self.cw, self.ccw = cw, ccw
        self.min_tip_width = float(min_tip_width)

    def __check_init__(self):
        _check_shapes(self)
        if is_concrete(self):
            _validate(self)

    # ------------------------------------------------------------------ factories
    @classmethod
    def from_iso(cls, profile: ToothProfile, arcs: int = 1, **changes) -> FreeformProfile:  # noqa: F821
        """The free-form profile with the same outline as the ISO-type ``profile``: both
        flanks one arc of curvature 1/re, split into ``arcs`` arcs of that curvature (break
        points evenly spaced in the radial rise), seat angle α/2 on each side. Keyword
        ``changes`` replace fields (e.g. ``seating_radius=array`` for a per-tooth
        pattern)."""
        from .iso import ToothProfile  # here: iso imports this module to convert itself

        if not isinstance(profile, ToothProfile):
            raise TypeError(
                f"from_iso: profile must be a jc.ToothProfile, got {type(profile).__name__}"
            )
        if not isinstance(arcs, (int, np.integer)) or not 1 <= arcs <= 16:
            raise ValueError(f"arcs must be an integer in [1, 16], got {arcs!r}")
        kappa = jnp.full((arcs,), 1.0) / profile.flank_radius
        breaks = jnp.arange(1, arcs, dtype=float) / arcs
        flank = Flank(profile.seating_angle / 2, kappa, breaks)
        kw = dict(
            teeth=profile.teeth,
            pitch=profile.pitch,
            roller_diameter=profile.roller_diameter,
            seating_radius=profile.seating_radius,
            tip_diameter=profile.tip_diameter,
            cw=flank,
            ccw=flank,
        )
        kw.update(changes)
        return cls(**kw)

    @classmethod
    def noncircular(
        cls, base: AbstractProfile, harmonics: Sequence[Sequence[ArrayLike]] = ()
    ) -> FreeformProfile:
        """A non-circular sprocket: ``base``'s tooth form (any kind with a free-form form;
        its seat offsets and phases replaced) about seats on a closed polygon of z chords,
        each exactly one chain pitch, whose corners lie on the pitch curve

            r(θ) = R₀ + Σ Aᵢ·sin(nᵢ·θ + φᵢ),   ``harmonics`` = ((nᵢ, Aᵢ [m], φᵢ [rad]), ...)

        (nᵢ whole cycles per revolution, ≥ 1), seat 0 at θ = 0 and R₀ solved with the
        seats' angles (Newton, to round-off; see :func:`.pitch_polygon.pitch_polygon`).
        Each gap keeps its form about its own seat, its axis on the seat's ray. The
        amplitudes and phases may be traced: the seats are differentiable in them
        (implicit function theorem). The tip circle stays the base's.

        Raises ``ValueError`` (concrete harmonics) for orders that are not whole numbers
        ≥ 1, or harmonics so large that no such polygon is found."""
        checks.instance(
            "noncircular: base", base, AbstractProfile,
            "a tooth profile whose form the sprocket keeps (jc.ToothProfile, "
            "jc.FreeformProfile, any jc.AbstractProfile with a free-form form)",
        )  # fmt: skip
        base = base.freeform()
        rows = checks.harmonics("noncircular", harmonics)
        for k, h in enumerate(rows):
            if isinstance(h[0], (bool, np.bool_)) or not is_concrete(h[0]):
                raise TypeError(
                    f"noncircular: harmonics[{k}]'s order must be a whole number >= 1 (cycles "
                    f"per revolution, static), got {h[0]!r}"
                )
            for part, v in zip(("order", "amplitude", "phase"), h, strict=True):
                if is_concrete(v) and not np.isfinite(float(v)):
                    raise ValueError(
                        f"noncircular: harmonics[{k}]'s {part} must be finite, got {v}"
                    )
        orders = np.asarray([float(h[0]) for h in rows], dtype=float)
        if np.any((orders < 1) | (orders != np.round(orders))):
            raise ValueError(
                f"noncircular: every order must be a whole number >= 1 (cycles per "
                f"revolution of a closed pitch curve), got {orders.tolist()}"
            )
        if np.any(2 * orders >= base.teeth):
            raise ValueError(
                f"noncircular: every order must be below z/2 = {base.teeth / 2:g} (the "
                f"{base.teeth} seats sample the pitch curve: an order of z/2 or more is "
                f"seen as a lower one, or as none), got {orders.tolist()}"
            )
        dtype = jnp.result_type(base.pitch)
        amplitudes = jnp.stack([jnp.asarray(h[1], dtype) for h in rows]) if rows else jnp.zeros(0)
        phases = jnp.stack([jnp.asarray(h[2], dtype) for h in rows]) if rows else jnp.zeros(0)
        z = base.teeth
        theta, radius, _, err = pitch_polygon(z, base.pitch, orders, amplitudes, phases)
        if is_concrete(err) and not float(err) <= 1e-9 * float(base.pitch):
            raise ValueError(
                f"noncircular: no closed polygon of {z} equal chords found on this pitch "
                f"curve (chord error {float(err):.3g} m); use smaller amplitudes"
            )
        offset = radius - base.pitch / (2 * jnp.sin(jnp.pi / z))
        phase = theta - 2 * jnp.pi * jnp.arange(z) / z
        kw = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
        return cls(**(kw | {"seat_offset": offset, "phase": phase}))  # validated per gap

    # ------------------------------------------------------------------ derived
    @property
    def arcs(self) -> int:
        """K, arcs per flank (both sides have the same K)."""
        return self.ccw.arcs

    def contact_shape(self) -> FreeShape:
        """What the contact reads, with ``teeth`` an array leaf (see :class:`FreeShape`)."""
        return FreeShape(
            jnp.asarray(self.teeth, dtype=self.pitch.dtype), self.pitch,
            self.roller_diameter, self.seating_radius, self.seat_offset, self.phase,
            self.tip_diameter, self.cw, self.ccw,
        )  # fmt: skip

    shape = contact_shape

    def freeform(self, arcs: int | None = None) -> FreeformProfile:
        """This profile (``arcs`` None or its own K), or the same outline with ``arcs``
        arcs per flank (the last arc split at the same curvature)."""
        if arcs is None or arcs == self.arcs:
            return self
        if not isinstance(arcs, (int, np.integer)) or not self.arcs < arcs <= 16:
            raise ValueError(f"arcs must be an integer in [{self.arcs}, 16], got {arcs!r}")
        return _refine(self, arcs)

    def pitch_polar(self) -> tuple[Array, Array]:
        """Seat k at radius R + seat_offset[k] and angle 2πk/z + phase[k] (arrays of the
        leaves, differentiable)."""
        z = self.teeth
        r = self.pitch_radius + jnp.broadcast_to(self.seat_offset, (z,))
        a = 2 * jnp.pi * jnp.arange(z, dtype=r.dtype) / z + jnp.broadcast_to(self.phase, (z,))
        return r, a

    def pitch_points(self) -> np.ndarray:
        """(z, 2) the seat centres [m], sprocket frame: seat k at radius R + seat_offset[k]
        on the ray at angle 2πk/z + phase[k]."""
        z = self.teeth
        r = float(self.pitch_radius) + np.broadcast_to(np.asarray(self.seat_offset), (z,))
        a = 2 * np.pi * np.arange(z) / z + np.broadcast_to(np.asarray(self.phase), (z,))
        return r[:, None] * np.stack([np.cos(a), np.sin(a)], -1)

    def outline_arcs(self) -> list[tuple]:
        """The sprocket's closed outline as circular arcs, counter-clockwise round the
        sprocket: ``(centre (2,), radius, start angle, end angle)`` [m, rad], each arc
        counter-clockwise about its centre from start to end (the DXF convention). Per gap:
        the clockwise flank's arcs from the tip down, the seat, the counter-clockwise
        flank's arcs up, the tip of the tooth after the gap. Zero-length arcs (a pointed
        tooth's tip) are left out."""
        z, k = self.teeth, self.arcs
        # every leaf per gap, so that the table holds one row per gap in the sprocket frame
        ri = jnp.broadcast_to(self.seating_radius, (z,))
        table = _table(eqx.tree_at(lambda q: q.seating_radius, self, ri))
        centre = np.asarray(table.centre, dtype=float)
        radius = np.asarray(table.radius, dtype=float)
        start = np.asarray(table.start, dtype=float)
        end = np.asarray(table.end, dtype=float)
        # row order [cw arcs (K, from the seat out), cw corner, seat, ccw arcs (K), ccw corner,
        # tip]: walk down the cw flank, round the seat, up the ccw flank, over the tip
        order = [*range(k - 1, -1, -1), k + 1, *range(k + 2, 2 * k + 2), 2 * k + 3]
        arcs = []
        for g in range(z):
            for f in order:
                a0 = math.atan2(start[g, f, 1], start[g, f, 0])
                a1 = math.atan2(end[g, f, 1], end[g, f, 0])
                sweep = (a1 - a0) % (2 * math.pi)
                if radius[g, f] * min(sweep, 2 * math.pi - sweep) < 1e-12:
                    continue
                arcs.append((centre[g, f], float(radius[g, f]), a0, a1))
        return arcs

    def gaps(self) -> GapGeometry:
        """Geometry of every gap (NumPy arrays, leading axis z; see :class:`GapGeometry`)."""
        return _gap_geometry_np(self)

    # ------------------------------------------------------------------ outline
    def outline(self, n: int = 60, gap: int = 0) -> np.ndarray:
        """Points (N, 2) [m] of gap ``gap``'s outline, sprocket frame, from the tooth centre
        line on its clockwise side, round the seat, to the one on its counter-clockwise
        side (``gap`` modulo the teeth). For plotting (NumPy, not traced)."""
        g = self.gaps()
        return _gap_outline(g, gap % self.teeth, n)

    def uniform(self) -> FreeformProfile:
        """This profile with each per-gap leaf replaced by its mean over the gaps."""
        z = self.teeth

        def mean(x):
            return jnp.mean(x, 0) if jnp.ndim(x) and jnp.shape(x)[0] == z else x

        return jax.tree_util.tree_map(mean, self)

    def sprocket_outline(self, n: int = 30) -> np.ndarray:
        """Closed outline (N, 2) [m] of the whole sprocket (all z gaps)."""
        g = self.gaps()
        pts = np.concatenate([_gap_outline(g, k, n)[:-1] for k in range(self.teeth)])
        return np.concatenate([pts, pts[:1]])


# --------------------------------------------------------------------------- checks
_GAP_LEAVES = ("seating_radius", "seat_offset", "phase")


def _check_shapes(p: FreeformProfile) -> None:
    """Leaf shapes: scalars or one value per gap; K ≥ 1 arcs, the same on both sides."""
    z = p.teeth
    for name in ("pitch", "roller_diameter", "tip_diameter"):
        if jnp.ndim(getattr(p, name)) != 0:
            raise ValueError(
                f"FreeformProfile: {name} must be a scalar, got shape {jnp.shape(getattr(p, name))}"
            )
    for name in _GAP_LEAVES:
        s = jnp.shape(getattr(p, name))
        if s not in ((), (z,)):
            raise ValueError(
                f"FreeformProfile: {name} must be a scalar or one value per gap, shape ({z},); "
                f"got shape {s}"
            )
    ks = set()
    for side in ("cw", "ccw"):
        f = getattr(p, side)
        a, c, b = jnp.shape(f.seat_angle), jnp.shape(f.curvature), jnp.shape(f.breaks)
        k = c[-1]
        ks.add(k)
        ok = k >= 1 and a in ((), (z,)) and c in ((k,), (z, k)) and b in ((k - 1,), (z, k - 1))
        if not ok:
            raise ValueError(
                f"FreeformProfile: {side} flank shapes must be seat_angle () or ({z},), "
                f"curvature (K,) or ({z}, K), breaks (K-1,) or ({z}, K-1) with K >= 1; got "
                f"seat_angle {a}, curvature {c}, breaks {b}"
            )
    if len(ks) != 1:
        raise ValueError(
            f"FreeformProfile: both flanks must have the same number of arcs, got cw "
            f"{p.cw.arcs}, ccw {p.ccw.arcs}"
        )


def _validate(p: FreeformProfile) -> None:
    """Range and closure checks of a concrete profile, gap by gap; raises ValueError
    naming the gap, what is wrong and the valid range."""
    z = p.teeth
    pitch, d1 = float(p.pitch), float(p.roller_diameter)
    leaves = jax.tree_util.tree_leaves(p)
    if not all(np.all(np.isfinite(np.asarray(x))) for x in leaves):
        raise ValueError("FreeformProfile: every parameter must be finite, got NaN or inf")
    if not pitch > 0:
        raise ValueError(f"pitch must be > 0 m, got {pitch}")
    if not 0 < d1 < pitch:
        raise ValueError(f"roller_diameter must be in (0, pitch = {pitch:.6g}) m, got {d1}")

    def per_gap(x):
        return np.broadcast_to(np.asarray(x, dtype=float), (z,))

    ri = per_gap(p.seating_radius)
    bad = np.flatnonzero(~((d1 / 2 < ri) & (ri < pitch / 2)))
    if bad.size:
        k = bad[0]
        raise ValueError(
            f"seating_radius of gap {k} must be in (roller radius {d1 / 2:.6g}, pitch/2 = "
            f"{pitch / 2:.6g}) m, got {ri[k]:.6g}: the roller must fit inside every seat"
        )
    R = pitch / (2 * math.sin(math.pi / z))
    off = per_gap(p.seat_offset)
    bad = np.flatnonzero(np.abs(off) > 0.1 * pitch)
    if bad.size:
        k = bad[0]
        raise ValueError(
            f"seat_offset of gap {k} must be within ±0.1·pitch = ±{0.1 * pitch:.6g} m, got "
            f"{off[k]:.6g}"
        )
    phase = per_gap(p.phase)
    lim = 0.25 * math.pi / z
    bad = np.flatnonzero(np.abs(phase) > lim)
    if bad.size:
        k = bad[0]
        raise ValueError(
            f"phase of gap {k} must be within ±π/(4z) = ±{lim:.6g} rad, got {phase[k]:.6g}"
        )
    # neighbouring seats must let a chain of pitch p wrap: seat-centre distance within
    # the two seats' radial play of the pitch
    theta = 2 * np.pi * np.arange(z) / z + phase
    c = np.stack([(R + off) * np.cos(theta), (R + off) * np.sin(theta)], -1)
    dist = np.linalg.norm(np.roll(c, -1, 0) - c, axis=-1)
    play = (ri - d1 / 2) + np.roll(ri - d1 / 2, -1)
    bad = np.flatnonzero(np.abs(dist - pitch) > play)
    if bad.size:
        k = bad[0]
        raise ValueError(
            f"seats of gaps {k} and {(k + 1) % z} are {dist[k] * 1e3:.5g} mm apart; a chain of "
            f"pitch {pitch * 1e3:.5g} mm wraps only if that is within their radial play "
            f"{play[k] * 1e3:.4g} mm of the pitch: use smaller phase or seat_offset steps "
            "between neighbours"
        )
    for side in ("cw", "ccw"):
        f = getattr(p, side)
        a = per_gap(f.seat_angle)
        kap = np.broadcast_to(np.asarray(f.curvature), (z, f.arcs))
        brk = np.broadcast_to(np.asarray(f.breaks), (z, f.arcs - 1))
        lo, hi = math.radians(30.0), math.radians(85.0)
        bad = np.flatnonzero(~((lo <= a) & (a <= hi)))
        if bad.size:
            k = bad[0]
            raise ValueError(
                f"{side}.seat_angle of gap {k} must be in [30°, 85°] ([{lo:.4f}, {hi:.4f}] "
                f"rad), got {a[k]:.6g} rad ({math.degrees(a[k]):.2f}°); it is in radians "
                "(the ISO seating angle α is the sum of both sides)"
            )
        k_lo, k_hi = 1.0 / (200 * pitch), 1.0 / (0.5 * d1)
        bad = np.argwhere(~((k_lo <= kap) & (kap <= k_hi)))
        if bad.size:
            k, i = bad[0]
            raise ValueError(
                f"{side}.curvature[{i}] of gap {k} must be in [{k_lo:.6g}, {k_hi:.6g}] 1/m "
                f"(radius from d1/2 to 200·pitch; the flanks are convex), got {kap[k, i]:.6g}"
            )
        steps = np.diff(np.concatenate([np.zeros((z, 1)), brk, np.ones((z, 1))], 1), axis=1)
        bad = np.argwhere(steps <= 0)
        if bad.size:
            k, _ = bad[0]
            raise ValueError(
                f"{side}.breaks of gap {k} must increase strictly inside (0, 1), got "
                f"{brk[k].tolist()}"
            )
        # the seat must stay a graph in polar angle (the sign test reads it so)
        c_x = R + off
        bad = np.flatnonzero(~(np.cos(math.pi - a) < -ri / c_x))
        if bad.size:
            k = bad[0]
            raise ValueError(
                f"{side}.seat_angle {a[k]:.4f} rad of gap {k} is too large for seating_radius "
                f"{ri[k]:.6g} m on this pitch circle: the seat arc would curl back over itself"
            )
    g = _gap_geometry_np(p)
    ra = float(p.tip_diameter) / 2
    r_j = np.hypot(*np.moveaxis(g.vertices[..., 0, :], -1, 0))  # (z, 2 sides)
    if not np.all(r_j < ra):
        k, s = np.argwhere(~(r_j < ra))[0]
        raise ValueError(
            f"tip_diameter {2 * ra:.6g} m must exceed the seat/flank junctions' diameter "
            f"{2 * r_j[k, s]:.6g} m (gap {k}, {('ccw', 'cw')[s]} side)"
        )
    for k in range(z):
        for s, side in enumerate(("ccw", "cw")):
            _check_flank(g, k, s, side, ra)
    # tooth widths on the tip circle: gap k's ccw corner to gap k+1's cw corner
    ang = np.arctan2(g.vertices[..., -1, 1], g.vertices[..., -1, 0])  # (z, 2), local
    theta = g.theta
    ccw_corner = theta + ang[:, 0]
    cw_corner_next = (
        np.roll(theta, -1)
        + 2 * np.pi * (np.arange(z) == z - 1)
        - ang[:, 1].take((np.arange(z) + 1) % z)
    )
    width = ra * (cw_corner_next - ccw_corner)
    bad = np.flatnonzero(~((width >= max(p.min_tip_width, 0.0)) & (width > 0)))
    if bad.size:
        k = bad[0]
        raise ValueError(
            f"tooth between gaps {k} and {(k + 1) % z} is {width[k] * 1e3:.4g} mm wide on the tip "
            f"circle; it must be at least min_tip_width = {p.min_tip_width * 1e3:.4g} mm (and "
            "positive): use a smaller tip_diameter, flatter flanks (smaller curvature) or a "
            "smaller seat_angle"
        )


def _check_flank(g: GapGeometry, k: int, s: int, side: str, ra: float) -> None:
    """One flank of one gap rises monotonically in radius and in polar angle (a graph in
    polar angle, as the sign test reads it), each arc reaching its break radius."""
    pts = _flank_points(g, k, s, 64)  # (K, 64, 2), canonical (upper-half) frame
    r = np.hypot(pts[..., 0], pts[..., 1]).ravel()
    a = np.arctan2(pts[..., 1], pts[..., 0]).ravel()
    ends = g.vertices[k, s, 1:]
    reached = np.hypot(ends[:, 0], ends[:, 1])
    target = g.targets[k, s]
    sweep = g.sweeps[k, s]
    if not (
        np.all(np.abs(reached - target) <= 1e-9 * ra)
        and np.all(np.diff(r) > -1e-12 * ra)
        and np.all(np.diff(a) > -1e-12)
        and np.all((sweep > 0) & (sweep < math.pi / 2))
    ):
        raise ValueError(
            f"the {side} flank of gap {k} does not rise to the tip circle: each arc must reach "
            f"its break radius ({np.round(target * 1e3, 4).tolist()} mm; reached "
            f"{np.round(reached * 1e3, 4).tolist()} mm) while moving away from the gap axis "
            "(turning less than 90°); use smaller curvatures or a larger seat_angle"
        )


# --------------------------------------------------------------------------- geometry
class GapGeometry(NamedTuple):
    """Every gap's two sides (NumPy): leading axes (z, 2 sides: ccw, cw), canonical
    frames; ``theta`` the gaps' axis angles (2πk/z + phase)."""

    seat_centre: np.ndarray  # (z, 2, 2)
    seating_radius: np.ndarray  # (z, 2)
    centres: np.ndarray  # (z, 2, K, 2)
    radii: np.ndarray  # (z, 2, K)
    vertices: np.ndarray  # (z, 2, K+1, 2)
    targets: np.ndarray  # (z, 2, K) break radii
    sweeps: np.ndarray  # (z, 2, K) turning of each arc [rad]
    split: np.ndarray  # (z, 2, 2) where the tip meets the next gap's outline
    theta: np.ndarray  # (z,)


def _side_params(shape, side: str, z: int):
    """(cx, ri, seat_angle, curvature, breaks) of one side of every gap."""
    f = getattr(shape, side)
    z_arr = jnp.asarray(z, dtype=float)
    radius = shape.pitch / (2 * jnp.sin(jnp.pi / z_arr))

    def full(x, tail=()):
        return jnp.broadcast_to(x, (z,) + tail)

    k = f.arcs
    return (
        full(radius + shape.seat_offset),
        full(shape.seating_radius),
        full(f.seat_angle),
        full(f.curvature, (k,)),
        full(f.breaks, (k - 1,)),
    )


@jax.jit
def _every_half_gap(p: FreeformProfile) -> tuple[HalfGap, HalfGap]:
    """Both sides of every gap (jitted: construction checks call it for every profile)."""
    ra = p.tip_diameter / 2
    return tuple(
        jax.vmap(half_gap, (0, 0, 0, 0, 0, None))(*_side_params(p, side, p.teeth), ra)
        for side in ("ccw", "cw")
    )


def _gap_geometry_np(p: FreeformProfile) -> GapGeometry:
    z = p.teeth
    ra = p.tip_diameter / 2
    sides = _every_half_gap(p)
    stack = lambda name: np.stack([np.asarray(getattr(h, name)) for h in sides], 1)  # noqa: E731
    verts = stack("vertices")
    centres = stack("centres")
    radii = stack("radii")
    rel0 = verts[..., :-1, :] - centres
    rel1 = verts[..., 1:, :] - centres
    sweeps = np.arctan2(
        rel0[..., 0] * rel1[..., 1] - rel0[..., 1] * rel1[..., 0], np.sum(rel0 * rel1, -1)
    )
    r_j = np.hypot(verts[..., 0, 0], verts[..., 0, 1])[..., None]
    brk = np.stack(
        [np.broadcast_to(np.asarray(getattr(p, s).breaks), (z, p.arcs - 1)) for s in ("ccw", "cw")],
        1,
    )
    ra_np = float(ra)
    targets = np.concatenate([r_j + brk * (ra_np - r_j), np.full(r_j.shape, ra_np)], -1)
    theta = 2 * np.pi * np.arange(z) / z + np.broadcast_to(np.asarray(p.phase), (z,))
    # tip corners in the sprocket frame: gap k's ccw one and gap k+1's cw one bound tooth k
    corner = verts[:, :, -1]  # (z, 2, 2) canonical
    cos, sin = np.cos(theta)[:, None], np.sin(theta)[:, None]
    ccw = np.concatenate([cos * corner[:, 0, :1] - sin * corner[:, 0, 1:],
                          sin * corner[:, 0, :1] + cos * corner[:, 0, 1:]], -1)  # fmt: skip
    cw_local = corner[:, 1] * np.array([1.0, -1.0])
    cw = np.concatenate([cos * cw_local[:, :1] - sin * cw_local[:, 1:],
                         sin * cw_local[:, :1] + cos * cw_local[:, 1:]], -1)  # fmt: skip
    mid = np.asarray(split_between(ccw, np.roll(cw, -1, 0), ra_np))  # tooth k, sprocket frame
    prev = np.roll(mid, 1, 0)  # tooth k−1
    split_ccw = np.stack([cos[:, 0] * mid[:, 0] + sin[:, 0] * mid[:, 1],
                          -sin[:, 0] * mid[:, 0] + cos[:, 0] * mid[:, 1]], -1)  # fmt: skip
    split_cw = np.stack([cos[:, 0] * prev[:, 0] + sin[:, 0] * prev[:, 1],
                         sin[:, 0] * prev[:, 0] - cos[:, 0] * prev[:, 1]], -1)  # fmt: skip
    return GapGeometry(
        stack("seat_centre"), stack("seating_radius"), centres, radii, verts, targets, sweeps,
        np.stack([split_ccw, split_cw], 1), theta,
    )  # fmt: skip


def _arc(centre, radius, start, end, n):
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    a1 = math.atan2(end[1] - centre[1], end[0] - centre[0])
    a1 = a0 + (a1 - a0 + math.pi) % (2 * math.pi) - math.pi  # the short way
    t = np.linspace(a0, a1, n)
    return centre + radius * np.stack([np.cos(t), np.sin(t)], -1)


def _flank_points(g: GapGeometry, k: int, s: int, n: int) -> np.ndarray:
    """(K, n, 2) points of each flank arc of gap k, side s, canonical frame."""
    v = g.vertices[k, s]
    return np.stack(
        [_arc(g.centres[k, s, i], g.radii[k, s, i], v[i], v[i + 1], n) for i in range(len(v) - 1)]
    )


def _half_outline(g: GapGeometry, k: int, s: int, n: int) -> np.ndarray:
    """Gap k, side s, canonical frame: gap bottom, seat, flank, tip to the centre line."""
    c, ri = g.seat_centre[k, s], g.seating_radius[k, s]
    v = g.vertices[k, s]
    bottom = c - np.array([ri, 0.0])
    seat = _arc(c, ri, bottom, v[0], n)
    flank = _flank_points(g, k, s, n)[:, 1:].reshape(-1, 2)
    tip = _arc(np.zeros(2), np.hypot(*g.split[k, s]), v[-1], g.split[k, s], max(n // 3, 2))
    return np.concatenate([seat, flank, tip[1:]])


def _gap_outline(g: GapGeometry, k: int, n: int) -> np.ndarray:
    upper = _half_outline(g, k, 0, n)
    lower = _half_outline(g, k, 1, n) * np.array([1.0, -1.0])
    pts = np.concatenate([lower[::-1][:-1], upper])
    a = g.theta[k]
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return pts @ rot.T


# --------------------------------------------------------------------------- contact
def _refine(p: FreeformProfile, arcs: int) -> FreeformProfile:
    """The same outline with ``arcs`` arcs per flank: the last arc split (same curvature)
    at break points evenly spaced between its start and the tip."""
    extra = arcs - p.arcs

    def side(f: Flank) -> Flank:
        last = f.breaks[..., -1:] if f.arcs > 1 else jnp.zeros(f.curvature.shape[:-1] + (1,))
        frac = jnp.arange(1, extra + 1, dtype=float) / (extra + 1)
        new = last + (1 - last) * frac
        kap = jnp.concatenate([f.curvature] + [f.curvature[..., -1:]] * extra, -1)
        return Flank(f.seat_angle, kap, jnp.concatenate([f.breaks, new], -1))

    return eqx.tree_at(lambda q: (q.cw, q.ccw), p, (side(p.cw), side(p.ccw)))


def stack_shapes(profiles: list[FreeformProfile]) -> FreeShape:
    """The profiles' shapes along a leading axis (one per sprocket; the same K). A leaf
    uniform in every profile stays uniform; otherwise each profile's leaf becomes one
    value per gap, padded to the largest tooth count by repeating its last gap (a pad gap
    is never read: gap indices stay below each sprocket's own z)."""
    shapes = [p.shape() for p in profiles]
    zmax = max(p.teeth for p in profiles)

    def field(get, tail):
        xs = [jnp.asarray(get(s)) for s in shapes]
        if all(x.ndim == len(tail) for x in xs):
            return stack(xs)
        out = []
        for x, p in zip(xs, profiles, strict=True):
            x = jnp.broadcast_to(x, (p.teeth,) + tail)
            out.append(jnp.concatenate([x, jnp.repeat(x[-1:], zmax - x.shape[0], 0)]))
        return jnp.stack(out)

    k = shapes[0].ccw.arcs

    def flank(side):
        return Flank(
            field(lambda s: getattr(s, side).seat_angle, ()),
            field(lambda s: getattr(s, side).curvature, (k,)),
            field(lambda s: getattr(s, side).breaks, (k - 1,)),
        )

    return FreeShape(
        *(field(lambda s, n=n: getattr(s, n), ()) for n in ("teeth", "pitch", "roller_diameter")),
        *(field(lambda s, n=n: getattr(s, n), ()) for n in _GAP_LEAVES),
        field(lambda s: s.tip_diameter, ()),
        flank("cw"),
        flank("ccw"),
    )


@eqx.filter_jit  # one compile instead of hundreds of eager ops
def _table(p: FreeformProfile):
    return gap_table(p.contact_shape())[0]
