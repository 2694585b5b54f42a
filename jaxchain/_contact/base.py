"""Abstract contact laws and the shared hysteresis-damping machinery."""

from __future__ import annotations

import abc
import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike

from .._checks import fields
from .._numerics import is_concrete, safe_pow, smooth_ramp

__all__ = [
    "AbstractContactLaw",
    "AbstractHysteresisLaw",
    "AbstractPointLaw",
    "hysteresis_restitution",
    "check_fields",
    "contact_potential",
]


def check_fields(module, checks) -> None:
    """Raise for the first field whose value (every element, if an array) is not a finite
    real number passing its check (:func:`jaxchain._checks.fields`). ``checks``: (field
    name, predicate on a NumPy array, range text)."""
    fields(module, checks)


class AbstractContactLaw(eqx.Module):
    """A normal contact force law F(δ, δ̇, v⁻) ≥ 0.

    ``depth`` δ [m] > 0 is overlap; ``depth_rate`` δ̇ [m/s] > 0 is approach;
    ``impact_speed`` v⁻ [m/s] is the approach speed at the onset of the current impact
    (laws with velocity-ratio damping need it; others ignore it).
    """

    @abc.abstractmethod
    def normal_force(
        self, depth: ArrayLike, depth_rate: ArrayLike, impact_speed: ArrayLike
    ) -> Array:
        """Normal force [N], ≥ 0 (never pulls), finite with finite gradients for any input."""

    def onset(self) -> Array:
        """The depth [m] (≤ 0) below which the law carries no force: where its stored
        energy starts (default 0; a regularized law's onset is a little below)."""
        return jnp.zeros(())

    def potential(self, depth: ArrayLike) -> Array:
        """Energy [J] the contact stores at ``depth`` [m]: ∫ F(s, 0, ·) ds from the
        :meth:`onset` (the force at rest, no damping), what the energy balance and the
        statics' relaxation read. The default integrates :meth:`normal_force` by
        Gauss–Legendre quadrature (24 nodes); a law with a closed form may override it."""
        return contact_potential(lambda d: self.normal_force(d, 0.0, 1.0), self.onset(), depth)


def contact_potential(force, onset, depth, n_nodes: int = 24) -> Array:
    """∫ ``force``(s) ds from ``onset`` to ``depth`` [J] (Gauss–Legendre, ``n_nodes``
    nodes; zero below the onset)."""
    x, w = np.polynomial.legendre.leggauss(n_nodes)
    hi = jnp.maximum(jnp.asarray(depth), onset)
    half = 0.5 * (hi - onset)
    pts = onset + half[..., None] * (x + 1.0)
    return half * jnp.sum(w * force(pts), axis=-1)


