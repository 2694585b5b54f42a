"""``simulate``: one jitted entry point around ``diffrax.diffeqsolve``."""

from __future__ import annotations

import warnings
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ._dynamics import initial_state, outputs, roller_contacts, vector_field
from ._numerics import parabola_max
from ._scene import Scene

__all__ = ["simulate", "Solution", "Result"]


class Result(eqx.Enumeration):
    """Outcome of a solve, with what to change."""

    successful = ""
    max_steps_reached = (
        "The solver used up max_steps before t1. Stiff contact forces an explicit solver to "
        "tiny steps: raise max_steps, loosen rtol/atol, lower the contact stiffness or widen "
        "its regularization, or choose an implicit solver (e.g. diffrax.Kvaerno5())."
    )
    step_size_collapse = (
        "The step size collapsed to dtmin: the state changes faster than the solver can "
        "resolve at this tolerance (usually a contact too stiff or an impact too violent). "
        "Loosen rtol/atol, lower dtmin, or widen the contact regularization."
    )
    diverged = (
        "The solution became non-finite (NaN/inf) or flew apart (rollers thrown out of the "
        "scene, or faster than 5 × (pitch-line speed + reference impact speed)): the solve "
        "diverged. With "
        "fixed steps the step is above the explicit stability limit of the stiffest contact or "
        "link "
        "(measured on the engagement scene: h·ω_max ≈ 0.2 for Euler, which needs damping to be "
        "stable at all, 1.0–1.3 for Heun, ≈ 3 for Tsit5; see benchmarks/stability.py): "
        "reduce dt0, or use an adaptive "
        "step-size controller or an implicit solver. In float32, enable float64 "
        "(jax.config.update('jax_enable_x64', True))."
    )
    implicit_solver_failed = (
        "The implicit solver's Newton iteration did not converge. Reduce the step (dt0 or "
        "tolerances), or use an explicit solver for this non-stiff scene."
    )
    contact_slots_exceeded = (
        "More rollers came within reach of a sprocket than it has contact slots "
        "(Sprocket.contact_slots), so contacts may have been missed: rebuild the scene with "
        "more slots, or contact_slots=None to check every roller."
    )
    internal = "diffrax reported an internal failure; see the diffrax result in Solution.stats."


# a roller faster than this many times (pitch-line speed + reference impact speed) has
# flown apart (the solve diverged)
_FLYING_APART = 5.0


def _classify(diffrax_result, finite) -> Result:
    r = diffrax.RESULTS
    out = Result.where(diffrax_result == r.successful, Result.successful, Result.internal)
    out = Result.where(diffrax_result == r.max_steps_reached, Result.max_steps_reached, out)
    out = Result.where(diffrax_result == r.dt_min_reached, Result.step_size_collapse, out)
    out = Result.where(diffrax_result == r.nonfinite, Result.diverged, out)
    for bad in (r.nonlinear_max_steps_reached, r.nonlinear_divergence):
        out = Result.where(diffrax_result == bad, Result.implicit_solver_failed, out)
    # diffrax pads save times it never reached with inf: judge finiteness only when the
    # solve itself reports success (a fixed-step explicit blow-up does)
    ok = diffrax_result == r.successful
    return Result.where(ok & ~finite, Result.diverged, out)


class Solution(eqx.Module):
    """Named outputs of a drive simulation (SI units).

    Attributes:
        ts: (T,) save times [s].
        roller_position, roller_velocity: (T, R, 2) world frame [m], [m/s].
        roller_sprocket_force: (T, R) roller/tooth normal force, summed over sprockets [N].
        peak_contact_force: max of the roller/tooth force over the save times and every
            accepted solver step, each step's top read from 5 samples on the solver's
            dense output [N] (see :class:`PeakRecorder`).
        link_tension: (T, L) [N] (pin/bush joint forces averaged per link, or link springs).
        sprocket_speed, sprocket_angle: (T, S) [rad/s], [rad].
        sprocket_torque: (T, S) torque of the chain on each sprocket [N·m].
        result: :class:`Result` code; ``message`` says what happened and what to change.
        stats: solver statistics (num_steps, num_accepted_steps, num_rejected_steps, …).
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

    @property
    def ok(self) -> bool:
        return bool(self.result == Result.successful)

    @property
    def message(self) -> str:
        """What happened, and what to change ("" when successful)."""
        return Result[self.result]


PEAK_SAMPLES = 4  # force samples per accepted step for the peak record (see PeakRecorder)


def _roller_forces(t, y, scene):
    """(R,) each roller's tooth force, summed over sprockets."""
    return jnp.sum(roller_contacts(y, scene).normal, axis=0)


