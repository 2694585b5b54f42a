"""Chain-drive dynamics checked against independent truth: polygonal action, speed ratio,
static tension, energy balance, action = reaction, self-convergence; failures as values."""

import math

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import energy_balance_error, tooth_period


@pytest.fixture(scope="module")
def slow_engagement():
    """z = 9 (strong polygonal action) at 300 rpm: quasi-static span kinematics."""
    return jc.scenes.engagement("08B", 9, speed_rpm=300, wrap=4, n_entry=8, n_exit=3)


@pytest.fixture(scope="module")
def small_drive():
    return jc.scenes.drive(
        "08B", teeth=(9, 18), n_links=40, speed_rpm=600, load_torque=10.0, pretension=300.0
    )


def test_polygonal_action(slow_engagement):
    """Span speed = ωR·cos φ, φ sweeping ±π/z as the polygon turns: it fluctuates at the
    tooth-passing frequency with relative amplitude 1 − cos(π/z) (6.03 % for z = 9). The
    closed form is the ideal hinge chain's: the joints frictionless (with the joints'
    friction the filtered amplitude measures 4.87 %)."""
    sc = eqx.tree_at(lambda s: s.joint_friction, slow_engagement, None)
    z, T = 9, tooth_period(300, 9)
    sol = jc.simulate(sc, 3 * T, n_save=3001)
    dirn = np.asarray(sc.anchors.direction[0])
    # the entry span's roller next to the far end, speed along the span towards the sprocket
    v = -np.asarray(sol.roller_velocity[:, 2]) @ dirn
    ts = np.asarray(sol.ts)
    late = ts >= T  # skip the first tooth period
    # each engagement adds a short impact ringing on top of the kinematics: a running
    # median over ~6 % of a tooth period removes it and keeps the polygonal wave
    from scipy.signal import medfilt

    width = 2 * (len(ts) // 3 // 32) + 1
    # medfilt pads with zeros: the last half window is biased low, drop it
    keep = late & (np.arange(len(ts)) < len(ts) - width // 2)
    vv = medfilt(v, width)[keep]
    amplitude = (vv.max() - vv.min()) / vv.max()
    expected = 1 - math.cos(math.pi / z)
    assert abs(amplitude / expected - 1) < 0.15, (amplitude, expected)
    # mean speed is the polygon's z·p·ω/2π, and the fluctuation's period is one tooth
    omega = 300 * 2 * math.pi / 60
    np.testing.assert_allclose(vv.mean(), z * 0.0127 * omega / (2 * math.pi), rtol=0.01)
    spec = np.abs(np.fft.rfft(vv - vv.mean()))
    freqs = np.fft.rfftfreq(len(vv), ts[1] - ts[0])
    assert abs(freqs[np.argmax(spec)] * T - 1) < 0.25


def test_drive_speed_ratio_and_tight_span_tension(small_drive):
    """Mean ω2/ω1 = z1/z2 over whole tooth periods; the tight span carries the load torque
    over the pitch radius plus the slack span's tension (quasi-steady running)."""
    sc = small_drive
    T = tooth_period(600, 9)
    sol = jc.simulate(sc, 4 * T, n_save=801)
    ts = np.asarray(sol.ts)
    win = ts >= T  # three whole driver tooth periods
    w = np.asarray(sol.sprocket_speed)[win]
    np.testing.assert_allclose(w[:, 1].mean() / w[:, 0].mean(), 9 / 18, rtol=0.01)
    # span links: tension averaged over the window; tight = top span (drawn into the driver)
    tension = np.asarray(sol.link_tension)[win].mean(axis=0)
    x = np.asarray(sol.roller_position)[win].mean(axis=0)
    r1 = float(sc.sprockets[0].profile.pitch_radius)
    c2 = float(sc.sprockets[1].centre[0])
    span = (x[:, 0] > r1 + 0.01) & (x[:, 0] < c2 - 0.05)
    top, bottom = span & (x[:, 1] > 0), span & (x[:, 1] < 0)
    t_tight, t_slack = tension[top].mean(), tension[bottom].mean()
    r2 = float(sc.sprockets[1].profile.pitch_radius)
    np.testing.assert_allclose(t_tight - t_slack, 10.0 / r2, rtol=0.05)
    # (their sum is not the take-up's 2 × 300 N once running: with the centres fixed, the
    # loop length the two polygons demand varies with their phase, strongly for z1 = 9)
    assert t_slack > 0


def test_static_equilibrium_of_drive(small_drive):
    """The settled start: every body in force balance, tight/slack tensions from statics,
    driver torque = load · z1/z2."""
    sc = small_drive
    y = initial_state(sc)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, sc)
    assert float(jnp.max(jnp.abs(fr.body))) < 1e-3
    np.testing.assert_allclose(float(fr.sprocket_torque[1]), 10.0, rtol=1e-6)
    # the chain as a whole is in equilibrium: moments of the sprockets' reactions about the
    # driver's axis cancel (torques plus the driven axis force's moment)
    c2 = np.asarray(sc.sprockets[1].centre)
    f2 = np.asarray(fr.sprocket_force[1])
    moment = float(fr.sprocket_torque[0] + fr.sprocket_torque[1]) + (c2[0] * f2[1] - c2[1] * f2[0])
    assert abs(moment) < 1e-6
    # the driver's torque: tension difference times a lever arm between R1·cos(π/z1)
    # and R1 (a span leaves the polygon at a vertex)
    r1, r2 = (float(s.profile.pitch_radius) for s in sc.sprockets)
    tau1 = -float(fr.sprocket_torque[0])
    dt_lo, dt_hi = 10.0 / r2, 10.0 / (r2 * math.cos(math.pi / 18))
    assert dt_lo * r1 * math.cos(math.pi / 9) <= tau1 <= dt_hi * r1


def test_worn_chain_rides_higher_and_moves_the_take_up(small_drive):
    """A chain worn 2 % longer on the same sprockets (``elongation``): still a static
    equilibrium carrying the load; its rollers ride up the gaps, the highest by the worn
    polygon's radius gain Δp/(2 sin(π/z)); the longer loop moves the take-up out by at
    most half the extra length and at least that less the wraps' extra half-circumference."""
    e, z1, z2 = 0.02, 9, 18
    worn = jc.scenes.drive(
        "08B",
        teeth=(z1, z2),
        n_links=40,
        speed_rpm=600,
        load_torque=10.0,
        pretension=300.0,
        model=jc.scenes.ChainModel(elongation=e),
    )
    y = initial_state(worn)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, worn)
    assert float(jnp.max(jnp.abs(fr.body))) < 1e-3
    np.testing.assert_allclose(float(fr.sprocket_torque[1]), 10.0, rtol=1e-6)
    p = jc.ChainSpec.iso606("08B").pitch
    gain = [e * p / (2 * math.sin(math.pi / z)) for z in (z1, z2)]

    def rise(sc, k):
        x = np.asarray(initial_state(sc).q[:, :2]) - np.asarray(sc.sprockets[k].centre)
        r = np.hypot(*x.T) - float(sc.sprockets[k].profile.pitch_radius)
        return r[r < 2e-3]  # the rollers on the wrap

    for k in (0, 1):
        new, old = rise(worn, k), rise(small_drive, k)
        assert len(new) == len(old)
        np.testing.assert_allclose(new.max() - old.max(), gain[k], rtol=0.25)
        assert 0.5 * gain[k] < new.mean() - old.mean() < gain[k]
    extra = 40 * e * p
    dc = float(worn.sprockets[1].centre[0] - small_drive.sprockets[1].centre[0])
    assert extra / 2 - math.pi * sum(gain) / 2 < dc < extra / 2


