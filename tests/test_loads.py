"""Loads on driven sprockets (``jc.loads``): the harmonic load's formula, the statics
holding a load at its start value, the energy balance counting the loads' work, and a load
defined in this file alone."""

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import FREE_DRIVE, energy_balance_error, modelled, tooth_period

CAM = jc.loads.Harmonic(2.0, harmonics=((2, 1.5, 0.4), (4, 0.5, -1.0)))
# a dissipation-free 9/18 drive whose driven sprocket carries the harmonic load
FREE = FREE_DRIVE


def test_harmonic_formula_and_mean():
    angle = jnp.linspace(0.0, 2 * math.pi, 7)
    want = 2.0 + 1.5 * np.sin(2 * angle + 0.4) + 0.5 * np.sin(4 * angle - 1.0)
    np.testing.assert_allclose(jax.vmap(lambda a: CAM.torque(0.0, a, 1.0))(angle), want)
    assert float(CAM.mean_torque) == 2.0
    # the amplitudes and phases are differentiable leaves
    g = jax.grad(lambda h: h.torque(0.0, 0.3, 0.0))(CAM)
    np.testing.assert_allclose(g.amplitudes, [np.sin(0.6 + 0.4), np.sin(1.2 - 1.0)])
    assert float(jc.loads.Ramped(5.0, 2.0).torque(1.0, 0.0, 0.0)) == pytest.approx(2.5)
    assert float(jc.loads.Constant(3.0).torque(9.0, 1.0, 2.0)) == 3.0


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: jc.loads.Harmonic(1.0, ((0.0, 1.0, 0.0),)), "every order must be > 0"),
        (lambda: jc.loads.Harmonic(1.0, ((2, 1.0),)), r"must be \(order, amplitude, phase\)"),
        (lambda: jc.loads.Harmonic(float("nan")), "mean must be finite"),
        (lambda: jc.loads.Ramped(1.0, -1.0), "duration must be >= 0 s"),
        (lambda: jc.scenes.drive(load_torque=jc.contact.CoulombFriction(0.1)), "jc.loads load"),
        (
            lambda: jc.scenes.drive(load_torque=CAM, model=jc.scenes.ChainModel(load_ramp=0.1)),
            "load_ramp applies to a number",
        ),
        (
            lambda: jc.scenes.drive(
                teeth=(18, 36, 27),
                centres=((0.0, 0.0), (0.22, 0.03), (0.09, 0.17)),
                load_torque=(CAM, 1.0),
                model=jc.scenes.ChainModel(load_ramp=0.1),
            ),
            "load_ramp applies to a number",
        ),
    ],
)
def test_bad_loads_refused(make, match):
    with pytest.raises((ValueError, TypeError), match=match):
        make()


@pytest.fixture(scope="module")
def cam_drive():
    return jc.scenes.drive("08B", **modelled(load_torque=CAM, **FREE))


def test_camshaft_torque_is_the_valve_trains_torque():
    """``camshaft_torque``: its harmonics are the valve springs' torque F·dh/dφ summed over
    the lobes (checked here against the spring's potential: the torque is d/dφ of the
    springs' energy); the springs' work over a turn is zero, so the mean is the friction;
    the lobe frequency is the 2nd engine order (4th of the camshaft); inertia unloads the
    springs at speed."""
    lift, dur, f0, k = 8e-3, 240.0, 200.0, 30e3
    cam = jc.loads.camshaft_torque(
        lift=lift, duration_deg=dur, preload=f0, rate=k, mass=0.0, friction=1.2, orders=12
    )
    np.testing.assert_allclose(cam.orders, 4.0 * np.arange(1, 13))
    assert float(cam.mean_torque) == pytest.approx(1.2, abs=1e-4)  # the springs: no net work
    # the springs' energy E(φ) = Σ lobes (f0·h + k·h²/2) · 2 valves; τ = dE/dφ
    phi = np.linspace(0.0, 2 * np.pi, 721)
    width = np.radians(dur) / 2

    def energy(p):
        x = np.mod(p[:, None] - 2 * np.pi * np.arange(4) / 4, 2 * np.pi)
        h = np.where(x < width, lift * np.sin(np.pi * x / width) ** 2, 0.0)
        return 2 * np.sum(f0 * h + 0.5 * k * h * h, axis=1)

    d = 1e-6
    want = (energy(phi + d) - energy(phi - d)) / (2 * d) + 1.2
    got = jax.vmap(lambda a: cam.torque(0.0, a, 0.0))(jnp.asarray(phi))
    # 12 harmonics of a lobe with a jump in its acceleration: within 2 % of the swing
    assert np.max(np.abs(got - want)) < 0.02 * np.ptp(want)
    assert 10.0 < np.ptp(want) < 40.0
    slow = jc.loads.camshaft_torque(engine_rpm=0.0)
    fast = jc.loads.camshaft_torque(engine_rpm=6000.0)
    assert float(fast.amplitudes[0]) < float(slow.amplitudes[0])
    with pytest.raises(ValueError, match="duration_deg"):
        jc.loads.camshaft_torque(duration_deg=800.0)
    with pytest.raises(ValueError, match="lift must be > 0 m"):
        jc.loads.camshaft_torque(lift=0.0)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(phase_deg=float("nan")), ValueError, "phase_deg must be a finite number"),
        (dict(engine_rpm=-0.5), ValueError, r"engine_rpm must be >= 0 rpm"),
        (dict(friction=float("inf")), ValueError, "friction must be a finite number"),
        (dict(mass=-1e-3), ValueError, "mass must be >= 0 kg"),
        (dict(duration_deg=720.0), ValueError, r"duration_deg must be < 720"),
        (dict(cylinders=0), ValueError, "cylinders must be an integer >= 1"),
        (dict(valves=2.0), TypeError, "valves must be an integer"),
        (dict(orders=True), TypeError, "orders must be an integer"),
        (dict(cylinders=8, orders=200), ValueError, r"highest camshaft order kept\) must be"),
        (dict(lift="8 mm"), TypeError, "lift must be a real number"),
    ],
)
def test_camshaft_torque_refuses_bad_input(kwargs, error, match):
    with pytest.raises(error, match=match):
        jc.loads.camshaft_torque(**kwargs)


