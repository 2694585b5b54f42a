"""Traced programs kept across processes.

JAX's persistent compilation cache skips XLA's compile in a second process, but not the
tracing and lowering before it, which for a solve is about as long (a few seconds; the
gradient of a design objective's solve, ten or more). :func:`stored` keeps the traced
program itself, exported (``jax.export``) beside the compilation cache, so that a second
process that calls the same program (same structure, shapes and constants) reads it back
and runs it without tracing.

A program is stored only when its identity is known exactly from its arguments: every
class, function and constant in them must come from jaxchain or the numerical libraries
it builds on (jax, diffrax, equinox, optimistix, lineax), whose code the key covers by
jaxchain's source digest and the libraries' versions. A user's own class or function
anywhere in the arguments (a force element, a load, a lambda), a traced argument (inside
the caller's ``jax.jit``/``jax.grad``) or a program that cannot be exported runs the
ordinary way. The store is on when JAX's persistent compilation cache is
(``jax_compilation_cache_dir``), in a folder beside it (``JAXCHAIN_PROGRAM_STORE=<folder>``
puts it elsewhere), and off with ``JAXCHAIN_PROGRAM_STORE=0``.

The store keeps the programs of each version of jaxchain and its libraries in a folder of
their own (named by :func:`_environment`'s digest). A process that saves a program also
removes the folders of the versions that saved nothing for :data:`KEEP_DAYS` days beyond
the :data:`KEEP` newest, so that a store shared by several checkouts (or a long history
of commits) stays bounded.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import os
import pickle
import sys
import tempfile
import threading
import types
from importlib import metadata
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["stored", "store_folder"]

FORMAT = 1
KEEP = 4  # versions' folders always kept, the most recently written first
KEEP_DAYS = 7.0  # older versions' folders are kept while written to within this many days
LIBRARIES = ("jax", "jaxlib", "diffrax", "equinox", "optimistix", "lineax")
_TRUSTED = ("jaxchain", "diffrax", "equinox", "optimistix", "lineax", "jax", "jaxlib")
_MEMORY: dict[str, object] = {}  # key -> (jitted call, skeleton), or None: not storable
_ABSENT = object()
_LOCKS: dict[str, threading.Lock] = {}  # key -> held while its program is first set up
# held while a program is read or traced, taken before that key's lock (re-entrant: a
# trace may call another stored function, which takes it again)
_TRACING = threading.RLock()


class _Refused(Exception):
    """The arguments hold something whose identity a key cannot capture."""


class _Slot(int):
    """Where an output array goes in the stored output's skeleton."""


def store_folder() -> Path | None:
    """The folder of stored programs: ``JAXCHAIN_PROGRAM_STORE`` if it names one, else
    beside JAX's persistent compilation cache; None (no store) when that cache is off or
    ``JAXCHAIN_PROGRAM_STORE=0``."""
    chosen = os.environ.get("JAXCHAIN_PROGRAM_STORE", "")
    if chosen == "0":
        return None
    if chosen:
        return Path(chosen)
    cache = _cache_dir()
    return Path(cache) / "jaxchain-programs" if cache else None


def _cache_dir() -> str | None:
    return jax.config.jax_compilation_cache_dir


@functools.cache
def _environment() -> str:
    """What, besides the arguments, decides the traced program: jaxchain's source, the
    libraries' versions and the settings that change tracing or lowering."""
    digest = hashlib.sha256()
    root = Path(__file__).resolve().parent
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    versions = []
    for name in LIBRARIES:
        try:
            versions.append(f"{name}={metadata.version(name)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{name}=?")
    return "|".join([str(FORMAT), digest.hexdigest(), *versions, sys.version])


def _settings() -> str:
    from ._deps import on_error_mode

    return "|".join(
        str(x)
        for x in (
            jax.config.jax_enable_x64,
            jax.default_backend(),
            os.environ.get("XLA_FLAGS", ""),
            on_error_mode(),
            jax.config.jax_default_matmul_precision,
            jax.config.jax_numpy_dtype_promotion,
        )
    )


def _trusted(obj) -> str:
    module = getattr(obj, "__module__", None) or ""
    qualname = getattr(obj, "__qualname__", None) or ""
    if module.split(".")[0] not in _TRUSTED or "<" in qualname:  # <locals>, <lambda>
        raise _Refused(f"{module}.{qualname}")
    return f"{module}.{qualname}"


