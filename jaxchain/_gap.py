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

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._numerics import cross2
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


def _profile(profile, caller: str):
    """``profile`` if it is one tooth profile (scalar shape leaves)."""
    if not isinstance(profile, (ToothProfile, GapShape)):
        raise TypeError(
            f"{caller}: profile must be a jc.ToothProfile, got {type(profile).__name__} {profile!r}"
        )
    names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter", "pitch")
    shaped = {n: np.shape(getattr(profile, n)) for n in names if np.shape(getattr(profile, n))}
    if shaped:
        raise ValueError(
            f"{caller}: the profile's shape parameters must be scalars, got shapes {shaped}; "
            "for a batch of profiles use jax.vmap over the profile"
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


def nearest_gap(profile: ToothProfile | GapShape, point: Float[Array, 2]) -> Array:
    """Index k (integer array, in [0, z)) of the tooth gap nearest to ``point`` (sprocket
    frame); 0 for a non-finite point (an index has no NaN: the distance it feeds is NaN)."""
    point = _point(point, "nearest_gap")
    z = _profile(profile, "nearest_gap").teeth
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
    profile: ToothProfile | GapShape, point: Float[Array, 2]
) -> tuple[Float[Array, ""], Float[Array, 2]]:
    """Signed distance [m] from ``point`` (sprocket frame) to the tooth material, positive in
    the gap, and its gradient (unit normal, sprocket frame); NaN (both) for a NaN point."""
    point = _point(point, "signed_distance")
    z = _profile(profile, "signed_distance").teeth
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
    profile: ToothProfile | GapShape, point: Float[Array, 2] | ArrayLike
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
