"""Initial layouts of chain drives: closure, seating, straight supporting spans, symmetry,
ordering, transport velocities, open strands, and input validation.

Expectations come from the geometry (pitch points recomputed here from θ and z, the
pitch-circle belt length, hand-worked closures of equal sprockets), not from the code.
"""

import functools
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from jaxchain._scenes.layout import closed_drive_layout, strand_layout, transport_velocity

P08, P12 = 12.7e-3, 19.05e-3  # 08B and 12A pitches [m]
PAIRS = [(9, 9), (12, 25), (18, 18), (17, 41), (25, 57)]


def radius(lp, z):
    return lp / (2 * math.sin(math.pi / z))


def pitch_points(lp, z, theta, centre=(0.0, 0.0)):
    a = theta + 2 * np.pi * np.arange(z) / z
    return np.asarray(centre) + radius(lp, z) * np.stack([np.cos(a), np.sin(a)], -1)


def cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def belt_length(c, r1, r2):
    """Open-belt length over the pitch circles."""
    s = math.asin((r2 - r1) / c)
    return 2 * math.sqrt(c**2 - (r2 - r1) ** 2) + r1 * (math.pi - 2 * s) + r2 * (math.pi + 2 * s)


def n_links_for(z1, z2, pitches):
    """An even link count for a centre distance of about ``pitches`` pitches."""
    return 2 * round(pitches + (z1 + z2) / 4)


# (z1, z2, pitch, "C" | "n", value): centre distance in pitches, or a link count
CASES = [
    (z1, z2, p, mode, v)
    for z1, z2 in PAIRS
    for p in (P08, P12)
    for mode, v in (("C", 30.0), ("C", 47.3), ("C", 60.0), ("n", 35), ("n", 52))
]


@functools.cache
def layout(z1, z2, p, mode, v):
    if mode == "C":
        return closed_drive_layout(p, z1, z2, centre_distance=v * p)
    return closed_drive_layout(p, z1, z2, n_links=n_links_for(z1, z2, v))


def case_id(c):
    return f"{c[0]}-{c[1]}-p{c[2] * 1e3:.2f}-{c[3]}{c[4]}"


cases = pytest.mark.parametrize("case", CASES, ids=case_id)


def spans(lay):
    """[(index of the seated start roller, indices of the span rollers, seated end)]."""
    n = lay.n_links
    seated = np.nonzero(lay.sprocket_of >= 0)[0]
    out = []
    for i, j in zip(seated, np.roll(seated, -1), strict=True):
        k = (j - i) % n
        if k > 1 or lay.sprocket_of[i] != lay.sprocket_of[j]:
            out.append((i, (i + np.arange(1, k)) % n, j))
    return out


# ------------------------------------------------------------------------- closure
@cases
def test_consecutive_rollers_one_pitch_apart(case):
    lay = layout(*case)
    x = lay.rollers
    d = np.linalg.norm(np.roll(x, -1, axis=0) - x, axis=1)  # closing pair included
    assert x.shape == (lay.n_links, 2)
    np.testing.assert_allclose(d, case[2], rtol=1e-12, atol=0)


@cases
def test_seated_rollers_at_pitch_points(case):
    z1, z2, p = case[:3]
    lay = layout(*case)
    axes = np.array([[0.0, 0.0], [lay.centre_distance, 0.0]])
    for s, z in enumerate((z1, z2)):
        m = lay.sprocket_of == s
        assert m.sum() == lay.wrap[s] >= 1
        r = lay.rollers[m] - axes[s]
        np.testing.assert_allclose(np.hypot(r[:, 0], r[:, 1]), radius(p, z), rtol=1e-13)
        k = lay.gap_of[m]
        assert np.all((0 <= k) & (k < z))
        # consecutive gaps, in CCW order
        assert np.all(np.diff(k) % z == 1)
        want = lay.theta[s] + 2 * np.pi * k / z
        diff = np.angle(np.exp(1j * (np.arctan2(r[:, 1], r[:, 0]) - want)))
        np.testing.assert_allclose(diff, 0, atol=1e-12)
    assert np.all(lay.gap_of[lay.sprocket_of == -1] == -1)


