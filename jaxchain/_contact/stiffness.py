"""Contact stiffness of cylinder pairs from materials and geometry."""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike

from .._numerics import is_concrete

__all__ = ["hertz_stiffness", "effective_radius", "tangent_stiffness"]


def effective_radius(radius1: ArrayLike, radius2: ArrayLike, *, internal: bool = False) -> Array:
    """R* of two cylinders [m]: R₁R₂/(R₁ + R₂) external; R₁R₂/(R₂ − R₁) for a cylinder of
    radius R₁ inside a hole of radius R₂ > R₁ (internal)."""
    r1, r2 = jnp.asarray(radius1), jnp.asarray(radius2)
    if is_concrete(r1, r2):
        for name, r in (("radius1", r1), ("radius2", r2)):
            if not np.all(np.isfinite(r) & (np.asarray(r) > 0)):
                raise ValueError(f"effective_radius: {name} must be finite and > 0 m, got {r}")
        if internal and not np.all(np.asarray(r2) > np.asarray(r1)):
            raise ValueError(
                "effective_radius: an internal pair needs the hole larger than the cylinder, "
                f"radius2 > radius1, got radius1={r1}, radius2={r2}"
            )
    return r1 * r2 / ((r2 - r1) if internal else (r1 + r2))


def hertz_stiffness(
    modulus: ArrayLike, radius1: ArrayLike, radius2: ArrayLike, *, internal: bool = False
) -> Array:
    """Hertz stiffness K = (4/3)·E*·√R* [N/m^1.5], for use with exponent n = 1.5.

    ``modulus`` is the contact modulus E* (:func:`jaxchain.effective_modulus`). Fine for
    external (convex/convex) contact, e.g. a roller on a flank. For a near-conformal
    internal pair (roller in its seat, pin in its bush) R* = R₁R₂/(R₂ − R₁) grows without
    bound as the clearance closes, so the stiffness swings with the clearance: use
    :class:`~jaxchain.contact.JohnsonCylinder` there instead.
    """
    return (
        4.0
        / 3.0
        * jnp.asarray(modulus)
        * jnp.sqrt(effective_radius(radius1, radius2, internal=internal))
    )


@eqx.filter_jit
def tangent_stiffness(law, force):
    """dF/dδ of ``law`` (largest over array-valued fields) where its static force is
    ``force``: bisection on log δ over [1e-13, 1e-2] m."""

    def f(log_d):
        return jnp.max(law.normal_force(jnp.exp(log_d), 0.0, 1.0))

    def bisect(_, lohi):
        lo, hi = lohi
        mid = 0.5 * (lo + hi)
        below = f(mid) < force
        return jnp.where(below, mid, lo), jnp.where(below, hi, mid)

    _, hi = jax.lax.fori_loop(0, 80, bisect, (jnp.log(1e-13), jnp.log(1e-2)))
    return jax.grad(f)(hi) / jnp.exp(hi)
