"""Ensembles across processes on JAX's multi-process runtime (see :mod:`jaxchain.distributed`).

Every process runs the same program (JAX's multi-controller model). The M members of an
ensemble are laid out on the global member axis in contiguous shares, one per process and
in process order: member ``i`` sits at row ``i``; each share is padded to the same number
of rows (``Split.rows``) with repeats of a member the process holds, so every process
builds and stacks exactly ``rows`` scenes. Results are gathered after the solve (one
all-gather) and come back complete on every process.
"""

from __future__ import annotations

import atexit
import dataclasses
import functools
import math
import os
import sys
from collections.abc import Callable, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .._scene import Scene
from .stack import stack, take

__all__ = [
    "initialize",
    "Split",
    "split",
    "LocalMembers",
    "local_members",
    "global_mesh",
    "gather",
]

# what ``python -m jaxchain.launch`` hands each process
ENV_COORDINATOR = "JAXCHAIN_COORDINATOR"
ENV_PROCESSES = "JAXCHAIN_NUM_PROCESSES"
ENV_PROCESS_ID = "JAXCHAIN_PROCESS_ID"
ENV_HEARTBEAT = "JAXCHAIN_HEARTBEAT_TIMEOUT"
ENV_STATUS = "JAXCHAIN_LAUNCH_STATUS"  # a folder: how each failed process ended
MEMBER_AXIS = "members"


# ---------------------------------------------------------------------------- runtime
def _cluster_size() -> int:
    """Processes of a SLURM step or an Open MPI job this process belongs to (1: none)."""
    for name in ("SLURM_NTASKS", "OMPI_COMM_WORLD_SIZE"):
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 1


