"""What the test suite sets before JAX starts its backend (tests/conftest.py): an XLA
compiler flag, and each pytest-xdist worker pinned to a core of its own. The library
itself sets nothing.

XLA's CPU backend with its newer fusion emitters off compiles jaxchain's solves in about
a third less time at the same run time (jaxlib 0.10.2 on a 2-core CPU: the main job's
``--fast --problem iso`` run spends 26.5 s instead of 39.5 s in XLA's backend compile;
the default test run takes 414 s instead of 559 s), with results equal to rounding. An
unknown flag aborts XLA, so it is set only for the jaxlib versions it was measured on.

The main job does not set it. A design run amplifies rounding through its chaotic
meshing sequence, so its history is reproduced only with the same compiler settings on
the same kind of CPU (with the flag, or on another CPU model, the default run's Adam
objective moves in the fourth digit within ten iterations); its committed results are
computed with XLA's defaults, and its compile time is a small part of its run.
"""

from __future__ import annotations

import os
from importlib import metadata

FLAG = "--xla_cpu_use_fusion_emitters=false"
MEASURED = ((0, 10),)  # jaxlib (major, minor) releases the flag was measured on


def jaxlib_version() -> tuple[int, int] | None:
    """(major, minor) of the installed jaxlib, or None if it cannot be read."""
    try:
        major, minor = metadata.version("jaxlib").split(".")[:2]
        return int(major), int(minor)
    except (metadata.PackageNotFoundError, ValueError):
        return None


def fast_compile(environ=os.environ, version: tuple[int, int] | None = None) -> bool:
    """Add :data:`FLAG` to ``environ["XLA_FLAGS"]`` when jaxlib is a measured release and
    the flag is not set there already (a user's own choice stands). Call it before JAX's
    first computation. Returns whether the flag is in effect."""
    flags = environ.get("XLA_FLAGS", "")
    if "xla_cpu_use_fusion_emitters" in flags:
        return FLAG in flags.split()
    if (jaxlib_version() if version is None else version) not in MEASURED:
        return False
    environ["XLA_FLAGS"] = f"{flags} {FLAG}".strip()
    return True


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