def test_harmonic_refuses_an_array_where_a_number_belongs():
    with pytest.raises(ValueError, match=r"harmonics\[0\]'s amplitude must be a scalar"):
        jc.loads.Harmonic(1.0, ((2, np.array([1.0, 2.0]), 0.0),))
    with pytest.raises(ValueError, match=r"harmonics\[1\]'s phase must be a scalar"):
        jc.loads.Harmonic(1.0, ((2, 1.0, 0.0), (4, 1.0, np.zeros(3))))


def test_statics_hold_the_load_at_its_start_value(cam_drive):
    """At the settled start the chain's torque on the driven sprocket equals the harmonic
    load at angle 0: 2 + 1.5 sin 0.4 + 0.5 sin(−1)."""
    y = initial_state(cam_drive)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    held = 2.0 + 1.5 * math.sin(0.4) + 0.5 * math.sin(-1.0)
    assert float(cam_drive.sprockets[1].load(0.0)) == pytest.approx(held)
    torque = float(forces(0.0, y, cam_drive).sprocket_torque[1])
    assert torque == pytest.approx(held, rel=1e-6)


def test_energy_balance_counts_the_load_work(cam_drive):
    """Without dissipation the stored energy changes by the driver's work less the work
    the harmonic load takes out (which is most of the driver's work here)."""
    err, scale = energy_balance_error(cam_drive, 0.5 * tooth_period(600, 9), 2001)
    assert scale > 1e-2
    assert err < 1e-3, err


class Viscous(jc.loads.AbstractLoad):
    """A load of this file alone: a torque proportional to the speed (a fan, a pump)."""

    coefficient: jax.Array

    def __init__(self, coefficient):
        self.coefficient = jnp.asarray(coefficient, dtype=float)

    def torque(self, t, angle, speed):
        return self.coefficient * speed


def test_user_defined_load():
    """A load subclassed in this file drives the dynamics, the statics and the load-work
    observer, with no change anywhere else: its work matches ∫ c·ω² dt from the saved
    speeds."""
    load = Viscous(0.05)  # N·m per rad/s: 1.57 N·m at the driven sprocket's 31.4 rad/s
    scene = jc.scenes.drive("08B", **modelled(load_torque=load, **FREE))
    spr = scene.sprockets[1]
    assert isinstance(spr.torque_load, Viscous)
    assert float(spr.load(0.0)) == pytest.approx(0.05 * float(spr.speed))
    t1 = tooth_period(600, 9)
    sol = jc.simulate(scene, t1, n_save=2001, observers=(jc.observers.LoadWork(),))
    work = np.asarray(sol.observed[0])
    omega = np.asarray(sol.sprocket_speed[:, 1])
    ts = np.asarray(sol.ts)
    want = np.sum(0.5 * (0.05 * omega[1:] ** 2 + 0.05 * omega[:-1] ** 2) * np.diff(ts))
    assert work[0] == 0.0
    assert work[1] == pytest.approx(want, rel=1e-4)  # the trapezoid rule's error: 1.4e-6


def test_load_counts_in_the_running_direction():
    """A sprocket running clockwise (sense −1) sees its own angle and speed positive; its
    load resists clockwise rotation, a negative torque against counter-clockwise."""
    prof = jc.ToothProfile.iso606("08B", 18)
    cw = jc.Sprocket(prof, [0.0, 0.0], -3.0, load_torque=Viscous(0.05), driven=True, sense=-1)
    assert float(cw.load(0.0)) == pytest.approx(-0.15)
    cam = jc.Sprocket(prof, [0.0, 0.0], -3.0, load_torque=CAM, driven=True, sense=-1, angle0=1.0)
    # turned 0.2 rad clockwise from its start
    assert float(cam.load(0.0, 0.8, -3.0)) == pytest.approx(-float(CAM.torque(0.0, 0.2, 3.0)))
    assert float(cam.load_torque) == -2.0
    again = dataclasses.replace(cam, contact_slots=4)  # a field replaced, the load kept
    assert again.torque_load is cam.torque_load and again.sense == -1
    with pytest.raises(ValueError, match="sense must be"):
        jc.Sprocket(prof, [0.0, 0.0], 1.0, sense=0)


def test_number_loads_stack():
    """Builders turn numbers into one load type whatever the ramp, so such scenes stack."""
    a = jc.scenes.drive(
        "08B", **modelled(load_torque=5.0, **FREE, model=jc.scenes.ChainModel(settle=False))
    )
    b = jc.scenes.drive(
        "08B", **modelled(load_torque=7.0, **FREE, model=jc.scenes.ChainModel(settle=False))
    )
    stacked = jc.scenes.stack([a, b])
    np.testing.assert_allclose(stacked.sprockets[1].load_torque, [5.0, 7.0])
    assert eqx.tree_equal(jax.tree.structure(a), jax.tree.structure(b))
