"""Order-domain observers: mesh-order lines and speed variation, integrated inside the solve.

A test rig measures a drive signal (the torque on a sprocket, its bearing force) and reads
its spectrum in *orders* of a shaft's rotation: order n is n cycles per revolution. The
mesh order of a z-tooth sprocket is z; a pattern that differs from gap to gap spreads its
line into sidebands at the neighbouring integer orders. The observers here compute those
lines as running Fourier integrals carried by the one solve (extra ODE states under the
solver's error control), so they are exact in continuous time and differentiable, and no
trajectory is saved for an FFT.

Window: Hann over revolutions [start, end] of the reference sprocket (counted from its
angle at t = 0), C¹ at both ends (w and w' vanish there). Windows in revolutions make one
observer serve every member of a speed ensemble. Spanning N revolutions, neighbouring
integer orders are N bins apart; Hann's leakage reaches its first zero 2 bins off the
line, so N ≥ 2 revolutions separate every integer order. The window's own integral
∫ w dt is integrated alongside, so the normalization holds at any speed (exact order
tracking at a constant speed of the reference, as for a driver).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _checks as checks
from .._dynamics import DriveState, Forces
from .._numerics import is_concrete
from .._scene import Scene
from .base import AbstractIntegralObserver

__all__ = [
    "SIGNALS",
    "hann_window",
    "OrderSpectrum",
    "BandLevel",
    "SpeedVariation",
    "level_db",
]

#: Signals an order observer can read: the torque of the chain on a sprocket [N·m], the
#: magnitude of the chain's force on its axis (the bearing force) [N], or one component.
SIGNALS = ("torque", "bearing", "bearing_x", "bearing_y")

_FLOOR = 1e-12  # amplitudes are floored at this (signal units) before a logarithm


def hann_window(x, start, end):
    """Hann window over [start, end]: sin²(π(x − start)/(end − start)) inside, 0 outside;
    C¹ everywhere, its integral (end − start)/2."""
    u = jnp.clip((x - start) / (end - start), 0.0, 1.0)
    return jnp.sin(jnp.pi * u) ** 2


def _revolutions(y: DriveState, scene: Scene, k: int):
    """Revolutions sprocket k has turned since t = 0 (either direction)."""
    return jnp.abs(y.theta[k] - scene.sprockets[k].angle0) / (2 * jnp.pi)


def level_db(amplitude: ArrayLike, reference: ArrayLike = 1.0) -> Array:
    """20·log10(amplitude / reference) [dB], smooth down to a floor of 1e-12·reference."""
    a = jnp.asarray(amplitude) / reference
    return 10.0 * jnp.log10(a * a + _FLOOR**2)


def _signal(kind: str, k: int, forces: Forces) -> Array:
    if kind == "torque":
        return forces.sprocket_torque[k]
    f = forces.sprocket_force[k]
    if kind == "bearing_x":
        return f[0]
    if kind == "bearing_y":
        return f[1]
    return jnp.sqrt(jnp.sum(f * f) + 1e-12)  # smooth magnitude (1e-6 N floor)


def _check_window(owner: str, start, end) -> None:
    if is_concrete(start, end):
        a = checks.real(f"{owner}.start", start, lo=0.0, unit="revolutions")
        checks.real(f"{owner}.end", end, lo=a, lo_open=True, unit=f"revolutions (start = {a:.6g})")


def _check_sprocket(owner: str, name: str, k, n: int | None = None) -> int:
    return checks.integer(f"{owner}.{name}", k, lo=0, hi=None if n is None else n - 1)


def _check_in_scene(owner: str, scene: Scene, *indices: tuple[str, int]) -> None:
    ns = len(scene.sprockets)
    for name, k in indices:
        if k >= ns:
            raise ValueError(
                f"{owner}: {name}={k} but the scene has {ns} sprocket(s); use an index in "
                f"[0, {ns - 1}]"
            )


class _AbstractOrders(AbstractIntegralObserver):
    """Running Fourier integrals ∫ w·s(t)·(cos nφ, sin nφ) dt of a signal s at the
    rotation orders n of a reference sprocket (angle φ), and ∫ w dt. Concrete subclasses
    turn them into what they report."""

    orders: eqx.AbstractVar[Float[Array, " n"]]
    start: eqx.AbstractVar[Float[Array, ""]]
    end: eqx.AbstractVar[Float[Array, ""]]
    signal: eqx.AbstractVar[str]
    sprocket: eqx.AbstractVar[int]
    reference: eqx.AbstractVar[int]

    def integrand(self, t, y: DriveState, scene: Scene, forces: Forces) -> Array:
        _check_in_scene(
            type(self).__name__, scene, ("sprocket", self.sprocket), ("reference", self.reference)
        )
        w = hann_window(_revolutions(y, scene, self.reference), self.start, self.end)
        s = _signal(self.signal, self.sprocket, forces)
        phase = self.orders * y.theta[self.reference]
        lines = (w * s) * jnp.stack([jnp.cos(phase), jnp.sin(phase)])
        return jnp.concatenate([lines, jnp.broadcast_to(w, (1, self.orders.shape[0]))])

    def amplitudes(self, state: Array) -> Array:
        """(n,) amplitude of each order [signal units]: a signal a·cos(nφ + c) gives a
        (n > 0; the mean for n = 0)."""
        gain = jnp.maximum(state[2], 1e-300)  # ∫ w dt
        scale = jnp.where(self.orders == 0, 1.0, 2.0) / gain
        return scale * jnp.sqrt(jnp.sum(state[:2] ** 2, axis=0) + (_FLOOR * gain) ** 2)


def _orders_array(owner: str, orders) -> Array:
    a = np.asarray(orders, dtype=float)
    if a.ndim != 1 or a.size < 1:
        raise ValueError(f"{owner}: orders must be a 1-D array of rotation orders, got {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{owner}: orders must be finite and >= 0, got {a.tolist()}")
    return jnp.asarray(a)


def _set_order_fields(obs, orders, start, end, signal, sprocket, reference) -> None:
    """Check and set the fields every order observer has (``obs`` under construction)."""
    owner = type(obs).__name__
    obs.orders = _orders_array(owner, orders)
    _check_window(owner, start, end)
    obs.start = jnp.asarray(start, dtype=float)
    obs.end = jnp.asarray(end, dtype=float)
    obs.signal = checks.choice(f"{owner}.signal", signal, SIGNALS)
    obs.sprocket = _check_sprocket(owner, "sprocket", sprocket)
    ref = sprocket if reference is None else reference
    obs.reference = _check_sprocket(owner, "reference", ref)


class OrderSpectrum(_AbstractOrders):
    """Amplitudes of chosen rotation orders of a drive signal [signal units] (Hann window
    over revolutions [start, end] of the reference; see the module docstring for the
    resolution it needs).

    ``value`` is the (n,) array of amplitudes, one per order: a component a·cos(nφ + c) of
    the signal reads a. Convert with :func:`level_db`.

    Attributes:
        orders: (n,) rotation orders of sprocket ``reference`` (its mesh order is its
            tooth count).
        start, end: the window [revolutions of ``reference`` since t = 0].
        signal: one of ``SIGNALS`` (static).
        sprocket: the sprocket whose signal is read (static).
        reference: the sprocket whose rotation angle defines the orders (static; default
            the same sprocket).
    """

    orders: Float[Array, " n"]
    start: Float[Array, ""]
    end: Float[Array, ""]
    signal: str = eqx.field(static=True)
    sprocket: int = eqx.field(static=True)
    reference: int = eqx.field(static=True)

    def __init__(
        self,
        orders: ArrayLike,
        start: ArrayLike,
        end: ArrayLike,
        *,
        signal: str = "torque",
        sprocket: int = 0,
        reference: int | None = None,
    ):
        _set_order_fields(self, orders, start, end, signal, sprocket, reference)

    def value(self, state, t0, t1):
        return self.amplitudes(state)


class BandLevel(_AbstractOrders):
    """The largest spectrum line of a band of orders, smoothly [dB re ``level_reference``]:

        L = τ·log Σ_n exp(L_n/τ),   L_n = 20·log10(A_n / A_ref)

    a log-sum-exp of the lines' levels at temperature τ [dB]: never below the largest
    line and at most τ·log(n_lines) above it (one dominant line: τ·log(1 + …) above),
    differentiable in everything; a conservative upper bound to minimize. The band is
    every integer order in [``low``, ``high``] (mesh orders × tooth count, when built by
    :meth:`mesh_band`).

    Attributes:
        orders: (n,) the band's integer rotation orders of sprocket ``reference``.
        start, end: the window [revolutions of ``reference`` since t = 0] (≥ 2
            revolutions separate neighbouring integer orders).
        temperature: τ [dB], > 0.
        level_reference: A_ref [signal units] (1 N·m or 1 N by default).
        signal, sprocket, reference: as in :class:`OrderSpectrum` (static).
    """

    orders: Float[Array, " n"]
    start: Float[Array, ""]
    end: Float[Array, ""]
    temperature: Float[Array, ""]
    level_reference: Float[Array, ""]
    signal: str = eqx.field(static=True)
    sprocket: int = eqx.field(static=True)
    reference: int = eqx.field(static=True)

    def __init__(
        self,
        orders: ArrayLike,
        start: ArrayLike,
        end: ArrayLike,
        *,
        temperature: ArrayLike = 0.5,
        level_reference: ArrayLike = 1.0,
        signal: str = "torque",
        sprocket: int = 0,
        reference: int | None = None,
    ):
        _set_order_fields(self, orders, start, end, signal, sprocket, reference)
        if is_concrete(temperature, level_reference):
            checks.real("BandLevel.temperature", temperature, lo=0.0, lo_open=True, unit="dB")
            checks.real(
                "BandLevel.level_reference", level_reference, lo=0.0, lo_open=True,
                unit="(signal units)",
            )  # fmt: skip
        self.temperature = jnp.asarray(temperature, dtype=float)
        self.level_reference = jnp.asarray(level_reference, dtype=float)

    @classmethod
    def mesh_band(
        cls,
        teeth: int,
        start: ArrayLike,
        end: ArrayLike,
        band: tuple[float, float] = (0.5, 3.5),
        **kwargs,
    ) -> BandLevel:
        """Every integer rotation order between ``band[0]`` and ``band[1]`` mesh orders of
        a ``teeth``-tooth reference sprocket (default 0.5–3.5: the mesh order, its
        second and third harmonics and the sidebands between them)."""
        checks.integer("teeth", teeth, lo=1)
        lo, hi = checks.pair("band", band, 2, "mesh orders (low, high)")
        lo = checks.real("band[0]", lo, lo=0.0, unit="mesh orders")
        checks.real("band[1]", hi, lo=lo, lo_open=True, unit=f"mesh orders (band[0] = {lo})")
        orders = np.arange(math.ceil(lo * teeth - 1e-9), math.floor(hi * teeth + 1e-9) + 1)
        if orders.size == 0:
            raise ValueError(f"band {band} holds no integer order of a {teeth}-tooth sprocket")
        return cls(orders, start, end, **kwargs)

    def levels(self, state: Array) -> Array:
        """(n,) each line's level [dB re ``level_reference``]."""
        return level_db(self.amplitudes(state), self.level_reference)

    def value(self, state, t0, t1):
        tau = self.temperature
        return tau * jax.nn.logsumexp(self.levels(state) / tau)


