"""Drives over several sprockets: the exact loop layout, its errors, the settled statics,
and a short simulation's speed ratios and power balance.

Expectations come from closed forms: pitch points recomputed here from θ, z and the axes;
supporting lines checked against every pitch point; the belt length over the pitch circles
from the common tangents; ωk = ±ω1·z1/zk; static tension steps load_k/R_k; the driver's
work against the loads' work.
"""

import math

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import modelled

P08, P06 = 12.7e-3, 9.525e-3  # 08B and 06B pitches [m]
TRIANGLE = ((0.0, 0.0), (0.3, 0.05), (0.15, 0.25))
SQUARE = ((0, 0), (0.4, 0), (0.4, 0.4), (0, 0.4))

# (pitch, teeth, centres, keyword arguments of loop_layout)
LAYOUTS = {
    "three": (P08, (18, 36, 27), TRIANGLE, {}),
    "three-take-up-1": (P08, (18, 36, 27), TRIANGLE, {"take_up_sprocket": 1}),
    "three-long": (P08, (18, 36, 27), TRIANGLE, {"n_links": 120}),
    "timing": (P06, (21, 42, 42), ((0, 0), (0.05, 0.25), (-0.1, 0.25)), {}),
    "four": (P08, (13, 26, 19, 17), ((0, 0), (0.3, 0.0), (0.35, 0.2), (0.0, 0.25)), {}),
    "four-idler-out": (
        P08, (18, 36, 27, 15), ((0, 0), (0.3, 0.0), (0.3, 0.25), (0.15, 0.12)), {"outside": (3,)}
    ),
    "five-tensioner": (
        P08,
        (18, 18, 18, 18, 12),
        (*SQUARE, (0.0, 0.2)),
        {"outside": (4,), "take_up_sprocket": 4},
    ),
}  # fmt: skip


def radius(lp, z):
    return lp / (2 * math.sin(math.pi / z))


def pitch_points(lp, z, theta, centre):
    a = theta + 2 * np.pi * np.arange(z) / z
    return np.asarray(centre) + radius(lp, z) * np.stack([np.cos(a), np.sin(a)], -1)


def cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def circle_loop(lp, teeth, centres, sense):
    """Common tangents of the pitch circles (span j leaves circle j at a[j], reaches circle
    j + 1 at b[j]), each circle on its side: the tangent direction φ solves
    −d·sin(φ − ψ) = s_b·R_b − s_a·R_a (ψ the direction from axis a to axis b).
    Returns (a, b, wrap angles, belt length)."""
    n = len(teeth)
    c = np.asarray(centres, dtype=float)
    r = np.array([radius(lp, z) for z in teeth])
    a, b = np.zeros((n, 2)), np.zeros((n, 2))
    for j in range(n):
        k = (j + 1) % n
        d = c[k] - c[j]
        phi = math.atan2(d[1], d[0]) - math.asin(
            (sense[k] * r[k] - sense[j] * r[j]) / np.linalg.norm(d)
        )
        normal = np.array([-math.sin(phi), math.cos(phi)])  # left of the direction of travel
        a[j] = c[j] - sense[j] * r[j] * normal
        b[j] = c[k] - sense[k] * r[k] * normal
    arcs = np.zeros(n)
    for k in range(n):
        t_in, t_out = b[(k - 1) % n] - c[k], a[k] - c[k]
        ang = math.atan2(cross(t_in, t_out), t_in @ t_out)
        arcs[k] = (sense[k] * ang) % (2 * math.pi)
    return a, b, arcs, float(np.sum(np.linalg.norm(b - a, axis=1)) + np.sum(r * arcs))


@pytest.fixture(scope="module", params=list(LAYOUTS), ids=list(LAYOUTS))
def case(request):
    p, teeth, centres, kw = LAYOUTS[request.param]
    return p, teeth, centres, kw, jc.scenes.loop_layout(p, teeth, centres, **kw)