class PeakRecorder(diffrax.AbstractWrappedSolver):
    """Wraps any diffrax solver; also keeps the largest roller/tooth force of every
    accepted step, as a running max in the solver state.

    Each step's force is sampled per roller at its start, at ``samples - 1`` equally spaced
    interior times (states from the solver's own dense interpolant) and at its end; the
    step's top is the largest :func:`parabola_max` over consecutive sample triples (never
    below a sample, continuous in them). Sampling the step ends alone misses the top of a
    short impact by up to the step's share of it; on the engagement (2 tooth periods,
    peak 1593 N) the errors against the converged peak were, per setting
    (ends+midpoints max → 4 samples with parabolas):

    ====================  ===================  ====================
    Tsit5 rtol 1e-5       1.8e-3 → 6.9e-5      +10 % time
    Tsit5 rtol 1e-6       1.4e-4 → 2.1e-5      +25 %
    Tsit5 rtol 1e-7       6.1e-4 → 1.2e-5      +26 %
    Dopri8 rtol 1e-6      1.9e-3 → 1.9e-4      +16 %
    ====================  ===================  ====================

    (the old error moved erratically with where the steps fell; at rtol ≥ 1e-4 the
    state's own error dominates and sampling changes nothing). Cost: three roller-contact
    evaluations more per step than the ends alone, in one vmapped call. The running max
    needs no per-step buffer; a rejected step leaves it untouched (diffrax keeps the
    solver state of accepted steps only).
    """

    solver: diffrax.AbstractSolver
    samples: int = eqx.field(static=True, default=PEAK_SAMPLES)

    def __check_init__(self):
        if not (isinstance(self.samples, int) and self.samples >= 2):
            raise ValueError(
                f"PeakRecorder: samples must be an int >= 2 (a parabola needs a start, an "
                f"interior and an end sample); got {self.samples!r}"
            )

    @property
    def term_structure(self):
        return self.solver.term_structure

    @property
    def interpolation_cls(self):  # pyright: ignore
        return self.solver.interpolation_cls

    @property
    def term_compatible_contr_kwargs(self):
        return self.solver.term_compatible_contr_kwargs

    @property
    def root_finder(self):  # diffrax sets an implicit solver's tolerances through this
        return self.solver.root_finder

    @property
    def scan_kind(self):  # ... and a Runge–Kutta solver's stage loop for forward mode
        return self.solver.scan_kind

    def order(self, terms):
        return self.solver.order(terms)

    def strong_order(self, terms):
        return self.solver.strong_order(terms)

    def error_order(self, terms):
        return self.solver.error_order(terms)

    def init(self, terms, t0, t1, y0, args):
        f0 = _roller_forces(t0, y0, args)
        return self.solver.init(terms, t0, t1, y0, args), jnp.max(f0), f0

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        inner, peak, f0 = solver_state
        y1, y_error, dense_info, inner, result = self.solver.step(
            terms, t0, t1, y0, args, inner, made_jump
        )
        n = self.samples
        interp = self.solver.interpolation_cls(t0=t0, t1=t1, **dense_info)
        ts = t0 + (t1 - t0) * jnp.arange(1, n) / n
        ys = jax.vmap(interp.evaluate)(ts)
        ys = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b[None]]), ys, y1)
        f = jax.vmap(_roller_forces, in_axes=(0, 0, None))(jnp.append(ts, t1), ys, args)
        f = jnp.concatenate([f0[None], f])  # (n + 1, R) at t0, t0 + h/n, ..., t1
        # NaN propagates (maximum): a blown-up step is reported, never skipped
        peak = jnp.maximum(peak, jnp.max(parabola_max(f[:-2], f[1:-1], f[2:])))
        return y1, y_error, dense_info, (inner, peak, f[-1]), result

    def func(self, terms, t0, y0, args):
        return self.solver.func(terms, t0, y0, args)


