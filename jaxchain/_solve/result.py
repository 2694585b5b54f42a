"""Result codes of a solve, with what to change, and their one classification."""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool

from .._observers.base import FLYING_APART

__all__ = [
    "Result",
    "SolveError",
    "RESULT_NAMES",
    "result_names",
    "result_messages",
    "classify",
    "raise_if_failed",
    "FLYING_APART",
]


class SolveError(RuntimeError):
    """A solve (or a member of an ensemble or design objective) did not succeed; the
    message says what happened and what to change, ``names`` holds every member's
    :class:`Result` name."""

    def __init__(self, message: str, names: list[str]):
        super().__init__(message)
        self.names = names


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
        f"scene, or faster than {FLYING_APART:g} × (pitch-line speed + reference impact "
        "speed)): the solve diverged. With fixed steps the step is above the explicit "
        "stability limit of the stiffest contact or link (on the engagement scene "
        "h·ω_max ≈ 0.2 for Euler, which needs damping to be stable at all, 1.0–1.3 for Heun, "
        "≈ 3 for Tsit5; see benchmarks/stability.py): reduce dt0, or use an adaptive "
        "step-size controller or an implicit solver. In float32, enable float64 "
        "(jax.config.update('jax_enable_x64', True))."
    )
    implicit_solver_failed = (
        "The implicit solver's Newton iteration did not converge. Reduce the step (dt0 or "
        "tolerances), or use an explicit solver for this non-stiff scene."
    )
    contact_slots_exceeded = (
        "More rollers came within reach of a sprocket or a shoe than it has contact slots "
        "(Sprocket.contact_slots, Shoes.slots), so contacts may have been missed: rebuild "
        "the scene with more slots, or contact_slots=None (slots=None) to check every roller."
    )
    internal = "diffrax reported an internal failure; see the diffrax result in the stats."
    past_horizon = (
        "t1 lies past the scene's horizon (Scene.horizon), the time up to which it models "
        "its drive: an engagement's entry span holds n_entry rollers and meshes one per "
        "tooth period, so past n_entry tooth periods its held end reaches the sprocket and "
        "the forces mean nothing. End the solve by the horizon, or build the scene with a "
        "larger n_entry."
    )
    float32_state = (
        "The state is float32 (jax_enable_x64 is off): positions of ~0.1 m are then resolved "
        "to ~1e-8 m, comparable to contact deflections, and a solve can look successful "
        "with wrong forces. Call jax.config.update('jax_enable_x64', True) before building "
        "the scene, or pass allow_float32=True to accept a float32 solve."
    )
    chain_overloaded = (
        "A link tension exceeded the chain's tensile strength (Scene.tensile_strength, the "
        "ISO 606 minimum): a real chain would have broken. Lower the load torque or the "
        "pretension, or choose a larger chain; absurd tensions also come from a profile or "
        "contact law that does not fit the chain."
    )


RESULT_NAMES = (
    "successful",
    "max_steps_reached",
    "step_size_collapse",
    "diverged",
    "implicit_solver_failed",
    "contact_slots_exceeded",
    "internal",
    "past_horizon",
    "float32_state",
    "chain_overloaded",
)


def result_names(result: Result) -> list[str]:
    """The :class:`Result` name ("successful", "diverged", …) of every element of a
    (possibly batched) result, flattened."""
    if not isinstance(result, Result):
        raise TypeError(
            f"result must be a jc.Result (e.g. sol.result), got {type(result).__name__} {result!r}"
        )
    hits = [np.ravel(np.asarray(result == getattr(Result, n))) for n in RESULT_NAMES]
    return [RESULT_NAMES[int(np.argmax(col))] for col in np.stack(hits, axis=1)]


def result_messages(result: Result) -> list[str]:
    """What happened and what to change ("" when successful) for every element of a
    (possibly batched) result, flattened."""
    return [Result[getattr(Result, n)] for n in result_names(result)]


def classify(
    diffrax_result,
    healthy: Bool[Array, ""],
    slots_ok: Bool[Array, ""],
    *,
    within_horizon: Bool[Array, ""] = True,
    float_ok: bool = True,
    within_strength: Bool[Array, ""] = True,
) -> Result:
    """The one classification of a solve, first cause first: a solve past the scene's
    horizon, a float32 state not allowed, then diffrax's own result, then (for a solve
    diffrax calls successful) the solution's health — finite, rollers in the scene and
    slower than the flying-apart limit — the chain's tensile strength and the contact
    slots."""
    r = diffrax.RESULTS
    out = Result.where(diffrax_result == r.successful, Result.successful, Result.internal)
    out = Result.where(diffrax_result == r.max_steps_reached, Result.max_steps_reached, out)
    out = Result.where(diffrax_result == r.dt_min_reached, Result.step_size_collapse, out)
    out = Result.where(diffrax_result == r.nonfinite, Result.diverged, out)
    for bad in (r.nonlinear_max_steps_reached, r.nonlinear_divergence):
        out = Result.where(diffrax_result == bad, Result.implicit_solver_failed, out)
    # a fixed-step explicit blow-up is successful to diffrax: judge the health of a solve
    # it calls successful (an unfinished one has padded, meaningless outputs)
    ok = diffrax_result == r.successful
    out = Result.where(ok & ~healthy, Result.diverged, out)
    good = out == Result.successful
    out = Result.where(good & ~jnp.asarray(within_strength), Result.chain_overloaded, out)
    out = Result.where((out == Result.successful) & ~slots_ok, Result.contact_slots_exceeded, out)
    if not float_ok:
        out = Result.where(jnp.asarray(True), Result.float32_state, out)
    return Result.where(jnp.asarray(within_horizon), out, Result.past_horizon)


def raise_if_failed(result: Result, payload, caller: str):
    """``payload`` if every element of ``result`` is successful. Otherwise, outside a trace,
    raise :class:`SolveError` (a ``RuntimeError``) with what happened and what to change
    (naming the failed members of a batched result); inside the caller's
    ``jit``/``grad``, ``payload`` with a runtime error attached (``eqx.error_if``)."""
    failed = jnp.any(result != Result.successful)
    if isinstance(failed, jax.core.Tracer):
        return result.error_if(payload, failed)
    if not bool(failed):
        return payload
    names, messages = result_names(result), result_messages(result)
    if np.ndim(np.asarray(result == Result.successful)) == 0:
        raise SolveError(f"{caller} failed ({names[0]}): {messages[0]}", names)
    bad = [i for i, n in enumerate(names) if n != "successful"]
    lines = [f"member {i}: {names[i]}: {messages[i]}" for i in bad]
    raise SolveError(
        f"{caller}: {len(bad)} of {len(names)} members failed (members {bad}):\n"
        + "\n".join(lines),
        names,
    )
