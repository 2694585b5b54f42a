"""Order-domain observers (mesh-order lines, band level, chordal speed variation) against
quadratures of the saved trajectory, and design objectives built on them: gradients
through the solve against central differences over a per-gap design space, the
constrained (penalized) form, member combination, no retrace."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain.design import DesignSpace, Penalized, ProfileObjective
from jaxchain.observers import BandLevel, OrderSpectrum, SoftPeak, SpeedVariation

from helpers import (
    count_objective_traces,
    count_vector_field_calls,
    fixed_step_joints,
    own_program_store,
)

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = 60.0 / (Z * RPM)
REV = 60.0 / RPM


def hann(x, a, b):
    u = np.clip((x - a) / (b - a), 0.0, 1.0)
    return np.sin(np.pi * u) ** 2


def quadrature_lines(ts, signal, angle, angle0, orders, start, end):
    """The lines from the saved signal and reference angle (trapezoid rule)."""
    w = hann(np.abs(angle - angle0) / (2 * np.pi), start, end)
    gain = np.trapezoid(w, ts)
    out = []
    for n in orders:
        c = np.trapezoid(w * signal * np.cos(n * angle), ts)
        s = np.trapezoid(w * signal * np.sin(n * angle), ts)
        out.append((1.0 if n == 0 else 2.0) * math.hypot(c, s) / gain)
    return np.array(out)


def test_order_lines_of_a_known_signal():
    """OrderSpectrum's integrand and value on a prescribed torque with known lines,
    s = m + Σ a_n·cos(nφ + c_n), over whole revolutions of the reference (Hann window):
    each chosen order reads its amplitude (the mean for order 0), an absent order reads
    nothing, at any constant speed; BandLevel is the lines' log-sum-exp in dB, between
    the largest line and τ·log(n) above it; the bearing signal reads the force's
    magnitude."""
    from types import SimpleNamespace

    lines = {0: 20.0, 18: 1.6, 36: 1.3, 19: 0.05}
    w0 = 80.0
    t = np.linspace(0.0, 3.0 * 2 * np.pi / w0, 300_001)
    phi = w0 * t
    torque = sum(a * np.cos(n * phi + 0.3 * n) for n, a in lines.items())
    orders = np.array([0.0, 17.0, 18.0, 19.0, 36.0])
    spectrum = OrderSpectrum(orders, 0.5, 2.5, signal="torque")
    band = BandLevel([18.0, 19.0, 36.0], 0.5, 2.5, temperature=0.5)
    bearing = OrderSpectrum([0.0], 0.5, 2.5, signal="bearing")
    scene = SimpleNamespace(sprockets=(SimpleNamespace(angle0=0.0),))

    def integrals(obs, force):
        rate = jax.vmap(
            lambda ti, th, tq, f: obs.integrand(
                ti,
                SimpleNamespace(theta=th[None]),
                scene,
                SimpleNamespace(sprocket_torque=tq[None], sprocket_force=f[None]),
            )  # fmt: skip
        )(jnp.asarray(t), jnp.asarray(phi), jnp.asarray(torque), force)
        return np.trapezoid(np.asarray(rate), t, axis=0)

    force = jnp.stack([3.0 + 0 * t, 4.0 + 0 * t], -1)  # |F| = 5 N
    got = np.asarray(spectrum.value(jnp.asarray(integrals(spectrum, force)), 0.0, t[-1]))
    want = np.array([lines.get(int(n), 0.0) for n in orders])
    np.testing.assert_allclose(got, want, atol=1e-9)  # measured 2e-12
    level = float(band.value(jnp.asarray(integrals(band, force)), 0.0, t[-1]))
    top = 20 * math.log10(1.6)
    assert top - 1e-6 <= level <= top + 0.5 * math.log(3) + 1e-6
    mean_force = float(bearing.value(jnp.asarray(integrals(bearing, force)), 0.0, t[-1])[0])
    assert abs(mean_force - 5.0) < 1e-6


@pytest.mark.slow
def test_order_lines_match_a_quadrature_of_the_saved_torque():
    """OrderSpectrum's running Fourier integrals (inside the solve, under error control)
    against the trapezoid rule on the saved driver torque every 1.1 µs; BandLevel is their
    log-sum-exp in dB, never below the largest line and at most τ·log(n) above."""
    scene = jc.scenes.engagement(CHAIN, Z, speed_rpm=RPM, n_entry=4)
    t1 = 3 * PERIOD
    start, end = 1 / Z, 3 / Z  # revolutions of the driver
    orders = np.array([0.0, 6.0, 18.0, 27.0, 36.0, 54.0])
    spectrum = OrderSpectrum(orders, start, end, signal="torque")
    band = BandLevel.mesh_band(Z, start, end, temperature=0.5)
    ts = np.linspace(0.0, t1, 3001)
    sol = jc.simulate(scene, t1, ts=ts, rtol=1e-8, observers=(spectrum, band))
    lines = np.asarray(sol.observed[0])
    angle = np.asarray(sol.sprocket_angle[:, 0])
    ref = quadrature_lines(
        ts, np.asarray(sol.sprocket_torque[:, 0]), angle, float(scene.sprockets[0].angle0),
        orders, start, end,
    )  # fmt: skip
    # measured: largest difference 3e-6 of the mean torque (the save spacing's error)
    print("lines", np.abs(lines - ref).max() / ref[0])
    np.testing.assert_allclose(lines, ref, rtol=0, atol=1e-4 * ref[0])
    assert ref[0] > 10.0  # a real torque: the strand's tension difference × pitch radius
    every = OrderSpectrum(band.orders, start, end, signal="torque")
    level = float(sol.observed[1])
    assert np.array_equal(np.asarray(band.orders), np.arange(9, 64))  # 0.5–3.5 mesh orders
    # the band level against the lines, recomputed from the same quadrature
    quad = 20 * np.log10(
        quadrature_lines(
            ts, np.asarray(sol.sprocket_torque[:, 0]), angle,
            float(scene.sprockets[0].angle0), np.asarray(every.orders), start, end,
        )
    )  # fmt: skip
    assert quad.max() - 1e-3 <= level <= quad.max() + 0.5 * math.log(quad.size) + 1e-3


def test_speed_variation_of_a_sinusoidal_speed_is_its_rms():
    """SpeedVariation's integrand and value on a prescribed speed ω = ω0·(1 + a·sin(nφ)),
    φ the reference's angle: the Hann-weighted RMS about the mean over whole periods is
    a/√2 of the mean (closed form), whatever the speed it starts from."""
    from types import SimpleNamespace

    w0, a, n = 100.0, 0.01, 9.0
    obs = SpeedVariation(0.1, 2.1, sprocket=1, reference=0)
    t = np.linspace(0.0, 2.2 * 2 * np.pi / w0, 200_001)
    phi = w0 * t
    omega = w0 * (1 + a * np.sin(n * phi))
    scene = SimpleNamespace(
        sprockets=(SimpleNamespace(angle0=0.0, speed=w0), SimpleNamespace(speed=1.02 * w0))
    )
    ys = SimpleNamespace(theta=jnp.stack([phi, 0 * phi], -1), omega=jnp.stack([0 * t, omega], -1))
    rate = jax.vmap(
        lambda ti, th, om: obs.integrand(ti, SimpleNamespace(theta=th, omega=om), scene, None)
    )(jnp.asarray(t), ys.theta, ys.omega)
    state = np.trapezoid(np.asarray(rate), t, axis=0)
    value = float(obs.value(jnp.asarray(state), 0.0, t[-1]))
    assert abs(value - a / math.sqrt(2)) < 1e-9 * a, value  # measured 3.5e-14 of a


@pytest.mark.slow
def test_speed_variation_matches_a_quadrature_of_the_saved_speed():
    """SpeedVariation of a driven sprocket: RMS of its speed about the Hann-weighted mean,
    relative to that mean, against the saved speed; its bearing force and torque lines
    are finite and the torque's mean is the load (the driven sprocket turns steadily)."""
    drive = jc.scenes.drive(
        CHAIN, teeth=(12, 24), n_links=40, speed_rpm=RPM, load_torque=10.0, pretension=200.0
    )
    start, end = 0.1, 0.4  # driver revolutions
    t1 = 0.42 * REV
    ts = np.linspace(0.0, t1, 12001)
    chordal = SpeedVariation(start, end, sprocket=1)
    torque = OrderSpectrum([0.0, 12.0], start, end, signal="torque", sprocket=1, reference=0)
    bearing = OrderSpectrum([0.0, 12.0], start, end, signal="bearing", sprocket=1, reference=0)
    sol = jc.simulate(drive, t1, ts=ts, rtol=1e-7, observers=(chordal, torque, bearing))
    speed = np.asarray(sol.sprocket_speed[:, 1])
    angle = np.asarray(sol.sprocket_angle[:, 0])
    w = hann(np.abs(angle - float(drive.sprockets[0].angle0)) / (2 * np.pi), start, end)
    mean = np.trapezoid(w * speed, ts) / np.trapezoid(w, ts)
    rms = math.sqrt(np.trapezoid(w * (speed - mean) ** 2, ts) / np.trapezoid(w, ts))
    # measured: 0.0101577 both, relative difference 1.8e-8
    assert abs(float(sol.observed[0]) - rms / mean) < 1e-4 * rms / mean
    assert 1e-3 < rms / mean < 0.05  # chordal action of a 12-tooth driver: about 1 %
    # the driven sprocket carries its load on average (quasi-steady)
    assert abs(float(sol.observed[1][0]) - 10.0) < 0.5
    assert np.all(np.isfinite(np.asarray(sol.observed[2])))
    assert float(sol.observed[2][0]) > 2 * 200.0 * 0.5  # both spans pull on its axis


