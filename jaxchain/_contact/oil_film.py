"""Oil-film law of a lubricated revolute clearance joint (pin/bush, bush/roller).

The film obeys the isoviscous, incompressible Reynolds equation on the unwrapped gap,
θ periodic and z ∈ [−L/2, L/2] with ambient pressure p = 0 at both ends,

    ∂θ(h³∂θp)/R² + ∂z(h³∂zp) = 12μ·[(ω/2)·∂h/∂θ + ∂h/∂t] = −12μ·w·n(θ),

with h = c − e·n, n(θ) = (cos θ, sin θ) in the bearing frame and the effective squeeze
velocity w = ė − (ω/2)·ẑ×e: the spin acts on the film exactly as a squeeze at w, so one
function of (e, w) gives every force (Booker's mobility argument), linear in w in full film.

Why a finite-length approximation: the pin/bush has L/D ≈ 2.5 and the bush/roller
L/D ≈ 1.3, where neither limit fits (against a 2D solution at those dimensions, Ocvirk's
short bearing over-predicts the force 2–30×, Sommerfeld's long bearing by 13–190 %). The
law combines both limits pointwise by a harmonic mean,

    1/p = 1/p_s + 1/p_l    (Hirani, Athre & Biswas, J. Tribol. 121 (1999) 844–852),

exact in either limit (p → p_s as L/D → 0, p → p_l as L/D → ∞). Both are closed forms
(q = ē·n, ē = e/c, ε = |ē|, H = 1 − q = h/c):

    p_s = (3/2)·μL²·(w·n)/(c³H³)·(1 − 4z²/L²)                                  (Ocvirk)
    p_l = (12μR²/c³)·[(w·n)(2 − q)/(2 + ε²) + (w·ē)(3 + 1.5ε² − 4q + 2q²)/(D₁D₂)]/H²

with D₁ = 2 + ε², D₂ = 2 + 3ε²: the long-bearing pressure of squeeze and rotation at once,
integrated by the Sommerfeld substitution and written without e's direction (analytic at
e = 0). Its level is fixed by ∫h³p dθ = 0, which the finite bearing meets exactly on every
section z (integrate the Reynolds equation over θ; p = 0 at the ends); the usual
p(±90°) = 0 misplaces the cavitation boundary of a radial squeeze (the 2D check then
fails). The axial integral of the mean is closed: ∫p dz = L·a·g(t), a = p_l,
b = p_s(z = 0), t = b/(a + b), g(t) = 1 − (1 − t)·artanh(√t)/√t (2t/3: short; 1: long).

Cavitation (half-Sommerfeld, Gümbel): the film carries pressure only where both limits
are positive. p_s > 0 exactly where w·n > 0 (the gap closes), so the loaded part is the
half circle w·n > 0, and the film never feeds power into the squeeze, F·w ≤ 0, node by
node. On that half p_l > 0 whenever w·ē ≥ 0 (its bracket's second factor,
2(q − 1)² + 1 + 1.5ε², is positive), so only separating motion meets the zero of p_l
inside it, where a C¹ positive part is taken. "full_sommerfeld" adds the negative
pressures, the same mean of the negative parts on the other half; where the limits
disagree in sign (a thin band beside w·n = 0 in a radial squeeze) it carries none, which
leaves it 0.2 % below Ocvirk's full film in the short limit.

Quadrature: Gauss–Legendre on the loaded half, in the Sommerfeld angle (see ``_half``), so
the nodes crowd where the film is thin. 16 nodes integrate approaching and rotating states
to 1.4e-4 up to ε = 0.95 (4e-7 for a radial approach at ε = 0.99); a separating state's
kink leaves up to 1 % (median 5e-4). The nodes turn with w, so the law is isotropic to
round-off. Below ``rate_width`` the force fades as |w|² (C¹ at rest); the eccentricity
ratio is clamped smoothly below ``eccentricity_max`` (identity up to ε_max − d,
d = min(1 − ε_max, ε_max/2)), so the film stays finite for |e| ≥ c, where the dry
contact law the joint applies beside it takes over (mixed lubrication).

Against a converged 2D Reynolds solution at L/D = 2.5 and 1.25, ε = 0.3/0.6/0.9
(tests/test_oil_film.py): approach, oblique squeeze, rotation and both +3.7 to +13.1 % in
|F|, separation +1.1 to −12.9 %, direction within 4.4°; the full film +2.2 to +8.0 %.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._numerics import is_concrete, safe_norm, safe_normalize
from .base import check_fields
from .film_base import AbstractFilmLaw

__all__ = ["OilFilm"]

_CAVITATION = ("half_sommerfeld", "full_sommerfeld")
# g(t) = Σ 2tᵏ/((2k − 1)(2k + 1)) below t = 0.01 (6 terms: truncation < 1e-14 of g)
_SERIES = tuple(2.0 / ((2 * k - 1) * (2 * k + 1)) for k in range(1, 7))
_T_SERIES = 0.01
# width of the positive part of the long-bearing pressure, per unit squeeze speed [-]
# (the pressure is O(1) there at the bearing's centre and grows as (1 − ε)⁻²)
_LONG_WIDTH = 1e-3


@functools.cache
def _legendre(m: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [−1, 1]."""
    return np.polynomial.legendre.leggauss(m)