@cases
def test_spans_straight_outside_and_supporting(case):
    z1, z2, p = case[:3]
    lay = layout(*case)
    c = lay.centre_distance
    axes = np.array([[0.0, 0.0], [c, 0.0]])
    pts = np.concatenate(
        [pitch_points(p, z1, lay.theta[0]), pitch_points(p, z2, lay.theta[1], axes[1])]
    )
    found = spans(lay)
    assert len(found) == 2  # bottom and top
    for i, idx, j in found:
        a, b = lay.rollers[i], lay.rollers[j]
        u = (b - a) / np.linalg.norm(b - a)
        assert {lay.sprocket_of[i], lay.sprocket_of[j]} == {0, 1}
        np.testing.assert_allclose(np.linalg.norm(b - a), (len(idx) + 1) * p, rtol=1e-12)
        # collinear and in order along the line
        np.testing.assert_allclose(cross(u, lay.rollers[idx] - a), 0, atol=1e-12 * p)
        assert np.all(np.diff((lay.rollers[idx] - a) @ u) > 0)
        # outside both pitch circles
        for s, z in enumerate((z1, z2)):
            dist = np.linalg.norm(lay.rollers[idx] - axes[s], axis=1)
            assert np.all(dist > radius(p, z) - 1e-9 * p)
        # supporting line: both axes strictly on one side, no pitch point on the other
        side = np.sign(cross(u, axes - a))
        assert side[0] == side[1] != 0
        assert np.all(side[0] * cross(u, pts - a) > -1e-9 * p)
        # and no pitch point strictly inside the span is left unseated
        on = np.abs(cross(u, pts - a)) < 1e-9 * p
        t = (pts - a) @ u
        assert not np.any(on & (t > 1e-9 * p) & (t < np.linalg.norm(b - a) - 1e-9 * p))


@cases
def test_symmetric_about_x_axis(case):
    lay = layout(*case)
    x = lay.rollers
    mirror = x * np.array([1.0, -1.0])
    gap = np.linalg.norm(mirror[:, None, :] - x[None, :, :], axis=-1).min(axis=1)
    assert gap.max() < 1e-12 * case[2]
    assert lay.span[0] == lay.span[1]
    # the sprockets' pitch polygons are symmetric too: θ is 0 or π/z
    for th, z in zip(lay.theta, case[:2], strict=True):
        assert min(abs(th), abs(th - math.pi / z)) < 1e-15


@cases
def test_link_count_centre_distance_and_belt_length(case):
    z1, z2, p, mode, v = case
    lay = layout(*case)
    assert lay.n_links % 2 == 0
    assert lay.wrap.sum() + 2 * (lay.span[1] - 1) == lay.n_links
    if mode == "C":
        assert abs(lay.centre_distance - v * p) < p
    else:
        assert lay.n_links == n_links_for(z1, z2, v)
    r1, r2 = radius(p, z1), radius(p, z2)
    assert abs(belt_length(lay.centre_distance, r1, r2) - lay.n_links * p) < 2 * p
    # wraps close to the pitch circles' wrap angles
    s = math.asin((r2 - r1) / lay.centre_distance)
    for w, z, beta in ((lay.wrap[0], z1, math.pi - 2 * s), (lay.wrap[1], z2, math.pi + 2 * s)):
        assert abs((w - 1) - z * beta / (2 * math.pi)) <= 2


@pytest.mark.parametrize("z1, z2", PAIRS)
def test_requested_centre_distance_picks_the_nearest_closure(z1, z2):
    p = P08
    lay = closed_drive_layout(p, z1, z2, centre_distance=41.2 * p)
    same = closed_drive_layout(p, z1, z2, n_links=lay.n_links)
    assert same.centre_distance == lay.centre_distance
    for dn in (-2, 2):
        other = closed_drive_layout(p, z1, z2, n_links=lay.n_links + dn)
        assert (other.centre_distance - lay.centre_distance) * dn > 0  # C grows with n
        assert abs(other.centre_distance - 41.2 * p) >= abs(lay.centre_distance - 41.2 * p)


def test_equal_sprockets_even_teeth_closes_by_hand():
    # z = 18, θ = 0: the top pitch points at 80° and 100° are level, so the top span is
    # horizontal from the driven's 100° point to the driver's 80° point: |AB| = C − p
    # (2R cos 80° = 2R sin 10° = p). Wraps: 80° → 280° and −100° → 100°, 11 rollers each,
    # so n·p = 2(C − p) + 20p, C = (n − 18)/2 · p. (θ = π/18 gives the same C.)
    p = P08
    for n in (40, 78, 120):
        lay = closed_drive_layout(p, 18, 18, n_links=n)
        assert lay.centre_distance == pytest.approx((n - 18) / 2 * p, rel=1e-14)
    lay = closed_drive_layout(p, 18, 18, centre_distance=30 * p)
    assert lay.n_links == 78 and lay.centre_distance == pytest.approx(30 * p, rel=1e-14)


