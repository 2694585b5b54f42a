"""Observers: quantities computed along the one solve, carried by it.

Two kinds plug into the solve (see ``jaxchain._solve.solve``):

* a **step observer** sees every accepted step (its start and end states and the solver's
  dense interpolant over it) and keeps a running state in the solver state — the peak
  record, the solve's health;
* an **integral observer** adds an integrand to the vector field, integrated by the solver
  as extra states under its error control — the soft peak, running Fourier integrals.

Both read the drive's forces from the same evaluation the dynamics use, and finish with a
``value`` computed from their final state.
"""

from __future__ import annotations

import abc
from typing import Any, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _checks as checks
from .._dynamics import (
    DriveState,
    Forces,
    contact_slots_ok,
    peak_tension,
    roller_kinematics,
    roller_normal_forces,
)
from .._numerics import is_concrete, parabola_max
from .._scene import Scene

__all__ = [
    "AbstractObserver",
    "AbstractStepObserver",
    "AbstractIntegralObserver",
    "PeakRecord",
    "SoftPeak",
    "SampledSoftPeak",
    "LoadWork",
    "Health",
    "window_weight",
    "EXP_CAP",
]

# a roller faster than this many times (pitch-line speed + reference impact speed) has
# flown apart (the solve diverged): the solve's health check reports it
FLYING_APART = 5.0


class AbstractObserver(eqx.Module):
    """Something computed along a solve; ``value`` turns its final state into the result.

    ``reads_rollers``: whether it reads the rollers' contact forces (a scene without
    rollers, ``fidelity="spans"``, refuses it)."""

    reads_rollers: ClassVar[bool] = False

    @abc.abstractmethod
    def value(self, state: Any, t0: Array, t1: Array) -> Any:
        """The observed quantity from the final state over [t0, t1]."""


class AbstractStepObserver(AbstractObserver):
    """Sees every accepted step; its state rides in the solver state (a rejected step
    leaves it untouched)."""

    @abc.abstractmethod
    def init(self, t0: Array, y0: DriveState, scene: Scene) -> Any:
        """State before the first step."""

    @abc.abstractmethod
    def step(self, t0, t1, y0: DriveState, y1: DriveState, dense, scene: Scene, state) -> Any:
        """State after the accepted step [t0, t1]; ``dense(ts)`` gives the states at times
        ``ts`` (n,) inside it from the solver's own interpolant, stacked."""


class AbstractIntegralObserver(AbstractObserver):
    """An integrand added to the vector field: ``value`` receives ∫ integrand dt over the
    solve (extra ODE states, under the solver's error control)."""

    @abc.abstractmethod
    def integrand(self, t, y: DriveState, scene: Scene, forces: Forces) -> Array:
        """The integrand at one instant (any fixed shape)."""


class LoadWork(AbstractIntegralObserver):
    """The work each sprocket's load has taken out of the drive since the start [J], (S,):
    ∫ τ_load·ω dt, τ_load the load's torque against counter-clockwise rotation and ω the
    sprocket's speed (0 for the driver, which carries no load). With it the energy balance
    closes: the stored energy (:func:`~jaxchain.energy`) changes by the driver's work minus
    this, minus what damping and friction dissipate."""

    def integrand(self, t, y, scene, forces):
        del forces
        return jnp.stack(
            [s.load(t, y.theta[k], y.omega[k]) * y.omega[k] for k, s in enumerate(scene.sprockets)]
        )

    def value(self, state, t0, t1):
        return state


def check_rollers(scene: Scene, observers, caller: str) -> None:
    """``ValueError`` if an observer that reads the rollers' contact forces is given a
    scene without rollers."""
    require_rollers(scene, [type(o).__name__ for o in observers if _reads_rollers(o)], caller)


def require_rollers(scene: Scene, readers: list[str], caller: str) -> None:
    """``ValueError`` if ``readers`` (names of what reads the rollers' contact forces) are
    given a scene without rollers."""
    if readers and scene.n_rollers == 0:
        raise ValueError(
            f"{caller}: {', '.join(readers)} read(s) the roller/tooth forces, and this scene "
            "has no rollers (fidelity='spans': its spans are springs between the sprockets' "
            "pitch curves); use fidelity='lumped' or 'clearance', or observe what the span "
            "model has (OrderSpectrum, BandLevel or SpeedVariation of its tensions and speeds)"
        )


def _reads_rollers(observer) -> bool:
    """Whether ``observer`` (or an observer it holds) reads roller forces."""
    if observer.reads_rollers:
        return True
    held = [v for v in vars(observer).values() if isinstance(v, AbstractObserver)]
    return any(_reads_rollers(o) for o in held)


