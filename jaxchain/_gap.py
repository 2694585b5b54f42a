"""Contact of a roller with its nearest tooth gap, read in the tooth-fixed frame.

The roller centre is rotated into the frame of its nearest gap (O(1): ``k = round(θz/2π)``,
no loop over teeth) and folded onto the gap's upper half (the gap is mirror-symmetric).
There the signed distance from the roller centre to the tooth *material* is the exact
Euclidean distance to the nearest of three arcs (seat, flank, tip; each clamped to its
end points, so the convex flank/tip corner is rounded exactly), signed positive in the gap
and negative inside a tooth. The sign comes from a polar-graph test: seen from the
sprocket axis, the outline over one half pitch is a graph ρ(θ), so a point is in the gap
iff its radius exceeds ρ at its angle. Then

    depth  = roller radius − signed distance   (> 0: overlap)
    normal = ∂(signed distance)/∂(point)       (unit, pushes the roller out of the tooth)

Continuity: the distance to a closed set is continuous (1-Lipschitz) everywhere, and
the fold lines (gap axis, tooth centre line at half pitch) are mirror lines of the
outline, so the switch of nearest gap and the fold change nothing. The distance is C¹
off the medial axis of the gap; that medial axis (the seat centre and the gap axis above
it) lies at distance ≥ ri > d1/2 from the tooth, i.e. never in contact unless the roller
has already sunk by more than the seat clearance ri − d1/2. Gradients are finite
everywhere (double ``where`` around every norm and square root).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._freeform import Flank, FreeformProfile, FreeShape, as_freeform, half_gap, stack_shapes
from ._numerics import cross2, safe_norm
from ._profile import MAX_TEETH, ProfileGeometry, ToothProfile, _geometry

__all__ = ["gap_contact", "signed_distance", "nearest_gap", "GapShape"]


class GapShape(eqx.Module):
    """What the contact reads of a :class:`ToothProfile`, with the tooth count an array
    leaf instead of static: the shapes of sprockets with different tooth counts stack into
    one pytree, and the contact of every sprocket is one vmapped evaluation (one copy of
    the contact in the traced program, whatever the number of sprockets)."""

    teeth: Float[Array, ""]
    pitch: Float[Array, ""]
    roller_diameter: Float[Array, ""]
    seating_radius: Float[Array, ""]
    seating_angle: Float[Array, ""]
    flank_radius: Float[Array, ""]
    tip_diameter: Float[Array, ""]

    @classmethod
    def stack(cls, profiles: Sequence[ToothProfile]) -> GapShape:
        """The profiles' shapes along a leading axis (one per profile)."""

        def field(name):
            dtype = jnp.result_type(profiles[0].pitch)
            return jnp.stack([jnp.asarray(getattr(p, name), dtype=dtype) for p in profiles])

        return cls(*(field(f.name) for f in dataclasses.fields(cls)))

    @property
    def roller_radius(self) -> Array:
        return self.roller_diameter / 2

    def geometry(self) -> ProfileGeometry:
        return _geometry(
            self.teeth, self.pitch, self.seating_radius, self.seating_angle,
            self.flank_radius, self.tip_diameter,
        )  # fmt: skip


def gap_shapes(profiles: Sequence[ToothProfile | FreeformProfile]) -> GapShape | FreeShape:
    """The sprockets' shapes stacked for one vmapped contact: ISO-type profiles as a
    :class:`GapShape` (the folded, symmetric evaluation); if any profile is free-form,
    every one as a :class:`FreeShape` with the largest K arcs per flank (an ISO flank
    split into arcs of its own curvature is the same outline)."""
    if all(isinstance(p, ToothProfile) for p in profiles):
        return GapShape.stack(profiles)
    arcs = max(p.arcs for p in profiles if isinstance(p, FreeformProfile))
    return stack_shapes([as_freeform(p, arcs) for p in profiles])


def _profile(profile, caller: str):
    """``profile`` if it is one tooth profile (an ISO-type profile with scalar shape
    leaves, or a free-form one, its per-gap leaves one value per gap); a free-form
    profile as its :class:`FreeShape`."""
    if isinstance(profile, FreeformProfile):
        return profile.shape()
    if isinstance(profile, FreeShape):
        return profile
    if not isinstance(profile, (ToothProfile, GapShape)):
        raise TypeError(
            f"{caller}: profile must be a jc.ToothProfile or jc.FreeformProfile, got "
            f"{type(profile).__name__} {profile!r}"
        )
    names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter", "pitch")
    shaped = {n: np.shape(getattr(profile, n)) for n in names if np.shape(getattr(profile, n))}
    if shaped:
        raise ValueError(
            f"{caller}: the profile's shape parameters must be scalars, got shapes {shaped}; "
            "for a batch of profiles use jax.vmap over the profile (per-gap values: "
            "jc.FreeformProfile)"
        )
    return profile


