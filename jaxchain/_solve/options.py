"""``SolveOptions``: how every solve in jaxchain steps, controls its error and differentiates
(one object shared by ``simulate``, ``simulate_ensemble`` and the design objectives)."""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike

from .. import _checks as checks
from .._numerics import is_concrete
from .adjoint import StepResidualsAdjoint

__all__ = ["SolveOptions", "Resolved", "with_options"]


class Resolved(NamedTuple):
    """Options turned into what ``diffrax.diffeqsolve`` takes (arrays where a new value must
    not recompile)."""

    solver: diffrax.AbstractSolver
    controller: diffrax.AbstractStepSizeController
    dt0: Array | None
    max_steps: int
    adjoint: diffrax.AbstractAdjoint
    meter: diffrax.AbstractProgressMeter
    allow_float32: bool


#: The first step of an adaptive solve [s] when ``dt0`` is not given: 0.1 µs, well inside
#: the explicit stability limit of every contact in a chain drive (≳ 1 µs), so the first
#: step never throws the bodies apart; the controller grows it up to ×10 per accepted step
#: (a few steps more than a good guess). Diffrax's own first-step heuristic can overshoot
#: by orders of magnitude on a stiff contact scene (a clearance strand: a first step of a
#: millisecond), and a step that overflows leaves its controller with a NaN step size that
#: rejects every later step.
DEFAULT_DT0 = 1e-7
# the adaptive steps' settings, at their defaults (fixed steps refuse them set otherwise);
# max_steps None: it follows the horizon (horizon_steps)
_DEFAULTS = {"rtol": 1e-6, "atol": 1e-9, "max_steps": None}
#: The fewest steps an adaptive solve is given when ``max_steps`` is not set.
MIN_STEP_BUDGET = 200_000
#: The mean step [s] the default step budget allows for: a third of the smallest a
#: default-built drive takes at ``simulate``'s tolerances (1.6 µs for a 06B drive;
#: ``python -m benchmarks.step_budget``).
BUDGET_STEP = 0.5e-6


def horizon_steps(t0: ArrayLike, t1: ArrayLike) -> int:
    """The default step budget of an adaptive solve over [t0, t1]: the horizon over
    :data:`BUDGET_STEP`, rounded up to a power of two (so that nearby horizons share one
    compiled solve), at least :data:`MIN_STEP_BUDGET`; that minimum where the span is
    traced. (The budget is a bound, not a cost: a solve takes the steps it needs.)"""
    if not is_concrete(t0, t1):
        return MIN_STEP_BUDGET
    span = float(np.max(np.asarray(t1, dtype=float) - np.asarray(t0, dtype=float)))
    need = span / BUDGET_STEP
    if not math.isfinite(need) or need <= MIN_STEP_BUDGET:
        return MIN_STEP_BUDGET
    return 2 ** math.ceil(math.log2(need))


