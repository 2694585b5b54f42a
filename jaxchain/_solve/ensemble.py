"""Ensembles: many scenes of one structure solved together.

``stack`` puts scenes of one structure on a leading member axis; ``simulate_ensemble``
runs the jitted solve of :func:`~jaxchain.simulate` vmapped over that axis, in groups of
members of similar cost, each group split across devices with ``jax.shard_map``.

Why groups: a vmapped adaptive solve is one batched while loop, which runs until its
slowest member has finished; the faster members' steps are computed and thrown away. The
*waste ratio* of a run is the steps executed (every batch's size times its step count)
over the steps the members needed. A cheap pilot (or a user's cost estimate) predicts each
member's step count; members sorted by prediction are cut into contiguous groups whose
predicted waste stays below ``group_waste``. Groups are padded to a few batch sizes
(powers of two times the device count) so few shapes are ever compiled, and under
``shard_map`` each device runs its own while loop over its slice of a group.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec
from jaxtyping import Array, ArrayLike

from .. import _checks as checks
from .._observers.base import PeakRecord
from .._scene import Scene
from . import distributed as dist
from .distributed import LocalMembers
from .options import Resolved, SolveOptions, with_options
from .result import raise_if_failed
from .simulate import Solution, peak_of, split_saved, time_span
from .solve import check_horizon, solve, strong_scene
from .stack import stack, take as _take

__all__ = ["stack", "simulate_ensemble", "EnsembleSolution"]


def _n_members(scenes: Scene) -> int:
    if np.ndim(scenes.q0) != 3:
        raise ValueError(
            "simulate_ensemble needs a list of scenes or a stacked scene (jc.scenes.stack); "
            f"got a scene with q0 of shape {np.shape(scenes.q0)}"
        )
    return int(np.shape(scenes.q0)[0])


# ---------------------------------------------------------------------------- solution
EnsembleSolution = Solution
"""An ensemble's solution: a :class:`~jaxchain.Solution` with a leading member axis (the
name is kept for code written against it)."""


# ---------------------------------------------------------------------------- devices
def _resolve_mesh(mesh, sharding) -> Mesh:
    if mesh is not None and sharding is not None:
        raise ValueError("give either mesh or sharding, not both")
    if sharding is not None:
        if sharding != "auto":
            raise ValueError(f'sharding must be None or "auto", got {sharding!r}')
        return dist.global_mesh()  # one process: its local devices
    if mesh is None:  # one device, same code path
        return dist.mesh_of((jax.local_devices()[0],))
    if not isinstance(mesh, Mesh) or len(mesh.axis_names) != 1:
        raise ValueError(
            "mesh must be a jax.sharding.Mesh with one axis (the member axis), got "
            f"{getattr(mesh, 'axis_names', mesh)!r}"
        )
    return mesh


# ---------------------------------------------------------------------------- batched solve
class _Args(NamedTuple):
    """Everything ``solve`` takes besides the scene."""

    t0: Array
    t1: Array
    ts: Array
    resolved: Resolved
    observers: tuple

    def with_dt0(self, dt0):
        return self._replace(resolved=self.resolved._replace(dt0=dt0))


def _vmapped(scenes, dt0, args: _Args):
    """``solve`` vmapped over the scenes' array leaves (and per-member ``dt0``)."""
    if dt0 is None:
        return eqx.filter_vmap(lambda s: solve(s, *args))(scenes)
    return eqx.filter_vmap(lambda s, h: solve(s, *args.with_dt0(h)))(scenes, dt0)


@eqx.filter_jit
def _solve_batch(scenes, dt0, args, mesh):
    """``solve`` vmapped over the member axis, the axis split across ``mesh``'s devices
    with ``shard_map``: each device runs its own batched while loop over its slice and
    stops with its own slowest member. ``dt0``: per-member (P,) steps, or None (then
    the resolved options' ``dt0`` applies to all)."""
    axis = mesh.axis_names[0]
    s_dyn, s_static = eqx.partition(scenes, eqx.is_array)
    a_dyn, a_static = eqx.partition(args, eqx.is_array)
    out_static = []

    def local(s_dyn, dt0, a_dyn):
        out = _vmapped(eqx.combine(s_dyn, s_static), dt0, eqx.combine(a_dyn, a_static))
        dyn, static = eqx.partition(out, eqx.is_array)
        out_static.append(static)
        return dyn

    member = PartitionSpec(axis)
    dyn = jax.shard_map(
        local,
        mesh=mesh,
        in_specs=(member, member, PartitionSpec()),
        out_specs=member,
        # diffrax's loops do not carry the varying-axis annotations check_vma needs
        check_vma=False,
    )(s_dyn, dt0, a_dyn)
    return eqx.combine(dyn, out_static[0])