def test_loop_layout_is_exact(case):
    """Consecutive rollers one link pitch apart, the closing pair included; an even count;
    seated rollers on the pitch points of consecutive gaps; spans straight, of whole
    pitches, on lines that support both pitch polygons; every wrap at least one roller."""
    p, teeth, centres, kw, lay = case
    n, lp = lay.n_links, lay.link_pitch
    x = lay.rollers
    assert n % 2 == 0 and x.shape == (n, 2)
    step = np.linalg.norm(np.roll(x, -1, axis=0) - x, axis=1)
    np.testing.assert_allclose(step, lp, rtol=1e-12)
    sense = np.where(np.isin(np.arange(len(teeth)), kw.get("outside", ())), -1, 1)
    np.testing.assert_array_equal(lay.sense, sense)
    assert np.all(lay.wrap >= 1) and np.all(lay.span >= 1)
    assert lay.wrap.sum() + lay.span.sum() - len(teeth) == n
    starts, ends = [], []
    for k, z in enumerate(teeth):
        pts = pitch_points(lp, z, lay.theta[k], lay.centres[k])
        idx = np.nonzero(lay.sprocket_of == k)[0]
        assert len(idx) == lay.wrap[k]
        np.testing.assert_allclose(x[idx], pts[lay.gap_of[idx]], rtol=0, atol=1e-14)
        assert np.all((np.diff(lay.gap_of[idx]) - sense[k]) % z == 0)  # consecutive gaps
        starts.append(idx[-1])
        ends.append(idx[0])
    for j in range(len(teeth)):
        a_i, b_i = starts[j], ends[(j + 1) % len(teeth)]
        a, b = x[a_i], x[b_i]
        assert (b_i - a_i) % n == lay.span[j]
        u = (b - a) / np.linalg.norm(b - a)
        inner = x[(a_i + np.arange(1, lay.span[j])) % n]
        np.testing.assert_allclose(cross(u, inner - a), 0.0, atol=1e-14)  # straight
        for s in (j, (j + 1) % len(teeth)):  # both polygons on their own side
            pts = pitch_points(lp, teeth[s], lay.theta[s], lay.centres[s])
            assert np.all(sense[s] * cross(u, pts - a) >= -1e-12), (j, s)
        for s in set(range(len(teeth))) - {j, (j + 1) % len(teeth)}:  # others clear
            c = lay.centres[s]
            t = np.clip((c - a) @ u / np.linalg.norm(b - a), 0, 1)
            assert np.linalg.norm(a + t * (b - a) - c) > radius(lp, teeth[s]) + 0.625 * p
    # total turning of the roller polygon: one counter-clockwise loop
    d = np.roll(x, -1, axis=0) - x
    turn = np.arctan2(cross(d, np.roll(d, -1, axis=0)), np.sum(d * np.roll(d, -1, axis=0), 1))
    assert abs(turn.sum() - 2 * math.pi) < 1e-9


def test_loop_layout_moves_only_the_take_up(case):
    """Axes stay where given except the take-up's, which moves along the outward bisector
    of its spans over the pitch circles, (u_in − u_out)/|·|; with the default link count
    (the even count nearest the belt length over the pitch circles) by less than a pitch
    over cos α."""
    p, teeth, centres, kw, lay = case
    n = len(teeth)
    m = kw.get("take_up_sprocket", n - 1)
    assert lay.take_up == m
    c = np.asarray(centres, dtype=float)
    others = np.arange(n) != m
    np.testing.assert_array_equal(lay.centres[others], c[others])
    a, b, arcs, belt = circle_loop(p, teeth, centres, lay.sense)
    u = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    push = 0.5 * (u[m - 1] - u[m])
    shift = lay.centres[m] - c[m]
    assert abs(cross(shift, push)) <= 1e-12 * np.linalg.norm(push)
    np.testing.assert_allclose(np.linalg.norm(shift), abs(lay.take_up_shift), rtol=1e-12)
    assert np.sign(shift @ push) == np.sign(lay.take_up_shift) or lay.take_up_shift == 0
    if "n_links" not in kw:
        assert lay.n_links == 2 * round(belt / (2 * p))
        assert abs(lay.take_up_shift) < p / np.linalg.norm(push)