def test_equal_sprockets_odd_teeth_closes_by_hand():
    # z = 9 (pitch angle 40°): the two symmetric families with an even link count are
    # θ = (0, π/9): A at 80°, B at 100°, |AB| = C − 2R sin 10°, wraps 6 + 6 → n = 10 + 2 n_span;
    # θ = (π/9, 0): A at 100°, B at 80°, |AB| = C + 2R sin 10°, wraps 5 + 5.
    # The larger C, C = ((n − 10)/2 + 2 sin 10° / (2 sin 20°)) p, is the layout's.
    p = P12
    for n in (30, 64):
        lay = closed_drive_layout(p, 9, 9, n_links=n)
        want = ((n - 10) / 2 + math.sin(math.pi / 18) / math.sin(math.pi / 9)) * p
        assert lay.centre_distance == pytest.approx(want, rel=1e-14)
        assert tuple(lay.wrap) == (6, 6) and lay.span[0] == (n - 10) // 2
        np.testing.assert_allclose(lay.theta, [0, math.pi / 9], atol=1e-15)


def test_link_pitch_sets_every_length():
    p, lp = P08, P08 * 1.004
    lay = closed_drive_layout(p, 17, 41, centre_distance=40 * p, link_pitch=lp)
    x = lay.rollers
    d = np.linalg.norm(np.roll(x, -1, axis=0) - x, axis=1)
    np.testing.assert_allclose(d, lp, rtol=1e-12, atol=0)
    axes = np.array([[0.0, 0.0], [lay.centre_distance, 0.0]])
    for s, z in enumerate((17, 41)):
        r = x[lay.sprocket_of == s] - axes[s]
        np.testing.assert_allclose(np.hypot(r[:, 0], r[:, 1]), radius(lp, z), rtol=1e-13)


# ------------------------------------------------------------ transport velocity
@cases
def test_transport_velocity_and_order_of_travel(case):
    z1, z2 = case[:2]
    lay = layout(*case)
    omega1 = 104.7
    v = transport_velocity(lay, omega1, z1, z2)
    x = lay.rollers
    # order of travel for a CCW driver: every roller moves towards the next one
    step = np.roll(x, -1, axis=0) - x
    assert np.all(np.sum(v * step, axis=1) > 0)
    # seated: ω × r exactly, the driven at ω1 z1 / z2
    for s, (w, axis) in enumerate(((omega1, (0, 0)), (omega1 * z1 / z2, (lay.centre_distance, 0)))):
        r = x[lay.sprocket_of == s] - np.asarray(axis)
        np.testing.assert_allclose(v[lay.sprocket_of == s], w * np.stack([-r[:, 1], r[:, 0]], -1))
    # spans: linear between the end rollers
    for i, idx, j in spans(lay):
        t = np.arange(1, len(idx) + 1)[:, None] / (len(idx) + 1)
        np.testing.assert_allclose(v[idx], v[i] + t * (v[j] - v[i]), rtol=1e-12, atol=1e-12)


def test_transport_velocity_chain_speed():
    # Seated rollers move at ω R; the mean chain speed z1 p ω1 / 2π is the same on both
    # sprockets, and the driven turns at ω1 z1/z2.
    p, z1, z2, omega1 = P08, 12, 25, 50.0
    lay = closed_drive_layout(p, z1, z2, centre_distance=35 * p)
    v = transport_velocity(lay, omega1, z1, z2)
    speed = np.linalg.norm(v, axis=1)
    np.testing.assert_allclose(speed[lay.sprocket_of == 0], omega1 * radius(p, z1), rtol=1e-13)
    np.testing.assert_allclose(
        speed[lay.sprocket_of == 1], omega1 * z1 / z2 * radius(p, z2), rtol=1e-13
    )
    # reversing the driver reverses every velocity
    np.testing.assert_allclose(transport_velocity(lay, -omega1, z1, z2), -v)


# ------------------------------------------------------------------------ strands
STRANDS = [(P08, 18, 9, 8, 4), (P12, 9, 2, 1, 1), (P08, 25, 7, 12, 3), (P08, 40, 20, 5, 5)]