@eqx.filter_jit
def _solve(scene, t0, t1, ts, solver, controller, dt0, max_steps, adjoint, progress_meter):
    y0 = initial_state(scene)
    # the loop saves states only; the outputs (a second evaluation of the forces) are
    # computed from them after the solve, vmapped: inside the loop they would be traced,
    # linearized and transposed once more in every gradient (compile time)
    saveat = diffrax.SaveAt(
        subs=[diffrax.SubSaveAt(ts=ts), diffrax.SubSaveAt(t1=True)], solver_state=True
    )
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(vector_field),
        PeakRecorder(solver),
        t0,
        t1,
        dt0,
        y0,
        args=scene,
        saveat=saveat,
        stepsize_controller=controller,
        max_steps=max_steps,
        adjoint=adjoint,
        progress_meter=progress_meter,
        throw=False,
    )
    ys, y1 = sol.ys
    saved = jax.vmap(outputs, in_axes=(0, 0, None))(ts, ys, scene)
    step_peak = sol.solver_state[1]
    peak = jnp.maximum(jnp.max(saved["roller_sprocket_force"]), step_peak)
    finite = jnp.all(
        jnp.stack([jnp.all(jnp.isfinite(leaf)) for leaf in jax.tree_util.tree_leaves(saved)])
    ) & jnp.isfinite(peak)
    # a blow-up is caught before it overflows: rollers thrown far out of the scene
    size = jnp.max(jnp.abs(scene.q0[:, :2])) + jnp.max(
        jnp.stack([jnp.max(jnp.abs(s.centre)) for s in scene.sprockets])
    )
    finite = finite & jnp.all(jnp.abs(saved["roller_position"]) < 1e3 * size)
    # ... or while it is still growing: an explicit step above its stability limit makes
    # the stiffest mode ring up, and the rollers outrun anything the drive can give them
    # (measured on the engagement: ≤ 1.1× the pitch-line speed when right, 8× at a peak
    # force 5× too high, 10⁵× later)
    chain_speed = jnp.max(
        jnp.stack([jnp.abs(s.speed) * s.profile.pitch_radius for s in scene.sprockets])
    )
    speed_limit = _FLYING_APART * (chain_speed + scene.impact_speed)
    roller_speed = jnp.sqrt(jnp.sum(saved["roller_velocity"] ** 2, -1))
    finite = finite & jnp.all(roller_speed < speed_limit)
    result = _classify(sol.result, finite)
    slots_ok = jnp.all(saved.pop("contact_slots_ok"))
    result = Result.where(
        slots_ok | (result != Result.successful), result, Result.contact_slots_exceeded
    )
    stats = dict(sol.stats)
    stats["diffrax_result"] = sol.result._value
    return saved, peak, result, stats, jax.tree_util.tree_map(lambda x: x[-1], y1)


def simulate(
    scene: Scene,
    t1: ArrayLike,
    *,
    t0: ArrayLike = 0.0,
    solver: diffrax.AbstractSolver | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    dt0: ArrayLike | None = None,
    max_steps: int = 200_000,
    ts: ArrayLike | None = None,
    n_save: int = 501,
    stepsize_controller: diffrax.AbstractStepSizeController | None = None,
    adjoint: diffrax.AbstractAdjoint | None = None,
    progress: bool = False,
    throw: bool = True,
) -> Solution:
    """Simulate ``scene`` from ``t0`` to ``t1`` [s].

    Args:
        scene: built by :mod:`jaxchain.scenes`.
        t1, t0: time span [s].
        solver: any diffrax solver (default ``diffrax.Tsit5()``).
        rtol, atol: tolerances of the default PID step-size controller, which measures the
            error in the max norm (a single contact's error is not averaged away).
        dt0: initial step; with ``stepsize_controller=diffrax.ConstantStepSize()`` the
            fixed step.
        max_steps: step budget.
        ts: save times (default: ``n_save`` equally spaced over [t0, t1]).
        stepsize_controller: overrides the default controller.
        adjoint: diffrax adjoint for gradients (default: recursive checkpointing with
            diffrax's ≈ √(2·max_steps) checkpoints, which differentiates the discrete solve
            exactly). For a fixed-step gradient whose states fit in memory, checkpoint every
            step, ``diffrax.RecursiveCheckpointAdjoint(checkpoints=n_steps)``: nothing is
            recomputed (value+gradient 3.6–4.3× the value on the ensemble benchmark, vs
            4.2–4.9× with the default, over several runs). Not automatic: the checkpoint
            count is part of the compiled solve, so it would recompile for every new step
            size.
        progress: show a progress meter (tqdm if installed, else text).
        throw: raise on failure (``RuntimeError`` with what to change); with
            ``throw=False`` check ``Solution.result`` / ``Solution.message``.

    Returns:
        :class:`Solution`.

    Jitted once per scene *structure*: a second call with new array values (speeds,
    profiles, loads) does not retrace.
    """
    scene, args = _prepare(
        scene,
        t1,
        t0=t0,
        solver=solver,
        rtol=rtol,
        atol=atol,
        dt0=dt0,
        max_steps=max_steps,
        ts=ts,
        n_save=n_save,
        stepsize_controller=stepsize_controller,
        adjoint=adjoint,
        progress=progress,
        caller="simulate",
    )
    ts = args.ts
    saved, peak, result, stats, y1 = _solve(scene, *args)
    if throw:
        if isinstance(peak, jax.core.Tracer):  # inside the caller's jit/grad: runtime error
            saved = result.error_if(saved, result != Result.successful)
        elif result != Result.successful:
            raise RuntimeError(f"simulate failed: {Result[result]}")
    return Solution(
        ts=ts,
        peak_contact_force=peak,
        result=result,
        stats=stats,
        y1=y1,
        **saved,
    )


