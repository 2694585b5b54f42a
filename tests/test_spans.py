"""The span-level chain (``fidelity="spans"``): statics and speed ratios in closed form,
the torques are the span lines' moment arms (virtual work: AD of the stretch), the energy
balance closes, its design gradient matches central differences, and what it does not
model is refused with the fix."""

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state
from jaxchain._elements.spans import scaled_curve

from helpers import energy_balance_error, modelled

CHAIN = jc.ChainSpec.iso606("08B")
ISO18, ISO36 = jc.ToothProfile.iso606(CHAIN, 18), jc.ToothProfile.iso606(CHAIN, 36)


def oval(amplitude=1e-3, phase=0.3):
    return jc.FreeformProfile.noncircular(ISO18, ((2, amplitude, phase),))


@pytest.fixture(scope="module")
def round_drive():
    return jc.scenes.drive(
        CHAIN, teeth=(18, 36), speed_rpm=1000, load_torque=20.0, pretension=200.0,
        fidelity="spans",
    )  # fmt: skip


def test_statics_and_speed_ratio_of_round_sprockets(round_drive):
    """At rest the spans carry the statics: tight − slack = load·2π/(z₂p) (the chain's
    effective radius), tight + slack = 2·pretension, and the torques balance; running,
    the mean speed ratio is z₁/z₂ exactly and the tensions stay."""
    y = initial_state(round_drive)
    fr = forces(0.0, y, round_drive)
    slack, tight = np.asarray(fr.element_tension)
    r2 = 36 * CHAIN.pitch / (2 * math.pi)
    np.testing.assert_allclose(tight - slack, 20.0 / r2, rtol=1e-9)
    np.testing.assert_allclose(tight + slack, 400.0, rtol=1e-9)
    np.testing.assert_allclose(fr.sprocket_torque, [-10.0, 20.0], rtol=1e-9)
    sol = jc.simulate(round_drive, 0.12, n_save=201)
    assert sol.ok, sol.message
    w = np.asarray(sol.sprocket_speed)
    np.testing.assert_allclose(w[:, 1].mean() / w[:, 0].mean(), 0.5, rtol=1e-5)
    np.testing.assert_allclose(np.asarray(sol.link_tension).mean(0), [slack, tight], rtol=1e-3)
    np.testing.assert_array_equal(sol.span_tension, sol.link_tension)  # (T, 2): the spans


def test_torques_are_the_span_lines_moment_arms():
    """∂e_j/∂θ of the stretch (AD through the tangent-line Newton and the arc length) is
    the span line's moment arm about each end's axis (−s·h at its start, +s·h at its end):
    the chain's force acts along the line."""
    scene = jc.scenes.drive(
        CHAIN, teeth=(18, 36, 27), centres=((0.0, 0.0), (0.3, 0.05), (0.1, 0.25)),
        profiles=(oval(), ISO36, jc.ToothProfile.iso606(CHAIN, 27)), outside=(2,),
        load_torque=(10.0, 0.0), pretension=300.0, fidelity="spans",
    )  # fmt: skip
    el = scene.added[0]
    centres = jnp.stack([s.centre for s in scene.sprockets])

    @jax.jit
    def both(el, theta):
        jac = jax.jacfwd(lambda t: el.stretch(t, centres))(theta)
        _, _, arms, _ = el.geometry(theta, centres)
        rows = jnp.arange(3)
        analytic = jnp.zeros((3, 3)).at[rows, el.start].add(-el.sense[el.start] * arms[:, 0])
        return jac, analytic.at[rows, el.end].add(el.sense[el.end] * arms[:, 1])

    for theta in ([0.3, -0.2, 0.1], [1.7, 2.9, -4.0]):
        jac, analytic = both(el, jnp.asarray(theta))
        np.testing.assert_allclose(jac, analytic, atol=1e-12)
    # an idler outside the loop turns the other way, at z₁/z₃ of the driver's speed
    assert float(scene.sprockets[2].speed) == pytest.approx(
        -float(scene.sprockets[0].speed) * 18 / 27
    )


