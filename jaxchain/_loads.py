"""Loads: the torque a driven sprocket's machine puts on its shaft.

A load is a small ``eqx.Module`` with one method, ``torque(t, angle, speed)`` [N·m]: the
torque resisting the sprocket's rotation at time ``t`` [s], where ``angle`` [rad] is the
angle the sprocket has turned since the start and ``speed`` [rad/s] its speed, both
positive in the direction the sprocket runs (a sprocket the chain wraps clockwise runs
clockwise). Its array leaves can be differentiated and vmapped like the rest of a scene.

The statics hold a load at its value at the start (``t = 0``, ``angle = 0``, the
sprocket's starting speed); :class:`~jaxchain.observers.LoadWork` integrates the work the
loads take out of the drive, which closes the energy balance.

A new load subclasses :class:`AbstractLoad` and implements ``torque``; nothing else in
jaxchain changes.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from . import _checks as checks
from ._numerics import is_concrete

__all__ = ["AbstractLoad", "Constant", "Ramped", "Harmonic", "camshaft_torque", "as_load"]


class AbstractLoad(eqx.Module):
    """A torque resisting a sprocket's rotation, a function of time, its angle turned since
    the start and its speed (both in its running direction)."""

    @abc.abstractmethod
    def torque(self, t, angle, speed) -> Array:
        """The resisting torque [N·m] at time ``t`` [s], angle ``angle`` [rad] turned since
        the start and speed ``speed`` [rad/s]."""

    @property
    def mean_torque(self) -> Array:
        """The torque about which the load varies [N·m] (what layouts and the chain's
        static tension checks use); by default its value at the start, at rest."""
        return self.torque(0.0, 0.0, 0.0)

    def is_zero(self) -> bool:
        """Whether the load is known to be zero at every instant (an idler); concrete values
        only."""
        return False


class Constant(AbstractLoad):
    """A constant resisting torque ``value`` [N·m]."""

    value: Float[Array, ""]

    def __init__(self, value: ArrayLike):
        self.value = jnp.asarray(checks.real_leaf("Constant: value", value, "N·m"), dtype=float)

    def __check_init__(self):
        _finite(self, "Constant", "value")

    def torque(self, t, angle, speed):
        del t, angle, speed
        return self.value

    @property
    def mean_torque(self):
        return self.value

    def is_zero(self) -> bool:
        return is_concrete(self) and not np.any(np.asarray(self.value))


class Ramped(AbstractLoad):
    """A torque rising smoothly (C¹ smoothstep) from 0 at t = 0 to ``value`` [N·m] at
    ``duration`` [s], then constant; ``duration = 0`` applies it at once."""

    value: Float[Array, ""]
    duration: Float[Array, ""]

    def __init__(self, value: ArrayLike, duration: ArrayLike):
        self.value = jnp.asarray(checks.real_leaf("Ramped: value", value, "N·m"), dtype=float)
        self.duration = jnp.asarray(checks.real_leaf("Ramped: duration", duration, "s"), float)

    def __check_init__(self):
        _finite(self, "Ramped", "value", "duration")
        if is_concrete(self) and np.any(np.asarray(self.duration) < 0):
            raise ValueError(f"Ramped: duration must be >= 0 s, got {self.duration}")

    def torque(self, t, angle, speed):
        del angle, speed
        ramp = self.duration
        x = jnp.clip(t / jnp.where(ramp > 0, ramp, 1.0), 0.0, 1.0)
        return self.value * jnp.where(ramp > 0, x * x * (3 - 2 * x), 1.0)

    @property
    def mean_torque(self):
        return self.value

    def is_zero(self) -> bool:
        return is_concrete(self) and not np.any(np.asarray(self.value))


class Harmonic(AbstractLoad):
    """A torque periodic in the sprocket's angle: τ = mean + Σ Aₖ·sin(nₖ·angle + φₖ) [N·m].

    ``harmonics`` is a sequence of ``(order, amplitude, phase)``: order nₖ in cycles per
    revolution of this sprocket (need not be an integer), amplitude Aₖ [N·m], phase φₖ
    [rad]. A camshaft's valve-train torque is of this form: on a four-cylinder engine its
    strongest order is the 2nd of the crankshaft, the 4th of a camshaft that turns at half
    the crank's speed. The torque depends on the angle only, so it is conservative: its
    work over a whole number of periods is ``mean`` times the angle turned.
    """

    mean: Float[Array, ""]
    orders: Float[Array, " H"]
    amplitudes: Float[Array, " H"]
    phases: Float[Array, " H"]

    def __init__(self, mean: ArrayLike, harmonics: Sequence[Sequence[float]] = ()):
        rows = checks.harmonics(
            "Harmonic",
            harmonics,
            " (one (order, amplitude, phase) row per harmonic; a load per ensemble member is "
            "one Harmonic per scene)",
        )
        self.mean = jnp.asarray(checks.real_leaf("Harmonic: mean", mean, "N·m"), dtype=float)
        self.orders = jnp.asarray([h[0] for h in rows], dtype=float).reshape(-1)
        self.amplitudes = jnp.asarray([h[1] for h in rows], dtype=float).reshape(-1)
        self.phases = jnp.asarray([h[2] for h in rows], dtype=float).reshape(-1)

    def __check_init__(self):
        _finite(self, "Harmonic", "mean", "orders", "amplitudes", "phases")
        if is_concrete(self) and np.any(np.asarray(self.orders) <= 0):
            raise ValueError(
                f"Harmonic: every order must be > 0 (cycles per revolution), got "
                f"{np.asarray(self.orders).tolist()}"
            )

    def torque(self, t, angle, speed):
        del t, speed
        wave = self.amplitudes * jnp.sin(self.orders * angle + self.phases)
        return self.mean + jnp.sum(wave, axis=-1)

    @property
    def mean_torque(self):
        return self.mean


def camshaft_torque(
    *,
    cylinders: int = 4,
    valves: int = 2,
    lift: float = 8.5e-3,
    duration_deg: float = 240.0,
    preload: float = 220.0,
    rate: float = 35e3,
    mass: float = 0.06,
    friction: float = 1.5,
    engine_rpm: float = 0.0,
    phase_deg: float = 0.0,
    orders: int = 4,
) -> Harmonic:
    """The valve-train torque on one camshaft of an in-line engine with bucket tappets, as
    a :class:`Harmonic` in the camshaft's own angle.

    Each of ``cylinders`` lobes (evenly spaced, one per cylinder; ``valves`` valves per
    lobe) lifts its valves by h(φ) = lift·sin²(π·φ/Δ) over a cam angle Δ =
    ``duration_deg`` against the valve spring (``preload`` [N] at closed, ``rate`` [N/m])
    and the inertia of the moving mass per valve ``mass`` [kg] (valve, retainer, tappet, a
    third of the spring) at the engine speed ``engine_rpm`` (the camshaft turns at half
    it). Its torque is F·dh/dφ, F = preload + rate·h + mass·ω_cam²·h″: positive (resisting)
    while the valves open, negative (driving) while the springs close them. ``friction``
    [N·m] is the mean drag (bearings, tappets); ``phase_deg`` turns the lobes (intake
    against exhaust camshaft). The first ``orders`` harmonics of the lobe frequency are
    kept: camshaft orders ``cylinders``·k, the engine's 2nd, 4th, 6th, … orders on a
    four-cylinder four-stroke engine.

    The defaults are those of a 1.6–2.0 L four-cylinder 16-valve petrol engine (lift,
    opening duration, spring force and moving mass of that class): a torque swinging
    between about −9 and +12 N·m per camshaft, its 2nd engine order 8–10 N·m (less at
    speed, where the valves' inertia unloads the springs). These are a model's numbers,
    not a measured engine's: for a given engine, fit :class:`Harmonic` to its torque.
    """
    for name, v, unit in (("lift", lift, "m"), ("duration_deg", duration_deg, "(cam degrees)")):
        checks.real(f"camshaft_torque: {name}", v, lo=0.0, lo_open=True, unit=unit)
    checks.real("camshaft_torque: duration_deg", duration_deg, hi=720.0, hi_open=True)
    for name, v, unit in (
        ("rate", rate, "N/m"), ("preload", preload, "N"), ("mass", mass, "kg"),
        ("engine_rpm", engine_rpm, "rpm (the crank's speed; 0: no valve inertia)"),
    ):  # fmt: skip
        checks.real(f"camshaft_torque: {name}", v, lo=0.0, unit=unit)
    checks.real("camshaft_torque: friction", friction, lo=0.0, unit="N·m (the mean drag)")
    checks.real("camshaft_torque: phase_deg", phase_deg, unit="(degrees)")
    for name, v in (("cylinders", cylinders), ("valves", valves), ("orders", orders)):
        checks.integer(f"camshaft_torque: {name}", v, lo=1)
    checks.integer(
        "camshaft_torque: cylinders·orders (the highest camshaft order kept)",
        cylinders * orders, lo=1, hi=1024,
    )  # fmt: skip
    n = 4096
    phi = 2 * np.pi * np.arange(n) / n
    width = np.radians(duration_deg) / 2  # cam angle
    w_cam = engine_rpm * np.pi / 60  # rad/s: half the crank's
    tau = np.zeros(n)
    for c in range(cylinders):
        x = np.mod(phi - 2 * np.pi * c / cylinders - np.radians(phase_deg), 2 * np.pi)
        open_ = x < width
        s = np.pi * x / width
        h = np.where(open_, lift * np.sin(s) ** 2, 0.0)
        dh = np.where(open_, lift * np.pi / width * np.sin(2 * s), 0.0)
        ddh = np.where(open_, 2 * lift * (np.pi / width) ** 2 * np.cos(2 * s), 0.0)
        force = np.where(open_, preload + rate * h + mass * w_cam**2 * ddh, 0.0)
        tau += valves * force * dh
    spec = np.fft.rfft(tau) / n
    rows = []
    for k in range(1, orders + 1):
        order = k * cylinders
        c = 2 * spec[order]  # τ ⊃ Re(c·e^{i·order·φ}) = |c|·sin(order·φ + arg c + π/2)
        rows.append((float(order), float(abs(c)), float(np.angle(c) + np.pi / 2)))
    return Harmonic(friction + spec[0].real, rows)


def _finite(load, kind: str, *names: str) -> None:
    if not is_concrete(load):
        return
    for name in names:
        value = np.asarray(getattr(load, name))
        if not np.all(np.isfinite(value)):
            raise ValueError(f"{kind}: {name} must be finite, got {value.tolist()}")


def as_load(value, name: str = "load_torque", *, ramp: ArrayLike = 0.0) -> AbstractLoad:
    """A load from what a builder was given: an :class:`AbstractLoad` as is; a number as a
    :class:`Ramped` over ``ramp`` [s] (``ramp = 0``: applied at once), one type whatever
    the ramp so that scenes built from numbers stack."""
    if isinstance(value, AbstractLoad):
        return value
    if isinstance(value, eqx.Module):
        raise TypeError(
            f"{name} must be a number [N·m] or a jc.loads load (jc.loads.Constant, "
            f"jc.loads.Ramped, jc.loads.Harmonic, or a subclass of jc.loads.AbstractLoad), "
            f"got {type(value).__name__}"
        )
    return Ramped(value, ramp)