@eqx.filter_jit
def _solve_batch_traced(scenes, dt0, args, mesh):
    """The same vmapped solve for traced calls (inside the caller's ``jit``/``grad``):
    one batched loop, its member axis partitioned by the compiler (GSPMD) when ``mesh``
    has several devices. Reverse-mode AD of diffrax's checkpointed loop inside
    ``shard_map`` fails in equinox 0.13 (closure-conversion check on sharding metadata,
    patrick-kidger/equinox#1261), hence no ``shard_map`` here."""
    if mesh.devices.size > 1:
        spread = NamedSharding(mesh, PartitionSpec(mesh.axis_names[0]))
        pin = lambda x: jax.lax.with_sharding_constraint(x, spread) if eqx.is_array(x) else x
        scenes, dt0 = jax.tree_util.tree_map(pin, (scenes, dt0))
        return jax.tree_util.tree_map(pin, _vmapped(scenes, dt0, args))
    return _vmapped(scenes, dt0, args)


# ---------------------------------------------------------------------------- planning
def _padded(n: int, n_devices: int) -> int:
    """Batch size for ``n`` members: ``n_devices`` times a power of two."""
    per = -(-n // n_devices)
    return n_devices * (1 << (per - 1).bit_length())


def _group_cost(pred: np.ndarray, size: int, n_devices: int) -> float:
    """Steps executed by one padded group (``pred`` sorted descending, padded with its
    last entry): each device's slice costs its length times its first (largest) entry."""
    padded = np.concatenate([pred, np.full(size - len(pred), pred[-1])])
    per = size // n_devices
    return float(per * padded[::per].sum())


def _plan(pred: np.ndarray, group_waste: float, n_devices: int) -> list[np.ndarray]:
    """Cut the members, sorted by predicted cost (largest first), into contiguous groups:
    each the largest padded batch whose predicted waste is within ``group_waste`` (or,
    where none is, the one of least waste)."""
    order = np.argsort(-pred, kind="stable")
    p = np.maximum(pred[order], 1e-12)
    groups, i, m = [], 0, len(p)
    while i < m:
        sizes, size = [], n_devices
        while True:
            sizes.append(size)
            if size >= m - i:
                break
            size *= 2
        best, best_waste, chosen = None, math.inf, None
        for size in sizes:
            n = min(size, m - i)
            waste = _group_cost(p[i : i + n], size, n_devices) / p[i : i + n].sum()
            if waste <= group_waste:
                chosen = n  # sizes ascend: the last feasible one is the largest
            if waste < best_waste - 1e-12:
                best, best_waste = n, waste
        n = chosen if chosen is not None else best
        groups.append(order[i : i + n])
        i += n
    return groups


# ---------------------------------------------------------------------------- driver
def simulate_ensemble(
    scenes: Scene | Sequence[Scene] | LocalMembers,
    t1: ArrayLike,
    *,
    t0: ArrayLike = 0.0,
    ts: ArrayLike | None = None,
    n_save: int = 501,
    group_waste: float | None = 1.5,
    pilot_rtol: float | None = None,
    cost: ArrayLike | None = None,
    mesh: Mesh | None = None,
    sharding: str | None = None,
    throw: bool = True,
    options: SolveOptions | None = None,
    **solve_options,
) -> EnsembleSolution:
    """Simulate many scenes of one structure from ``t0`` to ``t1`` [s] together.

    Each member's result is that of :func:`~jaxchain.simulate` on it alone (the same
    jitted solve, vmapped); members only share the time span, save times and solve
    options.

    Args:
        scenes: a list of scenes of one structure, or a stacked scene
            (:func:`~jaxchain.scenes.stack`), or this process's share of them
            (:func:`jaxchain.distributed.local_members`).
        t1, t0, ts, n_save: time span and save times, as in :func:`~jaxchain.simulate`.
        group_waste: run the members in groups of similar predicted cost, each group's
            predicted waste ratio (steps executed over steps needed, padding included)
            at most this; None: one batch of all members. Fixed-step solves cost
            ``(t1 − t0)/dt0`` steps (no pilot; one batch unless ``dt0`` is per member);
            traced calls (inside the caller's ``jax.jit``/``jax.grad``) run as one
            batch, its member axis partitioned over ``mesh`` by the compiler instead of
            ``shard_map`` (reverse-mode AD of diffrax's loop inside ``shard_map`` fails
            in equinox 0.13).
        pilot_rtol: the cost prediction, when no ``cost`` is given, is each member's
            step count in a pilot solve of the whole batch at this looser tolerance
            (``atol`` scaled alike; default ``100·rtol``, at most ``1e-3``). Needs the
            default PID controller; with another controller give ``cost`` or get one
            batch. The pilot ranks members well, but where its loose solve is held at
            the explicit stability limit of stiff contacts its step counts have a floor
            that compresses their spread: it then splits less than the true costs
            would (benchmarks/ensembles.py). It costs a solve at loose tolerance.
        cost: (M,) predicted relative cost per member; replaces the pilot. A previous
            run's ``steps`` (free in an optimization loop or a refined sweep) is the
            best predictor.
        mesh: a one-axis ``jax.sharding.Mesh``: the member axis is split across its
            devices (members padded to a multiple of its size), each device running its
            own batched while loop (``jax.shard_map``).
        sharding: ``"auto"``: a mesh of all devices — under JAX's multi-process runtime
            (:mod:`jaxchain.distributed`) every process's, each process solving only its
            share of the members (one batch, no grouping), the results gathered complete
            on every process. Default: one device (the same code path).
        throw: raise ``RuntimeError`` naming every failed member and why; with
            ``throw=False`` check ``EnsembleSolution.result`` / ``.failed`` /
            ``.messages``.
        options, **solve_options: as in :func:`~jaxchain.simulate`; ``dt0`` may also be
            (M,) per-member steps (e.g. fixed steps scaled to each member's speed).

    Returns:
        :class:`EnsembleSolution`, members in the order given.

    Compiled once per scene structure, options and padded batch size: a second call with
    new values and the same batch sizes does not retrace.
    """
    opts = with_options(options, solve_options, "simulate_ensemble")
    mesh = _resolve_mesh(mesh, sharding)
    share = None  # across processes: this process's rows and the split
    if dist.spans_processes(mesh):
        scenes, share = dist.share(scenes, mesh)
    elif isinstance(scenes, LocalMembers):
        if scenes.split.processes > 1:
            raise ValueError("LocalMembers of several processes need sharding='auto'")
        scenes = scenes.scenes
    elif not isinstance(scenes, Scene):
        scenes = stack(scenes)
    m = _n_members(scenes) if share is None else share.members
    if pilot_rtol is not None:
        checks.real("pilot_rtol", pilot_rtol, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    if group_waste is not None and not group_waste >= 1.0:
        raise ValueError(f"group_waste must be >= 1 (or None), got {group_waste}")
    dt0 = opts.dt0
    member_dt0 = dt0 is not None and np.ndim(dt0) == 1
    if member_dt0 and np.shape(dt0) != (m,):
        raise ValueError(f"a per-member dt0 must have shape ({m},), got {np.shape(dt0)}")
    if dt0 is not None and not member_dt0 and np.ndim(dt0) != 0:
        raise ValueError(f"dt0 must be a scalar or ({m},), got shape {np.shape(dt0)}")
    scenes = strong_scene(scenes, "simulate_ensemble", members=True)
    t0a, t1a, tsa = time_span(t0, t1, ts, n_save)
    check_horizon(scenes, t1a, "simulate_ensemble", members=True)
    args = _Args(t0a, t1a, tsa, opts.resolve(t0a, t1a), (PeakRecord(),))
    dt0_m = None
    if member_dt0:
        dt0_m, args = args.resolved.dt0, args.with_dt0(None)
    n_dev = int(mesh.devices.size)
    traced = any(
        isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves((scenes, args, dt0_m))
    )
    if share is not None:
        if traced:
            raise ValueError(
                "simulate_ensemble across processes runs outside jax.jit/jax.grad; for "
                "gradients use jc.design.ProfileObjective(..., sharding='auto')"
            )
        if dt0_m is not None:
            dt0_m = jnp.asarray(dt0_m)[np.asarray(share.slots)]
        return _across_processes(scenes, share, dt0_m, args, mesh, throw)

    def run(index, a):
        """Solve the members ``index`` (numpy) padded to a planned size with options ``a``."""
        size = _padded(len(index), n_dev)
        full = np.concatenate([index, np.full(size - len(index), index[-1])])
        same = size == m and np.array_equal(full, np.arange(m))
        sub = scenes if same else _take(scenes, full)
        h = None if dt0_m is None else (dt0_m if same else dt0_m[full])
        batch = _solve_batch_traced if traced else _solve_batch
        return batch(sub, h, a, mesh), size

    # ---- plan
    predicted = None
    if cost is not None:
        predicted = np.asarray(cost, dtype=float)
        if predicted.shape != (m,) or not np.all(np.isfinite(predicted) & (predicted > 0)):
            raise ValueError(f"cost must be ({m},) finite and > 0, got {cost!r}")
    fixed = opts.fixed
    if traced or group_waste is None or m == 1 or (fixed and dt0_m is None):
        groups = [np.arange(m)]
    else:
        if predicted is None and fixed:  # fixed per-member steps: the cost is known
            span = float(t1a) - float(t0a)
            predicted = np.ceil(span / np.asarray(dt0_m, dtype=float))
        elif predicted is None and opts.stepsize_controller is None:
            prtol = min(100.0 * opts.rtol, 1e-3) if pilot_rtol is None else float(pilot_rtol)
            scale = prtol / opts.rtol
            pilot = dataclasses.replace(opts, rtol=prtol, atol=opts.atol * scale)
            # only the controller's tolerance arrays differ: the same compiled solve
            controller = pilot.resolve(t0a, t1a).controller
            traj, _ = run(
                np.arange(m), args._replace(resolved=args.resolved._replace(controller=controller))
            )
            predicted = np.asarray(traj.stats["num_steps"], dtype=float)[:m]
        groups = [np.arange(m)] if predicted is None else _plan(predicted, group_waste, n_dev)

    # ---- run: groups are dispatched one after the other (asynchronously)
    outs, sizes = [], []
    for g in groups:
        out, size = run(g, args)
        outs.append(out)
        sizes.append(size)

    # ---- steps executed: each device's slice runs until its slowest member is done
    loops = 1 if traced else n_dev  # traced: one loop over the batch (GSPMD)
    executed = 0
    for out, size in zip(outs, sizes, strict=True):
        steps_g = out.stats["num_steps"].reshape(loops, size // loops)
        executed = executed + (size // loops) * jnp.sum(jnp.max(steps_g, axis=1))

    # ---- back to the members' order: member g[i] sits at row offset(g) + i
    merged = outs[0]
    if len(outs) > 1:
        merged = jax.tree_util.tree_map(
            lambda *xs: jnp.concatenate(xs) if eqx.is_array(xs[0]) else xs[0], *outs
        )
    where = np.empty(m, dtype=int)
    for g, off in zip(groups, np.cumsum([0, *sizes[:-1]]), strict=True):
        where[g] = off + np.arange(len(g))
    if not (len(outs) == 1 and sizes[0] == m and np.array_equal(where, np.arange(m))):
        merged = _take(merged, where)
    if n_dev > 1 and m % n_dev == 0 and not traced:  # keep the result spread over devices
        spread = NamedSharding(mesh, PartitionSpec(mesh.axis_names[0]))
        merged = jax.tree_util.tree_map(
            lambda x: jax.device_put(x, spread) if eqx.is_array(x) else x, merged
        )
    return _solution(
        merged,
        tsa,
        executed,
        throw,
        predicted_steps=None if predicted is None else jnp.asarray(predicted),
        groups=tuple(tuple(int(i) for i in g) for g in groups),
        batch_sizes=tuple(sizes),
        n_devices=n_dev,
    )


def _solution(out, ts, executed, throw: bool, **layout) -> Solution:
    """The ensemble's solution from its merged batch output ``out`` (raising on a failed
    member if ``throw``); ``layout``: how the members were batched."""
    saved, result, stats = out.saved, out.result, out.stats
    if throw:
        saved = raise_if_failed(result, saved, "simulate_ensemble")
    return Solution(
        ts=ts,
        peak_contact_force=peak_of(saved, out.observed[0]),
        result=result,
        stats=stats,
        y1=out.y1,
        steps=stats["num_steps"],
        accepted_steps=stats["num_accepted_steps"],
        steps_executed=executed,
        waste=executed / jnp.sum(stats["num_steps"]),
        **layout,
        **split_saved(saved),
    )


def _across_processes(local, sp, dt0, args: _Args, mesh: Mesh, throw: bool):
    """One batch over ``mesh`` spanning processes: this process's rows ``local`` (and
    per-row ``dt0``) join the global member axis, each device solves its slice, and the
    results are gathered complete on every process (rows past the last member dropped)."""
    scenes_g, dt0_g = dist.to_global((local, dt0), mesh, sp)
    out = _solve_batch(scenes_g, dt0_g, args, mesh)
    out = dist.gather(out)  # (padded rows), the same on every process
    n_dev, m = int(mesh.devices.size), sp.members
    per = sp.padded // n_dev
    executed = per * jnp.sum(jnp.max(out.stats["num_steps"].reshape(n_dev, per), axis=1))
    out = _take(out, np.arange(m))
    return _solution(
        out,
        args.ts,
        executed,
        throw,
        predicted_steps=None,
        groups=(tuple(range(m)),),
        batch_sizes=(sp.padded,),
        n_devices=n_dev,
    )