def test_internal_forces_cancel(small_drive):
    """Action = reaction: at any state, the forces on all bodies and on all sprocket axes sum
    to zero (force and moment), since every element acts between two of them."""
    sc = small_drive
    y = initial_state(sc)
    key = jax.random.PRNGKey(0)
    q = y.q.at[:, :2].add(2e-5 * jax.random.normal(key, y.q[:, :2].shape))
    y = y._replace(q=q)
    fr = forces(0.0, y, sc)
    total = jnp.sum(fr.body[:, :2], 0) + jnp.sum(fr.sprocket_force, 0)
    assert float(jnp.max(jnp.abs(total))) < 1e-8 * float(jnp.max(jnp.abs(fr.body)))


def test_sprockets_of_different_teeth_in_one_vmapped_contact(small_drive):
    """The roller contacts of all sprockets are one vmapped evaluation (tooth shapes
    stacked, the tooth count an array): each sprocket's normal forces and torque equal a
    direct evaluation of its own profile (9 and 18 teeth), every roller checked."""
    from jaxchain._profiles.contact import gap_contact

    sc = small_drive
    y = initial_state(sc)
    key = jax.random.PRNGKey(1)
    y = y._replace(q=y.q.at[:, :2].add(2e-5 * jax.random.normal(key, y.q[:, :2].shape)))
    fr = forces(0.0, y, sc)
    xr = y.q[sc.roller_body, :2]  # rollers sit on their bodies' origins here
    assert float(jnp.max(jnp.abs(sc.roller_offset))) == 0.0
    vr = y.v[sc.roller_body, :2]

    @eqx.filter_jit  # one sprocket at a time, by hand (one program for both sprockets)
    def direct(profile, centre, theta, omega):
        c, s = jnp.cos(theta), jnp.sin(theta)
        rel = xr - centre
        local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
        depth, nl = jax.vmap(gap_contact, in_axes=(None, 0))(profile, local)
        nrm = jnp.stack([c * nl[:, 0] - s * nl[:, 1], s * nl[:, 0] + c * nl[:, 1]], -1)
        arm = rel - sc.roller_radius * nrm
        vrel = vr - omega * jnp.stack([-arm[:, 1], arm[:, 0]], -1)
        fn = sc.roller_law.normal_force(depth, -jnp.sum(nrm * vrel, -1), sc.impact_speed)
        torque = jnp.sum(arm[:, 0] * -fn * nrm[:, 1] - arm[:, 1] * -fn * nrm[:, 0])
        return fn, torque

    for k, spr in enumerate(sc.sprockets):
        fn, torque = direct(spr.profile, spr.centre, y.theta[k], y.omega[k])
        assert int(jnp.sum(fn > 1.0)) >= 1  # the check sees real contacts on both
        # the field's vmapped evaluation and this one agree to round-off (measured 6e-12
        # relative on a 512 N contact)
        np.testing.assert_allclose(fr.roller_normal[k], fn, rtol=1e-10, atol=1e-9)
        if sc.friction is None:
            np.testing.assert_allclose(fr.sprocket_torque[k], torque, rtol=1e-10)


