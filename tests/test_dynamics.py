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
from jaxchain._dynamics import energy, forces, initial_state

from helpers import brute_parabola_max, count_vector_field_calls, fixed_step_joints


def period(rpm, z):
    return 60.0 / rpm / z


@pytest.fixture(scope="module")
def slow_engagement():
    """z = 9 (strong polygonal action) at 300 rpm: quasi-static span kinematics."""
    return jc.scenes.engagement("08B", 9, speed_rpm=300, wrap=4, n_entry=8, n_exit=3)


@pytest.fixture(scope="module")
def engagement18():
    return jc.scenes.engagement("08B", 18, speed_rpm=1000, n_entry=8)


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
    z, T = 9, period(300, 9)
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
    T = period(600, 9)
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


@pytest.mark.xdist_group("dynamics-clearance")
@pytest.mark.parametrize("rollers", ["joint", "lumped"])
def test_clearance_drive_settles(rollers):
    """The clearance drive (pin/bush free play on every joint, and with ``"joint"`` the
    rollers' free play on their bushes too) starts in static equilibrium: every body
    balanced, the driven sprocket carrying its load, the spans tensioned by the take-up
    (tight − slack = load/R2, their mean the pretension) and nothing moved by a pitch."""
    kw = dict(
        teeth=(12, 24),
        n_links=40,
        load_torque=10.0,
        pretension=200.0,
        fidelity="clearance",
        rollers_on_bush=rollers,
    )
    sc = jc.scenes.drive("08B", **kw)
    y = initial_state(sc)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, sc)
    force_scale = 10.0 / float(sc.sprockets[1].profile.pitch_radius)  # the largest applied
    assert float(jnp.max(jnp.abs(fr.body[:, :2]))) <= 1e-6 * force_scale
    np.testing.assert_allclose(float(fr.sprocket_torque[1]), 10.0, rtol=1e-6)
    # every pin/bush joint carries tension; spans: tight − slack = load / R2
    layout = jc.scenes.drive("08B", **kw, settle=False)
    moved = np.abs(np.asarray(sc.q0[:, :2] - layout.q0[:, :2])).max()
    assert moved < 0.1 * 0.0127
    tension = np.asarray(fr.element_tension)
    assert tension.min() > 0
    x = np.asarray(sc.q0[: sc.n_links, :2])
    r1 = float(sc.sprockets[0].profile.pitch_radius)
    c2 = float(sc.sprockets[1].centre[0])
    span = (x[:, 0] > r1 + 0.01) & (x[:, 0] < c2 - 0.03)
    link_t = np.asarray(sc.link_weights) @ tension
    top, bottom = span & (x[:, 1] > 0), span & (x[:, 1] < 0)
    r2 = float(sc.sprockets[1].profile.pitch_radius)
    np.testing.assert_allclose(link_t[top].mean() - link_t[bottom].mean(), 10.0 / r2, rtol=0.02)
    np.testing.assert_allclose(0.5 * (link_t[top].mean() + link_t[bottom].mean()), 200.0, rtol=0.05)


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
    from jaxchain._gap import gap_contact

    sc = small_drive
    y = initial_state(sc)
    key = jax.random.PRNGKey(1)
    y = y._replace(q=y.q.at[:, :2].add(2e-5 * jax.random.normal(key, y.q[:, :2].shape)))
    fr = forces(0.0, y, sc)
    xr = y.q[sc.roller_body, :2]  # rollers sit on their bodies' origins here
    assert float(jnp.max(jnp.abs(sc.roller_offset))) == 0.0
    vr = y.v[sc.roller_body, :2]
    for k, spr in enumerate(sc.sprockets):
        c, s = jnp.cos(y.theta[k]), jnp.sin(y.theta[k])
        rel = xr - spr.centre
        local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
        depth, nl = jax.vmap(gap_contact, in_axes=(None, 0))(spr.profile, local)
        nrm = jnp.stack([c * nl[:, 0] - s * nl[:, 1], s * nl[:, 0] + c * nl[:, 1]], -1)
        arm = rel - sc.roller_radius * nrm
        vrel = vr - y.omega[k] * jnp.stack([-arm[:, 1], arm[:, 0]], -1)
        fn = sc.roller_law.normal_force(depth, -jnp.sum(nrm * vrel, -1), sc.impact_speed)
        assert int(jnp.sum(fn > 1.0)) >= 1  # the check sees real contacts on both
        np.testing.assert_allclose(fr.roller_normal[k], fn, rtol=1e-12, atol=1e-9)
        torque = jnp.sum(arm[:, 0] * -fn * nrm[:, 1] - arm[:, 1] * -fn * nrm[:, 0])
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
        restitution=1.0,
        link_damping=0.0,
        joint_friction=None,
    )
    t1 = 0.5 * period(600, 9)
    ts = jnp.linspace(0.0, t1, 4001)
    dsol = diffrax.diffeqsolve(
        diffrax.ODETerm(jc.vector_field),
        diffrax.Tsit5(),
        0.0,
        t1,
        None,
        initial_state(sc),
        args=sc,
        saveat=diffrax.SaveAt(ts=ts),
        stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-13),
        max_steps=500_000,
    )
    # jitted: an eager vmap over 4001 states dispatches (and batches) op by op
    e, torque = jax.jit(
        jax.vmap(lambda t, y: (energy(t, y, sc), forces(t, y, sc).sprocket_torque[0]))
    )(ts, dsol.ys)
    total = np.asarray(e["kinetic"] + e["elastic"])
    power = -np.asarray(torque) * float(sc.sprockets[0].speed)
    dt = float(ts[1] - ts[0])
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * dt)])
    scale = np.abs(work).max()
    assert scale > 1e-2  # the driver does work (J)
    err = np.abs((total - total[0]) - work).max() / scale
    assert err < 1e-3, err  # measured 1.8e-4 (trapezoidal work integral)


