"""Per-engagement meshing peaks: the statistics against their closed forms, the event
logic of :class:`~jaxchain.observers.EngagementPeaks` on a constructed force trace
(onsets, windows, rattle, passes, capacity, vmapped), and the observer on a real solve of
the engagement strand against its saved trace and its peak record."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

import jaxchain as jc

from helpers import count_vector_field_calls, own_program_store, tooth_period

# ---------------------------------------------------------------------------- statistics


def test_peak_statistics_match_closed_forms():
    """Mean, sample std, 95th percentile, extremes and the Student-t interval on the mean
    against numpy/scipy; an Engagements gives the same as its peaks."""
    x = np.random.default_rng(1).gamma(4.0, 400.0, size=37)
    s = jc.peak_statistics(x, confidence=0.9)
    sem = x.std(ddof=1) / math.sqrt(x.size)
    lo, hi = stats.t.interval(0.9, x.size - 1, loc=x.mean(), scale=sem)
    assert s.n == 37 and s.confidence == 0.9
    np.testing.assert_allclose(s.mean, x.mean(), rtol=1e-14)
    np.testing.assert_allclose(s.std, x.std(ddof=1), rtol=1e-14)
    np.testing.assert_allclose(s.std_error, stats.sem(x), rtol=1e-14)
    np.testing.assert_allclose(s.p95, np.percentile(x, 95), rtol=1e-14)
    assert (s.min, s.max) == (x.min(), x.max())
    np.testing.assert_allclose([s.ci_low, s.ci_high], [lo, hi], rtol=1e-12)
    z = np.zeros(x.size, int)
    eng = jc.Engagements(z, z, np.arange(x.size), z * 1.0, z * 1.0, x, z * 1.0)
    assert eng.statistics(0.9) == s and len(eng) == 37
    # one engagement: no spread; none, or a bad confidence: refused
    one = jc.peak_statistics([1500.0])
    assert one.mean == one.max == 1500.0 and math.isnan(one.std) and math.isnan(one.ci_low)
    with pytest.raises(ValueError, match="no engagements"):
        jc.peak_statistics([])
    with pytest.raises(ValueError, match="confidence"):
        jc.peak_statistics(x, confidence=1.0)


def test_compare_peaks_is_welch():
    """The difference b − a, its relative size and Welch's interval, against scipy's
    unequal-variance t-test; a shift far beyond the scatter excludes zero, none does not."""
    rng = np.random.default_rng(2)
    a = rng.normal(1900.0, 400.0, size=31)
    b = rng.normal(1500.0, 150.0, size=45)
    c = jc.compare_peaks(a, b, confidence=0.95)
    ci = stats.ttest_ind(b, a, equal_var=False).confidence_interval(0.95)
    np.testing.assert_allclose(c.difference, b.mean() - a.mean(), rtol=1e-13)
    np.testing.assert_allclose(c.relative, (b.mean() - a.mean()) / a.mean(), rtol=1e-13)
    np.testing.assert_allclose([c.ci_low, c.ci_high], [ci.low, ci.high], rtol=1e-10)
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    np.testing.assert_allclose(c.dof, dof, rtol=1e-13)
    assert c.excludes_zero and c.ci_high < 0 and c.a.n == 31 and c.b.n == 45
    same = jc.compare_peaks(a, a + rng.normal(0.0, 1.0, size=a.size))
    assert not same.excludes_zero and same.ci_low < 0 < same.ci_high
    exact = jc.compare_peaks([1.0, 1.0], [2.0, 2.0])  # no scatter: the difference is exact
    assert (exact.ci_low, exact.ci_high, exact.excludes_zero) == (1.0, 1.0, True)
    with pytest.raises(ValueError, match=">= 2 engagements"):
        jc.compare_peaks(a, [1.0])


def test_p95_interval_covers_the_true_difference():
    """The bootstrap interval on p95(b) − p95(a) against the true difference of two
    normal populations, μ_b − μ_a + z₀.₉₅·(σ_b − σ_a): it covers it in about 95 % of 300
    independent draws of 40 peaks each (measured 0.94; a percentile bootstrap of a tail
    quantile may undercover a little at n = 40), its centre is the samples' own difference,
    and the same peaks give the same interval."""
    rng = np.random.default_rng(5)
    truth = (1500.0 - 1900.0) + stats.norm.ppf(0.95) * (150.0 - 400.0)
    hits = 0
    for _ in range(300):
        a, b = rng.normal(1900.0, 400.0, 40), rng.normal(1500.0, 150.0, 40)
        c = jc.compare_peaks(a, b)
        assert c.p95_ci_low < c.p95_difference < c.p95_ci_high
        hits += c.p95_ci_low <= truth <= c.p95_ci_high
    assert 0.88 <= hits / 300 <= 0.98, hits / 300
    np.testing.assert_allclose(c.p95_difference, np.percentile(b, 95) - np.percentile(a, 95))
    again = jc.compare_peaks(a, b)
    assert (again.p95_ci_low, again.p95_ci_high) == (c.p95_ci_low, c.p95_ci_high)


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda: jc.peak_statistics(np.ones((2, 5))), ValueError, r"one 1-D array.*shape \(2, 5\)"),
        (lambda: jc.peak_statistics([900.0, -3.0, 1000.0]), ValueError, "must be >= 0 N"),
        (lambda: jc.peak_statistics([]), ValueError, "no engagements"),
        (lambda: jc.peak_statistics([1.0, np.nan]), ValueError, "must be finite"),
        (lambda: jc.peak_statistics("900 N"), TypeError, "array of forces"),
        (lambda: jc.compare_peaks(np.zeros(5), np.ones(5)), ValueError, "all 0 N.*undefined"),
        (lambda: jc.compare_peaks(np.ones((2, 3)), np.ones(6)), ValueError, "one 1-D array"),
        (lambda: jc.compare_peaks([1.0, 2.0], [3.0]), ValueError, ">= 2 engagements"),
    ],
)
def test_statistics_refuse_what_they_cannot_summarize(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_populations_tell_first_and_second_rollers():
    """Rollers 2k and 2k + 1 share inner link k: the one of each pair that meshed first
    on a sprocket is population 1, its partner 2, per member and sprocket; a roller whose
    partner never meshed there is 0."""
    ev = jc.Engagements(
        member=np.array([0, 0, 0, 0, 0, 1, 1]),
        sprocket=np.array([0, 0, 0, 1, 1, 0, 0]),
        roller=np.array([3, 2, 4, 2, 3, 2, 3]),
        onset=np.array([1.0, 2.0, 3.0, 0.5, 0.7, 9.0, 8.0]),
        t_peak=np.zeros(7),
        peak=np.ones(7),
        end=np.zeros(7),
    )
    assert ev.populations().tolist() == [1, 2, 0, 1, 2, 2, 1]
    assert ev.select(sprocket=1).roller.tolist() == [2, 3]
    with pytest.raises(TypeError, match="Engagements.select: sprocket must be an integer"):
        ev.select(sprocket="1")


# ---------------------------------------------------------------------------- event logic
# One sprocket, four rollers, on a constructed trace (times in s, forces in N, distances
# in m; reach 1 m, tooth period 10 s, window 0.5 periods = 5 s):
#   roller 0 touches at t0 (not armed), leaves the reach at 28 s, comes back and meshes
#     at 40 s: one event;
#   roller 1 meshes at 10.33 s (peak 1000 N), rebounds at 12.5 s within the window
#     (600 N), is hit at 18 s after it (2000 N, no new event: it never left), leaves at
#     25 s and meshes again at 35.4 s (800 N): two events;
#   roller 2 meshes at 47 s, its window runs past the end (50 s): not recorded;
#   roller 3 never comes near.
THRESHOLD, PERIOD, WINDOW, T_END = 1.0, 10.0, 0.5, 50.0


def _pulse(t, t_peak, height, half_width=1.0):
    """A parabolic pulse: exact for the observer's parabolas where three samples lie on it."""
    return np.maximum(0.0, height * (1.0 - ((t - t_peak) / half_width) ** 2))