def _point(point, caller: str) -> Array:
    """``point`` as a float array of shape (2,), or ``ValueError`` saying how to batch."""
    point = jnp.asarray(point)
    if point.shape != (2,):
        batch = point.ndim > 1 and point.shape[-1] == 2
        raise ValueError(
            f"{caller}: point must be one roller centre (x, y) of shape (2,), got shape "
            f"{point.shape}"
            + (
                f"; for many points use jax.vmap: jax.vmap(lambda x: jc.{caller}(profile, "
                "x))(points)"
                if batch
                else ""
            )
        )
    return point if jnp.issubdtype(point.dtype, jnp.floating) else point.astype(float)


def nearest_gap(profile: ToothProfile | FreeformProfile, point: Float[Array, 2]) -> Array:
    """Index k (integer array, in [0, z)) of the tooth gap nearest to ``point`` (sprocket
    frame); 0 for a non-finite point (an index has no NaN: the distance it feeds is NaN).
    For a free-form profile: the gap whose half pitch holds the point's polar angle."""
    point = _point(point, "nearest_gap")
    profile = _profile(profile, "nearest_gap")
    if isinstance(profile, FreeShape):
        return _free_signed_distance(profile, point)[2]
    z = profile.teeth
    theta = jnp.arctan2(point[1], point[0])
    k = jnp.round(jax.lax.stop_gradient(theta) * z / (2 * jnp.pi))
    return jnp.mod(k, z).astype(jnp.int32)


# bits of the largest gap index (MAX_TEETH − 1)
_GAP_BITS = (MAX_TEETH - 1).bit_length()


def _gap_rotation(k, z, dtype):
    """Rotation matrix by 2πk/z, the angle of gap k (integer in [0, z)), as the product
    of the rotations by 2π·2ᵇ/z of k's set bits: no cos/sin per point (2·8 per profile).
    Per-point trig was ~20 % of the engagement's vector field. Each factor is computed
    directly (not by repeated squaring, whose angle error doubles per squaring): the
    product differs from cos/sin of 2πk/z by ≤ 1.5e-15 (every k of every tooth count
    7…250)."""
    z = jnp.asarray(z, dtype)
    c, s = jnp.ones((), dtype), jnp.zeros((), dtype)
    for b in range(_GAP_BITS):
        a = 2 * jnp.pi * jnp.mod(2.0**b, z) / z
        wc, ws = jnp.cos(a), jnp.sin(a)
        bit = ((k >> b) & 1) == 1
        c, s = jnp.where(bit, c * wc - s * ws, c), jnp.where(bit, c * ws + s * wc, s)
    return jnp.array([[c, -s], [s, c]])