# ---------------------------------------------------------------------------- peak record
def _roller_forces(y: DriveState, scene: Scene) -> Float[Array, " R"]:
    """(R,) each roller's tooth force, summed over sprockets."""
    return jnp.sum(roller_normal_forces(y, scene), axis=0)


class PeakRecord(AbstractStepObserver):
    """The largest roller/tooth normal force over every accepted step [N] (what
    ``Solution.peak_contact_force`` reports, with the save times').

    Each step's force is read per roller at its start and end; where it can reach the
    record inside the step, also at ``samples − 1`` equally spaced interior times (states
    from the solver's dense interpolant). The step's top is then the largest
    :func:`~jaxchain._numerics.parabola_max` over consecutive sample triples (never below
    a sample, continuous in them). The step ends alone miss the top of a short impact by
    up to the step's share of it; the samples take the peak's error down by about an
    order of magnitude at the tolerances a meshing study uses
    (``benchmarks/work_precision.py`` charts error against time for each solver).

    Where the top can be (``gate``, the default): a roller's force inside a step exceeds
    the larger of its ends by at most |f''|·h²/8; f'' is estimated from the roller's
    force at the ends of this step and the last one. The interior is sampled only in the
    steps where some roller's end force plus eight times that bound reaches the record —
    the steps of an impact's top; elsewhere (seated rollers, free spans) only the end
    force is read, one contact evaluation per step instead of ``samples``
    (``python -m benchmarks.step_cost`` measures both and their peaks). ``gate=False``
    samples every step. Under ``vmap`` (ensembles) both branches run, as without the
    gate. NaN in any sample propagates (a blown-up step is reported, never skipped).

    Give one in ``simulate``'s ``observers`` to set how ``peak_contact_force`` is read
    (it is then that record, not a second one).

    Attributes:
        samples: intervals per step (static, ≥ 2: a parabola needs a start, an interior
            and an end sample).
        gate: sample the interior only where the record can be reached (static).
    """

    reads_rollers: ClassVar[bool] = True
    #: the curvature bound's safety factor (the force's curvature changes within a step)
    SAFETY: ClassVar[float] = 8.0

    samples: int = eqx.field(static=True, default=4)
    gate: bool = eqx.field(static=True, default=True)

    def __init__(self, samples: int = 4, gate: bool = True):
        ok = isinstance(samples, (int, np.integer)) and not isinstance(samples, bool)
        if not (ok and samples >= 2):
            raise ValueError(
                f"PeakRecord: samples must be an int >= 2 (a parabola needs a start, an "
                f"interior and an end sample); got {samples!r}"
            )
        self.samples = int(samples)
        self.gate = checks.flag("PeakRecord: gate", gate)

    def init(self, t0, y0, scene):
        f0 = _roller_forces(y0, scene)
        peak = jnp.max(f0, initial=0.0)  # forces ≥ 0; 0 for a scene without rollers
        # (peak, force at the step's start, at the last step's start, the last step's h)
        return peak, f0, f0, jnp.zeros_like(peak)

    def step(self, t0, t1, y0, y1, dense, scene, state):
        peak, f0, fp, hp = state
        n = self.samples
        h = t1 - t0
        f1 = _roller_forces(y1, scene)

        def sampled():
            ts = t0 + h * jnp.arange(1, n) / n
            fi = jax.vmap(_roller_forces, in_axes=(0, None))(dense(ts), scene)
            f = jnp.concatenate([f0[None], fi, f1[None]])  # (n + 1, R) at t0, ..., t1
            return jnp.maximum(peak, jnp.max(parabola_max(f[:-2], f[1:-1], f[2:]), initial=0.0))

        if not self.gate:
            return sampled(), f1, f0, h
        ends = lambda: jnp.maximum(peak, jnp.max(f1, initial=0.0))
        peak = jax.lax.cond(self.interior_needed(h, f1, state), sampled, ends)
        return peak, f1, f0, h

    def interior_needed(self, h, f1, state) -> Array:
        """Whether a step of length ``h`` whose rollers end at forces ``f1`` can hold a
        force at or above the record inside (the ``gate``): f'' from the three end forces
        (t0 − hp, t0, t0 + h), the first step always."""
        peak, f0, fp, hp = state
        hp_safe = jnp.where(hp > 0, hp, 1.0)
        curve = 2 * ((f1 - f0) / h - (f0 - fp) / hp_safe) / (h + hp_safe)
        reach = jnp.maximum(f0, f1) + self.SAFETY * jnp.abs(curve) * h * h / 8
        return (hp <= 0) | jnp.any(reach >= peak) | ~jnp.all(jnp.isfinite(reach))

    def value(self, state, t0, t1):
        return state[0]


