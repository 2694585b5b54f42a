"""The one solve: ``diffrax.diffeqsolve`` of the drive's vector field, with observers.

``simulate``, ``simulate_ensemble`` and every design objective run :func:`solve`; they
differ only in the observers they plug in and what they save. The solve also carries the
:class:`~jaxchain._observers.base.Health` observer, and classifies every outcome with the one
:func:`~jaxchain._solve.result.classify`.
"""

from __future__ import annotations

import contextlib
import typing
import warnings
from typing import Any, NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .._deps import errors_as_nan
from .._dynamics import DriveState, forces, initial_state, outputs, rates
from .._numerics import is_concrete
from .._observers.base import AbstractIntegralObserver, AbstractStepObserver, Health
from .._scene import Scene
from .options import Resolved
from .result import Result, classify

__all__ = ["solve", "Trajectory", "strong_scene", "check_horizon"]


class _Args(NamedTuple):
    scene: Scene
    integrals: tuple[AbstractIntegralObserver, ...]


def _drive(state, args: _Args) -> DriveState:
    """The drive's part of the ODE state: the state itself without integral observers
    (diffrax takes no empty containers in a state), else its first entry."""
    return state[0] if args.integrals else state


def _field(t, state, args: _Args):
    """dy/dt of the drive and of every integral observer, from one force evaluation."""
    y = _drive(state, args)
    fr = forces(t, y, args.scene)
    dy = rates(t, y, args.scene, fr)
    if not args.integrals:
        return dy
    return dy, tuple(o.integrand(t, y, args.scene, fr) for o in args.integrals)


def _zero_field(t, state, args):
    return jax.tree_util.tree_map(jnp.zeros_like, state)


def _terms(solver: diffrax.AbstractSolver):
    """The field as the solver's terms: an IMEX solver (``MultiTerm`` structure) takes it
    whole as its implicit term."""
    if typing.get_origin(solver.term_structure) is diffrax.MultiTerm:
        return diffrax.MultiTerm(diffrax.ODETerm(_zero_field), diffrax.ODETerm(_field))
    return diffrax.ODETerm(_field)


class _Observed(diffrax.AbstractWrappedSolver):
    """Wraps any diffrax solver; also advances the step observers on every accepted step
    (their states ride in the solver state, which diffrax keeps for accepted steps only)."""

    solver: diffrax.AbstractSolver
    observers: tuple[AbstractStepObserver, ...]

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
        states = tuple(o.init(t0, _drive(y0, args), args.scene) for o in self.observers)
        return self.solver.init(terms, t0, t1, y0, args), states

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        inner, states = solver_state
        y1, y_error, dense_info, inner, result = self.solver.step(
            terms, t0, t1, y0, args, inner, made_jump
        )
        interp = self.solver.interpolation_cls(t0=t0, t1=t1, **dense_info)
        dense = lambda ts: _drive(jax.vmap(interp.evaluate)(ts), args)
        y0, y1d = _drive(y0, args), _drive(y1, args)
        states = tuple(
            o.step(t0, t1, y0, y1d, dense, args.scene, s)
            for o, s in zip(self.observers, states, strict=True)
        )
        return y1, y_error, dense_info, (inner, states), result

    def func(self, terms, t0, y0, args):
        return self.solver.func(terms, t0, y0, args)


class Trajectory(NamedTuple):
    """What :func:`solve` returns."""

    saved: dict[str, Array] | None  # outputs at the save times (jaxchain._dynamics.outputs)
    y1: DriveState  # the state at t1
    observed: tuple[Any, ...]  # each observer's value, in the order given
    result: Result
    stats: dict


def _all_finite(tree) -> Array:
    leaves = [jnp.all(jnp.isfinite(x)) for x in jax.tree_util.tree_leaves(tree)]
    return jnp.all(jnp.stack(leaves)) if leaves else jnp.asarray(True)


@eqx.filter_jit
def solve(
    scene: Scene,
    t0: Array,
    t1: Array,
    ts: Array | None,
    resolved: Resolved,
    observers: tuple[AbstractStepObserver | AbstractIntegralObserver, ...] = (),
) -> Trajectory:
    """Solve ``scene`` over [t0, t1] with the resolved options, saving the outputs at
    ``ts`` (None: nothing saved) and carrying ``observers``.

    The loop saves states only; the outputs (a second evaluation of the forces) are
    computed from them after the solve, vmapped: inside the loop they would be traced,
    linearized and transposed once more in every gradient (compile time).
    """
    steps = tuple(o for o in observers if isinstance(o, AbstractStepObserver))
    integrals = tuple(o for o in observers if isinstance(o, AbstractIntegralObserver))
    if len(steps) + len(integrals) != len(observers):
        raise TypeError(f"observers must be step or integral observers, got {observers!r}")
    scene = scene.prepared()
    y0 = initial_state(scene)
    i0 = tuple(_zeros_of(o, t0, y0, scene) for o in integrals)
    subs = [diffrax.SubSaveAt(t1=True)]
    if ts is not None:
        subs.insert(0, diffrax.SubSaveAt(ts=ts))
    args = _Args(scene, integrals)
    with _input_checks_without_callbacks():
        sol = _diffeqsolve(resolved, steps, t0, t1, y0, i0, integrals, args, subs)
    *saved_states, final = sol.ys
    y1 = jax.tree_util.tree_map(lambda x: x[-1], _drive(final, args))
    i1 = jax.tree_util.tree_map(lambda x: x[-1], final[1]) if integrals else ()
    saved = None
    if ts is not None:
        ys = _drive(saved_states[0], args)
        saved = jax.vmap(outputs, in_axes=(0, 0, None))(ts, ys, scene)
    (healthy, slots_ok, tension), *step_states = sol.solver_state[1]
    # each observer's value, in the order given
    step_values = iter([o.value(s, t0, t1) for o, s in zip(steps, step_states, strict=True)])
    integral_values = iter([o.value(s, t0, t1) for o, s in zip(integrals, i1, strict=True)])
    observed = tuple(
        next(step_values if isinstance(o, AbstractStepObserver) else integral_values)
        for o in observers
    )
    result = classify(
        sol.result,
        healthy & _all_finite(observed),
        slots_ok,
        within_horizon=t1 <= scene.horizon * (1 + 1e-9),
        float_ok=resolved.allow_float32 or jnp.result_type(y0.q) == jnp.float64,
        within_strength=tension <= scene.tensile_strength,
    )
    stats = dict(sol.stats)
    stats["diffrax_result"] = sol.result
    stats["peak_link_tension"] = tension
    return Trajectory(saved, y1, observed, result, stats)


