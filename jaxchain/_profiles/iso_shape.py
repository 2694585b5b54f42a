"""The signed distance to an ISO-type tooth gap, read in the tooth-fixed frame.

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

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._numerics import cross2
from .base import gap_rotation

__all__ = ["iso_signed_distance", "iso_nearest_gap"]


def iso_nearest_gap(profile, point: Float[Array, 2]) -> Array:
    """Index k (integer array, in [0, z)) of the gap nearest to ``point``: k = round(θz/2π)
    (0 for a non-finite point: an index has no NaN; the distance it feeds is NaN)."""
    z = profile.teeth
    theta = jnp.arctan2(point[1], point[0])
    k = jnp.round(jax.lax.stop_gradient(theta) * z / (2 * jnp.pi))
    return jnp.mod(k, z).astype(jnp.int32)


def iso_signed_distance(profile, point: Float[Array, 2]) -> tuple[Array, Array]:
    """Signed distance [m] from ``point`` (sprocket frame) to the tooth material of an
    ISO-type gap shape (a :class:`~.iso.GapShape`), positive in the gap, and its gradient
    (unit normal, sprocket frame); NaN (both) for a NaN point."""
    z = profile.teeth
    k = iso_nearest_gap(profile, point)
    rot = gap_rotation(k, z, point.dtype)
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