def _trace(t):
    """(T, 1, 4) forces [N] and distances [m] at times ``t`` (T,)."""
    f = np.zeros((t.size, 4))
    f[:, 0] = np.where(t < 27.0, 50.0, 0.0) + _pulse(t, 40.2, 1200.0)
    f[:, 1] = (
        _pulse(t, 10.33, 1000.0) + _pulse(t, 12.5, 600.0, 0.7) + _pulse(t, 18.0, 2000.0)
    ) + _pulse(t, 35.4, 800.0)
    f[:, 2] = _pulse(t, 47.0, 900.0)
    d = np.full((t.size, 4), 2.0)
    d[:, 0] = np.where((t > 28.0) & (t < 37.0), 2.0, 0.5)
    d[:, 1] = np.where((t > 9.0) & (t < 25.0) | (t > 33.0), 0.5, 2.0)
    d[:, 2] = np.where(t > 45.0, 0.5, 2.0)
    return f[:, None, :], d[:, None, :]


def _steps(seed: int, n: int):
    """100 uneven steps over [0, T_END] (0.3–0.7 s) and the samples of each at
    t0 + (t1 − t0)·j/n, j = 1 … n (as the observer reads a solver step)."""
    rng = np.random.default_rng(seed)
    edges = np.linspace(0.0, T_END, 101)
    edges[1:-1] += rng.uniform(-0.1, 0.1, size=99)
    t0, t1 = edges[:-1], edges[1:]
    ts = t0[:, None] + (t1 - t0)[:, None] * np.arange(1, n + 1) / n
    return t0, t1, ts