class SolveOptions(eqx.Module):
    """How a solve steps, controls its error and differentiates.

    Attributes:
        solver: any diffrax solver (default ``diffrax.Tsit5()``). An IMEX solver
            (``KenCarp*``, ``Sil3``) takes the whole vector field as its implicit term.
        rtol, atol: tolerances of the default PID step-size controller, which measures the
            error in the max norm (a single contact's error is not averaged away).
        dt0: initial step [s] (default :data:`DEFAULT_DT0`, 0.1 µs, or the span if
            shorter); with ``stepsize_controller=diffrax.ConstantStepSize()`` the fixed
            step (scalar, or per member in ``simulate_ensemble``).
        dt: fixed steps of about ``dt`` [s]: ⌈(t1 − t0)/dt⌉ equal steps, differentiated
            by :class:`~jaxchain.StepResidualsAdjoint` unless ``adjoint`` says otherwise
            (the exact discrete gradient, every step's residuals kept: nothing recomputed,
            memory 12–22 states per step; past 1 GB per solve it checkpoints instead). The
            step count is part of the compiled solve.
        max_steps: step budget of an adaptive solve (static); default (None): it follows
            the horizon, (t1 − t0)/0.5 µs rounded up to a power of two and at least 200 000
            (:func:`horizon_steps`), so a default-built drive runs the revolutions asked
            for. A solve that uses it up ends with ``max_steps_reached``.
        stepsize_controller: overrides the default controller.
        adjoint: diffrax adjoint for gradients (default: with ``dt``,
            :class:`~jaxchain.StepResidualsAdjoint`; otherwise recursive checkpointing with
            diffrax's ≈ √(2·max_steps) checkpoints, which differentiates the discrete
            solve exactly, recomputing steps). Fixed steps whose residuals would not fit in
            memory: ``StepResidualsAdjoint(memory_limit=...)`` sets where it switches to
            ``diffrax.RecursiveCheckpointAdjoint(checkpoints=n_steps)`` (one state per
            step, each step run again backwards: value+gradient 4.1–4.9× the value on the
            design objective, against 3.5–4.2× with the residuals kept).
        progress: show a progress meter (tqdm if installed, else text).
        allow_float32: accept a float32 scene (jax_enable_x64 off); otherwise its solve is
            reported as ``float32_state`` (its forces can be wrong while it looks
            successful).
        n_steps: fixed steps, exactly ``n_steps`` equal ones over [t0, t1], differentiated
            as with ``dt``. The step count is static and the span is not: ``t1`` (and
            ``ts``) may be traced, so a jitted or vmapped objective over several speeds and
            horizons compiles one solve.
    """

    solver: diffrax.AbstractSolver | None = None
    rtol: float = _DEFAULTS["rtol"]
    atol: float = _DEFAULTS["atol"]
    dt0: ArrayLike | None = None
    dt: float | None = None
    max_steps: int | None = _DEFAULTS["max_steps"]
    stepsize_controller: diffrax.AbstractStepSizeController | None = None
    adjoint: diffrax.AbstractAdjoint | None = None
    progress: bool = False
    allow_float32: bool = False
    n_steps: int | None = None

    def __check_init__(self):
        if self.solver is not None and not isinstance(self.solver, diffrax.AbstractSolver):
            raise TypeError(f"solver must be a diffrax solver, got {self.solver!r}")
        c = self.stepsize_controller
        if c is not None and not isinstance(c, diffrax.AbstractStepSizeController):
            raise TypeError(f"stepsize_controller must be a diffrax controller, got {c!r}")
        if self.adjoint is not None and not isinstance(self.adjoint, diffrax.AbstractAdjoint):
            raise TypeError(f"adjoint must be a diffrax adjoint, got {self.adjoint!r}")
        if self.max_steps is not None:
            m = self.max_steps
            if not isinstance(m, (int, np.integer)) or isinstance(m, bool) or m < 1:
                raise ValueError(
                    f"max_steps must be a positive integer (or None: it follows the horizon), "
                    f"got {m!r}"
                )
        if is_concrete(self.rtol, self.atol):
            for name, hi in (("rtol", 1.0), ("atol", np.inf)):
                v = np.asarray(getattr(self, name), dtype=float)
                if not (v.shape == () and np.isfinite(v) and 0 < v < hi):
                    rng = "in (0, 1)" if hi == 1.0 else "> 0"
                    raise ValueError(f"{name} must be a finite number {rng}, got {v}")
        adaptive = self.dt is None and (c is None or isinstance(c, diffrax.PIDController))
        if (
            adaptive
            and self.solver is not None
            and not isinstance(self.solver, diffrax.AbstractAdaptiveSolver)
        ):
            raise ValueError(
                f"{type(self.solver).__name__} gives no error estimate for adaptive steps: "
                "use fixed steps (dt=...) or an adaptive solver (e.g. diffrax.Tsit5(), "
                "diffrax.Dopri8(), diffrax.Kvaerno5())"
            )
        if self.dt0 is not None and is_concrete(self.dt0):
            v = np.asarray(self.dt0, dtype=float)
            if not np.all(np.isfinite(v) & (v > 0)):
                raise ValueError(f"dt0 must be finite and > 0 s, got {self.dt0}")
        if self.dt is not None:
            if not (isinstance(self.dt, (int, float, np.floating)) and math.isfinite(self.dt)):
                raise ValueError(f"dt must be a finite number of seconds > 0, got {self.dt!r}")
            if not self.dt > 0:
                raise ValueError(f"dt must be > 0 s, got {self.dt}")
            if self.dt0 is not None or self.stepsize_controller is not None:
                raise ValueError(
                    "give dt (fixed steps) or dt0/stepsize_controller, not both: dt sets the "
                    "step count and the constant step-size controller itself"
                )
        if self.n_steps is not None:
            if isinstance(self.n_steps, bool) or not isinstance(self.n_steps, (int, np.integer)):
                raise ValueError(f"n_steps must be a positive integer, got {self.n_steps!r}")
            if self.n_steps < 1:
                raise ValueError(f"n_steps must be a positive integer, got {self.n_steps!r}")
            if self.dt is not None or self.dt0 is not None or self.stepsize_controller is not None:
                raise ValueError(
                    "give n_steps (fixed steps) or dt/dt0/stepsize_controller, not both: "
                    "n_steps sets the step count and the constant step-size controller itself"
                )
        if self.dt is not None or self.n_steps is not None:
            # what only adaptive steps use, given with fixed ones: refused, not ignored
            unused = [
                f"{name}={getattr(self, name)!r}"
                for name in ("rtol", "atol", "max_steps")
                if getattr(self, name) is not None
                and is_concrete(getattr(self, name))
                and not np.array_equal(getattr(self, name), _DEFAULTS[name])
            ]
            if unused:
                fixed = "dt" if self.dt is not None else "n_steps"
                raise ValueError(
                    f"{', '.join(unused)} set(s) the adaptive steps' error control and "
                    f"budget; with fixed steps ({fixed}=...) the step count is fixed and they "
                    "would be ignored: drop them, or drop "
                    f"{fixed} for adaptive steps"
                )
        if isinstance(c, diffrax.ConstantStepSize) and self.dt0 is None:
            raise ValueError("a fixed step (ConstantStepSize) needs dt0 > 0 [s] (or use dt=)")
        for name in ("progress", "allow_float32"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be True or False, got {getattr(self, name)!r}")

    @property
    def fixed(self) -> bool:
        """Whether the steps are fixed (``dt``, ``n_steps``, or a constant step-size
        controller)."""
        return (
            self.dt is not None
            or self.n_steps is not None
            or isinstance(self.stepsize_controller, diffrax.ConstantStepSize)
        )

    def steps(self, t0: float, t1: float) -> int:
        """Number of fixed steps ``dt`` gives over [t0, t1] (static)."""
        return max(1, math.ceil((float(t1) - float(t0)) / self.dt - 1e-9))

    def resolve(self, t0: ArrayLike, t1: ArrayLike) -> Resolved:
        """What ``diffeqsolve`` takes over [t0, t1] (concrete values when ``dt`` is set:
        the step count fixes the compiled loop)."""
        solver = diffrax.Tsit5() if self.solver is None else self.solver
        adjoint = self.adjoint
        if self.max_steps is None:
            max_steps = horizon_steps(t0, t1)
        else:
            max_steps = int(self.max_steps)
        if self.dt is not None:
            if not is_concrete(t0, t1):
                raise ValueError("dt (fixed steps) needs a concrete time span: its step count")
            n = self.steps(t0, t1)
            controller, dt0, max_steps = diffrax.ConstantStepSize(), (t1 - t0) / n, n
            adjoint = adjoint or StepResidualsAdjoint()
        elif self.n_steps is not None:
            n = int(self.n_steps)
            controller, dt0, max_steps = diffrax.ConstantStepSize(), (t1 - t0) / n, n
            adjoint = adjoint or StepResidualsAdjoint()
        else:
            controller = self.stepsize_controller or diffrax.PIDController(
                rtol=jnp.asarray(self.rtol, dtype=float),  # arrays: no recompile
                atol=jnp.asarray(self.atol, dtype=float),
                norm=optx.max_norm,
                pcoeff=0.2,
                icoeff=0.4,
            )
            if self.dt0 is None:  # see DEFAULT_DT0
                dt0 = jnp.minimum(jnp.asarray(DEFAULT_DT0, dtype=float), t1 - t0)
            else:
                dt0 = jnp.asarray(self.dt0, dtype=float)
        adjoint = adjoint or diffrax.RecursiveCheckpointAdjoint()
        if self.progress:
            try:
                import tqdm  # noqa: F401

                meter = diffrax.TqdmProgressMeter()
            except ImportError:
                meter = diffrax.TextProgressMeter()
        else:
            meter = diffrax.NoProgressMeter()
        return Resolved(solver, controller, dt0, max_steps, adjoint, meter, self.allow_float32)


_FIELDS = tuple(f.name for f in dataclasses.fields(SolveOptions))


def with_options(options: SolveOptions | None, given: dict, caller: str) -> SolveOptions:
    """``options`` (default ``SolveOptions()``) with the keyword options ``given`` replaced;
    an unknown keyword raises ``TypeError`` listing the valid ones, and a known one of the
    wrong kind (``rtol="1e-6"``) ``TypeError`` naming it (:func:`checks.solve_keywords`)."""
    unknown = sorted(set(given) - set(_FIELDS))
    if unknown:
        raise TypeError(
            f"{caller}() got unexpected keyword argument(s) {unknown}; solve options are "
            f"{list(_FIELDS)}"
        )
    checks.solve_keywords(caller, given)
    if options is None:
        return SolveOptions(**given)
    if not isinstance(options, SolveOptions):
        raise TypeError(f"options must be a jaxchain.SolveOptions, got {type(options).__name__}")
    return dataclasses.replace(options, **given) if given else options