def _describe(x, depth: int = 0, static: bool = False) -> str:
    """A description of ``x`` that equal programs share and different ones do not:
    arrays by dtype and shape (by value too in a static field, which the program holds
    as a constant), everything else by value; ``_Refused`` for what has no such
    description."""
    if depth > 64:
        raise _Refused("too deep")
    d = functools.partial(_describe, depth=depth + 1, static=static)
    if isinstance(x, jax.core.Tracer):
        raise _Refused("traced")
    if isinstance(x, jax.Array) and len(x.sharding.device_set) != 1:
        raise _Refused("sharded")  # an exported program runs on one device
    if isinstance(x, (jax.Array, np.ndarray, np.generic)):
        weak = getattr(x, "weak_type", False)
        text = f"A{np.dtype(x.dtype).str}{tuple(np.shape(x))}{'w' if weak else ''}"
        if static:
            text += hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest()
        return text
    if x is None or isinstance(x, (bool, int, float, complex, str, bytes)):
        return f"{type(x).__name__}:{x!r}"
    if isinstance(x, enum.Enum):
        return f"E{_trusted(type(x))}.{x.name}"
    if isinstance(x, type):
        return f"T{_trusted(x)}"
    if isinstance(x, (types.FunctionType, types.BuiltinFunctionType)):
        return f"F{_trusted(x)}"
    if isinstance(x, types.MethodType):
        return f"M{d(x.__self__)}.{x.__func__.__name__}"
    if isinstance(x, functools.partial):
        return f"P({d(x.func)},{d(x.args)},{d(x.keywords)})"
    if isinstance(x, (tuple, list)) and type(x) in (tuple, list):
        return f"{type(x).__name__}({','.join(d(v) for v in x)})"
    if isinstance(x, dict) and type(x) is dict:
        items = sorted(x.items(), key=lambda kv: repr(kv[0]))
        return "dict(" + ",".join(f"{d(k)}:{d(v)}" for k, v in items) + ")"
    name = _trusted(type(x))
    if isinstance(x, tuple) and hasattr(x, "_fields"):  # a NamedTuple
        return f"N{name}({','.join(d(v) for v in x)})"
    if dataclasses.is_dataclass(x):  # equinox modules among them
        fields = []
        for f in dataclasses.fields(x):
            held = static or bool(f.metadata.get("static"))
            fields.append(f"{f.name}={_describe(getattr(x, f.name, None), depth + 1, held)}")
        return f"D{name}({','.join(fields)})"
    raise _Refused(name)


def _key(name: str, args) -> str | None:
    try:
        text = "\n".join([name, _environment(), _settings(), _describe(args)])
    except _Refused:
        return None
    return hashlib.sha256(text.encode()).hexdigest()


def _skeleton(out):
    """``out`` with its arrays replaced by their positions (picklable), and the arrays."""
    dynamic, static = eqx.partition(out, eqx.is_array)
    leaves, treedef = jax.tree_util.tree_flatten(dynamic)
    slots = jax.tree_util.tree_unflatten(treedef, [_Slot(i) for i in range(len(leaves))])
    return eqx.combine(slots, static, is_leaf=lambda v: isinstance(v, _Slot)), leaves


def _fill(skeleton, leaves):
    return jax.tree_util.tree_map(
        lambda v: leaves[v] if isinstance(v, _Slot) else v,
        skeleton,
        is_leaf=lambda v: isinstance(v, _Slot),
    )


def _export(fn, leaves, treedef, static):
    """Trace ``fn`` once into an exported program of the arguments' arrays ``leaves``
    (the arguments: ``treedef`` of them combined with ``static``)."""
    box = []

    def flat(arrays):
        out = fn(*eqx.combine(jax.tree_util.tree_unflatten(treedef, arrays), static))
        skeleton, out_leaves = _skeleton(out)
        box.append(skeleton)
        # strongly typed: a program read back returns no weak types, so the first process
        # must not either (what consumes the outputs traces alike in every process)
        return [jnp.asarray(v, dtype=v.dtype) for v in out_leaves]

    exported = jax.export.export(jax.jit(flat))(leaves)
    return exported, box[0]


@functools.cache
def _generation() -> str:
    """The folder name of this version's programs: a digest of :func:`_environment`."""
    return hashlib.sha256(_environment().encode()).hexdigest()[:16]


def _prune(store: Path, keep: str) -> None:
    """Remove the folders of other versions beyond the :data:`KEEP` most recently written
    and older than :data:`KEEP_DAYS` (a version still in use elsewhere writes to its own
    folder and keeps it young), and entries of the store's former flat layout."""
    import shutil
    import time

    try:
        entries = list(store.iterdir())
    except OSError:
        return
    old = time.time() - KEEP_DAYS * 86400.0
    folders = []
    for entry in entries:
        if entry.name == keep or entry.name.startswith("."):
            continue
        try:
            if entry.is_dir():
                folders.append((entry.stat().st_mtime, entry))
            elif len(entry.name) == 64:  # a program saved flat, before versions' folders
                entry.unlink(missing_ok=True)
        except OSError:
            continue
    folders.sort(reverse=True)
    for mtime, folder in folders[KEEP - 1 :]:
        if mtime < old:
            shutil.rmtree(folder, ignore_errors=True)


