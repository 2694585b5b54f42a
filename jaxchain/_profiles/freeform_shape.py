"""What the contact reads of a free-form profile: its flanks' parameters, every gap's
outline features (arcs and corners) and the exact signed distance to them.

Frame conventions and the outline of a gap: :mod:`.freeform`.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._numerics import cross2, safe_norm, safe_sqrt
from .base import AbstractShape, gap_rotation

__all__ = [
    "Flank",
    "FreeShape",
    "HalfGap",
    "half_gap",
    "split_between",
    "GapTable",
    "gap_table",
    "with_table",
    "free_signed_distance",
]


class Flank(eqx.Module):
    """One side of a tooth gap: the seat's part on that side and the flank above it.

    Attributes:
        seat_angle: angle [rad] the seat arc spans on this side of the gap axis (an ISO
            606 gap has α/2 on each side); scalar or (z,).
        curvature: curvatures [1/m] of the flank's K arcs from the seat outwards, > 0
            (convex teeth); shape (K,) or (z, K).
        breaks: where arcs 1 … K−1 end, as fractions of the flank's radial rise from the
            seat junction to the tip circle, increasing in (0, 1); shape (K−1,) or
            (z, K−1) (empty for K = 1).
    """

    seat_angle: Float[Array, "*z"]
    curvature: Float[Array, "*z K"]
    breaks: Float[Array, "*z Km1"]

    def __init__(self, seat_angle: ArrayLike, curvature: ArrayLike, breaks: ArrayLike = ()):
        self.seat_angle = jnp.asarray(seat_angle, dtype=float)
        self.curvature = jnp.atleast_1d(jnp.asarray(curvature, dtype=float))
        b = jnp.asarray(breaks, dtype=float)
        self.breaks = b.reshape(self.curvature.shape[:-1] + (0,)) if b.size == 0 else b

    @property
    def arcs(self) -> int:
        """K, the number of arcs."""
        return self.curvature.shape[-1]


class FreeShape(AbstractShape):
    """What the contact reads of a :class:`FreeformProfile`, with the tooth count an array
    leaf: the shapes of sprockets with different tooth counts stack into one pytree
    (per-gap leaves padded to the largest z) and are evaluated by one vmapped contact."""

    teeth: Float[Array, ""]
    pitch: Float[Array, ""]
    roller_diameter: Float[Array, ""]
    seating_radius: Float[Array, "*z"]
    seat_offset: Float[Array, "*z"]
    phase: Float[Array, "*z"]
    tip_diameter: Float[Array, ""]
    cw: Flank
    ccw: Flank
    table: Any = None  # its GapTable, where computed ahead (with_table)

    @property
    def roller_radius(self) -> Array:
        return self.roller_diameter / 2

    def signed_distance(self, point):
        return free_signed_distance(self, point)[:2]

    def nearest_gap(self, point):
        """The gap whose half pitch holds the point's polar angle."""
        return free_signed_distance(self, point)[2]

    def prepared(self) -> FreeShape:
        return with_table(self)


# --------------------------------------------------------------------------- geometry
class HalfGap(NamedTuple):
    """One side of one gap in its canonical frame (gap axis +x, the side at y ≥ 0; the
    clockwise side is mirrored into it). K arcs per flank."""

    seat_centre: Float[Array, 2]
    seating_radius: Float[Array, ""]
    centres: Float[Array, "K 2"]  # flank arcs' centres
    radii: Float[Array, " K"]
    vertices: Float[Array, "Kp1 2"]  # J, break points, tip corner
    tip_radius: Float[Array, ""]
    split: Float[Array, 2]  # where the tip circle meets the tooth centre line


