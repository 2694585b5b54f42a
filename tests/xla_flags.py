"""What the test suite sets before JAX starts its backend (tests/conftest.py): the main
job's XLA compiler flag (``optimize/xla_flags.py``), and each pytest-xdist worker pinned
to a core of its own. The library itself sets nothing."""

from __future__ import annotations

import os


def worker_core(environ, cores: list[int]) -> int | None:
    """The core for this pytest-xdist worker among the allowed ``cores``: worker i gets
    the i-th, when there are no more workers than cores; None otherwise (or outside
    xdist)."""
    worker, count = environ.get("PYTEST_XDIST_WORKER"), environ.get("PYTEST_XDIST_WORKER_COUNT")
    if not (worker and count and worker.startswith("gw")):
        return None
    index = int(worker.removeprefix("gw"))
    if int(count) > len(cores) or index >= len(cores):
        return None
    return sorted(cores)[index]


def pin_worker(environ=os.environ) -> int | None:
    """Pin a pytest-xdist worker to a core of its own (:func:`worker_core`) before JAX
    starts, so that XLA's threads and the notebook kernels the worker starts inherit it.
    Returns the core, or None.

    On the 2-core CI-class VM an unpinned process's solves sometimes run at half speed
    for its whole life (the same compiled solve 0.25 s instead of 0.13 s, every call);
    not seen pinned (benchmarks/README.md, gradient_cost). The default test run from a
    fresh clone: 313–324 s pinned (three runs), against 351–382 s in five unpinned runs of nearly
    the same suite (and 10 % less CPU time); 341–363 s pinned in three later runs with about
    15 s more tests, the rest this VM's spread between days."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    core = worker_core(environ, list(os.sched_getaffinity(0)))
    if core is not None:
        os.sched_setaffinity(0, {core})
    return core