@pytest.mark.parametrize("p, z, wrap, n_entry, n_exit", STRANDS)
@pytest.mark.parametrize("theta", [0.0, 0.3])
def test_strand_layout(p, z, wrap, n_entry, n_exit, theta):
    lay = strand_layout(p, z, wrap=wrap, n_entry=n_entry, n_exit=n_exit, theta=theta)
    x = lay.rollers
    n = n_entry + wrap + n_exit
    assert x.shape == (n, 2)
    np.testing.assert_allclose(np.linalg.norm(np.diff(x, axis=0), axis=1), p, rtol=1e-12)
    seat = slice(n_entry, n_entry + wrap)
    assert np.all(lay.sprocket_of[seat] == 0) and np.all(lay.gap_of[seat] == np.arange(wrap))
    assert np.all(np.delete(lay.sprocket_of, np.r_[seat]) == -1)
    assert np.all(np.delete(lay.gap_of, np.r_[seat]) == -1)
    # seated at pitch points θ + 2πk/z
    want = pitch_points(p, z, lay.theta)[:wrap]
    np.testing.assert_allclose(x[seat], want, rtol=0, atol=1e-15)
    # wrap centred on the ray at angle π/2 + theta
    off = np.angle(np.exp(1j * (np.arctan2(x[seat, 1], x[seat, 0]) - (math.pi / 2 + theta))))
    assert abs(np.mean(off)) < 1e-12
    # straight spans continuing the end chords, pointing away from the sprocket
    for d in (lay.entry_dir, lay.exit_dir):
        assert np.linalg.norm(d) == pytest.approx(1.0, rel=1e-15)
    entry = x[: n_entry + 2][::-1]  # second seated, first seated, then out along the span
    exit_ = x[n_entry + wrap - 2 :]
    pts = pitch_points(p, z, lay.theta)
    for line, d in ((entry, lay.entry_dir), (exit_, lay.exit_dir)):
        np.testing.assert_allclose(cross(d, line - line[0]), 0, atol=1e-15)
        np.testing.assert_allclose(np.diff(line, axis=0) @ d, p, rtol=1e-12)
        # outside the pitch circle, the sprocket (axis, pitch points) on one side
        assert np.all(np.linalg.norm(line[2:], axis=1) > radius(p, z))
        side = np.sign(cross(d, -line[0]))
        assert np.all(side * cross(d, pts - line[0]) > -1e-12 * p)
    # order of travel for a CCW sprocket: it draws the chain in from the entry span
    step = np.diff(x, axis=0)
    seated_v = np.stack([-x[seat, 1], x[seat, 0]], -1)
    assert np.all(np.sum(seated_v[:-1] * step[seat.start : seat.stop - 1], axis=1) > 0)
    np.testing.assert_allclose(
        step[:n_entry], np.tile(-p * lay.entry_dir, (n_entry, 1)), atol=1e-15
    )
    np.testing.assert_allclose(
        step[n_entry + wrap - 1 :], np.tile(p * lay.exit_dir, (n_exit, 1)), atol=1e-15
    )
    assert seated_v[0] @ lay.entry_dir < 0 < seated_v[-1] @ lay.exit_dir


def test_strand_symmetric_about_y_axis():
    lay = strand_layout(P08, 18, wrap=6, n_entry=5, n_exit=5)
    x = lay.rollers
    np.testing.assert_allclose(x[::-1] * np.array([-1.0, 1.0]), x, atol=1e-15)
    np.testing.assert_allclose(lay.exit_dir, lay.entry_dir * np.array([-1.0, 1.0]), atol=1e-15)
    assert lay.entry_dir[0] > 0  # entry on the right: a CCW sprocket draws chain in there


def test_strand_link_pitch():
    p, lp = P08, P08 * 1.01
    lay = strand_layout(p, 18, wrap=9, n_entry=3, n_exit=3, link_pitch=lp)
    np.testing.assert_allclose(np.linalg.norm(np.diff(lay.rollers, axis=0), axis=1), lp)
    np.testing.assert_allclose(np.linalg.norm(lay.rollers[3:12], axis=1), radius(lp, 18))