def half_gap(cx, ri, seat_angle, curvature, breaks, ra) -> HalfGap:
    """Geometry of one side of a gap from its parameters (module docstring); K (the
    length of ``curvature``) is static, so the arcs unroll into K short blocks. The tip
    part ends at the tip corner (``split``): the caller extends it to where the next
    gap's outline takes over (:func:`split_between`)."""
    c = jnp.stack([cx, jnp.zeros_like(cx)])
    n = jnp.stack([-jnp.cos(seat_angle), jnp.sin(seat_angle)])  # from c through J
    p = c + ri * n
    r_j = safe_norm(p)
    k = curvature.shape[-1]
    targets = jnp.concatenate([r_j + breaks * (ra - r_j), ra[None]])
    centres, radii, verts = [], [], [p]
    for i in range(k):
        r = 1.0 / curvature[i]
        centre = p + r * n  # n: unit normal toward the arc's centre (the material side)
        lc = safe_norm(centre)
        ch = centre / lc
        a = (targets[i] ** 2 - r**2 + lc**2) / (2 * lc)
        h = safe_sqrt(targets[i] ** 2 - a**2)
        # the crossing of radius targets[i] on the arc's rising side (clockwise of O→C)
        p = a * ch - h * jnp.stack([-ch[1], ch[0]])
        n = (centre - p) / r
        centres.append(centre)
        radii.append(r)
        verts.append(p)
    return HalfGap(c, ri, jnp.stack(centres), jnp.stack(radii), jnp.stack(verts), ra, p)


def split_between(corner_a, corner_b, ra):
    """Where a tooth's tip is split between its two gaps: the tip circle's point midway
    (in angle) between the two tip corners (same frame, both on the tip circle)."""
    mid = corner_a + corner_b
    return ra * mid / safe_norm(mid)[..., None]


# relative slack of the arcs' end-ray tests: neighbouring arcs' interiors overlap by
# ~1e-12 rad, so a point on the normal line through a junction (tangent arcs: centres,
# junction and point collinear) is inside one of them whatever the rounding; the
# distance there to the circle beyond its arc differs from the true one by ~r·1e-24
_RAY_SLACK = 1e-12


class GapTable(NamedTuple):
    """Every gap's outline features in the sprocket frame, leading axis z (gap), then F =
    2K + 4 features in the order [cw arcs (K), cw tip corner, seat, ccw arcs (K), ccw tip
    corner, tip of the tooth after the gap]. An arc is bounded by its two end rays from
    its centre (counter-clockwise from ``start`` to ``end``); a corner is a point
    (radius 0, no rays). ``kind`` is +1 where the material lies inside the circle (flank
    arcs, tip; a corner), −1 for the seat: the signed distance to a feature is
    kind·(|x − centre| − radius)."""

    centre: Float[Array, "z F 2"]
    radius: Float[Array, "z F"]
    start: Float[Array, "z F 2"]
    end: Float[Array, "z F 2"]


def _kinds(k: int) -> tuple[np.ndarray, np.ndarray]:
    """(kind, is_corner) of the F = 2K + 4 features of a table row (static)."""
    kind = np.ones(2 * k + 4)
    kind[k + 1] = -1.0  # the seat
    corner = np.zeros(2 * k + 4, bool)
    corner[[k, 2 * k + 2]] = True
    return kind, corner


def _gaps_given(shape: FreeShape) -> int | None:
    """The number of gaps the shape's per-gap leaves give values for (None: uniform)."""
    # leaves with one value per gap (a flank's curvature and breaks: a leading gap axis)
    leaves = [shape.seating_radius, shape.seat_offset, shape.phase]
    leaves += [f.seat_angle for f in (shape.cw, shape.ccw)]
    gapped = [x for x in leaves if jnp.ndim(x)]
    gapped += [x for f in (shape.cw, shape.ccw) for x in (f.curvature, f.breaks) if x.ndim == 2]
    return jnp.shape(gapped[0])[0] if gapped else None


def with_table(shape: FreeShape) -> FreeShape:
    """``shape`` carrying its :func:`gap_table`: a solve computes it once, before its loop,
    instead of in every evaluation of the contact (and, in a gradient, pulls its
    cotangent back through the table once instead of at every stage of every step)."""
    return eqx.tree_at(lambda s: s.table, shape, gap_table(shape)[0], is_leaf=lambda x: x is None)


