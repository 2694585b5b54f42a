"""Per-engagement meshing peaks: the peak roller/tooth force of every meshing event, read
along the one solve, and their statistics.

In the clearance-joint chain each roller rattles in its bush, so the peak force of one
meshing event is one sample of a distribution: a design claim is a claim on that
distribution (its mean, its upper tail), measured over many engagements after the start
transient. :class:`EngagementPeaks` is the step observer that finds every event and its
peak; :func:`engagement_peaks` turns its record into plain numpy :class:`Engagements`;
:func:`peak_statistics` and :func:`compare_peaks` give the statistics and the difference
of two designs with its confidence interval.

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

import dataclasses
import math
from typing import ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .. import _checks as checks
from .._dynamics import roller_contacts, roller_kinematics
from .._numerics import is_concrete, parabola_max
from .._scene import Scene
from .._solve.result import Result
from .._solve.simulate import Solution
from .base import AbstractStepObserver, require_rollers

__all__ = [
    "EngagementPeaks",
    "EngagementRecord",
    "Engagements",
    "PeakStatistics",
    "PeakComparison",
    "engagement_peaks",
    "peak_statistics",
    "compare_peaks",
]


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
        normal = roller_contacts(y, scene).normal
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


# ---------------------------------------------------------------------------- events
@dataclasses.dataclass(frozen=True)
class Engagements:
    """Completed meshing events, one entry each, ordered by member then onset (numpy).

    Attributes:
        member: (E,) member of the solve (0 for one solve; the flat index of the leading
            axes of a vmapped one).
        sprocket, roller: (E,) indices of the pair.
        onset: (E,) onset [s]; t_peak: (E,) time of the peak [s]; end: (E,) end of the
            window [s].
        peak: (E,) peak roller/tooth normal force [N].
    """

    member: np.ndarray
    sprocket: np.ndarray
    roller: np.ndarray
    onset: np.ndarray
    t_peak: np.ndarray
    peak: np.ndarray
    end: np.ndarray

    def __len__(self) -> int:
        return int(self.peak.shape[0])

    def select(
        self, *, sprocket: int | None = None, roller: int | None = None, member: int | None = None
    ) -> Engagements:
        """The events of one sprocket, roller and/or member."""
        keep = np.ones(len(self), bool)
        for name, v in (("sprocket", sprocket), ("roller", roller), ("member", member)):
            if v is not None:
                keep &= getattr(self, name) == checks.integer(
                    f"Engagements.select: {name}", v, lo=0
                )
        return Engagements(
            **{f.name: getattr(self, f.name)[keep] for f in dataclasses.fields(self)}
        )

    def statistics(self, confidence: float = 0.95) -> PeakStatistics:
        """:func:`peak_statistics` of the peaks."""
        return peak_statistics(self.peak, confidence)

    def populations(self) -> np.ndarray:
        """(E,) which of its inner link's two rollers each event's roller is: 1 if it
        meshed first on its sprocket (its link's other roller not yet meshed), 2 if
        second, 0 where its partner never met that sprocket in the record, so it cannot
        be told. Rollers (bushes) 2k and 2k + 1 sit on inner link k, as every builder
        numbers them. In the clearance-joint chain the two populations peak apart: the
        second roller meets the tooth with its link's other bush already seated."""
        first: dict[tuple[int, int, int], float] = {}
        keys = list(
            zip(self.member.tolist(), self.sprocket.tolist(), self.roller.tolist(), strict=True)
        )
        for key, t in zip(keys, self.onset.tolist(), strict=True):
            first[key] = min(first.get(key, math.inf), t)
        out = np.zeros(len(self), int)
        for i, (m, k, r) in enumerate(keys):
            partner = (m, k, r ^ 1)
            if partner in first:
                out[i] = 1 if first[(m, k, r)] < first[partner] else 2
        return out


def _record_of(source, caller: str) -> EngagementRecord:
    if isinstance(source, EngagementRecord):
        return source
    if isinstance(source, Solution):
        ok = np.asarray(source.result == Result.successful)
        if not np.all(ok):
            which = (
                f"({source.result_name})"
                if ok.ndim == 0
                else f"(members {np.flatnonzero(~ok.ravel()).tolist()} of the flattened batch)"
            )
            raise ValueError(
                f"{caller}: the solve failed {which}: its engagements are not measured; "
                "see Solution.message and fix the solve"
            )
        found = [v for v in source.observed if isinstance(v, EngagementRecord)]
        if len(found) == 1:
            return found[0]
        if not found:
            raise ValueError(
                f"{caller}: the solution carries no EngagementPeaks record: simulate with "
                "observers=(jc.observers.EngagementPeaks(...),)"
            )
        raise ValueError(
            f"{caller}: the solution carries {len(found)} EngagementPeaks records: pass the "
            "one to read, e.g. sol.observed[i]"
        )
    raise TypeError(
        f"{caller}: expected a jc.Solution carrying an EngagementPeaks observer, or its "
        f"EngagementRecord, got {type(source).__name__}"
    )


def engagement_peaks(source: Solution | EngagementRecord, t_start: float = 0.0) -> Engagements:
    """Every completed meshing event with onset at or after ``t_start`` [s] (the start
    transient before it discarded), as plain numpy :class:`Engagements`.

    ``source``: a :class:`~jaxchain.Solution` of a solve carrying one
    :class:`~jaxchain.observers.EngagementPeaks` (its record is found in
    ``Solution.observed``), or that record itself — leading member axes of a vmapped
    solve flatten into ``Engagements.member``. ``ValueError`` when the solve failed, or
    when a pair completed more events than the observer's capacity (with the capacity to
    use instead).
    """
    rec = _record_of(source, "engagement_peaks")
    t_start = checks.real("t_start", t_start, unit="s")
    onset, t_peak, peak, end = (np.asarray(a, dtype=float) for a in rec[:4])
    count = np.asarray(rec.count)
    if onset.ndim < 3 or count.shape != onset.shape[:-1]:
        raise ValueError(
            f"engagement_peaks: a record's slots are (..., S, R, K) and its count (..., S, "
            f"R); got {onset.shape} and {count.shape}"
        )
    k = onset.shape[-1]
    most = int(count.max(initial=0))
    if most > k:
        raise ValueError(
            f"engagement_peaks: a (sprocket, roller) pair completed {most} events, more than "
            f"the observer's capacity {k} (the rest were counted, not stored): use "
            f"EngagementPeaks(capacity={most}) or EngagementPeaks.for_solve(scene, t1)"
        )
    s, r = onset.shape[-3:-1]
    flat = lambda a: a.reshape(-1, s, r, k)  # noqa: E731
    onset, t_peak, peak, end = map(flat, (onset, t_peak, peak, end))
    valid = (np.arange(k) < count.reshape(-1, s, r)[..., None]) & (onset >= t_start)
    m, si, ri, ki = np.nonzero(valid)
    order = np.lexsort((ri, si, onset[valid], m))
    pick = lambda a: a[m, si, ri, ki][order]  # noqa: E731
    return Engagements(
        member=m[order],
        sprocket=si[order],
        roller=ri[order],
        onset=pick(onset),
        t_peak=pick(t_peak),
        peak=pick(peak),
        end=pick(end),
    )


# ---------------------------------------------------------------------------- statistics
class PeakStatistics(NamedTuple):
    """Statistics of per-engagement peaks [N]: count, mean, sample standard deviation
    (ddof 1), 95th percentile (linear interpolation), extremes, and the Student-t
    confidence interval on the mean at ``confidence`` (NaN with one sample)."""

    n: int
    mean: float
    std: float
    std_error: float
    p95: float
    min: float
    max: float
    ci_low: float
    ci_high: float
    confidence: float


class PeakComparison(NamedTuple):
    """Design b against design a: ``difference`` = mean(b) − mean(a) [N], ``relative`` =
    difference / mean(a), the Welch confidence interval on the difference at
    ``confidence`` with its Welch–Satterthwaite degrees of freedom ``dof``, and whether
    that interval excludes zero (the difference is resolved from the scatter). The
    95th percentiles' difference ``p95_difference`` = p95(b) − p95(a) [N] comes with a
    percentile-bootstrap interval at ``confidence`` (``p95_ci_low``, ``p95_ci_high``:
    2000 resamples of each side, seeded, so the same peaks give the same interval)."""

    a: PeakStatistics
    b: PeakStatistics
    difference: float
    relative: float
    ci_low: float
    ci_high: float
    dof: float
    excludes_zero: bool
    confidence: float
    p95_difference: float = math.nan
    p95_ci_low: float = math.nan
    p95_ci_high: float = math.nan


def _peaks(x, name: str) -> np.ndarray:
    v = x.peak if isinstance(x, Engagements) else x
    if isinstance(v, (str, bytes, dict)):
        raise TypeError(f"{name}: peaks must be an array of forces [N], got {type(v).__name__}")
    v = np.asarray(v, dtype=float)
    if v.ndim > 1:
        raise ValueError(
            f"{name}: peaks must be one 1-D array of per-engagement peaks, got shape "
            f"{v.shape}: pass each design's peaks on its own (compare_peaks(a, b) compares "
            "two), or flatten them if they really are one sample"
        )
    v = v.ravel()
    if v.size == 0:
        raise ValueError(
            f"{name}: no engagements (lengthen the solve, lower t_start, or check that the "
            "rollers mesh)"
        )
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: peaks must be finite")
    if np.any(v < 0):
        raise ValueError(
            f"{name}: peaks are normal contact forces and must be >= 0 N, got a minimum of "
            f"{v.min():g}"
        )
    return v


def _t_quantile(p: float, dof: float) -> float:
    """Student's t quantile (SciPy's statistics imported here: they take 0.4 s to import)."""
    from scipy import stats

    return float(stats.t.ppf(p, dof))


def _confidence(confidence) -> float:
    return checks.real("confidence", confidence, lo=0.0, hi=1.0, lo_open=True, hi_open=True)


def peak_statistics(peaks: Engagements | ArrayLike, confidence: float = 0.95) -> PeakStatistics:
    """n, mean, std, p95, max and the Student-t ``confidence`` interval on the mean of
    per-engagement peaks [N] (an :class:`Engagements` or an array of peaks). The
    interval assumes independent engagements; ≥ 30 of them make it robust to the
    distribution's skew."""
    c = _confidence(confidence)
    v = _peaks(peaks, "peak_statistics")
    n, mean = v.size, float(v.mean())
    std = float(v.std(ddof=1)) if n > 1 else math.nan
    se = std / math.sqrt(n)
    half = _t_quantile(0.5 + c / 2, n - 1) * se if n > 1 else math.nan
    return PeakStatistics(
        n=n,
        mean=mean,
        std=std,
        std_error=se,
        p95=float(np.percentile(v, 95)),
        min=float(v.min()),
        max=float(v.max()),
        ci_low=mean - half,
        ci_high=mean + half,
        confidence=c,
    )


_BOOT = 2000  # bootstrap resamples of compare_peaks' p95 interval


def _p95_interval(a: np.ndarray, b: np.ndarray, confidence: float) -> tuple[float, float]:
    """Percentile-bootstrap interval on p95(b) − p95(a): ``_BOOT`` resamples of each side,
    seeded (the same peaks give the same interval)."""
    rng = np.random.default_rng(0)
    boot = np.percentile(b[rng.integers(0, b.size, (_BOOT, b.size))], 95, axis=1)
    boot -= np.percentile(a[rng.integers(0, a.size, (_BOOT, a.size))], 95, axis=1)
    q_lo, q_hi = np.percentile(boot, [50 * (1 - confidence), 50 * (1 + confidence)])
    return float(q_lo), float(q_hi)


def compare_peaks(
    a: Engagements | ArrayLike, b: Engagements | ArrayLike, confidence: float = 0.95
) -> PeakComparison:
    """The mean per-engagement peak of b against a: difference mean(b) − mean(a) [N],
    relative difference, and Welch's ``confidence`` interval on the difference (unequal
    variances; each side needs ≥ 2 engagements)."""
    c = _confidence(confidence)
    pa, pb = _peaks(a, "compare_peaks"), _peaks(b, "compare_peaks")
    sa, sb = peak_statistics(pa, c), peak_statistics(pb, c)
    if min(sa.n, sb.n) < 2:
        raise ValueError(
            f"compare_peaks: each side needs >= 2 engagements for a variance, got {sa.n} and {sb.n}"
        )
    if sa.mean == 0:
        raise ValueError(
            "compare_peaks: the baseline a's peaks are all 0 N, so the relative difference "
            "is undefined: is a the right record (did its rollers mesh)?"
        )
    d = sb.mean - sa.mean
    va, vb = sa.std**2 / sa.n, sb.std**2 / sb.n
    se = math.sqrt(va + vb)
    if se > 0:
        dof = (va + vb) ** 2 / (va**2 / (sa.n - 1) + vb**2 / (sb.n - 1))
        half = _t_quantile(0.5 + c / 2, dof) * se
    else:  # both sides constant: the difference is exact
        dof, half = math.inf, 0.0
    lo, hi = d - half, d + half
    q_lo, q_hi = _p95_interval(pa, pb, c)
    return PeakComparison(
        a=sa,
        b=sb,
        difference=d,
        relative=d / sa.mean,
        ci_low=lo,
        ci_high=hi,
        dof=dof,
        excludes_zero=bool(lo > 0 or hi < 0),
        confidence=c,
        p95_difference=sb.p95 - sa.p95,
        p95_ci_low=q_lo,
        p95_ci_high=q_hi,
    )
