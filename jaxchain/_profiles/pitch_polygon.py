"""The seats of a non-circular sprocket: a closed polygon of z equal chords on a pitch
curve r(θ) = R₀ + Σ Aᵢ·sin(nᵢθ + φᵢ)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import optimistix as optx

__all__ = ["pitch_polygon"]


def _points(theta, radius0, orders, amplitudes, phases):
    r = radius0 + jnp.sum(
        amplitudes[:, None] * jnp.sin(orders[:, None] * theta[None, :] + phases[:, None]), 0
    )
    return r, jnp.stack([r * jnp.cos(theta), r * jnp.sin(theta)], -1)


@functools.partial(jax.jit, static_argnames=("teeth", "rtol"))  # one program, not op by op
def pitch_polygon(teeth: int, pitch, orders, amplitudes, phases, *, rtol: float = 1e-14):
    """Seat angles θ (z,) [rad] (θ₀ = 0, increasing) and radii r(θ) (z,) [m] of the closed
    polygon whose z chords all equal ``pitch``, on the curve r(θ) = R₀ + Σ Aᵢsin(nᵢθ + φᵢ)
    with R₀ solved for (the curve's mean radius that closes the polygon). Newton from the
    circle; differentiable in ``pitch``, ``amplitudes`` and ``phases`` (implicit function
    theorem). Also returns R₀ and the largest chord error [m]."""
    z = teeth
    dtype = jnp.result_type(jnp.asarray(pitch, float), jnp.asarray(amplitudes, float))
    pitch = jnp.asarray(pitch, dtype)
    orders = jnp.asarray(orders, dtype)
    amplitudes, phases = jnp.asarray(amplitudes, dtype), jnp.asarray(phases, dtype)
    nominal = 2 * jnp.pi * jnp.arange(z, dtype=dtype) / z
    circle = pitch / (2 * jnp.sin(jnp.pi / z))

    def unpack(x, args):
        p, a, ph = args
        theta = nominal + jnp.concatenate([jnp.zeros((1,), dtype), x[1:]])
        return theta, circle + x[0] * p

    def residual(x, args):
        p, a, ph = args
        theta, r0 = unpack(x, args)
        _, pts = _points(theta, r0, orders, a, ph)
        chord = jnp.roll(pts, -1, 0) - pts
        return jnp.sum(chord * chord, -1) / p**2 - 1.0

    args = (pitch, amplitudes, phases)
    sol = optx.root_find(
        residual, optx.Newton(rtol=rtol, atol=rtol), jnp.zeros((z,), dtype), args,
        max_steps=64, throw=False,
    )  # fmt: skip
    theta, r0 = unpack(sol.value, args)
    r, pts = _points(theta, r0, orders, amplitudes, phases)
    err = jnp.max(jnp.abs(jnp.linalg.norm(jnp.roll(pts, -1, 0) - pts, axis=-1) - pitch))
    return theta, r, r0, err