def gap_table(shape: FreeShape) -> tuple[GapTable, bool]:
    """The features of every gap, computed once per solve (:func:`with_table`) or per
    evaluation of the contact (every point then reads its two gaps' rows), and whether the
    shape has per-gap leaves.
    Per-gap: one row per gap, sprocket frame. Uniform: gaps 0 and 1 in gap 0's frame
    (every pair of neighbours is that pair rotated), and gap 2 for gap 1's tip."""
    z = shape.teeth
    n = _gaps_given(shape)
    per_gap = n is not None  # any leaf with one value per gap: geometry for each gap
    radius = shape.pitch / (2 * jnp.sin(jnp.pi / z))
    ra = shape.tip_diameter / 2

    def side(f: Flank):
        args = (radius + shape.seat_offset, shape.seating_radius, f.seat_angle)
        args = (*args, f.curvature, f.breaks)
        axes = tuple(0 if jnp.ndim(a) else None for a in args[:3])
        axes = (*axes, 0 if f.curvature.ndim == 2 else None, 0 if f.breaks.ndim == 2 else None)
        if all(a is None for a in axes):  # this side's geometry is the same in every gap
            return jax.tree_util.tree_map(lambda x: x[None], half_gap(*args, ra))
        return jax.vmap(half_gap, (*axes, None))(*args, ra)

    ccw, cw = side(shape.ccw), side(shape.cw)
    m = jnp.array([1.0, -1.0], ra.dtype)
    kk = ccw.radii.shape[-1]
    n_rows = max(ccw.radii.shape[0], cw.radii.shape[0])
    ccw, cw = (
        jax.tree_util.tree_map(lambda x: jnp.broadcast_to(x, (n_rows,) + x.shape[1:]), h)
        for h in (ccw, cw)
    )
    # local frame (gap axis +x), rows: 1 (uniform) or one per gap
    cw_c, cw_v = cw.centres * m, cw.vertices * m
    zero = jnp.zeros((n_rows, 1, 2), ra.dtype)
    seat_c = ccw.seat_centre[:, None]
    centre = jnp.concatenate(
        [cw_c, cw_v[:, -1:], seat_c, ccw.centres, ccw.vertices[:, -1:], zero], 1
    )
    radius_f = jnp.concatenate(
        [cw.radii, jnp.zeros((n_rows, 1)), ccw.seating_radius[:, None], ccw.radii,
         jnp.zeros((n_rows, 1)), jnp.broadcast_to(ra, (n_rows, 1))], 1
    )  # fmt: skip
    start = jnp.concatenate(
        [cw_v[:, 1:] - cw_c, zero, ccw.vertices[:, :1] - seat_c, ccw.vertices[:, :-1] - ccw.centres,
         zero, zero], 1
    )  # fmt: skip
    end = jnp.concatenate(
        [cw_v[:, :-1] - cw_c, zero, cw_v[:, :1] - seat_c, ccw.vertices[:, 1:] - ccw.centres,
         zero, zero], 1
    )  # fmt: skip
    if per_gap:  # to the sprocket frame: gap g's axis at 2πg/z + phase[g]
        g = jnp.arange(n)
        theta = 2 * jnp.pi * g / z + shape.phase
    else:  # rows: gaps 0, 1 (and 2, for gap 1's tip), in gap 0's frame
        g = jnp.arange(3)
        theta = 2 * jnp.pi * g / z
    c, s = jnp.cos(theta), jnp.sin(theta)
    rot = jnp.stack([jnp.stack([c, -s], -1), jnp.stack([s, c], -1)], -2)
    n_out = g.shape[0]

    def rotate(x):
        return jnp.einsum("gij,gfj->gfi", rot, jnp.broadcast_to(x, (n_out,) + x.shape[1:]))

    centre, start, end = rotate(centre), rotate(start), rotate(end)
    radius_f = jnp.broadcast_to(radius_f, (n_out, radius_f.shape[1]))
    # the tooth after gap g: tip circle from gap g's ccw corner to gap g+1's cw corner
    nxt = jnp.mod(g + 1, z.astype(g.dtype)) if per_gap else jnp.array([1, 2, 2])
    start = start.at[:, -1].set(centre[:, 2 * kk + 2])
    end = end.at[:, -1].set(centre[nxt, kk])
    return GapTable(centre, radius_f, start, end), per_gap