class AbstractHysteresisLaw(AbstractContactLaw):
    """F = F_el(δᵣ)·ramp(1 + χ(e)·δ̇/v⁻): an elastic law with hysteresis damping.

    A concrete law gives the elastic part F_el (``elastic_force``) and the damping factor
    χ(e) (``damping_factor``); the damping, regularization and clamp are written here
    once. δᵣ = smooth_ramp(δ, width) is the penetration regularization (C¹; exact for
    |δ| ≥ width, over-reports δ by at most width/4 at δ = 0, force onset at δ = −width).
    v⁻ is floored smoothly, v⁻ → √(v⁻² + speed_floor²), so resting contact (v⁻ → 0)
    stays finite. The bracket is clamped at zero by a C¹ ramp of half-width
    ``clamp_width`` so the force never pulls.

    With F = F_el(δ)·(1 + χ·δ̇/v⁻), m·δ̈ = −F integrates in closed form over a whole
    impact, whatever F_el is: the coefficient of restitution e* solves
    1 − χe* = (1 + χ)·exp(−χ(1 + e*)) (see :func:`hysteresis_restitution`).

    Fields every concrete law has (declared there, so each keeps its own defaults and
    field order):
        restitution: e ∈ (0, 1], the coefficient the law is meant to reproduce.
        width: penetration regularization half-width [m] (0: none).
        speed_floor: smallest impact speed used in the damping ratio [m/s].
        clamp_width: half-width of the no-pull clamp on the bracket [-].
    """

    def __check_init__(self):
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("restitution", lambda v: (v > 0.0) & (v <= 1.0), "in (0, 1]"),
                ("width", lambda v: v >= 0, ">= 0 m"),
                ("speed_floor", lambda v: v > 0, "> 0 m/s"),
                ("clamp_width", lambda v: (v >= 0) & (v <= 1), "in [0, 1]"),
            ],
        )

    @abc.abstractmethod
    def elastic_force(self, depth: ArrayLike) -> Array:
        """F_el on the regularized depth [N]."""

    @abc.abstractmethod
    def damping_factor(self) -> Array:
        """χ(e) [-] of the law."""

    def normal_force(self, depth, depth_rate, impact_speed):
        depth = jnp.asarray(depth)
        v0 = jnp.sqrt(jnp.asarray(impact_speed) ** 2 + self.speed_floor**2)
        bracket = 1.0 + self.damping_factor() * jnp.asarray(depth_rate) / v0
        force = self.elastic_force(depth) * smooth_ramp(bracket, self.clamp_width)
        # NaN in, NaN out: a NaN depth must not read as "no contact" (zero force)
        return jnp.where(jnp.isnan(depth), depth, force)

    def onset(self) -> Array:
        """−width: where the regularized force starts."""
        return -jnp.asarray(self.width)

    def potential(self, depth: ArrayLike) -> Array:
        """∫ F_el from the onset (−width) to ``depth`` [J] (the damping does no work at
        rest)."""
        return contact_potential(self.elastic_force, self.onset(), depth)

    def effective_restitution(self) -> float:
        """Coefficient of restitution this law actually produces in an isolated impact
        (closed form, independent of the elastic law and the mass; ignores the no-pull
        clamp)."""
        return hysteresis_restitution(float(self.damping_factor()))


class AbstractPointLaw(AbstractHysteresisLaw):
    """F_el = K·δᵣⁿ (Hertz-type point or line contact), hysteresis-damped; concrete laws
    differ only in the damping factor χ(e), their static ``chi``.

    Attributes:
        stiffness: K [N/mⁿ].
        exponent: n [-] (1.5 for Hertz point contact).
        restitution, width, speed_floor, clamp_width: see
            :class:`AbstractHysteresisLaw`.
    """

    stiffness: ArrayLike
    exponent: ArrayLike = 1.5
    restitution: ArrayLike = 0.9
    width: ArrayLike = 1e-7
    speed_floor: ArrayLike = 1e-3
    clamp_width: ArrayLike = 0.05

    def __check_init__(self):
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("stiffness", lambda v: v > 0, "> 0"),
                ("exponent", lambda v: (v >= 1.0) & (v <= 3.0), "in [1, 3]"),
            ],
        )

    @staticmethod
    @abc.abstractmethod
    def chi(restitution: ArrayLike) -> Array:
        """χ(e) of the law's damping family (also used by name by JohnsonCylinder)."""

    def damping_factor(self) -> Array:
        return self.chi(jnp.asarray(self.restitution))

    def elastic_force(self, depth: ArrayLike) -> Array:
        """K·δᵣⁿ [N]."""
        return self.stiffness * safe_pow(smooth_ramp(depth, self.width), self.exponent)


def hysteresis_restitution(chi: float) -> float:
    """Restitution e* of an impact under F = F_el(δ)·(1 + χ·δ̇/v⁻): the root in (0, 1] of
    1 − χe* = (1 + χ)·exp(−χ(1 + e*)). Exact for any elastic law F_el(δ) ≥ 0.

    Solved for w = −ln(1 − χe*) ∈ [0, ∞), where the equation reads
    w + expm1(−w) = χ − ln(1 + χ) (monotone in w; no loss of range as χe* → 1).
    """
    if not chi >= 0:
        raise ValueError(f"damping factor must be >= 0, got {chi}")
    if chi < 1e-6:
        return 1.0 - 2.0 * chi / 3.0  # series; error O(χ²) < 1e-12
    target = chi - math.log1p(chi)
    lo, hi = 0.0, target + 2.0  # w + expm1(−w) ≥ w − 1
    for _ in range(300):
        mid = 0.5 * (lo + hi)
        if mid + math.expm1(-mid) < target:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-17 * max(hi, 1e-300):
            break
    w = 0.5 * (lo + hi)
    return min(-math.expm1(-w) / chi, 1.0)