@pytest.mark.xdist_group("dynamics-engagement")
def test_peak_force_self_converges(engagement18):
    """Peak roller/tooth force as the tolerance tightens, against rtol 1e-9: rtol 1e-8
    within 0.05 %, the default 1e-6 within 0.1 %, 1e-4 within 1 % (measured +0.008 %,
    −0.005 %, +0.42 %). The step ends alone would miss the top of the impact by −0.28 % to
    −0.84 % at the default, depending on where ~1800 step ends fall on it."""
    T = period(1000, 18)
    peaks = {
        rtol: float(
            jc.simulate(engagement18, 2 * T, rtol=rtol, atol=rtol * 1e-3).peak_contact_force
        )
        for rtol in (1e-4, 1e-6, 1e-8, 1e-9)
    }
    ref = peaks[1e-9]
    assert abs(peaks[1e-8] - ref) < 5e-4 * ref
    assert abs(peaks[1e-6] - ref) < 1e-3 * ref
    assert abs(peaks[1e-4] - ref) < 1e-2 * ref


@pytest.mark.xdist_group("dynamics-engagement")
def test_peak_record_is_the_top_of_parabolas_through_quarter_step_samples(engagement18):
    """With fixed steps the recorded peak is the largest top of the parabolas through each
    step's consecutive samples at quarter steps (dense-output states), read back
    independently by saving at those times and maximizing each parabola by brute force.
    At this step (4.1 µs, through the first meshing impact, whose force rises over ~5 µs)
    the samples alone are 0.29 % below the top of this solve's own dense output (the
    best of them falls on a step end), the parabolas 0.14 % above (the pulse is
    lopsided); measured with the joints' friction (frictionless: samples 0.53 % below,
    parabolas 0.12 % above, step ends alone 5 % below)."""
    dt, n = 4.1e-6, 1000
    fixed = dict(solver=diffrax.Tsit5(), stepsize_controller=diffrax.ConstantStepSize(), dt0=dt)
    engagement18 = eqx.tree_at(lambda s: s.joint_friction.law, engagement18, fixed_step_joints())
    k = jc.observers.PeakRecord().samples
    # saving at the samples' own times adds only values the step tops already bound
    quarter = jc.simulate(engagement18, n * dt, ts=dt * np.arange(k * n + 1) / k, **fixed)
    f = np.asarray(quarter.roller_sprocket_force)  # (k n + 1, R)
    # each consecutive triple's parabola, maximized on its own span by brute force,
    # (k n - 1, R): triples centred on sample 1 … k n - 1
    tops = brute_parabola_max(f[:-2], f[1:-1], f[2:])
    inside = np.arange(1, k * n) % k != 0  # ... but never across a step's end
    recorded = float(quarter.peak_contact_force)
    np.testing.assert_allclose(recorded, tops[inside].max(), rtol=1e-8)
    # the top of this solve's dense output, on 4001 times across the best step
    j = int(np.argmax(tops[inside].max(axis=1)))
    step = np.flatnonzero(inside)[j] // k  # the step holding that triple's centre
    fine = jc.simulate(engagement18, n * dt, ts=dt * (step + np.linspace(0, 1, k * n + 1)), **fixed)
    top = float(np.asarray(fine.roller_sprocket_force).max())
    samples = f.max()
    assert abs(recorded / top - 1) < 2e-3
    assert top - samples > 1.5 * abs(top - recorded)
    assert recorded >= samples  # never below the samples


