"""``simulate``: a scene's trajectory, its named outputs and its peak contact force."""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .. import _checks as checks
from .._dynamics import CHAIN_OUTPUTS
from .._numerics import is_concrete
from .._observers.base import (
    AbstractIntegralObserver,
    AbstractStepObserver,
    PeakRecord,
    check_rollers,
)
from .._programs import stored
from .._scene import Scene
from .options import SolveOptions, with_options
from .result import Result, raise_if_failed, result_messages, result_names
from .solve import check_horizon, solve, strong_scene

__all__ = ["simulate", "Solution", "time_span"]


class Solution(eqx.Module):
    """Named outputs of a drive simulation (SI units): one member's, from
    :func:`simulate`, or an ensemble's, from :func:`~jaxchain.simulate_ensemble`, with a
    leading member axis M on every field but ``ts`` (shapes below are one member's).

    Attributes:
        ts: (T,) save times [s] (shared by an ensemble's members).
        roller_position, roller_velocity: (T, R, 2) world frame [m], [m/s].
        roller_sprocket_force: (T, R) roller/tooth normal force, summed over sprockets [N].
        peak_contact_force: max of the roller/tooth force over the save times and every
            accepted solver step, each step's top read from 5 force samples on the
            solver's dense output [N] (see :class:`~jaxchain.observers.PeakRecord`).
        link_tension: (T, L) [N] (pin/bush joint forces averaged per link, or link springs).
        sprocket_speed, sprocket_angle: (T, S) [rad/s], [rad].
        sprocket_torque: (T, S) torque of the chain on each sprocket [N·m].
        result: :class:`Result` code; ``message`` says what happened and what to change.
        stats: solver statistics (num_steps, num_accepted_steps, num_rejected_steps, …).
        y1: the state at t1 (a :class:`~jaxchain.DriveState`).
        observed: the value of each observer passed to :func:`simulate`, in order.
        roller_shoe_force: (T, R) roller/shoe normal force, summed over the tensioner
            shoes and guides [N]; None for a scene without shoes.
        tensioner_angle: (T, A) each tensioner arm's angle [rad], world frame (of the line
            from its pivot to its shoe's middle, counter-clockwise from +x); None
            without tensioners.
        tensioner_force: (T, A) magnitude of the chain's force on each tensioner shoe [N].
        tensioner_torque: (T, A) torque of each tensioner's spring and damper on its arm
            [N·m] (counter-clockwise positive).
        guide_force: (T, G) magnitude of the chain's force on each guide [N]; None
            without shoes.
        span_tension: (T, J) mean tension of each free span of a closed drive [N], span j
            from sprocket j to j + 1 (every fidelity; the lumped and clearance chains: the
            mean over the links in the span); None for a strand.
        element_outputs: every force element's saved outputs, by name, each (T, ...):
            the built-in elements' (``roller_shoe_force``, ``tensioner_angle``,
            ``joint_friction_power``, ``tooth_friction_power``, ...; those with a field
            above are that field too) and those of the elements added to the scene
            (:meth:`~jaxchain.Scene.add_elements`).

    An ensemble's solution also has (None for one member's):
        steps: (M,) steps each member took (accepted + rejected): the work it needed.
        accepted_steps: (M,) accepted steps per member.
        steps_executed: steps the batched loops executed: over groups and devices, the
            slice size times the slowest member's steps (padding included).
        waste: ``steps_executed / sum(steps)`` (1: no step thrown away).
        predicted_steps: (M,) the pilot's (or the given) cost estimate, or None.
        groups: the member indices of each group, in the order run (static).
        batch_sizes: each group's padded batch size (static).
        n_devices: devices the member axis was split across (static).
    """

    ts: Float[Array, " T"]
    roller_position: Float[Array, "T R 2"]
    roller_velocity: Float[Array, "T R 2"]
    roller_sprocket_force: Float[Array, "T R"]
    link_tension: Float[Array, "T L"]
    sprocket_speed: Float[Array, "T S"]
    sprocket_angle: Float[Array, "T S"]
    sprocket_torque: Float[Array, "T S"]
    peak_contact_force: Float[Array, ""]
    result: Result
    stats: dict
    y1: object
    observed: tuple = ()
    roller_shoe_force: Float[Array, "T R"] | None = None
    tensioner_angle: Float[Array, "T A"] | None = None
    tensioner_force: Float[Array, "T A"] | None = None
    tensioner_torque: Float[Array, "T A"] | None = None
    guide_force: Float[Array, "T G"] | None = None
    element_outputs: dict = eqx.field(default_factory=dict)
    steps: Int[Array, " M"] | None = None
    accepted_steps: Int[Array, " M"] | None = None
    steps_executed: Int[Array, ""] | None = None
    waste: Float[Array, ""] | None = None
    predicted_steps: Float[Array, " M"] | None = None
    groups: tuple[tuple[int, ...], ...] | None = eqx.field(static=True, default=None)
    batch_sizes: tuple[int, ...] | None = eqx.field(static=True, default=None)
    n_devices: int | None = eqx.field(static=True, default=None)
    span_tension: Float[Array, "T J"] | None = None

    @property
    def is_ensemble(self) -> bool:
        """Whether this is an ensemble's solution (a leading member axis)."""
        return self.groups is not None

    @property
    def n_members(self) -> int:
        """Members of an ensemble (1 for one member's solution)."""
        return int(np.shape(self.peak_contact_force)[0]) if self.is_ensemble else 1

    @property
    def successful(self) -> np.ndarray:
        """Which members succeeded: bool, (M,) for an ensemble."""
        return np.asarray(self.result == Result.successful)

    @property
    def ok(self) -> bool:
        """Whether the solve (every member) succeeded."""
        return bool(np.all(self.successful))

    @property
    def failed(self) -> list[int]:
        """Indices of the members that did not succeed ([] or [0] for one member)."""
        return [int(i) for i in np.nonzero(~np.atleast_1d(self.successful))[0]]

    @property
    def result_name(self) -> str:
        """The :class:`Result` name ("successful", "diverged", …); an ensemble's: its
        first failed member's ("successful" if none failed)."""
        if not self.is_ensemble:
            return result_names(self.result)[0]
        names = result_names(self.result)
        return names[self.failed[0]] if self.failed else names[0]

    @property
    def message(self) -> str:
        """What happened, and what to change ("" when successful); an ensemble's: its
        first failed member's."""
        if not self.is_ensemble:
            return Result[self.result]
        return self.messages[self.failed[0]] if self.failed else ""

    @property
    def messages(self) -> list[str]:
        """Per member: what happened and what to change ("" when successful)."""
        return result_messages(self.result)

    @property
    def result_names(self) -> list[str]:
        """Per member: the :class:`Result` name ("successful", "diverged", …)."""
        return result_names(self.result)

    def member(self, i: int) -> Solution:
        """Member ``i`` of an ensemble as one member's solution."""
        if not self.is_ensemble:
            raise TypeError("member: this is one member's solution (from jc.simulate)")
        m = self.n_members
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not -m <= i < m:
            raise IndexError(f"member index must be an integer in [-{m}, {m}), got {i!r}")
        pick = lambda x: x[i] if eqx.is_array(x) else x
        one = {
            f.name: jax.tree_util.tree_map(pick, getattr(self, f.name))
            for f in dataclasses.fields(self)
            if f.name not in _ENSEMBLE_ONLY + ("ts",)
        }
        return Solution(ts=self.ts, **one)