def test_order_observers_refuse_bad_input():
    with pytest.raises(ValueError, match="end"):
        OrderSpectrum([18.0], 1.0, 0.5)
    with pytest.raises(ValueError, match="orders"):
        OrderSpectrum([-1.0], 0.0, 1.0)
    with pytest.raises(ValueError, match="signal"):
        OrderSpectrum([18.0], 0.0, 1.0, signal="noise")
    with pytest.raises(ValueError, match="temperature"):
        BandLevel([18.0], 0.0, 1.0, temperature=0.0)
    with pytest.raises(ValueError, match="no integer order"):
        BandLevel.mesh_band(18, 0.0, 1.0, band=(0.51, 0.52))
    with pytest.raises(TypeError, match="observers"):
        jc.simulate(
            jc.scenes.engagement(CHAIN, Z, n_entry=2, model=jc.scenes.ChainModel(settle=False)),
            1e-4,
            observers=(1,),
        )
    with pytest.raises(TypeError, match="integral observer"):
        Penalized(BandLevel([18.0], 0.0, 1.0), "peak", limit=1.0)
    scene = jc.scenes.engagement(CHAIN, Z, n_entry=2, model=jc.scenes.ChainModel(settle=False))
    with pytest.raises(ValueError, match="sprocket=1 but the scene has 1"):
        jc.simulate(scene, 1e-4, observers=(SpeedVariation(0.0, 0.01, sprocket=1),))