class SpeedVariation(AbstractIntegralObserver):
    """Chordal speed variation of a sprocket: the RMS of its angular speed about its mean,
    relative to the mean, over a Hann window in revolutions of a reference sprocket
    (fraction; 0.01 = 1 %):

        v = sqrt(⟨ω²⟩ − ⟨ω⟩²) / ⟨ω⟩,   ⟨x⟩ = ∫ w x dt / ∫ w dt

    A polygonal drive's driven sprocket varies by about (1 − cos(π/z))/2 per sprocket
    at the mesh order; the RMS of a sinusoid is its amplitude / √2.

    Attributes:
        start, end: the window [revolutions of ``reference`` since t = 0].
        sprocket: the sprocket observed (static).
        reference: the sprocket whose revolutions place the window (static; default the
            driver, 0).
    """

    start: Float[Array, ""]
    end: Float[Array, ""]
    sprocket: int = eqx.field(static=True)
    reference: int = eqx.field(static=True)

    def __init__(self, start: ArrayLike, end: ArrayLike, *, sprocket: int = 1, reference=0):
        _check_window("SpeedVariation", start, end)
        self.start = jnp.asarray(start, dtype=float)
        self.end = jnp.asarray(end, dtype=float)
        self.sprocket = _check_sprocket("SpeedVariation", "sprocket", sprocket)
        self.reference = _check_sprocket("SpeedVariation", "reference", reference)

    def integrand(self, t, y, scene, forces):
        _check_in_scene(
            "SpeedVariation", scene, ("sprocket", self.sprocket), ("reference", self.reference)
        )
        w = hann_window(_revolutions(y, scene, self.reference), self.start, self.end)
        # about the sprocket's initial speed (the nominal ω1·z1/zk of a built drive): the
        # integrals then hold the small deviation, not ω² (whose error control would
        # swamp the variance)
        spr = scene.sprockets[self.sprocket]
        d = y.omega[self.sprocket] - spr.speed
        return w * jnp.stack([d, d * d, jnp.ones_like(d), spr.speed])

    def value(self, state, t0, t1):
        gain = jnp.maximum(state[2], 1e-300)  # ∫ w dt
        mean_dev, square = state[0] / gain, state[1] / gain
        mean = state[3] / gain + mean_dev
        var = square - mean_dev * mean_dev
        return jnp.sqrt(jnp.maximum(var, 0.0) + 1e-30) / jnp.abs(mean)