def test_loop_transport_velocity(case):
    """Seated rollers turn with their sprocket at ωk = ±ω1·z1/zk (minus outside the loop)."""
    *_, lay = case
    w1 = 50.0
    v = jc.scenes.transport_velocity(lay, w1)
    for k, z in enumerate(lay.teeth):
        idx = lay.sprocket_of == k
        w = lay.sense[k] * w1 * lay.teeth[0] / z
        r = lay.rollers[idx] - lay.centres[k]
        np.testing.assert_allclose(v[idx], w * np.stack([-r[:, 1], r[:, 0]], -1), rtol=1e-12)


@pytest.mark.parametrize("n", [60, 90, 120])
def test_two_sprocket_loop_agrees_with_closed_drive(n):
    """Two sprockets on the x axis: the loop closes with the same link count as the
    symmetric two-sprocket layout, the driven axis moved along the centre line by less
    than a pitch from that layout's centre distance."""
    closed = jc.scenes.closed_drive_layout(P08, 18, 36, n_links=n)
    lay = jc.scenes.loop_layout(P08, (18, 36), ((0, 0), (closed.centre_distance, 0)), n_links=n)
    assert lay.n_links == closed.n_links
    assert lay.centres[1, 1] == 0.0
    assert abs(lay.centres[1, 0] - closed.centre_distance) < P08


def test_two_teeth_without_centres_is_the_two_sprocket_drive():
    """Two teeth and no centres build today's two-sprocket drive: its layout exactly."""
    chain = jc.ChainSpec.iso606("08B")
    sc = jc.scenes.drive(
        chain, (18, 36), n_links=60, pretension=0.0, model=jc.scenes.ChainModel(settle=False)
    )
    lay = jc.scenes.closed_drive_layout(chain.pitch, 18, 36, n_links=60)
    np.testing.assert_array_equal(np.asarray(sc.q0[:, :2]), lay.rollers)
    np.testing.assert_array_equal(np.asarray(sc.sprockets[1].centre), [lay.centre_distance, 0])
    assert all(s.take_up_vector is None for s in sc.sprockets)