_ENSEMBLE_ONLY = (
    "steps",
    "accepted_steps",
    "steps_executed",
    "waste",
    "predicted_steps",
    "groups",
    "batch_sizes",
    "n_devices",
)


def split_saved(saved: dict) -> dict:
    """The solve's saved outputs as :class:`Solution` keyword arguments: the chain's and
    the sprockets' in their fields; every force element's, built-in or added, by its
    name in ``element_outputs``, those with a field of their own (a shoe's, a
    tensioner's) in that field too."""
    own = {f.name for f in dataclasses.fields(Solution)}
    out = {k: v for k, v in saved.items() if k in own}
    out["element_outputs"] = {k: v for k, v in saved.items() if k not in CHAIN_OUTPUTS}
    return out


def time_span(t0: ArrayLike, t1: ArrayLike, ts: ArrayLike | None, n_save: int):
    """Checked (t0, t1, save times) as float arrays; default save times ``n_save`` equally
    spaced over [t0, t1]."""
    for name, v in (("t0", t0), ("t1", t1)):
        checks.real_values(name, v, "a time [s]")
    t0a, t1a = jnp.asarray(t0, dtype=float), jnp.asarray(t1, dtype=float)
    for name, v in (("t0", t0a), ("t1", t1a)):
        if np.shape(v) != ():
            raise ValueError(f"{name} must be a scalar time [s], got shape {np.shape(v)}")
    if is_concrete(t0a, t1a):
        if not (np.isfinite(float(t0a)) and np.isfinite(float(t1a))):
            raise ValueError(f"t0 and t1 must be finite, got t0={float(t0a)}, t1={float(t1a)}")
        if not float(t1a) > float(t0a):
            raise ValueError(f"t1 must be > t0, got t0={float(t0a)}, t1={float(t1a)}")
        if float(t0a) != 0.0:
            raise ValueError(
                f"t0 must be 0 s, got {float(t0a)}: a scene's initial state is its state at "
                "t = 0 (its guides, load ramp and horizon run on absolute time); to look at a "
                "later window, save only there with ts=..."
            )
    if ts is None:
        if isinstance(n_save, bool) or not isinstance(n_save, (int, np.integer)) or n_save < 2:
            raise ValueError(f"n_save must be an integer >= 2, got {n_save!r}")
        return t0a, t1a, jnp.linspace(t0a, t1a, n_save)
    checks.real_values("ts", ts, "a 1-D array of save times [s]")
    tsa = jnp.asarray(ts, dtype=float)
    if tsa.ndim != 1 or tsa.shape[0] < 1:
        raise ValueError(f"ts must be a 1-D array of save times, got shape {tsa.shape}")
    if is_concrete(tsa, t0a, t1a):
        v, lo, hi = np.asarray(tsa), float(t0a), float(t1a)
        if not np.all(np.isfinite(v)):
            raise ValueError("ts must be finite")
        if np.any(np.diff(v) < 0):
            raise ValueError("ts must be non-decreasing")
        if v[0] < lo or v[-1] > hi:
            raise ValueError(
                f"ts must lie within [t0, t1] = [{lo:.6g}, {hi:.6g}] s, got "
                f"[{v[0]:.6g}, {v[-1]:.6g}]"
            )
    return t0a, t1a, tsa