@pytest.mark.xdist_group("dynamics-engagement")
def test_engagement_starts_in_equilibrium(engagement18):
    """Settled start: the anchors pull with exactly their tensions, rollers are seated (in
    contact) on the wrap, and the first tooth period has no start-up shock."""
    sc = engagement18
    fr = forces(0.0, initial_state(sc), sc)  # moving: transport velocities, guides moving
    # what is left is damping from the transport velocities' polygonal mismatch, and the
    # friction of the joints articulating where the spans meet the wrap (running, not a
    # shock): at most μ·T·r/p per link end, 17 N at 1000 N, on each of a joint's links
    frictionless = eqx.tree_at(lambda s: s.joint_friction, sc, None)
    rest = forces(0.0, initial_state(sc), frictionless)
    assert float(jnp.max(jnp.abs(rest.body))) < 0.02 * 1000.0
    couple = 0.1 * 1000.0 * jc.ChainSpec.iso606("08B").pin_diameter / 2 / 0.0127
    assert float(jnp.max(jnp.abs(fr.body - rest.body))) < 3 * couple
    tension = np.asarray(fr.element_tension)
    np.testing.assert_allclose(tension[0], 1000.0, rtol=0.02)
    np.testing.assert_allclose(tension[-1], 100.0, rtol=0.05)
    assert int(jnp.sum(fr.roller_normal > 1.0)) >= 3


@pytest.mark.xdist_group("dynamics-engagement")
def test_failures_are_values(engagement18):
    """Bad options are refused before anything is traced; failed solves come back as
    result codes (every failure mode, on a strand small enough to compile quickly, and the
    same codes from the design objective's solve: tests/test_failures.py)."""
    T = period(1000, 18)
    with pytest.raises(ValueError, match="dt0"):
        jc.simulate(engagement18, T, stepsize_controller=diffrax.ConstantStepSize())
    with pytest.raises(ValueError, match="t1 must be > t0"):
        jc.simulate(engagement18, 0.0)


@pytest.mark.xdist_group("dynamics-engagement")
def test_second_call_does_not_retrace(engagement18, monkeypatch):
    calls = count_vector_field_calls(monkeypatch)
    T = period(1000, 18)
    sc2 = jax.tree_util.tree_map(lambda x: x, engagement18)
    sc2 = __import__("equinox").tree_at(lambda s: s.sprockets[0].speed, sc2, jnp.asarray(110.0))
    # (weakly typed on purpose: simulate canonicalizes dtypes so this does not retrace)
    # default options: the solve test_peak_force_self_converges compiles
    jc.simulate(engagement18, 0.2 * T)
    n = len(calls)
    jc.simulate(sc2, 0.3 * T)  # new speed, new t1: same structure
    assert len(calls) == n


