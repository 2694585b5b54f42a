"""``StepResidualsAdjoint``: reverse mode through a fixed-step solve that keeps every step's
residuals, so that the backward pass recomputes nothing."""

from __future__ import annotations

import functools as ft

import diffrax
import equinox.internal as eqxi
import jax

__all__ = ["StepResidualsAdjoint"]

# states per step the residuals are reckoned at (see the class)
RESIDUAL_STATES = 24


def state_bytes(y) -> int:
    """Bytes of one solve's state ``y`` (one member's, inside a vmapped batch)."""
    return sum(
        x.size * x.dtype.itemsize for x in jax.tree_util.tree_leaves(y) if hasattr(x, "dtype")
    )


_outer = jax.named_call(eqxi.while_loop, name="outer-loop")
_inner = jax.named_call(eqxi.while_loop, name="inner-loop")


class StepResidualsAdjoint(diffrax.AbstractAdjoint):
    """Reverse mode through a fixed-step solve, every step's residuals kept.

    diffrax's ``RecursiveCheckpointAdjoint`` keeps (at most) each step's *input*: its
    backward pass runs every step forward again before pulling the cotangent back through
    it. Here the solve's steps are one ``lax.scan`` of exactly ``max_steps`` iterations
    (each a no-op once the solve has ended), which JAX differentiates as it does any scan:
    the forward pass keeps what each step's pullback needs, and the backward pass runs
    only the pullbacks: less time than with every step checkpointed, at the same gradient,
    for some tens of states of memory per step instead of one
    (``benchmarks/gradient_cost.py`` measures both).

    For fixed steps only (``diffrax.ConstantStepSize``), with ``max_steps`` the solve's
    step count (``SolveOptions(dt=...)`` sets both, and uses this adjoint by default):
    iterations past the solve's end are skipped alone but computed and discarded in a
    vmapped batch, so a larger budget can be paid in full. A solve that is not
    differentiated runs at the speed of diffrax's own loop.

    The residuals grow with the steps (an engagement's design objective keeps about 12
    states per step, a closed drive's mesh-order objective 22). Where
    :data:`RESIDUAL_STATES` states per step
    would pass ``memory_limit`` [bytes, per solve: each member of a vmapped ensemble
    counts], the solve is differentiated by recursive checkpointing instead — each step's
    input kept (``RecursiveCheckpointAdjoint(checkpoints=max_steps)``) where that fits the
    limit, diffrax's default ≈ √(2·max_steps) checkpoints where not — at the same gradient
    (to rounding) and 15–20 % more time. ``memory_limit=None`` keeps the residuals always.
    """

    memory_limit: float | None = 1e9

    def loop(
        self,
        *,
        terms,
        saveat,
        init_state,
        max_steps,
        throw,
        passed_solver_state,
        passed_controller_state,
        stepsize_controller,
        **kwargs,
    ):
        if not isinstance(stepsize_controller, diffrax.ConstantStepSize):
            raise ValueError(
                "StepResidualsAdjoint needs fixed steps (diffrax.ConstantStepSize, or "
                f"SolveOptions(dt=...)), got {type(stepsize_controller).__name__}"
            )
        if max_steps is None:
            raise ValueError("StepResidualsAdjoint needs max_steps: the solve's step count")
        common = dict(
            terms=terms,
            saveat=saveat,
            init_state=init_state,
            max_steps=max_steps,
            stepsize_controller=stepsize_controller,
            **kwargs,
        )
        state = state_bytes(init_state.y)
        if (
            self.memory_limit is not None
            and RESIDUAL_STATES * state * max_steps > self.memory_limit
        ):
            every = state * max_steps <= self.memory_limit
            fallback = diffrax.RecursiveCheckpointAdjoint(checkpoints=max_steps if every else None)
            return fallback.loop(
                throw=throw,
                passed_solver_state=passed_solver_state,
                passed_controller_state=passed_controller_state,
                **common,
            )
        # "bounded" with base = max_steps: one scan of max_steps conditional steps, no
        # nesting and no checkpoints (equinox's bounded loop checkpoints only its inner levels)
        return self._loop(
            inner_while_loop=ft.partial(_inner, kind="bounded"),
            outer_while_loop=ft.partial(_outer, kind="bounded", base=max(max_steps, 2)),
            **common,
        )