_PRUNED: set[Path] = set()  # stores pruned by this process (once each)


def _save(folder: Path, key: str, exported, skeleton) -> None:
    if folder.parent not in _PRUNED:
        _PRUNED.add(folder.parent)
        _prune(folder.parent, folder.name)
    folder.mkdir(parents=True, exist_ok=True)
    data = pickle.dumps({"exported": bytes(exported.serialize()), "skeleton": skeleton})
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.chmod(tmp, 0o644)  # as the compilation cache's own entries
    os.replace(tmp, folder / key)  # atomic: a reader sees the whole entry or none


def _load(folder: Path, key: str):
    path = folder / key
    if not path.exists():
        return None
    try:
        data = pickle.loads(path.read_bytes())
        return jax.export.deserialize(bytearray(data["exported"])), data["skeleton"]
    except Exception:  # damaged or from another version of a library: trace anew
        path.unlink(missing_ok=True)
        return None


def _device(leaves) -> tuple:
    """The device the arrays are on (the first committed one's, else the first's), and
    whether any is committed to it."""
    arrays = [x for x in leaves if isinstance(x, jax.Array)]
    committed = [x for x in arrays if x.committed]
    for x in committed or arrays:
        return next(iter(x.devices())), bool(committed)
    return jax.devices()[0], False


def _prepare(fn, folder: Path, key: str, leaves, treedef, static) -> None:
    """Set the memory's entry for ``key`` (read back, else traced and saved): (exported
    program, output skeleton, jitted calls by device), or None where not exportable."""
    found = _load(folder, key)
    if found is None:
        try:
            found = _export(fn, leaves, treedef, static)
        except Exception:  # not exportable (e.g. a host callback)
            _MEMORY[key] = None
            return
        try:
            _save(folder, key, *found)
        except Exception:  # unwritable folder, no flatbuffers: kept in memory
            pass
    _MEMORY[key] = (*found, {})


def stored(name: str):
    """Decorate a jitted function of arrays and static data: its concrete calls run a
    program exported to (and read back from) :func:`store_folder`, traced once across
    processes; everything else calls it as it is. ``name`` identifies the function in the
    key."""

    def wrap(fn):
        @functools.wraps(fn)
        def call(*args):
            folder = store_folder()
            key = None if folder is None else _key(name, args)
            folder = None if folder is None else folder / _generation()
            if key is None or _MEMORY.get(key, _ABSENT) is None:  # not storable
                return fn(*args)
            dynamic, static = eqx.partition(args, eqx.is_array)
            leaves, treedef = jax.tree_util.tree_flatten(dynamic)
            device, committed = _device(leaves)
            entry = _MEMORY.get(key, _ABSENT)
            run = None if entry is _ABSENT else entry[2].get(device)
            out = None
            if run is None:
                lock = _LOCKS.setdefault(key, threading.Lock())
                if _MEMORY.get(key, _ABSENT) is _ABSENT:
                    # read or traced once, by one thread at a time: tracing holds Python's
                    # lock anyway, and a trace finished first lets its compile (which does
                    # not hold it) run beside the next thread's trace
                    with _TRACING, lock:
                        if _MEMORY.get(key, _ABSENT) is _ABSENT:
                            _prepare(fn, folder, key, leaves, treedef, static)
                # compiled once: threads calling at once wait for the first
                with lock:
                    entry = _MEMORY[key]
                    run = None if entry is None else entry[2].get(device)
                    if entry is not None and run is None:
                        # placed explicitly: otherwise a call whose arrays are committed to
                        # the device (jax.device_put, or an earlier read-back program's
                        # outputs) lowers to another program than one whose arrays are
                        # not, and compiles again
                        sharding = jax.sharding.SingleDeviceSharding(device)
                        run = jax.jit(entry[0].call, in_shardings=sharding)
                        out = run(leaves)  # compiled here, once
                        entry[2][device] = run
                if entry is None:  # not exportable
                    return fn(*args)
            skeleton = entry[1]
            if out is None:
                out = run(leaves)
            if not committed and device.platform == "cpu":
                # a read-back program's outputs are committed to its device, an ordinary
                # call's are not where its arguments were not: handed back uncommitted
                # (on the CPU a copy in memory), what consumes them compiles as it would
                # after the ordinary call, not once more for committed arguments
                # (placed by device_put: jnp.asarray compiles a program per shape)
                out = [jax.device_put(np.asarray(v)) for v in out]
            return _fill(skeleton, out)

        return call

    return wrap
