"""Sprocket tooth profiles (ISO 606 and beyond) and their derived geometry.

Frame conventions (sprocket frame, SI units): the origin is on the sprocket axis and tooth
gap ``k`` is centred on the ray at angle 2πk/z from +x. Gap 0's seat centre (the pitch
point) is ``c = (R, 0)`` with R = d/2 the pitch radius.

Outline of one gap, upper half (the lower half is its mirror image in the x axis):

* **seat** — arc of radius ri about ``c``, from the gap bottom ``B = c − (ri, 0)`` to the
  junction ``J = c + ri·u`` with ``u = (−cos α/2, sin α/2)``. Concave: the roller lies
  inside it (internal contact).
* **flank** — arc of radius re about ``F = c + (ri + re)·u`` from ``J`` (where it is tangent
  to the seat: the outline is C¹, its curvature jumps) out to the tip circle at ``K``.
  Convex: external contact.
* **tip** — arc of the tip circle (radius da/2 about the axis) from ``K`` to the tooth's
  centre line at angle π/z.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._chain import ChainSpec, as_chain
from .._numerics import is_concrete, safe_norm, safe_sqrt, stack
from .base import AbstractProfile, AbstractShape, check_teeth
from .freeform import FreeformProfile
from .iso_shape import iso_nearest_gap, iso_signed_distance

__all__ = [
    "ToothProfile",
    "GapShape",
    "ProfileGeometry",
    "iso606_limits",
    "iso_geometry",
    "flank_meeting_diameter",
]


def _cbrt_mm(x_m):
    """∛(x in mm), returned in mm·(...)-consistent metres: 1e-3·∛(1e3·x)."""
    return 1e-3 * (1e3 * x_m) ** (1.0 / 3.0)


def iso606_limits(chain: ChainSpec, teeth: int) -> dict[str, tuple[float, float]]:
    """ISO 606 limits of the tooth-gap parameters for ``chain`` and ``teeth``.

    Returns ``{name: (lower, upper)}`` for ``seating_radius`` [m], ``seating_angle``
    [rad], ``flank_radius`` [m] and ``tip_diameter`` [m]:

    * ri: 0.505·d1 … 0.505·d1 + 0.069·∛d1 (d1 in mm in the standard's formula)
    * α: 120° − 90°/z … 140° − 90°/z
    * re: 0.12·d1·(z + 2) … 0.008·d1·(z² + 180)
    * da: d + p(1 − 1.6/z) − d1 … d + 1.25p − d1

    The *minimum tooth-gap form* is (ri min, α max, re max, da max); the *maximum* form
    is (ri max, α min, re min, da min).
    """
    check_teeth(teeth)
    chain = as_chain(chain)
    z = teeth
    p = float(chain.pitch)
    d1 = float(chain.roller_diameter)
    d = p / math.sin(math.pi / z)
    return {
        "seating_radius": (0.505 * d1, 0.505 * d1 + 0.069 * _cbrt_mm(d1)),
        "seating_angle": (math.radians(120 - 90 / z), math.radians(140 - 90 / z)),
        "flank_radius": (0.12 * d1 * (z + 2), 0.008 * d1 * (z**2 + 180)),
        "tip_diameter": (d + p * (1 - 1.6 / z) - d1, d + 1.25 * p - d1),
    }


class ProfileGeometry(NamedTuple):
    """Derived points of gap 0's upper half, sprocket frame [m] (see module docstring)."""

    seat_centre: Float[Array, 2]  # c
    junction: Float[Array, 2]  # J, seat/flank
    flank_centre: Float[Array, 2]  # F
    tip_corner: Float[Array, 2]  # K, flank/tip
    tip_radius: Float[Array, ""]  # da / 2, or the flanks' meeting radius if smaller
    half_angle: Float[Array, ""]  # π / z


class ToothProfile(AbstractProfile):
    """A sprocket's tooth-gap profile: seat arc, two flank arcs, tip circle.

    All geometric fields are array leaves (differentiable); ``teeth`` is static.

    Attributes:
        teeth: number of teeth z (static).
        pitch: chain pitch p [m].
        roller_diameter: d1 of the roller that engages it [m].
        seating_radius: ri [m], > d1/2.
        seating_angle: α [rad], the angle the seat arc spans.
        flank_radius: re [m].
        tip_diameter: da [m].
    """

    teeth: int = eqx.field(static=True)
    pitch: Float[Array, ""]
    roller_diameter: Float[Array, ""]
    seating_radius: Float[Array, ""]
    seating_angle: Float[Array, ""]
    flank_radius: Float[Array, ""]
    tip_diameter: Float[Array, ""]

    def __init__(
        self,
        *,
        teeth: int,
        pitch: ArrayLike,
        roller_diameter: ArrayLike,
        seating_radius: ArrayLike,
        seating_angle: ArrayLike,
        flank_radius: ArrayLike,
        tip_diameter: ArrayLike,
    ):
        check_teeth(teeth)
        self.teeth = int(teeth)
        self.pitch = jnp.asarray(pitch, dtype=float)
        self.roller_diameter = jnp.asarray(roller_diameter, dtype=float)
        self.seating_radius = jnp.asarray(seating_radius, dtype=float)
        self.seating_angle = jnp.asarray(seating_angle, dtype=float)
        self.flank_radius = jnp.asarray(flank_radius, dtype=float)
        self.tip_diameter = jnp.asarray(tip_diameter, dtype=float)

    def __check_init__(self):
        leaves = {
            n: getattr(self, n)
            for n in ("pitch", "roller_diameter", "seating_radius", "seating_angle",
                      "flank_radius", "tip_diameter")
        }  # fmt: skip
        if not is_concrete(self):
            return  # traced: nothing to inspect
        if any(jnp.ndim(x) != 0 for x in leaves.values()):
            # a batch of profiles (built by vmap, or given as arrays): each must be finite
            bad = [n for n, x in leaves.items() if not np.all(np.isfinite(np.asarray(x)))]
            if bad:
                raise ValueError(f"ToothProfile: {bad} must be finite, got NaN or inf")
            return
        _validate(self)

    # ------------------------------------------------------------------ factory
    @classmethod
    def iso606(
        cls, chain: ChainSpec, teeth: int, form: Literal["min", "max", "mid"] = "min"
    ) -> ToothProfile:
        """The ISO 606 tooth-gap form for ``chain`` and ``teeth``.

        ``"min"``: minimum tooth-gap form (ri min, α max, re max, da max);
        ``"max"``: maximum tooth-gap form (ri max, α min, re min, da min);
        ``"mid"``: every parameter at the middle of its range.

        Where the standard's tip diameter lies beyond the circle on which the two flanks
        of a tooth meet (a pointed tooth: the maximum form at large z with small d1/p,
        e.g. 06B with z = 120), the tip diameter is lowered to that circle.
        """
        chain = as_chain(chain)
        lim = iso606_limits(chain, teeth)
        pick = {"min": (0, 1, 1, 1), "max": (1, 0, 0, 0)}
        names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")
        if form == "mid":
            vals = [0.5 * (lim[n][0] + lim[n][1]) for n in names]
        elif form in pick:
            vals = [lim[n][i] for n, i in zip(names, pick[form], strict=True)]
        else:
            raise ValueError(f"form must be 'min', 'max' or 'mid', got {form!r}")
        kw = dict(teeth=teeth, pitch=chain.pitch, roller_diameter=chain.roller_diameter)
        kw.update(zip(names, vals, strict=True))
        # At the maximum form's corner of the standard (large z, small d1/p, e.g. 06B with
        # z = 120) the flanks meet before the tip circle: lower the tip to where they meet.
        kw["tip_diameter"] = min(kw["tip_diameter"], flank_meeting_diameter(**kw) * (1 - 1e-9))
        return cls(**kw)

    # ------------------------------------------------------------------ derived
    def geometry(self) -> ProfileGeometry:
        """Derived points of gap 0 (upper half), differentiable in the profile's leaves."""
        return iso_geometry(
            self.teeth, self.pitch, self.seating_radius, self.seating_angle,
            self.flank_radius, self.tip_diameter,
        )  # fmt: skip

    def contact_shape(self) -> GapShape:
        """What the contact reads (a :class:`GapShape`); its shape parameters must be
        scalars (for a batch of profiles use ``jax.vmap`` over the profile; per-gap
        values: :class:`~jaxchain.FreeformProfile`)."""
        names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter", "pitch")
        shaped = {n: np.shape(getattr(self, n)) for n in names if np.shape(getattr(self, n))}
        if shaped:
            raise ValueError(
                f"the profile's shape parameters must be scalars, got shapes {shaped}; for "
                "a batch of profiles use jax.vmap over the profile (per-gap values: "
                "jc.FreeformProfile)"
            )
        return GapShape.stack([self], squeeze=True)

    def freeform(self, arcs: int | None = None) -> FreeformProfile:
        """The same outline as a free-form profile: both flanks one arc of curvature 1/re
        split into ``arcs`` arcs (default 1), seat angle α/2 on each side."""
        return FreeformProfile.from_iso(self, 1 if arcs is None else arcs)

    # ------------------------------------------------------------------ outline
    def outline(self, n: int = 60, gap: int = 0) -> np.ndarray:
        """Points (N, 2) [m] of the tooth outline over one pitch centred on gap ``gap``:
        from the tooth centre line at −π/z, down the lower flank, round the seat, up the
        upper flank, along the tip to +π/z. For plotting (NumPy, not traced)."""
        g = _np_geometry(self)
        c, j, f, k, ra, hz = g
        ri = float(self.seating_radius)
        re = float(self.flank_radius)
        # upper half from the gap bottom outwards
        a_bottom = math.pi
        a_j = math.atan2(j[1] - c[1], j[0] - c[0])
        seat = c + ri * np.stack(
            [np.cos(np.linspace(a_bottom, a_j, n)), np.sin(np.linspace(a_bottom, a_j, n))], -1
        )
        fa0 = math.atan2(j[1] - f[1], j[0] - f[0])
        fa1 = math.atan2(k[1] - f[1], k[0] - f[0])
        fa = np.linspace(fa0, fa1, n)
        flank = f + re * np.stack([np.cos(fa), np.sin(fa)], -1)
        ta = np.linspace(math.atan2(k[1], k[0]), hz, max(n // 3, 2))
        tip = ra * np.stack([np.cos(ta), np.sin(ta)], -1)
        upper = np.concatenate([seat, flank[1:], tip[1:]])
        lower = upper[::-1] * np.array([1.0, -1.0])
        pts = np.concatenate([lower[:-1], upper])
        ang = 2 * math.pi * gap / self.teeth
        rot = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
        return pts @ rot.T

    def sprocket_outline(self, n: int = 30) -> np.ndarray:
        """Closed outline (N, 2) [m] of the whole sprocket (all z gaps)."""
        pts = [self.outline(n, gap)[:-1] for gap in range(self.teeth)]
        out = np.concatenate(pts)
        return np.concatenate([out, out[:1]])


def _np_geometry(profile: ToothProfile):
    g = profile.geometry()
    return tuple(np.asarray(x, dtype=float) for x in g)


@jax.jit  # one program for every tooth count and size (called eagerly by the builders)
def iso_geometry(z, pitch, ri, alpha, re, da) -> ProfileGeometry:
    """Derived points of gap 0's upper half from the profile parameters (see module doc)."""
    ra = da / 2
    half = alpha / 2
    c = jnp.stack([pitch / (2 * jnp.sin(jnp.pi / z)), jnp.zeros_like(ri)])
    u = jnp.stack([-jnp.cos(half), jnp.sin(half)])
    j = c + ri * u
    f = c + (ri + re) * u
    # A tip circle beyond the point where the flank crosses the tooth centre line
    # (angle π/z) is never reached: the tooth is pointed there. Clamp it, so that any
    # parameter set (an optimizer's, under jit, unvalidated) gives a closed outline.
    hz = jnp.pi / z
    m = jnp.stack([jnp.cos(hz), jnp.sin(hz)])
    b = m @ f
    ra = jnp.minimum(ra, b + safe_sqrt(b**2 - f @ f + re**2))
    # K: intersection of the flank circle (F, re) with the tip circle (0, ra) on the
    # clockwise side of OF (the side of the gap).
    lf = safe_norm(f)
    a = (ra**2 - re**2 + lf**2) / (2 * lf)
    h = safe_sqrt(ra**2 - a**2)
    fh = f / lf
    fperp = jnp.stack([-fh[1], fh[0]])
    k = a * fh - h * fperp
    return ProfileGeometry(c, j, f, k, ra, jnp.asarray(hz))


def _np_geometry_of(**kw) -> tuple:
    """Derived points (NumPy) of an unvalidated parameter set."""
    names = ("pitch", "seating_radius", "seating_angle", "flank_radius", "tip_diameter")
    g = iso_geometry(kw["teeth"], *(jnp.asarray(kw[n], dtype=float) for n in names))
    return tuple(np.asarray(x, dtype=float) for x in g)


def flank_meeting_diameter(**kw) -> float:
    """The diameter [m] where the two flanks of a tooth meet (on its centre line) for the
    profile fields ``kw`` (unvalidated): a tip circle beyond it is never reached."""
    return 2 * _flank_centre_line_radius(_np_geometry_of(**kw), kw["flank_radius"])


def _flank_centre_line_radius(geo, re) -> float:
    """Radius where the flank circle crosses the tooth centre line (angle π/z)."""
    _, j, f, _, _, hz = geo
    m = np.array([math.cos(hz), math.sin(hz)])
    b = float(m @ f)
    disc = b**2 - (float(f @ f) - float(re) ** 2)
    return b + math.sqrt(disc) if disc > 0 else float(np.hypot(*j))


def _validate(p: ToothProfile) -> None:
    """Range and closure checks of a concrete profile; raises ValueError with the fix."""
    z = p.teeth
    pitch = float(p.pitch)
    d1 = float(p.roller_diameter)
    ri = float(p.seating_radius)
    alpha = float(p.seating_angle)
    re = float(p.flank_radius)
    da = float(p.tip_diameter)
    if not pitch > 0:
        raise ValueError(f"pitch must be > 0 m, got {pitch}")
    if not 0 < d1 < pitch:
        raise ValueError(f"roller_diameter must be in (0, pitch = {pitch:.6g}) m, got {d1}")
    if not d1 / 2 < ri < pitch / 2:
        raise ValueError(
            f"seating_radius must be in (roller radius {d1 / 2:.6g}, pitch/2 = "
            f"{pitch / 2:.6g}) m, got {ri:.6g}: the roller must fit inside the seat"
        )
    lo, hi = math.radians(90.0), math.radians(170.0)
    if not lo <= alpha <= hi:
        raise ValueError(
            f"seating_angle must be in [90°, 170°] ([{lo:.4f}, {hi:.4f}] rad), got "
            f"{alpha:.6g} rad ({math.degrees(alpha):.2f}°); it is in radians"
        )
    re_lo = 0.5 * 0.12 * d1 * (z + 2)
    re_hi = 5.0 * 0.008 * d1 * (z**2 + 180)
    if not re_lo <= re <= re_hi:
        raise ValueError(
            f"flank_radius must be in [{re_lo:.6g}, {re_hi:.6g}] m (half the ISO 606 minimum "
            f"to 5× the ISO 606 maximum for z={z}, d1={d1:.6g}), got {re:.6g}"
        )
    geo = _np_geometry(p)
    c, j, f, _, _, hz = geo
    r_j = float(np.hypot(*j))
    # Largest tip radius: where the flank circle crosses the tooth centre line (angle π/z).
    r_centre = _flank_centre_line_radius(geo, re)
    if not r_j < da / 2 < r_centre:
        raise ValueError(
            f"tip_diameter must be in ({2 * r_j:.6g}, {2 * r_centre:.6g}) m for this profile "
            f"(above the seat/flank junction, and the flank must meet the tip circle before "
            f"the tooth's centre line), got {da:.6g}"
        )
    k = geo[3]
    theta_j = math.atan2(j[1], j[0])
    theta_k = math.atan2(k[1], k[0])
    a, b = j - f, k - f
    sweep = math.atan2(float(a[0] * b[1] - a[1] * b[0]), float(a @ b))
    if not (0 < theta_j < theta_k < hz and 0 < sweep < math.pi / 2):
        raise ValueError(
            "tooth outline does not close: the flank from the seat junction must rise to the "
            f"tip circle before the tooth centre line (θJ={theta_j:.4f}, θK={theta_k:.4f}, "
            f"π/z={hz:.4f} rad, flank sweep {sweep:.4f} rad); use a larger flank_radius or "
            "smaller tip_diameter"
        )
    # the seat must stay a graph in polar angle (see gap_contact's sign test)
    if not math.cos(math.pi - alpha / 2) < -ri / float(c[0]):
        raise ValueError(
            f"seating_angle {alpha:.4f} rad is too large for seating_radius {ri:.6g} m on this "
            "pitch circle: the seat arc would curl back over itself"
        )


class GapShape(AbstractShape):
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
    def stack(cls, profiles: Sequence[ToothProfile], squeeze: bool = False) -> GapShape:
        """The profiles' shapes along a leading axis (one per profile; ``squeeze``: one
        profile's, without the axis)."""

        def field(name):
            dtype = jnp.result_type(profiles[0].pitch)
            xs = [getattr(p, name) for p in profiles]
            return jnp.asarray(xs[0], dtype) if squeeze else stack(xs, dtype)

        return cls(*(field(f.name) for f in dataclasses.fields(cls)))

    @property
    def roller_radius(self) -> Array:
        return self.roller_diameter / 2

    def signed_distance(self, point):
        return iso_signed_distance(self, point)

    def nearest_gap(self, point):
        return iso_nearest_gap(self, point)

    def geometry(self) -> ProfileGeometry:
        return iso_geometry(
            self.teeth, self.pitch, self.seating_radius, self.seating_angle,
            self.flank_radius, self.tip_diameter,
        )  # fmt: skip