# ----------------------------------------------------------------- property based
@settings(max_examples=40)
@given(
    z1=st.integers(7, 250),
    z2=st.integers(7, 250),
    extra=st.floats(0.0, 3.0),
    stretch=st.floats(0.0, 0.01),
)
def test_any_drive_closes(z1, z2, extra, stretch):
    p = P08
    lp = p * (1 + stretch)
    c_min = radius(lp, z1) + radius(lp, z2) + lp
    lay = closed_drive_layout(p, z1, z2, centre_distance=c_min * (1 + extra), link_pitch=lp)
    x = lay.rollers
    d = np.linalg.norm(np.roll(x, -1, axis=0) - x, axis=1)
    np.testing.assert_allclose(d, lp, rtol=1e-12, atol=0)
    assert lay.n_links % 2 == 0 and np.all(lay.wrap >= 1)
    assert lay.centre_distance >= c_min - 1e-12 * lp
    pts = np.concatenate(
        [
            pitch_points(lp, z1, lay.theta[0]),
            pitch_points(lp, z2, lay.theta[1], (lay.centre_distance, 0.0)),
        ]
    )
    for i, _, j in spans(lay):
        a, b = x[i], x[j]
        u = (b - a) / np.linalg.norm(b - a)
        side = np.sign(cross(u, np.array([0.0, 0.0]) - a))
        assert np.all(side * cross(u, pts - a) > -1e-9 * lp)
    v = transport_velocity(lay, 1.0, z1, z2)
    assert np.all(np.sum(v * (np.roll(x, -1, axis=0) - x), axis=1) > 0)


# ----------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(z1=6), r"z1 must be an integer in \[7, 250\], got 6"),
        (dict(z2=251), r"z2 must be an integer in \[7, 250\], got 251"),
        (dict(z1=18.0), r"z1 must be an integer in \[7, 250\]"),
        (dict(pitch=0.0), r"pitch must be a finite length > 0 m, got 0.0"),
        (dict(pitch=-P08), r"pitch must be a finite length > 0 m"),
        (dict(link_pitch=-1.0), r"link_pitch must be a finite length > 0 m"),
        (dict(centre_distance=None), r"exactly one of centre_distance and n_links, got neither"),
        (dict(n_links=100), r"exactly one of centre_distance and n_links, got both"),
        (
            dict(centre_distance=5 * P08),
            r"centre_distance must be >= R1 \+ R2 \+ p = 0\.122\d* m .* got 0\.0635",
        ),
        (dict(centre_distance=None, n_links=101), r"n_links must be even .* got 101"),
        (dict(centre_distance=None, n_links=20), r"n_links must be an integer >= \d+ for z1"),
        (dict(centre_distance=None, n_links=100.0), r"n_links must be an integer"),
    ],
)
def test_closed_drive_errors(kwargs, match):
    args = dict(pitch=P08, z1=18, z2=36, centre_distance=40 * P08) | kwargs
    with pytest.raises(ValueError, match=match):
        closed_drive_layout(**args)


def test_minimum_centre_distance_and_link_count_are_the_stated_ones():
    p, z1, z2 = P08, 18, 36
    c_min = radius(p, z1) + radius(p, z2) + p
    with pytest.raises(ValueError, match=f"R1 \\+ R2 \\+ p = {c_min:.6g} m"):
        closed_drive_layout(p, z1, z2, centre_distance=c_min * (1 - 1e-9))
    lay = closed_drive_layout(p, z1, z2, centre_distance=c_min)
    with pytest.raises(ValueError, match=r"n_links must be an integer >= \d+") as err:
        closed_drive_layout(p, z1, z2, n_links=2)
    n_min = int(re.search(r">= (\d+)", str(err.value)).group(1))
    assert n_min <= lay.n_links
    closed_drive_layout(p, z1, z2, n_links=n_min)  # the stated minimum is accepted
    with pytest.raises(ValueError, match=f"n_links must be an integer >= {n_min}"):
        closed_drive_layout(p, z1, z2, n_links=n_min - 2)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(wrap=1), r"wrap must be an integer \[2, 17\] .*z=18.*got 1"),
        (dict(wrap=18), r"wrap must be an integer \[2, 17\] .*got 18"),
        (dict(n_entry=0), r"n_entry must be an integer >= 1, got 0"),
        (dict(n_exit=0), r"n_exit must be an integer >= 1, got 0"),
        (dict(z=6), r"z must be an integer in \[7, 250\], got 6"),
        (dict(pitch=-1.0), r"pitch must be a finite length > 0 m"),
        (dict(theta=math.inf), r"theta must be a finite angle"),
    ],
)
def test_strand_errors(kwargs, match):
    args = dict(pitch=P08, z=18, wrap=9, n_entry=3, n_exit=3) | kwargs
    with pytest.raises(ValueError, match=match):
        strand_layout(**args)


def test_transport_velocity_checks_teeth():
    lay = closed_drive_layout(P08, 18, 36, centre_distance=40 * P08)
    with pytest.raises(ValueError, match=r"z2 must be an integer in \[7, 250\], got 3"):
        transport_velocity(lay, 1.0, 18, 3)
