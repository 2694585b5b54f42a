"""XLA compiler flags for the test suite, set in the environment before JAX starts its
backend (tests/conftest.py). The library itself sets nothing.

XLA's CPU backend with its newer fusion emitters off compiles jaxchain's solves in about
a third less time at the same run time (jaxlib 0.10.2 on a 2-core CPU: the main job's
``--fast --problem iso`` run spends 26.5 s instead of 39.5 s in XLA's backend compile;
the default test run takes 414 s instead of 559 s), with results equal to rounding. An
unknown flag aborts XLA, so the flags are set only for the jaxlib versions they were
measured on.

The main job sets none of them. A design run amplifies rounding through its chaotic
meshing sequence, so its history is reproduced only with the same compiler settings on
the same kind of CPU (with the flag, or on another CPU model, the default run's Adam
objective moves in the fourth digit within ten iterations); its committed results are
computed with XLA's defaults, and its compile time is a small part of its run.
"""

from __future__ import annotations

import os
from importlib import metadata

#: flag name -> value: the older fusion emitters (a third less compile time), and LLVM
#: code generation in one piece (XLA splits it into up to 32 parts compiled on threads of
#: its own; with every core busy running test workers that only adds work: the main
#: job's ``--fast --problem iso`` run takes 67 s of CPU time instead of 71-73 s, its
#: wall time 1.5 s longer when it runs alone)
FLAGS = {
    "xla_cpu_use_fusion_emitters": "false",
    "xla_cpu_parallel_codegen_split_count": "1",
}
MEASURED = ((0, 10),)  # jaxlib (major, minor) releases the flags were measured on


def jaxlib_version() -> tuple[int, int] | None:
    """(major, minor) of the installed jaxlib, or None if it cannot be read."""
    try:
        major, minor = metadata.version("jaxlib").split(".")[:2]
        return int(major), int(minor)
    except (metadata.PackageNotFoundError, ValueError):
        return None


def fast_compile(environ=os.environ, version: tuple[int, int] | None = None) -> bool:
    """Add each of :data:`FLAGS` to ``environ["XLA_FLAGS"]`` that is not set there already
    (a user's own choice stands), when jaxlib is a measured release. Call it before JAX's
    first computation. Returns whether every one of :data:`FLAGS` is in effect."""
    if (jaxlib_version() if version is None else version) not in MEASURED:
        return False
    flags = environ.get("XLA_FLAGS", "").split()
    for name, value in FLAGS.items():
        if not any(f.startswith(f"--{name}=") for f in flags):
            flags.append(f"--{name}={value}")
    environ["XLA_FLAGS"] = " ".join(flags)
    return all(f"--{name}={value}" in flags for name, value in FLAGS.items())