class _SolveArgs(NamedTuple):
    """Everything ``_solve`` takes besides the scene, in its argument order."""

    t0: Array
    t1: Array
    ts: Array
    solver: diffrax.AbstractSolver
    controller: diffrax.AbstractStepSizeController
    dt0: Array | None
    max_steps: int
    adjoint: diffrax.AbstractAdjoint
    meter: diffrax.AbstractProgressMeter


def _prepare(
    scene: Scene,
    t1: ArrayLike,
    *,
    t0: ArrayLike,
    solver: diffrax.AbstractSolver | None,
    rtol: float,
    atol: float,
    dt0: ArrayLike | None,
    max_steps: int,
    ts: ArrayLike | None,
    n_save: int,
    stepsize_controller: diffrax.AbstractStepSizeController | None,
    adjoint: diffrax.AbstractAdjoint | None,
    progress: bool,
    caller: str,
) -> tuple[Scene, _SolveArgs]:
    """Check and canonicalize the options of ``simulate`` (shared with
    ``simulate_ensemble``): the scene with strong dtypes and ``_solve``'s other arguments."""
    if solver is None:
        solver = diffrax.Tsit5()
    if stepsize_controller is None:
        stepsize_controller = diffrax.PIDController(  # array tolerances: no recompile
            rtol=jnp.asarray(rtol, dtype=float),
            atol=jnp.asarray(atol, dtype=float),
            norm=optx.max_norm,
            pcoeff=0.2,
            icoeff=0.4,
        )
    if isinstance(stepsize_controller, diffrax.ConstantStepSize) and dt0 is None:
        raise ValueError("a fixed step (ConstantStepSize) needs dt0 > 0 [s]")
    if dt0 is not None and not np.all(np.asarray(dt0) > 0):
        raise ValueError(f"dt0 must be > 0 s, got {dt0}")
    if not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}")
    t0a = jnp.asarray(t0, dtype=float)
    t1a = jnp.asarray(t1, dtype=float)
    if not isinstance(t1a, jax.core.Tracer) and not isinstance(t0a, jax.core.Tracer):
        if not float(t1a) > float(t0a):
            raise ValueError(f"t1 must be > t0, got t0={float(t0a)}, t1={float(t1a)}")
    ts = jnp.linspace(t0a, t1a, n_save) if ts is None else jnp.asarray(ts, dtype=float)
    dt0a = None if dt0 is None else jnp.asarray(dt0, dtype=float)
    if adjoint is None:
        adjoint = diffrax.RecursiveCheckpointAdjoint()
    if progress:
        try:
            import tqdm  # noqa: F401

            meter = diffrax.TqdmProgressMeter()
        except ImportError:
            meter = diffrax.TextProgressMeter()
    else:
        meter = diffrax.NoProgressMeter()
    # strong dtypes: a weakly typed leaf (jnp.asarray(110.0)) must not force a retrace
    scene = jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=jnp.result_type(x)) if eqx.is_inexact_array(x) else x,
        scene,
    )
    if jnp.result_type(scene.q0) != jnp.float64:
        warnings.warn(
            f"{caller}: the scene is {jnp.result_type(scene.q0)} (jax_enable_x64 is off). "
            "Positions of ~0.1 m are then resolved to ~1e-8 m, coarser than the default atol "
            "and comparable to contact deflections: adaptive solves stall "
            "(max_steps_reached). Call jax.config.update('jax_enable_x64', True) before "
            "building the scene.",
            stacklevel=3,
        )
    return scene, _SolveArgs(
        t0a, t1a, ts, solver, stepsize_controller, dt0a, max_steps, adjoint, meter
    )