def _ramp(x: Array, width: ArrayLike) -> Array:
    """C¹ positive part, exact beyond ``width``: 0 for x ≤ 0, x²(2w − x)/w² on (0, w),
    x from w on; 0 ≤ ramp(x) ≤ max(x, 0)."""
    w = jnp.asarray(width)
    inner = x * x * (2.0 * w - x) / (w * w)
    return jnp.where(x >= w, x, jnp.where(x > 0, inner, 0.0))


def _axial_mean(a: Array, b: Array) -> Array:
    """(1/L)∫ a·b(z)/(a + b(z)) dz with b(z) = b·(1 − 4z²/L²), for a, b ≥ 0: a·g(t), t =
    b/(a + b), g(t) = 1 − (1 − t)·artanh(√t)/√t. Finite with finite gradients
    everywhere; 0 where a or b is 0."""
    pos = (a > 0) & (b > 0)
    a_s, b_s = jnp.where(pos, a, 1.0), jnp.where(pos, b, 1.0)
    t = b_s / (a_s + b_s)
    big = t >= _T_SERIES
    one_minus_t = jnp.where(big, a_s / (a_s + b_s), 1.0 - _T_SERIES)  # no cancellation at t → 1
    s = jnp.sqrt(jnp.where(big, t, _T_SERIES))
    artanh = 0.5 * jnp.log((1.0 + s) ** 2 / one_minus_t)
    large = 1.0 - one_minus_t * artanh / s
    ts = jnp.where(big, _T_SERIES, t)
    small = 0.0
    for coef in reversed(_SERIES):
        small = ts * (coef + small)
    return jnp.where(pos, a_s * jnp.where(big, large, small), 0.0)


