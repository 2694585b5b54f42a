"""Per-engagement meshing peaks read off a solve, and their statistics: plain numpy
:class:`Engagements` from the :class:`~jaxchain.observers.EngagementPeaks` record of a
:class:`~jaxchain.Solution`, :func:`peak_statistics` and :func:`compare_peaks` (the
difference of two designs with its confidence interval). What an event is, and why its
window is half a tooth period: ``jaxchain._observers.engagements``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from jaxtyping import ArrayLike

from . import _checks as checks
from ._observers.engagements import EngagementRecord
from ._solve.result import Result
from ._solve.simulate import Solution

__all__ = [
    "Engagements",
    "PeakStatistics",
    "PeakComparison",
    "engagement_peaks",
    "peak_statistics",
    "compare_peaks",
]


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

    def __post_init__(self):
        n = None
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            name = f"Engagements.{f.name}"
            checks.real_values(name, value, "a 1-D array, one entry per event")
            v = np.asarray(value)
            if v.ndim != 1:
                raise ValueError(
                    f"{name} must be a 1-D array, one entry per event, got shape {v.shape} "
                    "(jc.engagement_peaks reads them off a solve)"
                )
            if n is not None and v.shape[0] != n:
                raise ValueError(
                    f"Engagements: every field holds one entry per event; {name} has "
                    f"{v.shape[0]}, Engagements.member {n}"
                )
            n = v.shape[0]
            integral = f.name in ("member", "sprocket", "roller")
            if integral and not np.issubdtype(v.dtype, np.integer):
                if not np.all(v == np.round(v)):
                    raise ValueError(f"{name} must hold integer indices, got {v.tolist()}")
                v = v.astype(int)
            object.__setattr__(self, f.name, v)

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
    hint = (
        " (these are its events already: jc.peak_statistics takes them)"
        if isinstance(source, Engagements)
        else ""
    )
    raise TypeError(
        f"{caller}: source must be a jc.Solution carrying an EngagementPeaks observer, or its "
        f"EngagementRecord, got {type(source).__name__}{hint}"
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
    if isinstance(v, dict):
        raise TypeError(f"{name}: peaks must be an array of forces [N], got {type(v).__name__}")
    checks.real_values(f"{name}: peaks", v, "a 1-D array of forces [N] (or jc.Engagements)")
    v = np.asarray(v, dtype=float)
    if v.ndim == 0:
        raise ValueError(
            f"{name}: peaks must be a 1-D array of per-engagement peaks [N], got one number "
            f"{float(v)!r}: pass every engagement's peak, e.g. [{float(v)!r}]"
        )
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
