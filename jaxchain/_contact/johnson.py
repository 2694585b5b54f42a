"""Johnson's law for a cylinder in a conformal cylindrical hole (pin/bushing, roller/seat)."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike

from .._numerics import is_concrete, smooth_ramp
from .base import AbstractHysteresisLaw, check_fields
from .flores import Flores
from .gonthier import Gonthier
from .hunt_crossley import HuntCrossley
from .lankarani_nikravesh import LankaraniNikravesh

__all__ = ["JohnsonCylinder", "johnson_dimensionless_force"]

# the damping families JohnsonCylinder takes by name: each point law's own χ(e)
_DAMPING = {
    "lankarani-nikravesh": LankaraniNikravesh,
    "hunt-crossley": HuntCrossley,
    "flores": Flores,
    "gonthier": Gonthier,
}

# Johnson (1985): δ = F/(πLE*)·[ln(4πLE*ΔR/F) − 1]. In s = F/(πLE*ΔR), y = δ/ΔR:
#   y = g(s) = s·(ln(4/s) − 1),  g'(s) = ln(4/s) − 2.
# g rises only up to s = 4e⁻²; we use it up to s_c = 4e^(−2.5) (g' = 1/2) and continue
# linearly (C¹) beyond, where the theory has already left its range (δ ≈ 0.49 ΔR).
_S_C = 4.0 * math.exp(-2.5)
_Y_C = _S_C * (math.log(4.0 / _S_C) - 1.0)
_GP_C = math.log(4.0 / _S_C) - 2.0
_LN4 = math.log(4.0)
# Halley's iteration (cubic) from the one-fixed-point-step start: relative error 7e-6
# after 2 iterations and round-off (7e-15, as Newton's after 5) after 3 over y in
# [1e-14, y_c] (checked on 2.1e5 points). Each iteration costs one log, the bulk of the
# law's cost: 3 instead of Newton's 5 (vector field of the engagement ~8 % cheaper).
_ITERATIONS = 3


def _g(s):
    return s * (jnp.log(4.0 / s) - 1.0)


@jax.custom_jvp
def _johnson_s(y):
    """Root s of g(s) = y for y in (0, y_c]: Halley in u = ln s, on
    h(u) = u + ln(ln 4 − 1 − u) − ln y (concave, increasing: h' = 1 − 1/w, h'' = −1/w²
    with w = ln 4 − 1 − u)."""
    ys = jnp.clip(y, 1e-300, _Y_C)
    ly = jnp.log(ys)
    u = jnp.minimum(ly - jnp.log(jnp.log(4.0 / ys) - 1.0), math.log(_S_C))
    for _ in range(_ITERATIONS):
        w = _LN4 - 1.0 - u
        h = u + jnp.log(w) - ly
        d1 = 1.0 - 1.0 / w
        u = jnp.minimum(u - 2.0 * h * d1 / (2.0 * d1 * d1 + h / (w * w)), math.log(_S_C))
    return jnp.where(y > 0, jnp.exp(u), 0.0)


@_johnson_s.defjvp
def _johnson_s_jvp(primals, tangents):
    (y,), (dy,) = primals, tangents
    s = _johnson_s(y)
    pos = s > 0
    gp = jnp.log(4.0 / jnp.where(pos, s, 1.0)) - 2.0
    return s, jnp.where(pos, dy / jnp.where(pos, gp, 1.0), 0.0)


def johnson_dimensionless_force(y: ArrayLike) -> Array:
    """s = F/(πLE*ΔR) as a function of y = δ/ΔR ≥ 0 (Johnson, linearly continued past y_c)."""
    y = jnp.asarray(y)
    inside = y <= _Y_C
    return jnp.where(inside, _johnson_s(jnp.where(inside, y, _Y_C)), _S_C + (y - _Y_C) / _GP_C)


class JohnsonCylinder(AbstractHysteresisLaw):
    """Johnson's internal-cylinder law with hysteresis damping, for conformal pairs.

    Elastic part (Johnson, *Contact Mechanics*, 1985): a cylinder of radius R in a hole of
    radius R + ΔR, contact length L, contact modulus E*:

        δ = F/(πLE*)·[ln(4πLE*ΔR/F) − 1],

    solved for F by Halley's method with an implicit-function derivative (exact
    gradients, no unrolled-iteration noise). Valid while δ ≲ 0.49ΔR; beyond, the force is
    continued linearly with the slope there (C¹). Unlike Hertz δ^1.5 with
    R* = R(R+ΔR)/ΔR, its stiffness does not blow up as ΔR → 0.

    Damping: the χ(e) of the point law named by ``damping`` ("flores" by default: valid
    over the whole range of e); regularization, speed floor and no-pull clamp as in
    :class:`~jaxchain.contact.AbstractHysteresisLaw`.

    Attributes:
        clearance: ΔR, radial clearance of the pair [m].
        length: L, contact length [m].
        modulus: E*, contact modulus [Pa] (see :func:`jaxchain.effective_modulus`).
        restitution: e ∈ (0, 1].
        damping: "flores" | "gonthier" | "lankarani-nikravesh" | "hunt-crossley" (static).
        width, speed_floor, clamp_width: see :class:`AbstractHysteresisLaw`.
    """

    clearance: ArrayLike
    length: ArrayLike
    modulus: ArrayLike
    restitution: ArrayLike = 0.9
    damping: str = eqx.field(static=True, default="flores")
    width: ArrayLike = 1e-8
    speed_floor: ArrayLike = 1e-3
    clamp_width: ArrayLike = 0.05

    def __check_init__(self):
        if self.damping not in _DAMPING:
            raise ValueError(f"damping must be one of {sorted(_DAMPING)}, got {self.damping!r}")
        if not is_concrete(self):
            return
        check_fields(
            self,
            [
                ("clearance", lambda v: v > 0, "> 0 m"),
                ("length", lambda v: v > 0, "> 0 m"),
                ("modulus", lambda v: v > 0, "> 0 Pa"),
            ],
        )

    def damping_factor(self) -> Array:
        return _DAMPING[self.damping].chi(jnp.asarray(self.restitution))

    @property
    def _scale(self):
        """πLE*ΔR [N]: the force unit of the dimensionless law."""
        return jnp.pi * self.length * self.modulus * self.clearance

    def elastic_force(self, depth: ArrayLike) -> Array:
        """Johnson's F(δ) [N] on the regularized depth."""
        y = smooth_ramp(depth, self.width) / self.clearance
        return self._scale * johnson_dimensionless_force(y)

    def deflection(self, force: ArrayLike) -> Array:
        """Johnson's δ(F) = F/(πLE*)·(ln(4πLE*ΔR/F) − 1) [m] (explicit; 0 for F ≤ 0),
        the inverse of ``elastic_force`` (unregularized) within the theory's range."""
        s = jnp.asarray(force) / self._scale
        pos = s > 0
        delta = jnp.where(pos, self.clearance * _g(jnp.where(pos, s, 1.0)), 0.0)
        return jnp.where(jnp.isnan(s), s, delta)  # NaN in, NaN out

    def tangent_stiffness(self, force: ArrayLike) -> Array:
        """dF/dδ at ``force`` > 0 [N/m]: πLE*/g'(s), g'(s) = ln(4/s) − 2."""
        s = jnp.asarray(force) / self._scale
        return jnp.pi * self.length * self.modulus / (jnp.log(4.0 / s) - 2.0)