def test_scene_validation():
    with pytest.raises(ValueError, match="speed_rpm must be > 0"):
        jc.scenes.drive(speed_rpm=0.0, settle=False)
    with pytest.raises(ValueError, match="load_torque must be >= 0"):
        jc.scenes.drive(load_torque=-1.0, settle=False)
    with pytest.raises(ValueError, match="even"):
        jc.scenes.drive(n_links=101, settle=False)
    with pytest.raises(ValueError, match="centre"):
        jc.scenes.drive(centre_distance=0.05, settle=False)
    with pytest.raises(ValueError, match="tension must be > 0"):
        jc.scenes.engagement(tension=0.0, settle=False)
    with pytest.raises(ValueError, match="fidelity"):
        jc.scenes.drive(fidelity="exact", settle=False)
    with pytest.raises(ValueError, match="pretension >= "):  # the slack span would push
        jc.scenes.drive(teeth=(12, 24), n_links=40, load_torque=20.0, pretension=200.0)
    # a profile cut for another chain (10B on an 08B strand) would put rollers into teeth
    other = jc.ToothProfile.iso606(jc.ChainSpec.iso606("10B"), 18)
    with pytest.raises(ValueError, match=r"profile has pitch 15.88 mm but chain 08B has 12.7"):
        jc.scenes.engagement("08B", 18, profile=other, settle=False)
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


def _with_slots(scene, slots):
    import dataclasses

    import equinox as eqx

    sprockets = tuple(
        dataclasses.replace(s, contact_slots=n) for s, n in zip(scene.sprockets, slots, strict=True)
    )
    return eqx.tree_at(lambda sc: sc.sprockets, scene, sprockets)


@pytest.mark.xdist_group("dynamics-engagement")
def test_contact_slots_are_exact_and_checked(engagement18):
    """Checking only the nearest rollers changes nothing (the others' force is exactly 0);
    too few slots is reported, not silently wrong."""
    T = period(1000, 18)
    # every roller checked is the scene as built (the solve test_peak_force_self_converges
    # compiles: default options)
    assert engagement18.sprockets[0].contact_slots is None
    b = jc.simulate(engagement18, T)
    # the forces with 12 slots and with every roller, at the start, at the end of a tooth
    # period, and with the teeth turned a quarter and a half gap under the rollers (the
    # field, not a solve: one compile less, the same claim at every state a solve visits)
    y0 = initial_state(engagement18)
    turned = [
        y._replace(theta=y.theta + f * 2 * math.pi / 18) for y in (y0, b.y1) for f in (0, 0.25, 0.5)
    ]
    ys = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *turned)
    field = jax.jit(jax.vmap(lambda y, sc: forces(0.0, y, sc), in_axes=(0, None)))
    few, every = field(ys, _with_slots(engagement18, [12])), field(ys, engagement18)
    assert float(jnp.max(every.roller_normal)) > 100.0  # rollers are in contact
    np.testing.assert_array_equal(few.roller_normal, every.roller_normal)
    np.testing.assert_allclose(few.body, every.body, rtol=0, atol=1e-9)
    bad = jc.simulate(_with_slots(engagement18, [3]), T, throw=False)
    assert bad.result == jc.Result.contact_slots_exceeded
    assert "contact_slots" in bad.message


@pytest.mark.xdist_group("dynamics-clearance")
def test_clearance_fidelity_balances_and_runs():
    """Clearance model (rigid links, pin/bush and bush/roller joints): every joint and
    contact force has its reaction, a short solve of the engagement succeeds, and the
    strand settles by default (dynamic relaxation: the joints fall into contact)."""
    sc = jc.scenes.engagement("08B", 18, speed_rpm=1000, n_entry=6, fidelity="clearance")
    assert sc.fidelity == "clearance" and sc.n_bodies == 2 * sc.n_rollers - 1
    sol = jc.simulate(sc, 0.5 * period(1000, 18), n_save=51)
    assert sol.ok and float(sol.peak_contact_force) > 100.0
    # action = reaction at the layout (settling is test_clearance_drive_settles')
    drive = jc.scenes.drive("08B", teeth=(12, 24), n_links=40, fidelity="clearance", settle=False)
    y = initial_state(drive)
    fr = forces(0.0, y, drive)
    total = jnp.sum(fr.body[:, :2], 0) + jnp.sum(fr.sprocket_force, 0)
    assert float(jnp.max(jnp.abs(total))) <= 1e-8 * max(1.0, float(jnp.max(jnp.abs(fr.body))))