# ---------------------------------------------------------------- design on order objectives
LAW = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)
JOINTS = fixed_step_joints()


def _build(profile, rpm=RPM):
    return jc.scenes.engagement(
        CHAIN,
        Z,
        speed_rpm=rpm,
        profile=profile,
        n_entry=3,
        model=jc.scenes.ChainModel(roller_contact=LAW, joint_friction=JOINTS),
    )


def _per_gap_space():
    """36 coordinates: each gap's seating radius and its clockwise seat angle."""
    iso = jc.ToothProfile.iso606(CHAIN, Z, "mid")
    tooth = jc.FreeformProfile.from_iso(iso, 1)
    ri, a = float(iso.seating_radius), float(iso.seating_angle) / 2
    ones = np.ones(Z)
    return DesignSpace.select(
        tooth,
        {
            "seating_radius": (ri - 20e-6 * ones, ri + 20e-6 * ones),
            "cw.seat_angle": ((a - 0.05) * ones, (a + 0.05) * ones),
        },
    )


def test_band_level_design_gradient_matches_central_differences(monkeypatch, tmp_path):
    """The quiet-drive objective's form: the band level [dB] penalized by the soft peak
    force above a limit, over a 36-coordinate per-gap space, soft maximum of two speeds.
    Reverse mode through the fixed-step solve and the implicit statics against central
    differences of the same objective along random directions (scenes held at the base
    point, as the gradient sees them); the points after the first do not retrace (new
    scenes at a new point: ``test_design.py::test_second_call_does_not_retrace``)."""
    space = _per_gap_space()
    assert space.size == 36
    start, end = 1 / Z, 2 / Z
    objective = Penalized(
        BandLevel.mesh_band(Z, start, end, temperature=0.5),
        SoftPeak(t_start=PERIOD, rise=0.1 * PERIOD, temperature=50.0, reference=1500.0),
        limit=1200.0,
        weight=0.01,
        width=20.0,
    )
    obj = ProfileObjective(
        space,
        lambda p: [_build(p, RPM), _build(p, 1.2 * RPM)],
        t1=2 * PERIOD,
        objective=objective,
        combine=jc.design.SoftMax(0.5),
        dt=4e-6,
    )
    rng = np.random.default_rng(3)
    u = jnp.asarray(rng.normal(0.0, 0.5, 36))
    scenes = obj.scenes(u)
    value, grad, members = obj.value_and_grad_on(u, scenes)
    assert np.all(np.isfinite(np.asarray(grad)))
    assert set(jc.result_names(members.result)) == {"successful"}
    # the members' soft maximum lies between their largest and largest + τ·log 2 ... − τ·log 2
    vals = np.asarray(members.value)
    assert vals.max() - 0.5 * math.log(2) - 1e-9 <= float(value) <= vals.max() + 1e-9
    scale = float(jnp.linalg.norm(grad))
    h = 1e-5
    d = rng.normal(size=36)  # a random direction: every coordinate's derivative enters
    d /= np.linalg.norm(d)
    calls = count_vector_field_calls(monkeypatch)
    members = count_objective_traces(monkeypatch)
    own_program_store(monkeypatch, tmp_path)  # where a retraced program cannot hide
    # (the values from the compiled value-and-gradient: one compile, not two)
    hi = obj.value_and_grad_on(u + h * d, scenes)[0]
    lo = obj.value_and_grad_on(u - h * d, scenes)[0]
    assert len(calls) == len(members) == 0
    fd = (float(hi) - float(lo)) / (2 * h)
    err = abs(float(jnp.dot(grad, d)) - fd) / scale
    assert err < 1e-4, err  # measured: 5.7e-8 (value 35.0 dB, |∇J| 0.21)