@eqx.filter_jit
def _run(obs, f0, t0, t1, force, distance):
    """The observer's event logic over every step of a sampled trace; its value."""
    period = jnp.full(force.shape[:2] + (1,), PERIOD)
    reach = jnp.ones(1)

    def body(tracker, x):
        a, b, f, d, p = x
        return obs._advance(tracker, a, b, f, d, p, reach), None

    tracker, _ = jax.lax.scan(body, obs._begin(f0), (t0, t1, force, distance, period))
    return obs.value(tracker, t0[0], t1[-1])


def _inputs(obs, seed=0, scale=1.0):
    """(f0, t0, t1, force, distance) of the trace on the steps of ``seed``, forces scaled."""
    t0, t1, ts = _steps(seed, obs.samples)
    f, d = _trace(ts.ravel())
    f0, _ = _trace(np.zeros(1))
    shape = ts.shape + (1, 4)
    return scale * f0[0], t0, t1, scale * f.reshape(shape), d.reshape(shape)


def _record(obs, seed=0, scale=1.0):
    return _run(obs, *_inputs(obs, seed, scale))


def test_events_on_a_constructed_trace():
    """Onset (threshold crossing, linear between samples), peak (exact on a parabolic
    pulse), window (0.5 tooth periods), rebounds inside the window, no new event while a
    roller stays within reach, a second pass after leaving it, none for a roller touching
    at t0 or one whose window runs past the end."""
    obs = jc.observers.EngagementPeaks(window=WINDOW, threshold=THRESHOLD, capacity=2)
    rec = _record(obs)
    ts = _steps(0, obs.samples)[2]
    np.testing.assert_array_equal(np.asarray(rec.count), [[1, 2, 0, 0]])
    eng = jc.engagement_peaks(rec)
    assert list(eng.roller) == [1, 1, 0] and list(eng.sprocket) == [0, 0, 0]
    np.testing.assert_allclose(eng.peak, [1000.0, 800.0, 1200.0], rtol=1e-12)
    np.testing.assert_allclose(eng.t_peak, [10.33, 35.4, 40.2], rtol=1e-12)
    # onset: the crossing interpolated linearly between the samples around it
    t = ts.ravel()
    for k, (r, tp, height) in enumerate([(1, 10.33, 1000.0), (1, 35.4, 800.0), (0, 40.2, 1200.0)]):
        f = _trace(t)[0][:, 0, r]
        i = np.flatnonzero((f[1:] > THRESHOLD) & (np.abs(t[1:] - tp) < 1.5))[0] + 1
        want = t[i - 1] + (THRESHOLD - f[i - 1]) / (f[i] - f[i - 1]) * (t[i] - t[i - 1])
        np.testing.assert_allclose(eng.onset[k], want, rtol=1e-12)
        exact = tp - math.sqrt(1.0 - THRESHOLD / height)  # the pulse's own crossing
        assert abs(eng.onset[k] - exact) < t[i] - t[i - 1]
    np.testing.assert_allclose(eng.end, eng.onset + WINDOW * PERIOD, rtol=1e-12)
    # discarding the start transient
    late = jc.engagement_peaks(rec, t_start=20.0)
    assert list(late.roller) == [1, 0] and late.onset.min() >= 20.0
    assert len(eng.select(roller=1)) == 2 and len(eng.select(sprocket=1)) == 0
    # a window of 1 period reaches the 2000 N hit at 18 s (what the default avoids)
    wide = jc.engagement_peaks(_record(eqx.tree_at(lambda o: o.window, obs, jnp.asarray(1.0))))
    assert wide.peak[0] == pytest.approx(2000.0, rel=1e-12)