def test_energy_balance_without_dissipation():
    """Restitution 1, undamped links, frictionless joints, no load: kinetic + elastic (links and
    contact potentials) changes exactly by the driver's work ∫ −τ_chain·ω1 dt."""
    sc = jc.scenes.drive(
        "08B",
        teeth=(9, 18),
        n_links=40,
        speed_rpm=600,
        load_torque=0.0,
        pretension=300.0,
        model=jc.scenes.ChainModel(restitution=1.0, link_damping=0.0, joint_friction=None),
    )
    err, scale = energy_balance_error(sc, 0.5 * tooth_period(600, 9), 4001)
    assert scale > 1e-2  # the driver does work (J)
    assert err < 1e-3, err  # measured 1.8e-4 (trapezoidal work integral)


def test_scene_validation():
    with pytest.raises(ValueError, match="speed_rpm must be > 0"):
        jc.scenes.drive(speed_rpm=0.0, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="load_torque must be >= 0"):
        jc.scenes.drive(load_torque=-1.0, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="even"):
        jc.scenes.drive(n_links=101, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="centre"):
        jc.scenes.drive(centre_distance=0.05, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="tension must be > 0"):
        jc.scenes.engagement(tension=0.0, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="fidelity"):
        jc.scenes.drive(fidelity="exact", model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="pretension >= "):  # the slack span would push
        jc.scenes.drive(teeth=(12, 24), n_links=40, load_torque=20.0, pretension=200.0)
    # a profile cut for another chain (10B on an 08B strand) would put rollers into teeth
    other = jc.ToothProfile.iso606(jc.ChainSpec.iso606("10B"), 18)
    with pytest.raises(ValueError, match=r"profile has pitch 15.88 mm but chain 08B has 12.7"):
        jc.scenes.engagement("08B", 18, profile=other, model=jc.scenes.ChainModel(settle=False))
    mine = jc.ToothProfile.iso606(jc.ChainSpec.iso606("08B"), 36)
    with pytest.raises(ValueError, match=r"profiles\[0\] has roller_diameter"):
        jc.scenes.drive(
            "08B", (18, 36), profiles=(jc.ToothProfile.iso606(jc.ChainSpec.iso606("08A"), 18), mine)
        )


@pytest.mark.parametrize("ratio", [0.5, 1.0, 2.0])
def test_history_free_damping_restitution(ratio):
    """Scenes use history-free damping: the law's impact speed is the scene's fixed
    reference speed v_ref, so an impact at speed v sees χ(e)·v/v_ref and rebounds with the
    closed-form e*(χ·v/v_ref) — e exactly at v_ref, livelier below it, deader above."""
    law = jc.scenes.roller_law(jc.ChainSpec.iso606("08B"), restitution=0.7)
    v_ref, m = 1.0, 0.01
    v0 = ratio * v_ref

    def field(t, y, args):
        x, v = y  # x = depth, v = depth rate
        return v, -law.normal_force(x, v, v_ref) / m

    w = float(law.width)
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Tsit5(),
        0.0,
        2e-4,
        1e-8,
        (jnp.asarray(-1.01 * w), jnp.asarray(v0)),
        stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-14),
        max_steps=100_000,
    )
    e_measured = -float(sol.ys[1][-1]) / v0
    chi = float(law.damping_factor()) * v0 / np.sqrt(v_ref**2 + float(law.speed_floor) ** 2)
    np.testing.assert_allclose(e_measured, jc.contact.hysteresis_restitution(chi), atol=1e-6)