def _diffeqsolve(resolved: Resolved, steps, t0, t1, y0, i0, integrals, args, subs):
    return diffrax.diffeqsolve(
        _terms(resolved.solver),
        _Observed(resolved.solver, (Health(), *steps)),
        t0,
        t1,
        resolved.dt0,
        (y0, i0) if integrals else y0,
        args=args,
        saveat=diffrax.SaveAt(subs=subs, solver_state=True),
        stepsize_controller=resolved.controller,
        max_steps=resolved.max_steps,
        adjoint=resolved.adjoint,
        progress_meter=resolved.meter,
        throw=False,
    )


@contextlib.contextmanager
def _input_checks_without_callbacks():
    """While the solve is traced, equinox's ``error_if`` answers a failed check with NaN
    instead of a host callback.

    diffrax checks its inputs (the sign of dt0, the save times' order and range) with
    ``eqx.error_if``; with the times traced (one program for every horizon) each check is
    a host callback, and JAX does not write a program with host callbacks to its
    persistent compilation cache: every process would compile the solve again. jaxchain
    checks the same inputs itself before tracing (:func:`~jaxchain._solve.simulate.time_span`,
    :class:`~jaxchain.SolveOptions`); traced inputs that fail them give NaN, which the
    solve's health reports."""
    with errors_as_nan():
        yield


def _zeros_of(observer: AbstractIntegralObserver, t0, y0, scene):
    shapes = jax.eval_shape(lambda: observer.integrand(t0, y0, scene, forces(t0, y0, scene)))
    return jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)


def check_horizon(scene: Scene, t1, caller: str, members: bool = False) -> None:
    """Raise ``ValueError`` when a concrete ``t1`` lies past a concrete scene horizon
    (every member of a stacked scene with ``members``); traced values are left to the
    solve's ``past_horizon`` code."""
    if not is_concrete(t1, scene.horizon):
        return
    horizon = np.atleast_1d(np.asarray(scene.horizon, dtype=float))
    late = np.nonzero(float(t1) > horizon * (1 + 1e-9))[0]
    if late.size:
        which = f"members {late.tolist()} end" if members else "the scene ends"
        raise ValueError(
            f"{caller}: t1 = {float(t1):.6g} s lies past the scene's horizon: {which} at "
            f"{horizon[late].min():.6g} s (Scene.horizon). An engagement strand models "
            "n_entry tooth periods (its entry span then runs out of chain): end the solve "
            "by the horizon, or build the scene with a larger n_entry."
        )


def _check_finite(scene: Scene, caller: str) -> None:
    """A concrete scene's numbers must be finite (its horizon may be inf): a NaN mass or
    start position would only surface as a stalled solve."""
    leaves = jax.tree_util.tree_leaves_with_path(eqx.tree_at(lambda s: s.horizon, scene, 0.0))
    for path, x in leaves:
        if eqx.is_inexact_array(x) and is_concrete(x) and not np.all(np.isfinite(np.asarray(x))):
            raise ValueError(
                f"{caller}: scene{jax.tree_util.keystr(path)} has non-finite values (NaN or "
                "inf); rebuild the scene with finite inputs"
            )


def strong_scene(scene: Scene, caller: str, members: bool = False) -> Scene:
    """The scene with every inexact array leaf strongly typed (a weakly typed leaf such as
    ``jnp.asarray(110.0)`` must not force a retrace); warns when it is not float64. Every
    entry point passes its scene through here: ``TypeError`` for anything but a
    :class:`Scene`, ``ValueError`` for a stacked scene where one is expected (and the
    reverse with ``members``)."""
    if not isinstance(scene, Scene):
        raise TypeError(
            f"{caller}: scene must be a jaxchain Scene (built by jc.scenes.drive, "
            f"jc.scenes.engagement, ...), got {type(scene).__name__}"
        )
    if not members and np.ndim(scene.q0) != 2:
        raise ValueError(
            f"{caller}: the scene is stacked (q0 has shape {np.shape(scene.q0)}, members "
            "first): simulate an ensemble with jc.simulate_ensemble, or take one member"
        )
    _check_finite(scene, caller)
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
    return scene