def tensioned(**kw):
    """A two-sprocket span-level drive with a tensioner on the slack span (span 0)."""
    args = dict(
        teeth=(18, 36), centres=((0.0, 0.0), (0.33, 0.0)), speed_rpm=1000, load_torque=20.0,
        pretension=200.0, tensioner=jc.scenes.Tensioner(span=0, damping=0.5), fidelity="spans",
    )  # fmt: skip
    return jc.scenes.drive(CHAIN, **modelled(**args | kw))


def test_the_tensioner_shoe_is_laid_out_as_in_the_lumped_chain():
    """Same arguments, same tensioner: its pivot, preload and spring are the lumped
    chain's (the shoe laid out as an idler on the chain's back, ``n_links`` setting how far
    it pushes); at the start the spans carry the statics (the tensioner's span the
    pretension) and the arm is balanced; ∂e/∂ψ (AD through the three tangent lines and
    the wrap) is the shoe's lever (t_in − t_out)·∂c/∂ψ."""
    spans = tensioned()
    lumped = jc.scenes.drive(
        CHAIN,
        teeth=(18, 36),
        centres=((0.0, 0.0), (0.33, 0.0)),
        load_torque=20.0,
        pretension=200.0,
        tensioner=jc.scenes.Tensioner(span=0, damping=0.5),
        model=jc.scenes.ChainModel(settle=False),
    )
    for name in ("pivot", "layout_angle", "preload", "stiffness", "inertia", "damping"):
        np.testing.assert_allclose(
            getattr(spans.tensioners, name), getattr(lumped.tensioners, name), rtol=1e-12
        )
    y = initial_state(spans)
    fr = forces(0.0, y, spans)
    slack, tight = np.asarray(fr.element_tension)
    np.testing.assert_allclose(slack, 200.0, rtol=1e-9)
    np.testing.assert_allclose(tight - slack, 20.0 / (36 * CHAIN.pitch / (2 * math.pi)), rtol=1e-9)
    assert abs(float(fr.dof_force[0])) < 2e-3 * float(spans.tensioners.preload[0])
    el = spans.added[0]
    centres = jnp.stack([s.centre for s in spans.sprockets])
    for theta, arm in (([0.0, 0.0], 0.0), ([0.7, -0.2], 0.01)):
        theta, arm = jnp.asarray(theta), y.dof + arm
        jac = jax.jacfwd(el.stretch, argnums=2)(theta, centres, arm)
        lever = el.geometry(theta, centres, arm).shoe_lever
        np.testing.assert_allclose(jac[:, 0], [float(lever[0]), 0.0], atol=1e-12)


def test_energy_balance_closes_with_a_tensioner():
    """Undamped, an oval crank, a harmonic load and a tensioner: Δ(stored energy: the
    spans' stretch, the arm's spring and motion, the driven sprocket's) = driver work −
    load work, to the work integral's quadrature error."""
    scene = tensioned(
        profiles=(oval(), ISO36), load_torque=jc.loads.Harmonic(10.0, ((2, 4.0, 0.0),)),
        tensioner=jc.scenes.Tensioner(span=0), link_damping=0.0,
    )  # fmt: skip
    err, scale = energy_balance_error(scene, 0.01, 4001)
    assert scale > 0.05
    assert err < 1e-4, err


