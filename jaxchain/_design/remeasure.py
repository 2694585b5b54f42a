"""Re-measuring a design independently of the model it was designed on: the tight solve of
the sharp peak, a second contact law, and the per-engagement peak statistics of a strand
(what a design win must survive before it counts; ``python -m optimize`` reads every one
of its results through these)."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import diffrax
import jax
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._contact.lankarani_nikravesh import LankaraniNikravesh
from .._materials import STEEL, effective_modulus
from .._observers.engagements import EngagementPeaks
from .._scene import Scene
from .._solve.simulate import simulate
from .._statistics import engagement_peaks

__all__ = [
    "second_law",
    "sharp_peak",
    "remeasure",
    "engagement_sample",
    "solve_threads",
    "solve_each",
]

#: the finest spacing [s] and the most save times of :func:`sharp_peak`'s dense output
SPACING, MAX_SAVES = 0.5e-6, 60_001


def second_law(chain: ChainSpec | str, restitution: float = 0.7) -> LankaraniNikravesh:
    """The independent check's roller/tooth law: Hertz (Lankarani–Nikravesh damping) with
    one stiffness for every design — a roller on a flat, K = (4/3)·E*·√r — so a win cannot
    come from the design moving the stiffness (Johnson's law, the default, reads the
    roller/tooth clearance the design sets)."""
    chain = as_chain(chain)
    e_star = effective_modulus(STEEL, STEEL)
    k = 4.0 / 3.0 * e_star * math.sqrt(float(chain.roller_diameter) / 2)
    return LankaraniNikravesh(stiffness=k, exponent=1.5, restitution=restitution)


def solve_threads() -> int:
    """Threads for independent solves: the cores this process may run on; one under JAX's
    multi-process runtime (every process then solves alike)."""
    if jax.process_count() > 1:
        return 1
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def solve_each(solve: Callable, jobs: Sequence, threads: int | None = None) -> list:
    """``solve(job)`` of every job, in order, ``threads`` at a time (default
    :func:`solve_threads`): independent XLA solves, one per core; the results are those of
    one after the other, bit for bit."""
    if threads is not None:
        checks.integer("threads", threads, lo=1)
    threads = min(solve_threads() if threads is None else threads, len(jobs))
    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            return list(pool.map(solve, jobs))
    return [solve(job) for job in jobs]


def sharp_peak(scene: Scene, t1: float, *, t_start: float = 0.0, rtol: float = 1e-9) -> dict:
    """The tight solve of a design's peak: Dopri8 at ``rtol`` (``atol`` = rtol·1e-3 m),
    the largest roller/tooth force over [``t_start``, ``t1``] read from saves at most
    0.5 µs apart (2001 to 60 001 of them) — the sharp maximum, not a soft one, from a
    solver and tolerance independent of a fixed-step design solve.

    Returns a dict: ``peak_N`` (NaN where the solve failed), ``record_N`` (the same
    solve's exact peak between its steps, ``Solution.peak_contact_force``, over the whole
    solve: a second reading of the top), ``ok``, ``message``, ``steps`` (accepted), ``ts``
    [s], ``force`` (the largest roller force at each save [N]) and ``torque`` (the first
    sprocket's torque at each save [N·m])."""
    checks.instance("scene", scene, Scene, "a jaxchain Scene")
    t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
    t_start = checks.real("t_start", t_start, lo=0.0, hi=t1, unit="s")
    rtol = checks.real("rtol", rtol, lo=0.0, hi=1.0, lo_open=True)
    n = min(MAX_SAVES, max(2001, math.ceil((t1 - t_start) / SPACING) + 1))
    sol = simulate(
        scene,
        t1,
        solver=diffrax.Dopri8(),
        rtol=rtol,
        atol=rtol * 1e-3,
        ts=np.linspace(t_start, t1, n),
        max_steps=1_000_000,
        throw=False,
    )
    force = np.asarray(sol.roller_sprocket_force)
    return {
        "peak_N": float(np.max(force)) if sol.ok else float("nan"),
        "record_N": float(sol.peak_contact_force) if sol.ok else float("nan"),
        "ok": bool(sol.ok),
        "message": sol.message,
        "steps": int(sol.stats["num_accepted_steps"]),
        "ts": np.asarray(sol.ts),
        "force": force.max(axis=1),
        "torque": np.asarray(sol.sprocket_torque)[:, 0],
    }


def remeasure(
    scenes: Sequence[Scene | Callable[[], Scene]],
    t1: float,
    *,
    t_start: float = 0.0,
    rtol: float = 1e-9,
    threads: int | None = None,
) -> dict:
    """:func:`sharp_peak` of every member of an ensemble (the operating points of one
    design): ``scenes``, each a scene or a function building one (then built, settled and
    solved in a thread of its own), ``threads`` at a time (default: the cores this
    process may use). Returns ``peak_N`` (the worst member), ``mean_peak_N`` and
    ``members`` (each :func:`sharp_peak`'s dict)."""
    if isinstance(scenes, Scene) or not isinstance(scenes, Sequence) or not len(scenes):
        raise TypeError(
            "remeasure: scenes must be a non-empty sequence of scenes (or of functions "
            f"building one), got {scenes!r}"
        )

    def one(member):
        scene = member() if callable(member) and not isinstance(member, Scene) else member
        return sharp_peak(scene, t1, t_start=t_start, rtol=rtol)

    members = solve_each(one, list(scenes), threads)
    peaks = [m["peak_N"] for m in members]
    worst, mean = float(np.max(peaks)), float(np.mean(peaks))
    return {"peak_N": worst, "mean_peak_N": mean, "members": members}


def engagement_sample(
    scene: Scene, *, discard: int = 2, steps_per_period: int = 25_000
) -> dict[str, Any]:
    """Per-engagement peaks [N] of a meshing strand (``jc.scenes.engagement``, most often
    the clearance-joint chain's, whose peaks scatter between events), solved over its whole
    horizon at ``simulate``'s default tolerances; the first ``discard`` tooth periods (the
    start transient) left out. With the peaks, which roller of its link each is
    (``populations``: 1 first, 2 second), the solve's outcome and its wall time. A strand
    with ``n_entry`` = E + ``discard`` + 1 rollers gives E engagements (the last roller
    closes the last one's window). ``steps_per_period``: the step budget per tooth period
    (the Dahl-jointed clearance chain takes ~5 000 at 1250 rpm)."""
    checks.instance("scene", scene, Scene, "a jaxchain Scene (jc.scenes.engagement)")
    if not np.isfinite(float(scene.horizon)):
        raise ValueError(
            "engagement_sample: give a meshing strand (jc.scenes.engagement), whose horizon "
            "is its entry rollers' tooth periods"
        )
    discard = checks.integer("discard", discard, lo=0)
    steps_per_period = checks.integer("steps_per_period", steps_per_period, lo=1)
    sprocket = scene.sprockets[0]
    period = 2 * math.pi / (sprocket.profile.teeth * abs(float(sprocket.speed)))
    t1 = float(scene.horizon)
    n_periods = round(t1 / period)
    observer = EngagementPeaks.for_solve(scene, t1)
    t = time.perf_counter()
    sol = simulate(
        scene, t1, n_save=2, observers=(observer,),
        max_steps=steps_per_period * n_periods, throw=False,
    )  # fmt: skip
    ev = engagement_peaks(sol, t_start=discard * period) if sol.ok else None
    return {
        "peaks_N": [] if ev is None else ev.peak.tolist(),
        "populations": [] if ev is None else ev.populations().tolist(),
        "ok": bool(sol.ok),
        "message": sol.message,
        "steps": int(sol.stats["num_accepted_steps"]),
        "wall_s": time.perf_counter() - t,
    }