class OilFilm(AbstractFilmLaw):
    """Finite-length oil film of a revolute clearance joint: force, shear torque, damping.

    Every method broadcasts over leading axes (eccentricities (..., 2), scalars (...)).

    Attributes:
        viscosity: μ, dynamic viscosity of the oil [Pa·s] (> 0).
        cavitation: "half_sommerfeld" (negative pressures set to zero, Gümbel; default)
            or "full_sommerfeld" (the film holds tension) (static).
        eccentricity_max: ε_max, the eccentricity ratio the film is clamped below, smoothly
            [-] (in (0, 0.999]; the film is exact up to 2ε_max − 1). The default 0.8
            (exact to 0.6, 0.77 at the wall) is the solver's cost: the film's squeeze
            damping grows as (1 − ε²)^(−3/2) toward the wall, and an explicit solver's step
            with it. On the 08B strand's first meshing peak (clearance chain, 1000 rpm,
            ``benchmarks/lubrication.py`` has the distributions) caps of 0.8, 0.9 and 0.95
            give the same peak to 0.3 % (568.1, 569.4, 569.6 N; dry 663.6 N) at 0.82, 2.0 and
            2.2 times the dry chain's steps (0.99: 35 times). Raise it where the film's own
            load capacity matters: on smooth steel (composite roughness σ ≈ 0.5–1 µm) the
            film thins to three σ, the onset of mixed lubrication, near ε = 0.9 on an 08B
            pin (c = 25 µm).
        nodes: Gauss–Legendre nodes on the film's loaded half (static, >= 4; the full
            film uses twice as many).
        rate_width: squeeze speed [m/s] below which the force fades to zero, C¹ (> 0):
            the force is exact from |w| = rate_width on, ∝ |w|² below.
    """

    viscosity: ArrayLike
    cavitation: str = eqx.field(static=True, default="half_sommerfeld")
    eccentricity_max: ArrayLike = 0.8
    nodes: int = eqx.field(static=True, default=16)
    rate_width: ArrayLike = 1e-6

    def __check_init__(self):
        if self.cavitation not in _CAVITATION:
            raise ValueError(
                f"OilFilm.cavitation must be one of {', '.join(map(repr, _CAVITATION))}, "
                f"got {self.cavitation!r}"
            )
        if isinstance(self.nodes, bool) or not isinstance(self.nodes, int) or self.nodes < 4:
            raise ValueError(f"OilFilm.nodes must be an integer >= 4, got {self.nodes!r}")
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("viscosity", lambda v: v > 0, "> 0 Pa·s"),
                ("eccentricity_max", lambda v: (v > 0) & (v <= 0.999), "in (0, 0.999]"),
                ("rate_width", lambda v: v > 0, "> 0 m/s"),
            ],
        )

    def clamped_ratio(self, ratio: ArrayLike) -> Array:
        """ε clamped smoothly below ε_max [-]: ε up to the knee ε_max − d, then
        ε_max − d·exp(−(ε − ε_max + d)/d), d = min(1 − ε_max, ε_max/2) (C¹ through the
        knee, C^∞ elsewhere)."""
        ratio = jnp.asarray(ratio)
        top = jnp.asarray(self.eccentricity_max)
        d = jnp.minimum(1.0 - top, 0.5 * top)
        over = jnp.maximum(ratio - (top - d), 0.0)
        return jnp.where(over > 0, top - d * jnp.exp(-over / d), ratio)

    def _ratio(self, eccentricity, clearance):
        """(ē = e/c with its length clamped (..., 2), the clamped ratio ε (...))."""
        _vectors(eccentricity=eccentricity)
        e = jnp.asarray(eccentricity) / jnp.asarray(clearance)[..., None]
        ratio = safe_norm(e)
        clamped = self.clamped_ratio(ratio)
        scale = jnp.where(clamped < ratio, clamped / jnp.where(ratio > 0, ratio, 1.0), 1.0)
        return e * scale[..., None], clamped

    def _half(self, e, ratio, direction, slenderness):
        """Σ weight·p·n over the half of the film where direction·n > 0 (..., 2), p the
        line pressure for a unit squeeze along ``direction`` in units of 12μR²L/c³.

        The nodes are Gauss–Legendre in the Sommerfeld angle γ of the Möbius map
        e^{iγ} = (ζ − β)/(1 − β̄ζ), ζ = e^{iθ}, β = ē/(1 + √(1 − ε²)), whose Jacobian is
        dθ/dγ = h/(c√(1 − ε²)): the nodes crowd where the film is thin, and there the
        integrand, ∝ h⁻², turns into nearly a trigonometric polynomial in γ. The map is
        analytic in ē (the identity at ē = 0). Complex numbers are (x, y) pairs."""
        x, wt = _legendre(self.nodes)
        ex, ey = e[..., 0], e[..., 1]
        dx, dy = direction[..., 0], direction[..., 1]
        e2 = ratio * ratio
        k = 1.0 / (1.0 + jnp.sqrt(1.0 - e2))
        bx, by, bb = k * ex, k * ey, k * k * e2  # β, |β|²
        # the half starts at ζ₁ = −i·direction and ends at −ζ₁; its length in γ is twice
        # the angle ζ₁ − β → −ζ₁ − β (whose dot product is −(1 − |β|²) < 0), minus π
        u1x, u1y = dy - bx, -dx - by
        cross = u1x * (dx - by) - u1y * (-dy - bx)
        span = math.pi - 2.0 * jnp.arctan(cross / (1.0 - bb))
        # its start in γ: Z₁ = (ζ₁ − β)/(1 − β̄ζ₁)
        den_x, den_y = 1.0 - (bx * dy - by * dx), bx * dx + by * dy
        inv = 1.0 / (den_x * den_x + den_y * den_y)
        z1x, z1y = (u1x * den_x + u1y * den_y) * inv, (u1y * den_x - u1x * den_y) * inv
        # nodes Z = Z₁·e^{iγ}, mapped back: ζ = (Z + β)/(1 + β̄Z), dθ/dγ = (1 − |β|²)/|1 + β̄Z|²
        ex_, ey_, dx_, dy_ = (v[..., None] for v in (ex, ey, dx, dy))
        gamma = (0.5 * span)[..., None] * (jnp.asarray(x) + 1.0)
        cos, sin = jnp.cos(gamma), jnp.sin(gamma)
        zx = z1x[..., None] * cos - z1y[..., None] * sin
        zy = z1x[..., None] * sin + z1y[..., None] * cos
        bx_, by_ = bx[..., None], by[..., None]
        fx, fy = 1.0 + bx_ * zx + by_ * zy, bx_ * zy - by_ * zx
        inv = 1.0 / (fx * fx + fy * fy)
        nx = ((zx + bx_) * fx + (zy + by_) * fy) * inv
        ny = ((zy + by_) * fx - (zx + bx_) * fy) * inv
        weight = jnp.asarray(wt) * (0.5 * span * (1.0 - bb))[..., None] * inv
        # the two limits' pressures, per unit squeeze speed, in units of 12μR²/c³
        q = ex_ * nx + ey_ * ny
        un = dx_ * nx + dy_ * ny  # > 0 on the half
        ue = (dx * ex + dy * ey)[..., None]
        inv_gap = 1.0 / (1.0 - q)
        c1 = (1.0 / (2.0 + e2))[..., None]
        c2 = (1.0 / ((2.0 + e2) * (2.0 + 3.0 * e2)))[..., None]
        c3 = (3.0 + 1.5 * e2)[..., None]
        long = (un * (2.0 - q) * c1 + ue * (c3 + q * (2.0 * q - 4.0)) * c2) * inv_gap**2
        short = slenderness[..., None] * un * inv_gap**3
        line = weight * _axial_mean(_ramp(long, _LONG_WIDTH), short)
        return jnp.stack([jnp.sum(line * nx, -1), jnp.sum(line * ny, -1)], -1)

    def _unit_force(self, e, ratio, direction, clearance, radius, length):
        """Film force [N] per unit squeeze speed along the unit ``direction`` (..., 2)."""
        c, r, length = (jnp.asarray(v) for v in (clearance, radius, length))
        slenderness = length * length / (8.0 * r * r)  # p_s(z = 0)/p_l scale, (L/R)²/8
        shape = self._half(e, ratio, direction, slenderness)
        if self.cavitation == "full_sommerfeld":
            shape = shape - self._half(e, ratio, -direction, slenderness)
        unit = 12.0 * self.viscosity * r**3 * length / c**3
        return -unit[..., None] * shape

    def squeeze_force(
        self,
        eccentricity: Float[Array, "... 2"],
        velocity: Float[Array, "... 2"],
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Float[Array, "... 2"]:
        """Film force on the journal [N] (bearing frame, (..., 2)) of a non-rotating journal
        at ``eccentricity`` e [m] squeezing the film at ``velocity`` w [m/s]; radial
        clearance c [m], journal radius R [m], bearing length L [m]. Positively
        homogeneous in w (half-Sommerfeld: not linear), faded C¹ to 0 below
        ``rate_width``."""
        _vectors(velocity=velocity)
        _geometry("OilFilm.squeeze_force", clearance, radius, length)
        e, ratio = self._ratio(eccentricity, clearance)
        w = jnp.asarray(velocity)
        direction = safe_normalize(w, jnp.asarray([1.0, 0.0]))
        speed = _ramp(safe_norm(w), self.rate_width)
        unit = self._unit_force(e, ratio, direction, clearance, radius, length)
        return speed[..., None] * unit

    def force(
        self,
        eccentricity: Float[Array, "... 2"],
        eccentricity_rate: Float[Array, "... 2"],
        spin: ArrayLike,
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Float[Array, "... 2"]:
        """Film force on the journal [N] (bearing frame, (..., 2)).

        ``eccentricity`` e [m]: journal centre minus bearing centre; ``eccentricity_rate``
        ė [m/s], as seen in the bearing frame; ``spin`` ω [rad/s] of the journal relative
        to the bearing; radial clearance c [m], journal radius R [m], bearing length L [m].
        Equal to ``squeeze_force(e, ė − (ω/2)·ẑ×e, ...)``. Finite, with finite gradients,
        for any input (|e| ≥ c included: the film is that at the clamped ratio).
        """
        _vectors(eccentricity=eccentricity, eccentricity_rate=eccentricity_rate)
        e = jnp.asarray(eccentricity)
        spin = jnp.asarray(spin)[..., None]
        turn = jnp.stack([-e[..., 1], e[..., 0]], axis=-1)  # ẑ × e
        w = jnp.asarray(eccentricity_rate) - 0.5 * spin * turn
        return self.squeeze_force(e, w, clearance, radius, length)

    def friction_torque(
        self,
        eccentricity: Float[Array, "... 2"],
        spin: ArrayLike,
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Float[Array, ...]:
        """Shear (Couette) torque of the film on the journal [N·m], opposing the spin:

            T = −2πμR³Lω/(c·√(1 − ε²)),

        Petroff's law with the eccentric-film factor ∫dθ/h = 2π/(c√(1 − ε²)) (Hamrock,
        Schmid & Jacobson, *Fundamentals of Fluid Film Lubrication*, 2004, ch. 10): the
        Couette shear of a full film over the whole circumference, ε the clamped ratio.
        The pressure-flow part, −(e × F)/2, is the joint's to add (it balances the pair's
        moments: :class:`~jaxchain.contact.AbstractFilmLaw`)."""
        _geometry("OilFilm.friction_torque", clearance, radius, length)
        _, ratio = self._ratio(eccentricity, clearance)
        mu, r = self.viscosity, jnp.asarray(radius)
        factor = 2.0 * math.pi * mu * r**3 * jnp.asarray(length) / jnp.asarray(clearance)
        return -factor * jnp.asarray(spin) / jnp.sqrt(1.0 - ratio * ratio)

    def damping(
        self,
        eccentricity_ratio: ArrayLike,
        clearance: ArrayLike,
        radius: ArrayLike,
        length: ArrayLike,
    ) -> Array:
        """Radial squeeze damping [N·s/m] at eccentricity ratio ε (clamped): −F·ê/|ė| of
        the journal approaching the wall along e, the film's stiffest motion (for a
        stable-step estimate)."""
        _geometry("OilFilm.damping", clearance, radius, length)
        ratio, c = jnp.broadcast_arrays(jnp.asarray(eccentricity_ratio), jnp.asarray(clearance))
        along = jnp.stack([jnp.ones_like(c), jnp.zeros_like(c)], axis=-1)
        clamped = self.clamped_ratio(ratio)
        unit = self._unit_force(clamped[..., None] * along, clamped, along, c, radius, length)
        return -unit[..., 0]


def _vectors(**vectors) -> None:
    """``ValueError`` unless each is a planar vector (or a stack of them): (..., 2)."""
    for name, v in vectors.items():
        shape = np.shape(v)
        if not shape or shape[-1] != 2:
            raise ValueError(
                f"OilFilm: {name} must be a planar vector of shape (..., 2) [bearing frame], "
                f"got shape {shape}"
            )


def _geometry(caller: str, clearance, radius, length) -> None:
    """``ValueError`` unless the joint's clearance, radius and length are > 0 and finite
    (checked where concrete; inside a solve they come from the built scene)."""
    for name, v in (("clearance", clearance), ("radius", radius), ("length", length)):
        if is_concrete(v):
            a = np.asarray(v, dtype=float)
            if not np.all(np.isfinite(a) & (a > 0)):
                raise ValueError(f"{caller}: {name} must be > 0 m and finite, got {v}")