def peak_of(saved: dict, step_peak: Array) -> Array:
    """The peak roller/tooth force: the peak record's, and the save times' (members first
    when batched)."""
    f = saved["roller_sprocket_force"]
    return jnp.maximum(step_peak, jnp.max(f, axis=tuple(range(f.ndim - 2, f.ndim)), initial=0.0))


_N_SAVE = 501  # simulate's default number of save times


def simulate(
    scene: Scene,
    t1: ArrayLike,
    *,
    t0: ArrayLike = 0.0,
    ts: ArrayLike | None = None,
    n_save: int = _N_SAVE,
    throw: bool = True,
    observers: tuple[AbstractStepObserver | AbstractIntegralObserver, ...] = (),
    options: SolveOptions | None = None,
    **solve_options,
) -> Solution:
    """Simulate ``scene`` from ``t0`` to ``t1`` [s].

    Args:
        scene: built by :mod:`jaxchain.scenes`.
        t1: end of the solve [s] (t0 = 0: a scene's initial state is its state at t = 0).
        ts: save times within [t0, t1] (default: ``n_save`` equally spaced over it).
        throw: raise on failure (``RuntimeError`` with what to change); with
            ``throw=False`` check ``Solution.result`` / ``Solution.message``.
        options: a :class:`~jaxchain.SolveOptions` (solver, tolerances, steps, adjoint,
            progress); keyword options (``solver=``, ``rtol=``, ``atol=``, ``dt0=``,
            ``dt=``, ``max_steps=``, ``stepsize_controller=``, ``adjoint=``,
            ``progress=``) set or override its fields.
        observers: more quantities computed along the solve (:mod:`jaxchain.observers`:
            e.g. ``OrderSpectrum`` lines of a sprocket's torque, ``SpeedVariation``);
            their values are ``Solution.observed``, in order. A
            :class:`~jaxchain.observers.PeakRecord` among them is the one
            ``peak_contact_force`` is read with (e.g. ``PeakRecord(gate=False)`` samples
            every step's interior), not a second one.

    Returns:
        :class:`Solution`.

    Jitted once per scene *structure*: a second call with new array values (speeds,
    profiles, loads, tolerances) does not retrace.
    """
    opts = with_options(options, solve_options, "simulate")
    scene = strong_scene(scene, "simulate")
    checks.flag("simulate: throw", throw)
    if ts is not None and n_save != _N_SAVE:
        raise ValueError(
            f"simulate: give ts (the save times) or n_save (that many equally spaced), not "
            f"both: with ts, n_save={n_save!r} would be ignored"
        )
    checks.element_coordinates(scene, "simulate")
    t0a, t1a, tsa = time_span(t0, t1, ts, n_save)
    check_horizon(scene, t1a, "simulate")
    observers = _checked_observers(observers, "simulate")
    check_rollers(scene, observers, "simulate")
    given = [k for k, o in enumerate(observers) if isinstance(o, PeakRecord)]
    at = given[0] if given else 0  # the record peak_contact_force reads
    if not given:
        observers = (PeakRecord(), *observers)
    traj = _solve(scene, t0a, t1a, tsa, opts.resolve(t0a, t1a), observers)
    saved = traj.saved
    if throw:
        saved = raise_if_failed(traj.result, saved, "simulate")
    return Solution(
        ts=tsa,
        peak_contact_force=peak_of(saved, traj.observed[at]),
        result=traj.result,
        stats=traj.stats,
        y1=traj.y1,
        observed=traj.observed if given else traj.observed[1:],
        **split_saved(saved),
    )


_solve = stored("jaxchain.simulate.solve")(solve)  # traced once across processes


def _checked_observers(observers, caller: str) -> tuple:
    """``observers`` as a tuple of step or integral observers, or ``TypeError``."""
    if isinstance(observers, (AbstractStepObserver, AbstractIntegralObserver)):
        observers = (observers,)
    if not isinstance(observers, (tuple, list)) or not all(
        isinstance(o, (AbstractStepObserver, AbstractIntegralObserver)) for o in observers
    ):
        raise TypeError(
            f"{caller}: observers must be a tuple of jc.observers (PeakRecord, SoftPeak, "
            f"OrderSpectrum, BandLevel, SpeedVariation, ...), got {observers!r}"
        )
    return tuple(observers)
