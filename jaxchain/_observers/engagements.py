"""Per-engagement meshing peaks: the peak roller/tooth force of every meshing event, read
along the one solve, and their statistics.

In the clearance-joint chain each roller rattles in its bush, so the peak force of one
meshing event is one sample of a distribution: a design claim is a claim on that
distribution (its mean, its upper tail), measured over many engagements after the start
transient. :class:`EngagementPeaks` is the step observer that finds every event and its
peak; ``jaxchain._statistics`` turns its record into plain numpy ``Engagements`` and
gives their statistics (``peak_statistics``, ``compare_peaks``).

**What an event is.** A (sprocket, roller) pair is *armed* while the roller is free to
mesh: at t0 when the roller does not touch that sprocket (its normal force is at most
``threshold``), later once its centre has left the sprocket's reach (the tip radius plus
1.05 roller radii from the axis: no tooth can touch it there). An armed roller's event
*begins* (onset) when its force on that sprocket first exceeds ``threshold``; its *window*
is the ``window`` tooth periods of that sprocket after onset (the period 2π/(z·|ω|) at
the onset's speed); its *peak* is the largest force over the window. The pair is armed
again only when the roller leaves the reach, so a seated roller that loses and regains
contact as it rattles in the wrap starts no new event: one roller meshes with one sprocket
once per pass (once on an open strand; once per loop on a closed drive). At t0 a roller
about to mesh is armed, and so is one seated but momentarily loose (on the clearance
strand of the next paragraph, a roller at the wrap's exit end: 0.5 N at t0, then up to
22 N): discard the start transient with ``t_start`` (a tooth period or more).

**Why half a tooth period.** On the engagement strand (08B, z = 18, 1000 rpm, 1000 N;
tooth period 3.33 ms) the lumped chain's meshing impact peaks 6 µs after onset; the next
roller meshes about a period later, and its impact loads the seated one too (959 N on a
roller 3.31 ms after its own onset, twice that roller's meshing peak): not a meshing
peak of the seated roller, and a window of one full period reaches it. With rattling
rollers (the clearance chain, frictionless joints) the largest force of a mesh came
0.03–1.2 ms (up to 0.36 period) after the first touch, the roller bouncing in the gap
before it seats. Half a period (the default) holds the impact and its rebounds only.
"""

from __future__ import annotations

import math
from typing import ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .. import _checks as checks
from .._dynamics import roller_kinematics, roller_normal_forces
from .._numerics import is_concrete, parabola_max
from .._scene import Scene
from .base import AbstractStepObserver, require_rollers

__all__ = ["EngagementPeaks", "EngagementRecord"]


# ---------------------------------------------------------------------------- observer
class EngagementRecord(NamedTuple):
    """The value of :class:`EngagementPeaks` (JAX arrays; any leading member axes of a
    vmapped solve come first). Slot k of pair (s, r) holds the pair's k-th completed event
    for k < ``count[s, r]``; other slots are 0. Read it with :func:`engagement_peaks`.

    Attributes:
        onset: (S, R, K) onset of each completed event [s].
        t_peak: (S, R, K) time of its peak [s].
        peak: (S, R, K) its peak roller/tooth normal force [N].
        end: (S, R, K) end of its window [s].
        count: (S, R) completed events of each (sprocket, roller) pair; events past the
            capacity K are counted but not stored.
    """

    onset: Float[Array, "S R K"]
    t_peak: Float[Array, "S R K"]
    peak: Float[Array, "S R K"]
    end: Float[Array, "S R K"]
    count: Int[Array, "S R"]


class _Tracker(NamedTuple):
    """The observer's running state: the event in progress per pair and the record."""

    force: Float[Array, "S R"]  # each pair's normal force at the last sample [N]
    armed: Bool[Array, "S R"]
    open: Bool[Array, "S R"]  # an event's window is running
    onset: Float[Array, "S R"]  # ... its onset, window end, peak and peak time
    end: Float[Array, "S R"]
    peak: Float[Array, "S R"]
    t_peak: Float[Array, "S R"]
    record: EngagementRecord


def _vertex_offset(f0, fm, f1):
    """Where :func:`~jaxchain._numerics.parabola_max` takes its value, in sample spacings
    from the middle sample (−1 … 1)."""
    b = 0.5 * (f1 - f0)
    a = 0.5 * (f0 + f1) - fm
    inside = -2.0 * a > jnp.abs(b)
    a_safe = jnp.where(inside, a, -1.0)
    end = jnp.where(fm >= jnp.maximum(f0, f1), 0.0, jnp.where(f1 > f0, 1.0, -1.0))
    return jnp.where(inside, -b / (2.0 * a_safe), end)


