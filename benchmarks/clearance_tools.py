"""Shared helpers of the clearance-chain studies ``clearance_peak`` and
``clearance_gradient``: timed calls, the long adaptive solve of an engagement strand with
its observers, and strict JSON (non-finite floats as null)."""

from __future__ import annotations

import math
import time

import jax

import jaxchain as jc

MAX_STEPS = 2_000_000  # of a long adaptive solve


def timed(f, /, *args, **kwargs):
    """(``f(*args, **kwargs)`` once its arrays are ready, wall time [s])."""
    t = time.perf_counter()
    out = jax.block_until_ready(f(*args, **kwargs))
    return out, time.perf_counter() - t


def solve(scene, t1: float, observers: tuple, **kwargs):
    """(the solution, wall time [s]) of an adaptive solve of ``scene`` to ``t1`` at
    ``simulate``'s default tolerances with ``observers``, failures returned, not raised."""
    return timed(
        jc.simulate, scene, t1, observers=observers, max_steps=MAX_STEPS, throw=False, **kwargs
    )


def clean(x):
    """``x`` with every non-finite float as None (strict JSON)."""
    if isinstance(x, dict):
        return {k: clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x