def test_capacity_overflow_is_counted_and_refused():
    """Events past the capacity are counted, not stored; reading the record says which
    capacity holds them."""
    obs = jc.observers.EngagementPeaks(window=WINDOW, threshold=THRESHOLD, capacity=1)
    rec = _record(obs)
    np.testing.assert_array_equal(np.asarray(rec.count), [[1, 2, 0, 0]])
    np.testing.assert_allclose(np.asarray(rec.peak)[0, 1], [1000.0], rtol=1e-12)
    with pytest.raises(ValueError, match="capacity=2"):
        jc.engagement_peaks(rec)
    with pytest.raises(ValueError, match="capacity"):
        jc.observers.EngagementPeaks(capacity=0)
    with pytest.raises(ValueError, match="window"):
        jc.observers.EngagementPeaks(window=0.0)


def test_event_logic_vmaps_over_members():
    """A batch of traces (other step boundaries, forces scaled) vmapped through the event
    logic gives each member's own record; engagement_peaks numbers the members."""
    obs = jc.observers.EngagementPeaks(window=WINDOW, threshold=THRESHOLD, capacity=2)
    members = ((3, 1.0), (4, 1.5))
    singles = [_record(obs, seed, scale) for seed, scale in members]
    stacked = [np.stack(x) for x in zip(*(_inputs(obs, *m) for m in members), strict=True)]
    batch = jax.vmap(_run, in_axes=(None, 0, 0, 0, 0, 0))(obs, *stacked)
    for k, single in enumerate(singles):
        for got, want in zip(batch, single, strict=True):
            np.testing.assert_allclose(np.asarray(got)[k], np.asarray(want), rtol=1e-12)
    eng = jc.engagement_peaks(batch)
    assert list(eng.member) == [0, 0, 0, 1, 1, 1] and list(eng.roller) == [1, 1, 0] * 2
    np.testing.assert_allclose(eng.peak, [1000.0, 800.0, 1200.0, 1500.0, 1200.0, 1800.0])