# ---------------------------------------------------------------------------- health
class Health(AbstractStepObserver):
    """Whether the solution stayed physical at every accepted step's end: finite, rollers
    inside the scene (within 1000 × its size) and slower than ``FLYING_APART`` ×
    (pitch-line speed + reference impact speed) — an explicit step above its stability
    limit makes the stiffest mode ring up and the rollers outrun anything the drive can
    give them (engagement: ≤ 1.1× the pitch-line speed when right, 8× at a peak force 5×
    too high, 10⁵× later) — and every roller within reach of a sprocket inside its
    contact slots; it also keeps the largest tension of any link (compared with the
    chain's tensile strength). Carried by every solve; read by the one classification."""

    def _limits(self, scene):
        size = jnp.max(jnp.abs(scene.q0[:, :2]), initial=0.0) + jnp.max(
            jnp.stack([jnp.max(jnp.abs(s.centre)) for s in scene.sprockets])
        )
        chain_speed = jnp.max(
            jnp.stack([jnp.abs(s.speed) * s.profile.pitch_radius for s in scene.sprockets])
        )
        return 1e3 * size, FLYING_APART * (chain_speed + scene.impact_speed)

    def _check(self, y, scene):
        y, scene = jax.lax.stop_gradient((y, scene))
        reach, fastest = self._limits(scene)
        finite = jnp.all(
            jnp.stack([jnp.all(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(y)])
        )
        xr, vr = roller_kinematics(y, scene)
        inside = jnp.all(jnp.abs(xr) < reach)
        slow = jnp.all(jnp.sum(vr * vr, -1) < fastest**2)
        return finite & inside & slow, contact_slots_ok(y, scene), peak_tension(y, scene)

    def init(self, t0, y0, scene):
        return self._check(y0, scene)

    def step(self, t0, t1, y0, y1, dense, scene, state):
        healthy, slots, tension = self._check(y1, scene)
        # NaN tension (a blown-up state) is caught by `healthy`
        return state[0] & healthy, state[1] & slots, jnp.fmax(state[2], tension)

    def value(self, state, t0, t1):
        return state


# ---------------------------------------------------------------------------- soft peak
EXP_CAP = 60.0  # forces beyond reference + 60·temperature saturate the soft maximum


def window_weight(t, t_start, rise):
    """Smooth (C¹) window: 0 before ``t_start − rise/2``, 1 after ``t_start + rise/2``; its
    integral over [t0, t1] is ``t1 − t_start`` when the ramp lies inside. ``rise`` ≥ 0
    (0: a step at ``t_start``)."""
    if is_concrete(rise) and not np.all(np.asarray(rise, dtype=float) >= 0):
        raise ValueError(f"window_weight: rise must be >= 0 s, got {rise}")
    s = jnp.clip((t - t_start) / jnp.maximum(rise, 1e-30) + 0.5, 0.0, 1.0)
    return s * s * (3 - 2 * s)


class SoftPeak(AbstractIntegralObserver):
    """Smooth peak of the roller/tooth normal force over time and rollers [N]:

        P = F_ref + τ·log( (1/(t1 − t_start)) ∫ w(t) Σ_i exp((F_i(t) − F_ref)/τ) dt )

    a log-mean-exp ("soft maximum") of temperature τ over the window ``w`` (from
    ``t_start``, smooth over ``rise``), integrated by the solver as one extra state: exact
    in continuous time, differentiable, and free (the forces are the vector field's).
    τ → 0 gives the sharp maximum; otherwise P lies below it by about
    τ·log(window / time spent near the peak) and above it by at most τ·log(rollers near
    the peak). The exponent saturates smoothly ``EXP_CAP``·τ above ``reference`` (an
    overflow guard: a trial step the controller will reject can see absurd forces, and
    an overflowing exp there turns the whole gradient into NaN — 0·inf in the backward
    pass of the step's accept/reject select). Use a reference of the order of the peak.

    Attributes:
        t_start: start of the window [s].
        rise: width of the window's smooth rise [s].
        temperature: τ [N], > 0.
        reference: F_ref [N].
    """

    reads_rollers: ClassVar[bool] = True

    t_start: Float[Array, ""]
    rise: Float[Array, ""]
    temperature: Float[Array, ""]
    reference: Float[Array, ""]

    def __init__(
        self,
        t_start: ArrayLike = 0.0,
        rise: ArrayLike = 0.0,
        temperature: ArrayLike = 50.0,
        reference: ArrayLike = 0.0,
    ):
        _init_soft(self, "SoftPeak", t_start, rise, temperature, reference)

    def integrand(self, t, y, scene, forces):
        return _soft_terms(self, t, jnp.sum(forces.roller_normal, axis=0))  # (R,) summed

    def value(self, state, t0, t1):
        return _log_mean(self, state, t1)


def _init_soft(o, name, t_start, rise, temperature, reference):
    """A soft peak's window and temperature, checked and set on ``o`` (in its __init__)."""
    if is_concrete((t_start, rise, temperature, reference)):
        checks.real(f"{name}.t_start", t_start, lo=0.0, unit="s")
        checks.real(f"{name}.rise", rise, lo=0.0, unit="s (0: a step)")
        checks.real(f"{name}.temperature", temperature, lo=0.0, lo_open=True, unit="N")
        checks.real(f"{name}.reference", reference, unit="N")
    o.t_start = jnp.asarray(t_start, dtype=float)
    o.rise = jnp.asarray(rise, dtype=float)
    o.temperature = jnp.asarray(temperature, dtype=float)
    o.reference = jnp.asarray(reference, dtype=float)


def _soft_terms(o, t, f):
    """w(t)·Σ_i exp((F_i − F_ref)/τ) at time(s) ``t`` (…,) of the forces ``f`` (…, R)."""
    e = (f - o.reference) / o.temperature
    e = e - jax.nn.softplus(e - EXP_CAP)
    return window_weight(t, o.t_start, o.rise) * jnp.sum(jnp.exp(e), axis=-1)


def _log_mean(o, integral, t1):
    span = t1 - o.t_start
    return o.reference + o.temperature * jnp.log(jnp.maximum(integral, 1e-300) / span)


class SampledSoftPeak(AbstractStepObserver):
    """:class:`SoftPeak`'s value, its window integral taken by the trapezoid rule over
    ``samples`` equal parts of every accepted step (states from the solver's dense
    interpolant) instead of by the solver's stages — for fixed-step solves, whose step
    can be longer than the soft maximum's spike.

    Near the top F_max of an impact the integrand exp((F − F_ref)/τ) is a spike of
    width σ ≈ √(τ / |F''|) in time, about 0.5 µs for an 08B chain's meshing impact at
    τ = 16 N. A fixed step longer than that (4 µs puts Tsit5's six stages ~2 µs apart)
    makes the integrated :class:`SoftPeak` depend on where each spike falls between the
    stages: its value ripples in the design parameters and the ripple's slope, not the
    trend's, becomes the gradient. The trapezoid rule on a spike is exact up to
    ~2·exp(−2π²σ²/h²) for sub-steps h, so sub-steps of about σ give the trend's gradient
    (``benchmarks/step_convergence.py``). Adaptive solves resolve the spike by their
    error control and should use :class:`SoftPeak`.

    Cost: ``samples`` roller-contact evaluations per step (one vmapped call).

    Attributes:
        t_start, rise, temperature, reference: as :class:`SoftPeak`'s.
        samples: parts per step (static, ≥ 1).
    """

    reads_rollers: ClassVar[bool] = True

    t_start: Float[Array, ""]
    rise: Float[Array, ""]
    temperature: Float[Array, ""]
    reference: Float[Array, ""]
    samples: int = eqx.field(static=True, default=8)

    def __init__(
        self,
        t_start: ArrayLike = 0.0,
        rise: ArrayLike = 0.0,
        temperature: ArrayLike = 50.0,
        reference: ArrayLike = 0.0,
        samples: int = 8,
    ):
        _init_soft(self, "SampledSoftPeak", t_start, rise, temperature, reference)
        self.samples = checks.integer("SampledSoftPeak.samples", samples, lo=1)

    def init(self, t0, y0, scene):
        return jnp.zeros_like(self.temperature), _soft_terms(self, t0, _roller_forces(y0, scene))

    def step(self, t0, t1, y0, y1, dense, scene, state):
        total, g0 = state
        n = self.samples
        ts = t0 + (t1 - t0) * jnp.arange(1, n + 1) / n
        ends = jax.tree_util.tree_map(lambda b: b[None], y1)
        ys = ends if n == 1 else jax.tree_util.tree_map(
            lambda a, b: jnp.concatenate([a, b]), dense(ts[:-1]), ends
        )  # fmt: skip
        g = _soft_terms(self, ts, jax.vmap(_roller_forces, in_axes=(0, None))(ys, scene))
        total = total + (t1 - t0) / n * (0.5 * g0 + jnp.sum(g[:-1]) + 0.5 * g[-1])
        return total, g[-1]  # the end's term serves as the next step's start

    def value(self, state, t0, t1):
        return _log_mean(self, state[0], t1)