def free_signed_distance(shape: FreeShape, point: Array) -> tuple[Array, Array, Array]:
    """Signed distance, normal (sprocket frame) and the gap index owning ``point``, for a
    free-form shape.

    The point lies between the nominal axes of gaps k0 and k1 = k0 + 1: on the tooth
    between them or in one of their gaps. Read: both gaps' seats, the tooth's two flanks
    and tip, and both sides of the gap on the point's side of the tooth's nominal centre
    line (the sides of an asymmetric gap differ). The nearest point of a chain of tangent
    arcs is the projection onto one arc's interior or a corner (at a junction the point
    would project onto it from both arcs), so the features are the arcs and the tip
    corners: exact Euclidean distance, signed by the nearest feature's material side."""
    if shape.table is None:
        table, per_gap = gap_table(shape)
    else:
        table, per_gap = shape.table, _gaps_given(shape) is not None
    k = (table.radius.shape[1] - 4) // 2
    kind, corner = _kinds(k)
    z = shape.teeth
    theta = jax.lax.stop_gradient(jnp.arctan2(point[1], point[0]))
    turns = theta * z / (2 * jnp.pi)
    kf = jnp.floor(turns)
    before = (turns - kf) < 0.5  # on gap k0's side of the tooth's nominal centre line
    kf = jnp.where(jnp.isfinite(kf), kf, 0.0)
    k0 = jnp.mod(kf, z).astype(jnp.int32)
    k1 = jnp.mod(k0 + 1, z.astype(jnp.int32))
    if per_gap:
        r0, r1, x = k0, k1, point
    else:  # the point in gap k0's frame (its axis at 2πk0/z + phase), rotated as the
        # ISO evaluation rotates it (a zero phase is an exact identity: same rounding)
        c, s = jnp.cos(shape.phase), jnp.sin(shape.phase)
        rot = gap_rotation(k0, z, point.dtype) @ jnp.array([[c, -s], [s, c]])
        r0, r1, x = 0, 1, rot.T @ point
    full = jnp.where(before, r0, r1)
    part = jnp.where(before, r1, r0)
    rows = jax.tree_util.tree_map(lambda a: a[jnp.stack([full, part])], table)

    def features(x):
        a, b = x[0], x[1]
        return jnp.concatenate([a, jnp.where(before, b[: k + 4], b[k:])])

    cen, rad, st, en = (features(x) for x in rows)
    kind_f = jnp.asarray(np.concatenate([kind, kind[: k + 4]]))
    kind_f = jnp.where(before, kind_f, jnp.asarray(np.concatenate([kind, kind[k:]])))
    corner_f = np.concatenate([corner, corner[: k + 4]])
    corner_f = jnp.where(before, corner_f, np.concatenate([corner, corner[k:]]))
    rel = x - cen
    sq = jnp.sum(rel * rel, -1)
    pos = sq > 0
    inv = jnp.where(pos, jax.lax.rsqrt(jnp.where(pos, sq, 1.0)), 0.0)
    dist = sq * inv
    # at a centre or on a corner: the direction from the centre to the arc's start
    fallback = (
        jnp.where(corner_f[:, None], cen, st)
        / jnp.where(corner_f, safe_norm(cen), jnp.where(rad > 0, rad, 1.0))[:, None]
    )
    unit = jnp.where(pos[:, None], rel * inv[:, None], fallback)
    rel_s, st_s, en_s, d_s, r_s = jax.lax.stop_gradient((rel, st, en, dist, rad))
    slack = -_RAY_SLACK * r_s * d_s
    interior = corner_f | ((cross2(st_s, rel_s) >= slack) & (cross2(rel_s, en_s) >= slack))
    signed = kind_f * (dist - rad)
    masked = jnp.where(interior, jnp.abs(jax.lax.stop_gradient(signed)), jnp.inf)
    pick = jnp.arange(signed.shape[0]) == jnp.argmin(masked)
    sd = jnp.sum(jnp.where(pick, signed, 0.0))
    normal = jnp.sum(jnp.where(pick[:, None], kind_f[:, None] * unit, 0.0), 0)
    if not per_gap:
        normal = rot @ normal
    sd = jnp.where(jnp.any(jnp.isnan(point)), jnp.nan, sd)
    # the owning gap: which side of the tooth's split (midway between its tip corners)
    tip = jax.lax.stop_gradient(table.start[r0, -1] + table.end[r0, -1])
    gap = jnp.where(cross2(tip, jax.lax.stop_gradient(x)) > 0, k1, k0)
    return sd, jnp.where(jnp.isnan(sd), jnp.nan, normal), gap