# ------------------------------------------------------------------------------- errors
TRI = TRIANGLE


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"teeth": (18, 36), "centres": TRI}, r"centres must be 2 finite axis positions"),
        ({"centres": TRI[:2]}, r"centres must be 3 finite axis positions"),
        ({"teeth": (18,), "centres": TRI[:1]}, r"teeth must hold at least 2"),
        ({"teeth": (18, 36, 5)}, r"teeth\[2\] must be an integer in \[7, 250\]"),
        ({"outside": (0,)}, r"outside must hold indices of driven sprockets in \[1, 2\]"),
        ({"outside": (3,)}, r"outside must hold indices of driven sprockets in \[1, 2\]"),
        ({"outside": (1, 1)}, r"outside lists a sprocket twice"),
        ({"take_up_sprocket": 0}, r"take_up_sprocket must be an integer \[1, 2\]"),
        ({"n_links": 93}, r"n_links must be even"),
        ({"n_links": 30}, r"n_links=30 is too few .* use an even n_links >= \d+"),
        ({"centres": ((0, 0), (0.1, 0.0), (0.15, 0.25))}, r"sprockets 0 and 1 overlap"),
        ({"centres": ((0, 0), (0.15, 0.25), (0.3, 0.05))}, r"not run round .* counter-clockwise"),
        (
            {"teeth": (18, 18, 18, 18, 12), "centres": (*SQUARE, (0.2, -0.005)), "outside": (4,)},
            r"span 0 \(from sprocket 0 to 1\) cuts through sprocket 4",
        ),
        (
            {"teeth": (18, 18, 18, 18, 12), "centres": (*SQUARE, (-0.06, 0.2)), "outside": (4,)},
            r"wraps sprocket 4 by 0.6\d*°, less than one tooth \(360°/12 = 30°\)",
        ),
    ],
)
def test_loop_layout_errors(kw, match):
    args = {"teeth": (18, 36, 27), "centres": TRI} | kw
    with pytest.raises(ValueError, match=match):
        jc.scenes.loop_layout(P08, args.pop("teeth"), args.pop("centres"), **args)


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"load_torque": (1.0, 2.0, 3.0)}, r"load_torque must be one value .* \(2 for 3"),
        ({"load_torque": (1.0, -2.0)}, r"load_torque\[1\] must be >= 0 N·m"),
        ({"driven_inertia": (1e-3,)}, r"driven_inertia must be one value"),
        ({"profiles": (jc.ToothProfile.iso606("08B", 18),) * 2}, r"profiles must hold 3"),
        ({"centres": TRI + ((0.5, 0.5),)}, r"centres must be 3 finite axis positions"),
        ({"centre_distance": 0.3}, r"give centres .* or centre_distance .* not both"),
        ({"outside": (0,)}, r"outside must hold indices of driven sprockets"),
        ({"n_links": 77}, r"n_links must be even"),
        ({"centres": None, "outside": (1,)}, r"outside needs centres"),
        ({"centres": None}, r"teeth must hold 2 tooth counts .* give their axes in centres"),
        (
            {"load_torque": (40.0, 40.0), "pretension": 100.0, "settle": True},
            r"no static equilibrium: .* use pretension >= \d",
        ),
    ],
)
def test_drive_errors(kw, match):
    args = {"chain": "08B", "teeth": (18, 36, 27), "centres": TRI, "settle": False} | kw
    with pytest.raises(ValueError, match=match):
        jc.scenes.drive(**modelled(**args))


# ------------------------------------------------------------------- statics and dynamics
RPM, LOADS, PRETENSION = 600.0, (4.0, 3.0), 150.0
TEETH, CENTRES = (18, 36, 27), ((0.0, 0.0), (0.22, 0.03), (0.09, 0.17))
PERIOD = 60 / RPM / TEETH[0]  # one tooth period: every sprocket meshes at this rate
SAVES = jnp.array([1.0, 4.0]) * PERIOD  # window: 3 tooth periods, one after the start


@pytest.fixture(scope="module")
def loop_drive():
    """08B, 18/36/27 teeth, 76 links, 600 rpm, light loads, frictionless joints, settled."""
    return jc.scenes.drive(
        "08B",
        teeth=TEETH,
        centres=CENTRES,
        speed_rpm=RPM,
        load_torque=LOADS,
        pretension=PRETENSION,
        model=jc.scenes.ChainModel(joint_friction=None, link_damping=0.02),
    )


class TorqueIntegral(jc.observers.AbstractIntegralObserver):
    """∫ torque dt of the chain on every sprocket, from t = 0 (an observer of the solve)."""

    def integrand(self, t, y, scene, forces):
        return forces.sprocket_torque

    def value(self, state, t0, t1):
        return state


def _run(scene):
    """Sprocket angles, ∫ sprocket torques dt and the stored energy at the window's ends
    (two solves of one compiled program: t1 is traced)."""
    out = []
    for t1 in SAVES:
        sol = jc.simulate(scene, t1, n_save=2, rtol=1e-5, atol=1e-8, observers=(TorqueIntegral(),))
        e = jc.energy(t1, sol.y1, scene)
        out.append((sol.y1.theta, sol.observed[0], e["kinetic"] + e["elastic"]))
    return [np.stack([np.asarray(o[i]) for o in out]) for i in range(3)]