class EngagementPeaks(AbstractStepObserver):
    """The onset, peak time and peak roller/tooth normal force of every meshing event of
    every (sprocket, roller) pair over the solve; its value is an
    :class:`EngagementRecord`, read with :func:`engagement_peaks`::

        obs = jc.observers.EngagementPeaks(window=0.5)
        sol = jc.simulate(scene, t1, observers=(obs,))
        eng = jc.engagement_peaks(sol, t_start=...)      # plain numpy, per event
        jc.peak_statistics(eng)                          # n, mean, std, p95, max, CI

    An event begins (onset) when the roller's force on the sprocket first exceeds
    ``threshold`` while the pair is armed — at t0 if the roller does not touch the
    sprocket, later once its centre has left the sprocket's reach (tip radius + 1.05
    roller radii) — and its window lasts ``window`` tooth periods 2π/(z·|ω|) of that
    sprocket; its peak is the largest force in the window. A seated roller rattling in
    the wrap starts no new event: one per roller and sprocket per pass. Half a period
    holds the meshing impact and its rebounds, not the next roller's impact one period
    later, which loads the seated roller too (measurements: ``jaxchain._observers.engagements``).

    Each accepted step is read as :class:`~jaxchain.observers.PeakRecord` reads it: the
    force of every pair at the step's start, at ``samples − 1`` equally spaced interior
    times (states from the solver's dense interpolant) and at its end; the top at an
    interior sample is the :func:`~jaxchain._numerics.parabola_max` through it and its
    neighbours, at the end sample the sample. An event's peak is the largest top of the
    samples in its window, its time the parabola's vertex. With the same ``samples`` no
    event's peak exceeds ``Solution.peak_contact_force`` (the same parabolas, summed over
    sprockets). Onset is interpolated linearly between the samples around the threshold
    crossing. Only events whose window closed by t1 are recorded.

    Storage is static: ``capacity`` events per (sprocket, roller) pair. An open strand
    meshes each roller once (capacity 1); on a closed drive a roller meshes with each
    sprocket once per loop pass: size it with :meth:`for_solve`. Events beyond it are
    counted (``EngagementRecord.count``) and :func:`engagement_peaks` refuses the record.

    Cost: ``samples`` roller-contact evaluations per step (one vmapped call) and a scan
    over the samples of elementwise updates of (S, R) arrays; the state holds 4·S·R·K
    numbers. The window and threshold are array leaves (new values do not retrace); the
    observer is vmappable with the solve. The peaks carry gradients (through the
    parabola tops; which samples make an event is a selection).

    Attributes:
        window: each event's window, in tooth periods of its sprocket (> 0).
        threshold: force that marks contact [N] (≥ 0; above the contact law's regularized
            onset, well below a meshing impact).
        capacity: events stored per (sprocket, roller) pair (static, ≥ 1).
        samples: intervals per step (static, ≥ 2), as :class:`PeakRecord`'s.
    """

    reads_rollers: ClassVar[bool] = True

    window: Float[Array, ""]
    threshold: Float[Array, ""]
    capacity: int = eqx.field(static=True, default=1)
    samples: int = eqx.field(static=True, default=4)

    def __init__(
        self,
        window: ArrayLike = 0.5,
        threshold: ArrayLike = 1.0,
        capacity: int = 1,
        samples: int = 4,
    ):
        if is_concrete((window, threshold)):
            checks.real(
                "EngagementPeaks.window", window, lo=0.0, lo_open=True,
                unit="tooth periods of the sprocket",
            )  # fmt: skip
            checks.real("EngagementPeaks.threshold", threshold, lo=0.0, unit="N")
        self.window = jnp.asarray(window, dtype=float)
        self.threshold = jnp.asarray(threshold, dtype=float)
        self.capacity = checks.integer("EngagementPeaks.capacity", capacity, lo=1)
        self.samples = checks.integer("EngagementPeaks.samples", samples, lo=2)

    @classmethod
    def for_solve(
        cls,
        scene: Scene,
        t1: float,
        *,
        window: ArrayLike = 0.5,
        threshold: ArrayLike = 1.0,
        samples: int = 4,
        margin: float = 1.25,
    ) -> EngagementPeaks:
        """An observer whose capacity holds every pass of a solve of ``scene`` to ``t1``
        [s]: a sprocket of z teeth turning at ω takes z·|ω|/2π rollers a second, so each of
        the R rollers meshes with it at most ⌈margin·t1·z·|ω|/(2πR)⌉ + 1 times (the one
        counting a pass under way at t0; ``margin`` covers a driven sprocket running faster
        than its starting speed)."""
        checks.instance("scene", scene, Scene, "a jaxchain Scene")
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
        margin = checks.real("margin", margin, lo=1.0, unit="(factor on the speed)")
        if np.ndim(scene.q0) != 2:
            raise ValueError("EngagementPeaks.for_solve: give one scene, not a stacked one")
        require_rollers(scene, ["EngagementPeaks"], "EngagementPeaks.for_solve")
        rate = max(abs(float(s.speed)) * s.profile.teeth / (2 * math.pi) for s in scene.sprockets)
        passes = math.ceil(margin * t1 * rate / scene.n_rollers) + 1
        return cls(window, threshold, capacity=passes, samples=samples)

    # -- samples ------------------------------------------------------------------------
    def _sample(self, y, scene):
        """(S, R) each pair's normal force [N], (S, R) roller distance from each axis [m],
        (S,) sprocket speeds [rad/s] of one state."""
        normal = roller_normal_forces(y, scene)
        xr, _ = roller_kinematics(y, scene)
        centres = jnp.stack([s.centre for s in scene.sprockets])
        rel = xr[None, :, :] - centres[:, None, :]
        return normal, jnp.sqrt(jnp.sum(rel * rel, -1)), y.omega

    def init(self, t0, y0, scene):
        return self._begin(self._sample(y0, scene)[0])

    def step(self, t0, t1, y0, y1, dense, scene, state):
        n = self.samples
        ts = t0 + (t1 - t0) * jnp.arange(1, n) / n
        ys = jax.tree_util.tree_map(
            lambda a, b: jnp.concatenate([a, b[None]]), dense(ts), y1
        )  # fmt: skip
        force, distance, omega = jax.vmap(self._sample, in_axes=(0, None))(ys, scene)
        teeth = np.asarray([s.profile.teeth for s in scene.sprockets], dtype=float)
        period = 2 * jnp.pi / (teeth * jnp.maximum(jnp.abs(omega), 1e-12))  # (n, S)
        reach = jnp.stack([s.profile.reach_radius for s in scene.sprockets])
        return self._advance(state, t0, t1, force, distance, period, reach)

    # -- the event logic on sampled forces (what init and step run on the drive's) -------
    def _begin(self, f0: Float[Array, "S R"]) -> _Tracker:
        """The tracker before the first step, from each pair's force at t0 [N]: pairs
        not touching are armed."""
        zeros = jnp.zeros_like(f0)
        slots = jnp.zeros((*f0.shape, self.capacity), f0.dtype)
        record = EngagementRecord(
            slots, slots, slots, slots, jnp.zeros(f0.shape, jnp.int32)
        )  # fmt: skip
        closed = jnp.zeros(f0.shape, bool)
        return _Tracker(f0, f0 <= self.threshold, closed, zeros, zeros, zeros, zeros, record)

    def _advance(
        self,
        state: _Tracker,
        t0,
        t1,
        force: Float[Array, "n S R"],
        distance: Float[Array, "n S R"],
        period: Float[Array, "n S"],
        reach: Float[Array, " S"],
    ) -> _Tracker:
        """The tracker after the step [t0, t1] from its samples at t0 + (t1 − t0)·j/n,
        j = 1 … n: each pair's force [N] and roller distance from the axis [m], each
        sprocket's tooth period [s]; ``reach`` [m] per sprocket. The force at t0 is the
        tracker's (the previous step's end)."""
        n = force.shape[0]
        h = (t1 - t0) / n
        ts = t0 + h * jnp.arange(n + 1)  # τ_0 = t0, …, τ_n = t1
        fa = jnp.concatenate([state.force[None], force])  # (n + 1, S, R)
        tops = parabola_max(fa[:-2], fa[1:-1], fa[2:])  # centred on τ_1 … τ_{n−1}
        offsets = _vertex_offset(fa[:-2], fa[1:-1], fa[2:])
        tops = jnp.concatenate([tops, force[-1:]])  # the end sample alone
        t_end = jnp.broadcast_to(t1, force[-1:].shape)
        t_tops = jnp.concatenate([ts[1:-1, None, None] + h * offsets, t_end])
        xs = (ts[:-1], ts[1:], fa[:-1], force, tops, t_tops, distance, period)
        tracker, _ = jax.lax.scan(
            lambda tr, x: (self._one_sample(tr, x, reach), None), state, xs
        )  # fmt: skip
        return tracker

    def _one_sample(self, tr: _Tracker, x, reach) -> _Tracker:
        """The tracker after one sample: close windows that ended before it, raise the
        open events' peaks, start the events of armed rollers that touch, re-arm rollers
        that left the reach."""
        t_prev, t, f_prev, f, top, t_top, dist, period = x
        rec = tr.record
        closing = tr.open & (t > tr.end)
        slot = closing[..., None] & (jnp.arange(self.capacity) == rec.count[..., None])

        def stored(new, old):
            return jnp.where(slot, new[..., None], old)

        rec = EngagementRecord(
            onset=stored(tr.onset, rec.onset),
            t_peak=stored(tr.t_peak, rec.t_peak),
            peak=stored(tr.peak, rec.peak),
            end=stored(tr.end, rec.end),
            count=rec.count + closing.astype(rec.count.dtype),
        )
        still = tr.open & ~closing
        higher = still & (top > tr.peak)
        peak = jnp.where(higher, top, tr.peak)
        t_peak = jnp.where(higher, t_top, tr.t_peak)
        start = tr.armed & (f > self.threshold)
        rise = f - f_prev
        frac = jnp.clip((self.threshold - f_prev) / jnp.where(rise > 0, rise, 1.0), 0.0, 1.0)
        t_on = t_prev + frac * (t - t_prev)
        is_open = still | start
        return _Tracker(
            force=f,
            armed=(tr.armed & ~start) | (~is_open & (dist > reach[:, None])),
            open=is_open,
            onset=jnp.where(start, t_on, tr.onset),
            end=jnp.where(start, t_on + self.window * period[:, None], tr.end),
            peak=jnp.where(start, top, peak),
            t_peak=jnp.where(start, t_top, t_peak),
            record=rec,
        )

    def value(self, state, t0, t1):
        return state.record