# ---------------------------------------------------------------------------- on a solve
def test_engagements_of_the_strand(monkeypatch, tmp_path):
    """The lumped strand over two tooth periods: one event per roller that meshed (not
    touching at t0, its window closed by t1), onset at its saved threshold crossing, each
    peak at most the solve's peak record and at least the saved trace's maximum in its
    window, and equal to the top of the solve's own dense output there (read back by
    saving densely around it in a second call, which must not retrace). The parabolas
    through the step's samples read that top within ~3e-5 (either side): the bounds on
    saved values allow 1e-4."""
    scene = jc.scenes.engagement("08B", 18, speed_rpm=1000.0, tension=1000.0, n_entry=3)
    period = tooth_period(1000.0, 18)
    t1, n_save = 2 * period, 2001
    obs = jc.observers.EngagementPeaks()
    ts = np.linspace(0.0, t1, n_save)
    sol = jc.simulate(scene, t1, ts=ts, observers=(obs,))
    eng = jc.engagement_peaks(sol)
    f = np.asarray(sol.roller_sprocket_force)  # (T, R); one sprocket
    thr = float(obs.threshold)
    first = np.argmax(f > thr, axis=0)  # first saved sample above the threshold
    meshed = [
        r
        for r in range(scene.n_rollers)
        if f[0, r] <= thr and (f[:, r] > thr).any() and ts[first[r]] + 0.5 * period < t1
    ]
    assert len(meshed) == 2
    assert sorted(eng.roller.tolist()) == meshed and len(eng) == len(meshed)
    assert np.all(eng.sprocket == 0) and np.all(np.diff(eng.onset) > 0)
    peak = float(sol.peak_contact_force)
    for r, on, tp, p, end in zip(eng.roller, eng.onset, eng.t_peak, eng.peak, eng.end, strict=True):
        i = first[r]
        assert ts[i - 1] <= on <= ts[i]
        np.testing.assert_allclose(end - on, obs.window * period, rtol=1e-9)
        inside = (ts >= on) & (ts <= end)
        assert f[inside, r].max() <= p * (1 + 1e-4) and p <= peak * (1 + 1e-12)
        assert on < tp < on + 0.1 * period  # the meshing impact follows the first touch
    assert eng.peak.max() == pytest.approx(peak, rel=1e-12)  # the strand's top is an impact

    # read back: the same solve saving 300 times ±1.5 µs around each peak (same shapes,
    # another window: no retrace), its top in each window against the event's peak
    calls = count_vector_field_calls(monkeypatch)
    own_program_store(monkeypatch, tmp_path)  # where a retraced program cannot hide
    fine = [tp + np.linspace(-1.5e-6, 1.5e-6, 300) for tp in eng.t_peak]
    ts2 = np.sort(np.concatenate([np.linspace(0.0, t1, n_save - 300 * len(eng)), *fine]))
    obs2 = jc.observers.EngagementPeaks(window=0.4)
    sol2 = jc.simulate(scene, t1, ts=ts2, observers=(obs2,))
    assert calls == []
    eng2 = jc.engagement_peaks(sol2)
    np.testing.assert_allclose(eng2.peak, eng.peak, rtol=1e-12)
    np.testing.assert_allclose(eng2.end - eng2.onset, 0.4 * period, rtol=1e-9)
    f2 = np.asarray(sol2.roller_sprocket_force)
    for r, on, p, end in zip(eng.roller, eng.onset, eng.peak, eng.end, strict=True):
        top = f2[(ts2 >= on) & (ts2 <= end), r].max()
        assert abs(p / top - 1) < 1e-4
    # the start transient discarded; a solve without the observer, or a failed one, refused
    assert len(jc.engagement_peaks(sol, t_start=eng.onset[0] + 1e-9)) == len(eng) - 1
    with pytest.raises(ValueError, match="no EngagementPeaks"):
        jc.engagement_peaks(eqx.tree_at(lambda s: s.observed, sol, ()))
    with pytest.raises(ValueError, match="failed \\(max_steps_reached\\)"):
        jc.engagement_peaks(eqx.tree_at(lambda s: s.result, sol, jc.Result.max_steps_reached))


def test_capacity_for_a_closed_drive():
    """A roller meshes with each sprocket of a closed drive once per loop pass: the sized
    observer holds every pass over t1, with a margin for a driven sprocket running fast.
    Counted by hand: at 1000 rpm an 18-tooth driver moves the chain 18 · 1000/60 = 300
    pitches a second, so each roller of a 60-link loop comes round 5 times a second, 2.5
    times in 0.5 s: at most 3 passes begin in [0, t1], and a fourth may be under way at
    t0; the 25 % margin makes the 2.5 passes 3.125, so 4 + 1."""
    scene = jc.scenes.drive(
        "08B", (18, 36), n_links=60, speed_rpm=1000.0, model=jc.scenes.ChainModel(settle=False)
    )
    t1 = 0.5
    obs = jc.observers.EngagementPeaks.for_solve(scene, t1, window=0.3)
    assert obs.capacity == 5
    assert jc.observers.EngagementPeaks.for_solve(scene, t1, margin=1.0).capacity == 4
    # the driven sprocket (36 teeth at 500 rpm) takes the rollers at the same rate: a
    # drive with it as the driver sizes alike
    driven = jc.scenes.drive(
        "08B", (36, 18), n_links=60, speed_rpm=500.0, model=jc.scenes.ChainModel(settle=False)
    )
    assert jc.observers.EngagementPeaks.for_solve(driven, t1, window=0.3).capacity == 5
    assert float(obs.window) == 0.3 and obs.samples == 4
    with pytest.raises(ValueError, match="t1"):
        jc.observers.EngagementPeaks.for_solve(scene, 0.0)
