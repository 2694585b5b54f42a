"""What the main job and the test suite set in the environment before JAX starts
(``optimize/__main__.py``, ``tests/conftest.py``): the XLA compiler flag below and the
persistent caches' folder (:func:`use_user_cache`). The library itself sets nothing; a
notebook or script gets the same with ``XLA_FLAGS`` set to :data:`FLAG` and
``JAX_COMPILATION_CACHE_DIR`` in its environment.

XLA's CPU backend with its newer fusion emitters off compiles jaxchain's solves in about
a third less time at the same run time, with results equal to rounding (jaxlib 0.10.2 on
a 2-core CPU: the main job's ``--fast --problem iso`` run spends 26.5 s instead of 39.5 s
in XLA's backend compile; the default test run takes 414 s instead of 559 s; the default
``python -m optimize`` spends 83 s instead of 139 s in XLA's compile, summed over its
threads, with its Adam history equal to the fourth decimal of a newton and its delivered
design to 1e-9 relative; only the clearance-chain re-measurement, whose rattling rollers
carry rounding into other engagement sequences, moves within its confidence interval).
An unknown flag aborts XLA, so it is set only for the jaxlib versions it was measured on.
"""

from __future__ import annotations

import os
from importlib import metadata
from pathlib import Path

FLAG = "--xla_cpu_use_fusion_emitters=false"
CACHE_SIZE = 4 << 30  # [bytes] XLA's compiled programs kept in the user's cache, at most
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


def user_cache(environ=os.environ) -> Path:
    """The folder of the persistent caches: ``$JAXCHAIN_CACHE``, else ``jaxchain`` in the
    user's cache folder (``$XDG_CACHE_HOME``, else ``~/.cache``). Per user rather than per
    checkout, so that a fresh clone (CI's, a second worktree) starts with the programs an
    earlier run compiled: XLA's cache keys hold the program without its source paths, and
    jaxchain's stored programs are keyed by its source's digest, so code that changed
    compiles anew and code that did not is read back."""
    if environ.get("JAXCHAIN_CACHE"):
        return Path(environ["JAXCHAIN_CACHE"])
    base = environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "jaxchain"


def use_user_cache(environ=os.environ) -> str:
    """Point JAX's persistent compilation cache at :func:`user_cache` unless
    ``JAX_COMPILATION_CACHE_DIR`` is set already (a user's own choice stands), and keep
    it bounded (:func:`prune_cache`). Call it before JAX is imported. Returns the folder in
    effect."""
    environ.setdefault("JAX_COMPILATION_CACHE_DIR", str(user_cache(environ)))
    folder = environ["JAX_COMPILATION_CACHE_DIR"]
    if not environ.get("PYTEST_XDIST_WORKER"):  # once per run: the controller's
        prune_cache(Path(folder))
    return folder


def prune_cache(folder: Path, max_bytes: int = CACHE_SIZE) -> int:
    """Remove XLA's compiled programs from ``folder``, the longest written first, until
    they take three quarters of ``max_bytes``, when they take more than ``max_bytes``; a
    program removed and needed again is compiled and written anew. (JAX's own bound,
    ``jax_compilation_cache_max_size``, rescans the folder, every entry's size and access
    time, at every write: the default test run from an empty cache took 436 s with it
    against 386 s without, on a 2-core CPU, the slower run beside light other work.)
    Returns the bytes removed."""
    try:
        stats = [(e, e.stat()) for e in folder.glob("*-cache")]
    except OSError:
        return 0
    total = sum(st.st_size for _, st in stats)
    if total <= max_bytes:
        return 0
    removed = 0
    for entry, st in sorted(stats, key=lambda e: e[1].st_mtime):
        size = st.st_size
        if total - removed <= 0.75 * max_bytes:
            break
        try:
            entry.unlink()
            removed += size
        except OSError:
            continue
    return removed
