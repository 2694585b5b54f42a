"""Gradient-safe numerics: every function here is finite in value *and* gradient everywhere.

The pattern is the double ``where`` (jax-md ``safe_mask``): the unsafe input is replaced
by a harmless one *before* the singular operation, so the discarded branch never produces
an ``inf``/``nan`` that would poison the backward pass.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

__all__ = [
    "safe_norm",
    "safe_normalize",
    "safe_sqrt",
    "safe_pow",
    "smooth_ramp",
    "parabola_max",
    "cross2",
    "is_concrete",
    "stack",
]


def is_concrete(*xs) -> bool:
    """True when no argument is a JAX tracer (so Python-side validation may inspect values)."""
    leaves = jax.tree_util.tree_leaves(xs)
    return not any(isinstance(x, jax.core.Tracer) for x in leaves)


def stack(xs, dtype=None) -> Array:
    """``jnp.stack(xs)`` (in ``dtype``); concrete values are stacked by NumPy and placed
    on the device once: an eager ``jnp.stack`` compiles a program for every count, shape
    and dtype."""
    if not is_concrete(*xs):
        return jnp.stack([jnp.asarray(x, dtype) for x in xs])
    return jax.device_put(np.stack([np.asarray(x, dtype) for x in xs]))


def cross2(a: Float[Array, "... 2"], b: Float[Array, "... 2"]) -> Float[Array, ...]:
    """z-component of the planar cross product a × b."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def safe_sqrt(x: ArrayLike) -> Array:
    """sqrt(max(x, 0)) with gradient 0 (not inf/nan) at and below 0."""
    x = jnp.asarray(x)
    pos = x > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, x, 1.0)), 0.0)


def safe_norm(x: Float[Array, "... 2"], axis: int = -1) -> Float[Array, ...]:
    """Euclidean norm whose gradient at the zero vector is 0 instead of nan."""
    sq = jnp.sum(x * x, axis=axis)
    return safe_sqrt(sq)


def safe_normalize(
    x: Float[Array, "... 2"], fallback: Float[Array, "... 2"]
) -> Float[Array, "... 2"]:
    """x / |x|, or ``fallback`` (a unit vector) where x is the zero vector. Finite gradients."""
    sq = jnp.sum(x * x, axis=-1, keepdims=True)
    pos = sq > 0
    inv = jnp.where(pos, jax.lax.rsqrt(jnp.where(pos, sq, 1.0)), 0.0)
    return jnp.where(pos, x * inv, fallback)


def safe_pow(x: ArrayLike, exponent: ArrayLike) -> Array:
    """max(x, 0) ** exponent with finite gradients in x and exponent (0 at x <= 0).

    For exponent > 1 the result is C¹ at 0; for exponent == 1 it has a kink (use
    :func:`smooth_ramp` first to regularize).
    """
    x = jnp.asarray(x)
    pos = x > 0
    return jnp.where(pos, jnp.power(jnp.where(pos, x, 1.0), exponent), 0.0)


def smooth_ramp(x: ArrayLike, width: ArrayLike) -> Array:
    """C¹ regularization of max(x, 0) with a quadratic blend of half-width ``width``.

        ramp(x) = 0                    for x <= -w
                = (x + w)² / (4 w)     for |x| < w
                = x                    for x >= w

    Exact outside ``|x| < w``; inside, it over-reports by at most w/4 (at x = 0) and is
    positive from x = -w on. ``width = 0`` gives the plain (C⁰) ``max(x, 0)``.
    """
    x = jnp.asarray(x)
    w = jnp.asarray(width)
    w_pos = w > 0
    w_safe = jnp.where(w_pos, w, 1.0)
    blend = (x + w_safe) ** 2 / (4.0 * w_safe)
    smooth = jnp.where(x >= w_safe, x, jnp.where(x <= -w_safe, 0.0, blend))
    return jnp.where(w_pos, smooth, jnp.maximum(x, 0.0))


def parabola_max(f0: ArrayLike, fm: ArrayLike, f1: ArrayLike) -> Array:
    """Max of the parabola through three equally spaced samples, over their span.

    With ``b = (f1 - f0)/2`` and ``a = (f0 + f1)/2 - fm`` the parabola is
    ``fm + b s + a s²`` on ``s ∈ [-1, 1]``; its top lies inside when ``-2a > |b|`` and is
    ``fm - b²/(4a)`` there, else the larger end sample. Never below the three samples,
    continuous (at ``-2a = |b|`` both forms give the end sample) with bounded gradients
    (``|b/a| < 2`` where the vertex is used). The error of a smooth peak's top falls with
    the step as h³ rather than the samples' h². NaN in any sample propagates.
    """
    f0, fm, f1 = jnp.asarray(f0), jnp.asarray(fm), jnp.asarray(f1)
    b = 0.5 * (f1 - f0)
    a = 0.5 * (f0 + f1) - fm
    inside = -2.0 * a > jnp.abs(b)
    a_safe = jnp.where(inside, a, -1.0)
    top = jnp.where(inside, fm - b * b / (4.0 * a_safe), jnp.maximum(f0, f1))
    return jnp.maximum(fm, top)