def initialize(
    coordinator: str | None = None,
    num_processes: int | None = None,
    process_id: int | None = None,
    *,
    init_timeout: int = 120,
    heartbeat_timeout: int | None = None,
) -> bool:
    """Join JAX's multi-process runtime (``jax.distributed.initialize``), or stay one
    process where there is nothing to join. Call it first, before any computation.

    Where the processes come from, first match wins: the arguments; the environment set
    by ``python -m jaxchain.launch`` (``JAXCHAIN_COORDINATOR``, ``JAXCHAIN_NUM_PROCESSES``,
    ``JAXCHAIN_PROCESS_ID``); a SLURM step (``srun``) or an Open MPI job of more than one
    task, detected by JAX itself. Otherwise nothing happens and the program runs as one
    process, so a script calling this runs unchanged with and without a launcher. Where
    the program joined already (``jax.distributed.initialize`` called with options of its
    own, e.g. ``local_device_ids``), only the exit handling below is added.

    CPU collectives use gloo (TCP). A process that stops sending heartbeats for
    ``heartbeat_timeout`` seconds (default 60, or ``JAXCHAIN_HEARTBEAT_TIMEOUT``) is
    declared dead and every other process is stopped by JAX's coordination service
    instead of waiting forever; a process that cannot reach the coordinator within
    ``init_timeout`` seconds stops with an error. A Python exception that ends one
    process ends it at once (after its traceback), so the others fail in their next
    collective rather than wait; at a normal exit the processes leave together (JAX's
    shutdown barrier, at most ``init_timeout`` seconds), so that process 0, which runs
    the coordination service, is not gone while the others still need it.

    Returns:
        True when this program runs as several processes.
    """
    if jax.distributed.is_initialized():  # joined through JAX itself: the exit handling
        if jax.process_count() > 1:
            _exit_handling()
        return jax.process_count() > 1
    env = os.environ
    coordinator = coordinator or env.get(ENV_COORDINATOR)
    if num_processes is None and env.get(ENV_PROCESSES):
        num_processes = int(env[ENV_PROCESSES])
    if process_id is None and env.get(ENV_PROCESS_ID):
        process_id = int(env[ENV_PROCESS_ID])
    if heartbeat_timeout is None:
        heartbeat_timeout = int(env.get(ENV_HEARTBEAT, "60"))
    for name, value in (("init_timeout", init_timeout), ("heartbeat_timeout", heartbeat_timeout)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be a whole number of seconds >= 1, got {value!r}")
    given = (coordinator, num_processes, process_id)
    if all(v is None for v in given):
        if _cluster_size() <= 1:
            return False  # one process: nothing to join
    elif any(v is None for v in given):
        raise ValueError(
            "give coordinator ('host:port'), num_processes and process_id together (or none, "
            f"to detect a launcher or cluster); got {given}"
        )
    elif not (isinstance(num_processes, int) and 0 <= process_id < num_processes):
        raise ValueError(
            f"process_id must be in [0, num_processes), got {process_id} of {num_processes}"
        )
    if jax.config.jax_cpu_collectives_implementation is None:
        jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(
        coordinator,
        num_processes,
        process_id,
        initialization_timeout=init_timeout,
        heartbeat_timeout_seconds=heartbeat_timeout,
        shutdown_timeout_seconds=init_timeout,
    )
    _exit_handling()
    return jax.process_count() > 1


@functools.cache
def _exit_handling() -> None:
    """Once: leave together at a normal exit, at once after an uncaught exception."""
    atexit.register(jax.distributed.shutdown)
    sys.excepthook = functools.partial(_exit_now, sys.excepthook)


def lost_peer(kind: type, value: BaseException) -> bool:
    """Whether an exception is a collective failing because another process is gone (JAX
    raises it as a ``JaxRuntimeError`` or a ``ValueError``, depending on the call)."""
    text = str(value)
    return any(w in text for w in ("Gloo", "by peer", "coordination service", "heartbeat"))


def _exit_now(hook, kind, value, tb):
    """An uncaught exception in one process of several: its traceback, a note for the
    launcher (what ended it), then exit at once (skipping the shutdown barrier that the
    others, waiting in a collective, never reach)."""
    hook(kind, value, tb)
    sys.stdout.flush()
    sys.stderr.flush()
    status = os.environ.get(ENV_STATUS)
    if status:
        first = (str(value).strip().splitlines() or [""])[0][:300]
        note = ("lost a peer" if lost_peer(kind, value) else "raised") + f" {kind.__name__}"
        try:
            with open(os.path.join(status, f"{jax.process_index()}.txt"), "w") as f:
                f.write(f"{note}: {first}" if first else note)
        except OSError:
            pass
    os._exit(1)


@functools.cache
def mesh_of(devices: tuple) -> Mesh:
    return Mesh(np.asarray(devices, dtype=object), (MEMBER_AXIS,))


def global_mesh() -> Mesh:
    """A one-axis mesh of every process's devices, in process order (one process: its
    local devices)."""
    devices = sorted(jax.devices(), key=lambda d: (d.process_index, d.id))
    return mesh_of(tuple(devices))


def spans_processes(mesh: Mesh) -> bool:
    """Whether ``mesh`` holds devices of another process."""
    me = jax.process_index()
    return any(d.process_index != me for d in mesh.devices.flat)


# ---------------------------------------------------------------------------- the split
@dataclasses.dataclass(frozen=True)
class Split:
    """How M ensemble members are shared among the processes.

    Process ``p`` holds rows ``[p·rows, (p+1)·rows)`` of the global member axis; member
    ``i`` is row ``i``, rows past the last member are padding.

    Attributes:
        members: M, the members of the ensemble.
        processes: the processes sharing them.
        process: this process's index.
        rows: rows each process holds (its share, padded): its devices times the members
            per device, ⌈M / all devices⌉ (one process: M).
    """

    members: int
    processes: int
    process: int
    rows: int

    @property
    def local(self) -> range:
        """The members this process holds (possibly none)."""
        lo = self.process * self.rows
        return range(min(lo, self.members), min(lo + self.rows, self.members))

    @property
    def slots(self) -> tuple[int, ...]:
        """The member in each of this process's rows: its own, then repeats of its last
        (of the ensemble's last where it holds none) as padding."""
        own = list(self.local)
        pad = own[-1] if own else self.members - 1
        return tuple(own + [pad] * (self.rows - len(own)))

    @property
    def padded(self) -> int:
        """Rows of the global member axis."""
        return self.rows * self.processes


def split(n_members: int) -> Split:
    """How ``n_members`` members are shared among this program's processes."""
    if isinstance(n_members, bool) or not isinstance(n_members, (int, np.integer)):
        raise TypeError(f"n_members must be an integer, got {type(n_members).__name__}")
    if n_members < 1:
        raise ValueError(f"an ensemble needs at least one member, got n_members={n_members}")
    n, p = int(n_members), jax.process_count()
    if p == 1:
        return Split(n, 1, 0, n)
    local, total = jax.local_device_count(), jax.device_count()
    if total != local * p:
        raise ValueError(
            f"every process must have the same number of devices to share an ensemble; "
            f"this one has {local} of {total} over {p} processes"
        )
    return Split(n, p, jax.process_index(), local * math.ceil(n / total))


class LocalMembers(eqx.Module):
    """This process's share of an ensemble: its rows' scenes, stacked (see :class:`Split`).

    Pass it wherever a list of scenes goes (``simulate_ensemble``, a design objective's
    ``build``): each process then builds only its own members. Build it with
    :func:`local_members`.

    Attributes:
        scenes: the stacked scenes of this process's rows (``split.rows`` of them).
        split: the :class:`Split` (static).
    """

    scenes: Scene
    split: Split = eqx.field(static=True)

    def __check_init__(self):
        if not isinstance(self.scenes, Scene) or np.ndim(self.scenes.q0) != 3:
            raise ValueError("LocalMembers.scenes must be a stacked Scene (jc.scenes.stack)")
        if np.shape(self.scenes.q0)[0] != self.split.rows:
            raise ValueError(
                f"LocalMembers: {np.shape(self.scenes.q0)[0]} scenes stacked for a share of "
                f"{self.split.rows} rows; build them with jc.distributed.local_members"
            )

    @property
    def n_members(self) -> int:
        return self.split.members


def local_members(n_members: int, build: Callable[[int], Scene]) -> LocalMembers:
    """This process's share of an ``n_members`` ensemble: ``build(i)`` is called for the
    members ``i`` this process holds only (one process: all of them), each once."""

    if not callable(build):
        raise TypeError(f"build must be a function index -> Scene, got {type(build).__name__}")
    sp = split(n_members)
    built: dict[int, Scene] = {}
    for i in sp.slots:
        if i not in built:
            built[i] = build(i)
    return LocalMembers(stack([built[i] for i in sp.slots]), sp)


def share(scenes: Scene | Sequence[Scene] | LocalMembers, mesh: Mesh) -> tuple[Scene, Split]:
    """This process's rows of ``scenes`` (every member's scenes, or a share already) for
    ``mesh`` spanning processes, and the split."""

    if isinstance(scenes, LocalMembers):
        sp = scenes.split
        here = split(sp.members)
        if sp != here:
            raise ValueError(
                f"these LocalMembers were built for {sp.processes} process(es) with "
                f"{sp.rows} rows each, this program has {here.processes} with {here.rows}"
            )
        local = scenes.scenes
    elif isinstance(scenes, Scene):
        if np.ndim(scenes.q0) != 3:
            raise ValueError(
                "simulate_ensemble needs a list of scenes or a stacked scene "
                f"(jc.scenes.stack); got a scene with q0 of shape {np.shape(scenes.q0)}"
            )
        sp = split(int(np.shape(scenes.q0)[0]))
        local = take(scenes, np.asarray(sp.slots))
    else:
        scenes = list(scenes)
        sp = split(len(scenes))
        local = stack([scenes[i] for i in sp.slots])
    n_dev = int(mesh.devices.size)
    if sp.padded % n_dev or mesh.devices.size != jax.device_count():
        raise ValueError(
            f"a mesh across processes must hold every device ({jax.device_count()}), "
            f"got {n_dev}; use sharding='auto'"
        )
    return local, sp


def to_global(tree, mesh: Mesh, sp: Split):
    """Each array leaf of this process's rows (leading axis ``sp.rows``) as one array of
    the global member axis, split across ``mesh``."""
    spread = NamedSharding(mesh, PartitionSpec(mesh.axis_names[0]))

    def one(x):
        if not eqx.is_array(x):
            return x
        x = np.asarray(x)
        return jax.make_array_from_process_local_data(spread, x, (sp.padded, *x.shape[1:]))

    return jax.tree_util.tree_map(one, tree)


def gather(tree, rows: int | None = None):
    """Every process's rows of ``tree``'s array leaves, concatenated in process order
    (the first ``rows`` kept), on every process: one all-gather. Leaves may be global
    arrays split by rows or each process's own arrays; one process: returned as is."""
    if jax.process_count() == 1:
        return tree
    from jax.experimental import multihost_utils

    dyn, static = eqx.partition(tree, eqx.is_array)
    full = multihost_utils.process_allgather(dyn, tiled=True)
    cut = (lambda x: x) if rows is None else (lambda x: x[:rows])
    full = jax.tree_util.tree_map(lambda x: jnp.asarray(cut(x)), full)
    return eqx.combine(full, static)