def signed_distance(
    profile: ToothProfile | FreeformProfile, point: Float[Array, 2]
) -> tuple[Float[Array, ""], Float[Array, 2]]:
    """Signed distance [m] from ``point`` (sprocket frame) to the tooth material, positive in
    the gap, and its gradient (unit normal, sprocket frame); NaN (both) for a NaN point."""
    point = _point(point, "signed_distance")
    profile = _profile(profile, "signed_distance")
    if isinstance(profile, FreeShape):
        return _free_signed_distance(profile, point)[:2]
    z = profile.teeth
    k = nearest_gap(profile, point)
    rot = _gap_rotation(k, z, point.dtype)
    local = rot.T @ point  # gap-fixed frame
    flip = jnp.where(local[1] >= 0, 1.0, -1.0)
    q = jnp.stack([local[0], jnp.abs(local[1])])  # upper half

    g = profile.geometry()
    c, jn, f, kc, ra = g.seat_centre, g.junction, g.flank_centre, g.tip_corner, g.tip_radius
    ri, re = profile.seating_radius, profile.flank_radius

    # ---- sign: polar-graph test (piecewise constant, no gradient) -----------------
    s = _gap_sign(*jax.lax.stop_gradient((q, c, jn, f, kc, ra, ri, re)))

    # ---- the five distances, as one (5, 2) batch (few ops: compile and run time) ----
    # from the seat centre c, the flank centre F, the axis (tip circle), the end points
    # J and K; each unit vector falls back to a fixed direction at its own centre
    u = (jn - c) / ri
    zero = jnp.zeros_like(c)
    rel = q - jnp.stack([c, f, zero, jn, kc])
    sq = jnp.sum(rel * rel, -1)
    pos = sq > 0
    inv = jnp.where(pos, jax.lax.rsqrt(jnp.where(pos, sq, 1.0)), 0.0)
    dist = sq * inv
    x_axis = jnp.array([1.0, 0.0], dtype=q.dtype)
    fallback = jnp.stack([-x_axis, -u, x_axis, -u, zero])
    unit = jnp.where(pos[:, None], rel * inv[:, None], fallback)
    n_tip_in = unit[2]
    nj, nk = unit[3], jnp.where(pos[4], unit[4], n_tip_in)
    ej, ek = dist[3], dist[4]

    # ---- per-arc signed value (positive in the gap) and its gradient --------------
    # seat: concave arc about c (value ri − |q − c|, gradient toward c); flank: convex arc
    # about F from J (counter-clockwise) to K; tip: arc of the tip circle from K to the
    # centre line. Interior of each: the point's projection lies on the arc.
    arc_sign = jnp.array([-1.0, 1.0, 1.0], dtype=q.dtype)
    g_arc = arc_sign * dist[:3] + jnp.stack([ri, -re, -ra])
    n_arc = arc_sign[:, None] * unit[:3]
    crosses = cross2(jnp.stack([u, jn - f, f - kc, kc]), jnp.stack([rel[0], rel[1], rel[1], q]))
    side = crosses >= 0
    interior = jnp.stack([side[0], side[1] & side[2], side[3]])

    # oriented: s·|g| with the matching gradient
    same = g_arc * s >= 0
    v_arc = jnp.where(same, g_arc, -g_arc)
    n_arc = jnp.where(same[:, None], n_arc, -n_arc)
    # outside its arc, each is the distance to its nearer end point (J and K are the only
    # end points a folded point can be nearest to)
    flank_end_j = ej <= ek
    v_end = s * jnp.stack([ej, jnp.where(flank_end_j, ej, ek), ek])
    n_end = s * jnp.stack([nj, jnp.where(flank_end_j, nj, nk), nk])
    vals = jnp.where(interior, v_arc, v_end)
    norms = jnp.where(interior[:, None], n_arc, n_end)

    # the nearest of the three; a one-hot select (its transpose is a select, not a scatter)
    pick = jnp.arange(3) == jnp.argmin(jnp.abs(jax.lax.stop_gradient(vals)))
    sd = jnp.sum(jnp.where(pick, vals, 0.0))
    n_local = jnp.sum(jnp.where(pick[:, None], norms, 0.0), 0) * jnp.stack([1.0, flip])
    # NaN in, NaN out: a NaN point gets no plausible (fallback) normal
    return sd, jnp.where(jnp.isnan(sd), sd, rot @ n_local)


def _gap_sign(q, c, jn, f, kc, ra, ri, re):
    """+1 where the folded point q is in the gap (or outside the tip circle), −1 in a tooth."""
    r = jnp.sqrt(jnp.sum(q * q))
    qh = q / jnp.where(r > 0, r, 1.0)
    # outline radius at q's polar angle
    bc = qh @ c
    rho_seat = bc - jnp.sqrt(jnp.maximum(ri**2 - (c @ c - bc**2), 0.0))
    bf = qh @ f
    rho_flank = bf + jnp.sqrt(jnp.maximum(re**2 - (f @ f - bf**2), 0.0))
    in_seat_range = cross2(q, jn) >= 0
    in_tip_range = cross2(kc, q) >= 0
    rho = jnp.where(in_seat_range, rho_seat, jnp.where(in_tip_range, ra, rho_flank))
    return jnp.where(r > rho, 1.0, -1.0)


def gap_contact(
    profile: ToothProfile | FreeformProfile, point: Float[Array, 2] | ArrayLike
) -> tuple[Float[Array, ""], Float[Array, 2]]:
    """Contact of a roller centred at ``point`` with its nearest tooth gap.

    Args:
        profile: the sprocket's tooth profile.
        point: roller centre (2,) in the sprocket frame [m].

    Returns:
        ``(depth, normal)``: depth [m] = roller radius − signed distance from the centre to
        the tooth (> 0: overlap); normal (2,), unit, sprocket frame, pushing the roller out
        of the tooth (the gradient of the signed distance, so ∂depth/∂point = −normal).

    Defined, finite and continuous for any point in the plane; differentiable in
    ``point`` and in the profile's array leaves; jit- and vmap-able (vmap over points, or
    over profiles built with the same ``teeth``, or over a :class:`GapShape` stack).
    """
    profile, point = _profile(profile, "gap_contact"), _point(point, "gap_contact")
    sd, normal = signed_distance(profile, point)
    return profile.roller_radius - sd, normal


# --------------------------------------------------------------------------- free-form
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


def _free_signed_distance(shape: FreeShape, point: Array) -> tuple[Array, Array, Array]:
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
        rot = _gap_rotation(k0, z, point.dtype) @ jnp.array([[c, -s], [s, c]])
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