def test_loop_statics_balanced(loop_drive):
    """The settled start is at rest in balance: every body, every driven sprocket's torque
    equal to its load, the take-up's spans sharing 2·pretension (its push along the
    bisector), and each driven sprocket's load the moment of its span tensions with lever
    arms within the polygon's bounds r·cos(π/z) … r (r the seated rollers' radii)."""
    sc = loop_drive
    y = initial_state(sc)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, sc)
    assert float(jnp.abs(fr.body).max()) < 1e-6 * PRETENSION
    np.testing.assert_allclose(np.asarray(fr.sprocket_torque[1:]), LOADS, rtol=1e-7)
    # span tensions: links between two rollers touching no sprocket, grouped by span
    tension = np.asarray(sc.link_weights @ fr.element_tension)
    free = np.asarray(fr.roller_normal).max(axis=0) < 1e-3
    span_link = free & np.roll(free, -1)
    starts = np.nonzero(span_link & ~np.roll(span_link, 1))[0]
    x = np.asarray(sc.q0[:, :2])
    centres = np.array([np.asarray(s.centre) for s in sc.sprockets])
    spans = {}
    for i in starts:  # span j leaves sprocket j: the one nearest its first roller
        j = int(np.argmin(np.linalg.norm(centres - x[i], axis=1)))
        spans[j] = float(np.median(tension[i : i + 3]))
    assert sorted(spans) == [0, 1, 2]
    m = len(TEETH) - 1  # the take-up: the last sprocket
    np.testing.assert_allclose(spans[m - 1] + spans[m], 2 * PRETENSION, rtol=5e-3)
    normal = np.asarray(fr.roller_normal)
    for k in (1, 2):  # load = T_out·h_out − T_in·h_in, each arm h in [r_min·cos(π/z), r_max]
        r = np.linalg.norm(x[normal[k] > 1e-3] - centres[k], axis=1)
        h_lo, h_hi = r.min() * math.cos(math.pi / TEETH[k]), r.max()
        t_in, t_out = spans[k - 1], spans[k]
        assert t_out * h_lo - t_in * h_hi < LOADS[k - 1] < t_out * h_hi - t_in * h_lo, k


def test_loop_speeds_and_power_balance(loop_drive):
    """Over 3 tooth periods after a settling one: every sprocket's mean speed is ω1·z1/zk
    (within 1 %); the driver's work less the change of stored energy (kinetic + elastic)
    matches the loads' work, Σ load_k·Δθk, within 2 %, and exceeds it (damping only
    dissipates). The mean driver torque so corrected is Σ load_k·z1/zk. Measured: speeds
    within 1.2e-4 and 2.6e-4, balance +0.54 %, torque +0.52 % (over 4 periods: 2.0e-5,
    4.4e-5, +0.51 %, +0.52 %; over 6 periods after 2: 5.4e-5, 5.8e-5, +0.67 %, +0.67 %)."""
    theta, torque_integral, stored = (np.asarray(a) for a in _run(loop_drive))
    dt = float(SAVES[1] - SAVES[0])
    w1 = RPM * 2 * math.pi / 60
    speed = (theta[1] - theta[0]) / dt
    np.testing.assert_allclose(speed, w1 * TEETH[0] / np.array(TEETH), rtol=1e-2)
    driver_work = -w1 * (torque_integral[1, 0] - torque_integral[0, 0])
    load_work = float(np.dot(LOADS, theta[1, 1:] - theta[0, 1:]))
    balance = (driver_work - (stored[1] - stored[0])) / load_work - 1
    assert 0 < balance < 0.02, balance
    mean_torque = (driver_work - (stored[1] - stored[0])) / (w1 * dt)
    expected = sum(ld * TEETH[0] / z for ld, z in zip(LOADS, TEETH[1:], strict=True))
    np.testing.assert_allclose(mean_torque, expected, rtol=0.02)
