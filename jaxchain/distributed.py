"""Ensembles across processes and machines, on JAX's multi-process runtime.

jc.distributed.initialize()                  # first: joins a launch / SLURM step, else no-op
local = jc.distributed.local_members(16, lambda i: make_scene(i))   # this process's share
ens = jc.simulate_ensemble(local, t1, sharding="auto")   # complete on every process
objective = jc.design.ProfileObjective(space, build, t1=..., sharding="auto")

Every process runs the same program. ``sharding="auto"`` splits the members over every
process's devices: member ``i`` is row ``i`` of the global member axis, shared among the
processes in contiguous, padded shares (:class:`Split`). Each process solves only its
share; values, gradients and per-member result codes come back complete on every process
(one all-gather per call). Start N local processes with ``python -m jaxchain.launch -n N
script.py``; on a cluster, one process per task (``srun``).
"""

from ._solve.distributed import (
    LocalMembers as LocalMembers,
    Split as Split,
    gather as gather,
    global_mesh as global_mesh,
    initialize as initialize,
    local_members as local_members,
    split as split,
)

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "LocalMembers",
    "Split",
    "gather",
    "global_mesh",
    "initialize",
    "local_members",
    "split",
]