def test_the_span_element_is_differentiable_in_the_pitch_curve():
    """The torque on the driven sprocket at angles away from the start, as a function of
    the crank's 2nd-order pitch-curve coefficient (through the arc length's series, the
    tangent lines' Newton and the moment arms): AD = central differences. (Through the
    pitch polygon and a solve: the slow test below and ``benchmarks.spans``.)"""
    base = jc.scenes.drive(
        CHAIN, teeth=(18, 36), profiles=(oval(), ISO36), load_torque=20.0, pretension=200.0,
        fidelity="spans",
    )  # fmt: skip
    el = base.added[0]
    centres = jnp.stack([s.centre for s in base.sprockets])
    theta, omega = jnp.asarray([0.4, 0.15]), jnp.asarray([100.0, 50.0])
    perimeter = jnp.asarray([18 * CHAIN.pitch, 36 * CHAIN.pitch])

    @jax.jit
    def torque(c):
        coef = el.coefficients.at[0, 3].add(c)  # a₂ of the crank
        curves = jax.vmap(scaled_curve)(coef, perimeter)
        spans = dataclasses.replace(
            el, coefficients=curves[0], arc_mean=curves[1][0], arc_cos=curves[1][1],
            arc_sin=curves[1][2],
        )  # fmt: skip
        return spans.tensions(theta, omega, centres)[1][1]

    h = 1e-7
    ad = float(jax.grad(torque)(0.0))
    fd = (float(torque(h)) - float(torque(-h))) / (2 * h)
    assert abs(ad) > 1.0
    np.testing.assert_allclose(ad, fd, rtol=1e-6)


@pytest.mark.slow
def test_design_gradient_matches_central_differences():
    """d/dA of the tight span's mean squared tension over the last 5 of 10 revolutions (A:
    the crank's 2nd-order pitch-curve amplitude, traced through the pitch polygon, the
    curve fit and the span element), fixed steps (``n_steps``: the objective is jitted):
    AD = central differences."""
    base = jc.scenes.drive(
        CHAIN, teeth=(18, 36), profiles=(oval(), ISO36), speed_rpm=2000, load_torque=20.0,
        pretension=200.0, fidelity="spans",
    )  # fmt: skip
    el = base.added[0]
    centres = jnp.stack([s.centre for s in base.sprockets])
    zero = jnp.zeros(2)
    tension0 = el.tensions(zero, zero, centres)[0]
    length = el.geometry(zero, centres)[0]
    ea, ca = float((el.stiffness * length)[0]), float((el.damping * length)[0])
    rev = 60.0 / 2000
    ts = rev * (5 + jnp.arange(180) / 36)

    @jax.jit
    def objective(a):
        spans = jc.scenes.span_element((oval(a), ISO36), centres, el.sense, tension0, ea, ca)
        scene = eqx.tree_at(lambda s: s.added[0], base, spans)
        sol = jc.simulate(scene, 10 * rev, ts=ts, n_steps=15_000, throw=False)
        return jnp.mean(sol.link_tension[:, 1] ** 2)

    # over 10 revolutions J bends on the scale of 1 % of A: h = 1e-3·A leaves central
    # differences 8e-4 off, 1e-5·A 2e-6 off (measured)
    a0, h = 1e-3, 1e-8
    ad = float(jax.grad(objective)(a0))
    fd = (float(objective(a0 + h)) - float(objective(a0 - h))) / (2 * h)
    assert abs(ad) > 0
    np.testing.assert_allclose(ad, fd, rtol=2e-5)


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(n_links=80), "does not model n_links without a tensioner"),
        (dict(gravity=9.81), "does not model gravity"),
        (dict(centre_distance=0.08), "overlap"),
        (dict(load_torque=100.0, pretension=10.0), "no static equilibrium"),
        # what only a chain of links and rollers uses: refused, not dropped
        (dict(restitution=0.5), "does not use restitution"),
        (dict(joint_friction=None), "does not use joint_friction"),
        (dict(impact_speed=2.0, settle=False), "does not use impact_speed, settle"),
        (dict(roller_contact=jc.scenes.roller_law("08B", 0.7)), "does not use roller_contact"),
        (dict(friction=jc.contact.CoulombFriction(0.1, 1e-2)), "does not use friction.*lumped"),
    ],
)
def test_what_the_span_model_does_not_model_is_refused(kw, message):
    with pytest.raises(ValueError, match=message):
        jc.scenes.drive(CHAIN, **modelled(teeth=(18, 36), fidelity="spans", **kw))


def test_guides_are_checked_and_change_nothing():
    """A guide lies along its straight span, which the span model never moves across: the
    scene is the one without it; a guide on a span the drive has not is refused."""
    kw = dict(teeth=(18, 36), load_torque=20.0, fidelity="spans")
    plain = jc.scenes.drive(CHAIN, **modelled(**kw))
    guided = jc.scenes.drive(CHAIN, **modelled(guides=(jc.scenes.Guide(span=1, length=0.1),), **kw))
    same = jax.tree.map(lambda a, b: bool(np.array_equal(a, b)), plain, guided)
    assert all(jax.tree.leaves(same))
    with pytest.raises(ValueError, match="Guide.span"):
        jc.scenes.drive(CHAIN, **modelled(guides=(jc.scenes.Guide(span=2),), **kw))


def test_the_engagement_strand_has_no_span_fidelity():
    with pytest.raises(ValueError, match="no rollers"):
        jc.scenes.engagement(CHAIN, 18, fidelity="spans")


def test_every_fidelity_gives_span_tensions():
    """``span_tension`` of the lumped chain's settled start: the free spans carry the
    statics (tight − slack = load/R₂, their sum the take-up's 2·pretension); a strand has
    no spans."""
    from jaxchain._dynamics import outputs

    scene = jc.scenes.drive(CHAIN, teeth=(18, 36), n_links=80, load_torque=20.0, pretension=200.0)
    out = jax.jit(outputs)(0.0, initial_state(scene), scene)
    slack, tight = np.asarray(out["span_tension"])
    np.testing.assert_allclose(tight - slack, 20.0 / float(ISO36.pitch_radius), rtol=0.02)
    np.testing.assert_allclose(tight + slack, 400.0, rtol=0.02)


def test_observers_of_roller_forces_are_refused_on_the_span_model():
    """The span model has no rollers: an observer that reads roller/tooth forces is
    refused with the fix (alone or inside a penalty), not run to a zero."""
    scene = jc.scenes.drive(CHAIN, teeth=(18, 36), fidelity="spans")
    with pytest.raises(ValueError, match="EngagementPeaks read.*no rollers.*'lumped'"):
        jc.observers.EngagementPeaks.for_solve(scene, 0.01)
    with pytest.raises(ValueError, match="simulate: PeakRecord read"):
        jc.simulate(scene, 1e-4, observers=(jc.observers.PeakRecord(),))
    with pytest.raises(ValueError, match="soft_peak_force: SoftPeak read"):
        jc.design.soft_peak_force(scene, 1e-4, dt=1e-5)
    soft = jc.observers.SoftPeak(0.0, 1e-5, 50.0, 0.0)
    speed = jc.observers.SpeedVariation(0.1, 1.0)
    penalized = jc.design.Penalized(speed, soft, limit=1e3)
    with pytest.raises(ValueError, match="Penalized read"):
        jc.design.observe(scene, 1e-4, penalized, dt=1e-5)


@pytest.mark.slow
def test_the_span_model_follows_the_lumped_chain():
    """README and docs/figures.md: an oval crank's (0.2 mm of 2nd order) tight-span 2nd
    order and driven-speed 2nd order on the span-level chain within 10 % and 1 % of the
    lumped chain's at 1000 rpm, as benchmarks/spans.py compares them (four revolutions
    from the statics, the last three analysed; the study: +9.4 % and +0.8 %)."""
    from benchmarks.spans import compare

    r = compare(1000.0, 2e-4)
    lumped, spans = r["lumped"], r["spans"]
    assert lumped["ok"] and spans["ok"]
    order2 = spans["tight_order2_N"] / lumped["tight_order2_N"] - 1
    speed = spans["driven_speed_order2_rad_s"] / lumped["driven_speed_order2_rad_s"] - 1
    assert abs(order2) < 0.10 and abs(speed) < 0.01, (order2, speed)
