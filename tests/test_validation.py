"""Nothing wrong passes as a result: a table of bad inputs to the public API, each with the
error it must raise before anything is traced (naming the argument, what is wrong and the
valid range), and NaN in → NaN out for the functions that take numbers.

Run-time failures (result codes) are tested in ``test_failures.py``; the command line's
user errors in ``test_main_job.py``.
"""

import dataclasses
import math

import diffrax
import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain.design import DesignSpace, ProfileObjective, soft_peak_force, window_weight

from helpers import modelled

NAN, INF = float("nan"), float("inf")
CHAIN = jc.ChainSpec.iso606("08B")
PROFILE = jc.ToothProfile.iso606(CHAIN, 18)
SPACE = DesignSpace.iso606(CHAIN, 18)
LO, HI = np.asarray(SPACE.lower), np.asarray(SPACE.upper)
# a strand from its layout (no statics): building it is cheap, and nothing below solves it
SCENE = jc.scenes.engagement(
    "08B", 18, n_entry=3, n_exit=2, wrap=9, model=jc.scenes.ChainModel(settle=False)
)
STACKED = jc.scenes.stack([SCENE, SCENE])
Y0 = jc.initial_state(SCENE)
PERIOD = 60.0 / (18 * 1000.0)


def engagement(**kw):
    return jc.scenes.engagement(**modelled(**dict(chain="08B", teeth=18, settle=False) | kw))


def drive(**kw):
    return jc.scenes.drive(
        **modelled(**dict(chain="08B", teeth=(9, 18), n_links=30, settle=False) | kw)
    )


def objective(**kw):
    args = dict(t1=2 * PERIOD, t_start=PERIOD, dt=4e-6) | kw
    return ProfileObjective(SPACE, args.pop("build", lambda p: SCENE), **args)


def with_q(q):
    return Y0._replace(q=q)


BAD = [
    # ---------------------------------------------------------------- scene builders
    (lambda: engagement(chain=8), TypeError, "chain must be an ISO 606 designation"),
    (lambda: engagement(chain="99Z"), ValueError, "unknown ISO 606 chain '99Z'"),
    (lambda: jc.scenes.engagement("08B", 18.0), TypeError, r"teeth must be an integer in \[7"),
    (lambda: jc.scenes.engagement("08B", 5), ValueError, r"teeth must be an integer in \[7, 250\]"),
    (lambda: engagement(speed_rpm="1000"), TypeError, "speed_rpm must be a real number > 0 rpm"),
    (lambda: engagement(speed_rpm=NAN), ValueError, "speed_rpm must be a finite number > 0"),
    (lambda: engagement(speed_rpm=INF), ValueError, "speed_rpm must be a finite number > 0"),
    (lambda: engagement(speed_rpm=-5.0), ValueError, "speed_rpm must be > 0 rpm, got -5"),
    (lambda: engagement(speed_rpm=[1000, 1100]), TypeError, "speed_rpm must be a real number"),
    (lambda: engagement(speed_rpm=np.array([1e3, 2e3])), TypeError, r"array of shape \(2,\)"),
    (lambda: engagement(speed_rpm=1000 + 0j), TypeError, "speed_rpm must be a real number"),
    (lambda: engagement(tension=True), TypeError, "tension must be a real number > 0 N"),
    (lambda: engagement(tension=0.0), ValueError, "tension must be > 0 N"),
    (
        lambda: engagement(tension=2e4),
        ValueError,
        r"tension is 2e\+04 N, at or above the chain's tensile strength 1.78e\+04 N",
    ),
    (lambda: engagement(slack_tension=NAN), ValueError, "slack_tension must be a finite number"),
    (lambda: engagement(slack_tension=-1.0), ValueError, "slack_tension must be >= 0 N"),
    (lambda: engagement(restitution=0.0), ValueError, r"restitution must be in \(0, 1\]"),
    (lambda: engagement(restitution=np.array([0.7, 0.8])), TypeError, "restitution must be"),
    (
        lambda: engagement(profile="min"),
        TypeError,
        r"profile must be a tooth profile \(jc.ToothProfile, jc.FreeformProfile, any "
        r"jc.AbstractProfile\) or None",
    ),
    (
        lambda: engagement(profile=jc.ToothProfile.iso606("10B", 18)),
        ValueError,
        "profile has pitch 15.88 mm but chain 08B has 12.7 mm",
    ),
    (lambda: engagement(profile=jc.ToothProfile.iso606(CHAIN, 12)), ValueError, "12 teeth"),
    (lambda: engagement(friction=0.1), TypeError, "friction must be a jc.contact.CoulombFriction"),
    (lambda: engagement(impact_speed=0.0), ValueError, "impact_speed must be > 0 m/s"),
    (lambda: engagement(impact_speed=-1.0), ValueError, "impact_speed must be > 0 m/s"),
    (lambda: engagement(rollers_on_bush="foo"), ValueError, "rollers_on_bush must be one of"),
    (lambda: engagement(roller_contact="johnson"), TypeError, "roller_contact must be a normal"),
    (
        lambda: engagement(roller_contact=jc.contact.CoulombFriction()),
        TypeError,
        "roller_contact must be a normal contact law",
    ),
    (lambda: engagement(link_damping=-1.0), ValueError, "link_damping must be >= 0"),
    (lambda: engagement(link_damping=NAN), ValueError, "link_damping must be a finite number"),
    (lambda: engagement(span_stiffness=0.0), ValueError, "span_stiffness must be > 0 N/m"),
    (lambda: engagement(span_stiffness=NAN), ValueError, "span_stiffness must be a finite"),
    (lambda: engagement(settle="no"), TypeError, "settle must be True or False"),
    (lambda: engagement(fidelity="exact"), ValueError, "fidelity must be one of 'lumped'"),
    (lambda: engagement(form="minimum"), ValueError, "form must be one of 'min', 'max', 'mid'"),
    (lambda: engagement(n_entry=0), ValueError, "n_entry must be an integer >= 1"),
    (lambda: drive(teeth=18), TypeError, "teeth must be a sequence of 2 tooth counts"),
    (lambda: drive(teeth=(18,)), ValueError, "teeth must hold 2 tooth counts"),
    (lambda: drive(teeth=(12, 24, 36)), ValueError, r"2 tooth counts \(driver, driven\), got 3"),
    (lambda: drive(teeth=(18, 36.0)), TypeError, r"teeth\[1\] must be an integer"),
    (lambda: drive(profiles=(PROFILE,)), ValueError, "profiles must hold 2 tooth profiles"),
    (lambda: drive(load_torque=NAN), ValueError, "load_torque must be a finite number >= 0"),
    (lambda: drive(load_torque=1e6), ValueError, "at or above the chain's tensile strength"),
    (lambda: drive(pretension=-1.0), ValueError, "pretension must be >= 0 N"),
    (lambda: drive(load_ramp=-1.0), ValueError, "load_ramp must be >= 0 s"),
    (lambda: drive(load_ramp=NAN), ValueError, "load_ramp must be a finite number"),
    (lambda: drive(centre_distance=NAN), ValueError, "centre_distance must be a finite number"),
    (lambda: drive(driven_inertia=0.0), ValueError, "driven_inertia must be > 0 kg·m²"),
    (lambda: drive(speed_rpm=INF), ValueError, "speed_rpm must be a finite number"),
    (lambda: jc.scenes.joint_law(CHAIN, "bush", 0.7), ValueError, "which must be one of 'pin'"),
    (lambda: jc.scenes.roller_law(CHAIN, 0.7, width=-1.0), ValueError, "width must be >= 0 m"),
    (lambda: jc.scenes.roller_law(8, 0.7), TypeError, "chain must be an ISO 606 designation"),
    (lambda: jc.scenes.equilibrate("scene"), TypeError, "scene must be a jaxchain Scene"),
    (lambda: jc.scenes.equilibrate(SCENE, take_up=-100.0), ValueError, "take_up must be >= 0 N"),
    (lambda: jc.scenes.equilibrate(SCENE, take_up=NAN), ValueError, "take_up must be a finite"),
    (lambda: jc.scenes.equilibrate(SCENE, tolerance=0.0), ValueError, "tolerance must be > 0"),
    (lambda: jc.scenes.equilibrate(SCENE, max_steps=0), ValueError, "max_steps must be an int"),
    (lambda: jc.scenes.resettle(SCENE, take_up=-1.0), ValueError, "take_up must be >= 0 N"),
    (lambda: jc.scenes.resettle(SCENE, jacobian=np.eye(3)), ValueError, "jacobian must be"),
    (lambda: jc.scenes.statics_jacobian("scene"), TypeError, "scene must be a jaxchain Scene"),
    # ---------------------------------------------------- chains, profiles, materials, laws
    (lambda: jc.ChainSpec.iso606(8), TypeError, "name must be an ISO 606 designation"),
    (
        lambda: jc.ChainSpec.iso606("08B", material="steel"),
        TypeError,
        "material must be a jc.Material",
    ),
    (
        lambda: dataclasses.replace(CHAIN, pitch=INF),
        ValueError,
        r"ChainSpec.pitch must be > 0 and finite, got inf",
    ),
    (
        lambda: dataclasses.replace(CHAIN, tensile_strength=NAN),
        ValueError,
        "ChainSpec.tensile_strength must be > 0 and finite",
    ),
    (
        lambda: dataclasses.replace(CHAIN, pitch="0.0127"),
        TypeError,
        "ChainSpec.pitch must be a real number",
    ),
    (lambda: jc.Material(density=INF), ValueError, "Material.density must be > 0 kg/m³ and finite"),
    (lambda: jc.Material(youngs_modulus="206e9"), TypeError, "youngs_modulus must be a real"),
    (lambda: jc.Material(poisson_ratio=0.5), ValueError, r"poisson_ratio must be in \(-1, 0.5\)"),
    (lambda: jc.ToothProfile.iso606(CHAIN, 18, "minimum"), ValueError, "form must be 'min'"),
    (lambda: jc.ToothProfile.iso606(8, 18), TypeError, "chain must be an ISO 606 designation"),
    (
        lambda: dataclasses.replace(PROFILE, seating_angle=130.0),
        ValueError,
        "seating_angle must be in .*it is in radians",
    ),
    (
        lambda: jc.contact.LankaraniNikravesh(stiffness=INF, exponent=1.5, restitution=0.7),
        ValueError,
        "LankaraniNikravesh.stiffness must be > 0 and finite",
    ),
    (
        lambda: jc.contact.Gonthier(stiffness=1e10, exponent=1.5, restitution=0.7, width=INF),
        ValueError,
        "Gonthier.width must be >= 0 m and finite",
    ),
    (
        lambda: jc.contact.Flores(stiffness="1e10", exponent=1.5, restitution=0.7),
        TypeError,
        "Flores.stiffness must be a real number",
    ),
    (
        lambda: jc.contact.CoulombFriction(coefficient=INF),
        ValueError,
        "CoulombFriction.coefficient must be >= 0 and finite",
    ),
    (
        lambda: jc.contact.effective_radius(-1e-3, 2e-3),
        ValueError,
        "radius1 must be finite and > 0 m",
    ),
    (
        lambda: jc.contact.hertz_stiffness(2e11, 5e-3, 4e-3, internal=True),
        ValueError,
        r"internal pair needs the hole larger than the cylinder, radius2 > radius1",
    ),
    # ------------------------------------------------------------ points and states
    (lambda: jc.gap_contact("prof", jnp.zeros(2)), TypeError, "profile must be a jc.ToothProfile"),
    (
        lambda: jc.gap_contact(PROFILE, jnp.zeros((5, 2))),
        ValueError,
        r"point must be one roller centre \(x, y\) of shape \(2,\), got shape \(5, 2\); for "
        r"many points use jax.vmap",
    ),
    (lambda: jc.gap_contact(PROFILE, jnp.zeros(3)), ValueError, r"got shape \(3,\)$"),
    (lambda: jc.signed_distance(PROFILE, jnp.zeros((2, 2))), ValueError, "use jax.vmap"),
    (lambda: jc.nearest_gap(PROFILE, jnp.zeros((4, 2))), ValueError, "use jax.vmap"),
    (lambda: jc.vector_field(0.0, Y0.q, SCENE), TypeError, "y must be a jc.DriveState"),
    (
        lambda: jc.vector_field(0.0, with_q(Y0.q[:-1]), SCENE),
        ValueError,
        r"y.q must have shape \(\d+, 3\) for this scene",
    ),
    (
        lambda: jc.vector_field(0.0, with_q(jnp.stack([Y0.q] * 3)), SCENE),
        ValueError,
        "for a batch of states use jax.vmap over y",
    ),
    (lambda: jc.vector_field(0.0, SCENE, Y0), TypeError, "scene must be a jaxchain Scene"),
    (lambda: jc.energy(0.0, with_q(Y0.q[:, :2]), SCENE), ValueError, "y.q must have shape"),
    (lambda: jc.roller_kinematics(Y0.q, SCENE), TypeError, "y must be a jc.DriveState"),
    (lambda: jc.initial_state("scene"), TypeError, "scene must be a jaxchain Scene"),
    (lambda: jc.initial_state(STACKED), ValueError, "the scene is stacked"),
    # ---------------------------------------------------------------- simulate
    (lambda: jc.simulate("scene", 1e-3), TypeError, "simulate: scene must be a jaxchain Scene"),
    (lambda: jc.simulate(STACKED, 1e-3), ValueError, "stacked .*jc.simulate_ensemble"),
    (lambda: jc.simulate(SCENE, 0.0), ValueError, "t1 must be > t0"),
    (lambda: jc.simulate(SCENE, NAN), ValueError, "t0 and t1 must be finite"),
    (lambda: jc.simulate(SCENE, 1e-3, t0=-1e-3), ValueError, "t0 must be 0 s"),
    (lambda: jc.simulate(SCENE, 1.0), ValueError, "past the scene's horizon"),
    (lambda: jc.simulate(SCENE, 1e-3, ts=[2e-3]), ValueError, r"ts must lie within \[t0, t1\]"),
    (lambda: jc.simulate(SCENE, 1e-3, ts=[5e-4, 1e-4]), ValueError, "ts must be non-decreasing"),
    (lambda: jc.simulate(SCENE, 1e-3, ts=[[1e-4]]), ValueError, "ts must be a 1-D array"),
    (lambda: jc.simulate(SCENE, 1e-3, n_save=1), ValueError, "n_save must be an integer >= 2"),
    (lambda: jc.simulate(SCENE, 1e-3, rtol=-1.0), ValueError, r"rtol must be a finite number in"),
    (
        lambda: jc.simulate(SCENE, 1e-3, solver=diffrax.Euler()),
        ValueError,
        "Euler gives no error estimate",
    ),
    (lambda: jc.simulate(SCENE, 1e-3, rtl=1e-6), TypeError, r"unexpected keyword argument"),
    (
        lambda: jc.simulate(eqx.tree_at(lambda s: s.q0, SCENE, SCENE.q0.at[0, 0].set(NAN)), 1e-3),
        ValueError,
        r"simulate: scene.q0 has non-finite values",
    ),
    (lambda: jc.Sprocket("prof", [0.0, 0.0], 100.0), TypeError, "profile must be a jc.Tooth"),
    (lambda: jc.Sprocket(PROFILE, [0.0, 0.0, 0.0], 1.0), ValueError, r"centre must be \(x, y\)"),
    (lambda: jc.Sprocket(PROFILE, [0.0, 0.0], NAN), ValueError, "speed must be finite"),
    (
        lambda: jc.Sprocket(PROFILE, [0.0, 0.0], 1.0, contact_slots=-3),
        ValueError,
        "contact_slots must be an integer >= 1 or None",
    ),
    (lambda: jc.result_names("successful"), TypeError, "result must be a jc.Result"),
    (lambda: jc.effective_modulus(jc.STEEL, "steel"), TypeError, "b must be a jc.Material"),
    (lambda: jc.plot_forces("sol"), TypeError, "plot_forces: sol must be a jc.Solution"),
    (lambda: jc.plot_profiles(CHAIN, 18, gaps=-1), ValueError, r"gaps must be an integer in"),
    # ---------------------------------------------------------------- ensembles
    (lambda: jc.simulate_ensemble([], 1e-3), ValueError, "at least one scene"),
    (lambda: jc.simulate_ensemble([SCENE, "x"], 1e-3), TypeError, "scene 1 is a str"),
    (lambda: jc.simulate_ensemble(SCENE, 1e-3), ValueError, "a list of scenes or a stacked"),
    (
        lambda: jc.simulate_ensemble(STACKED, 1e-3, pilot_rtol=-1.0),
        ValueError,
        r"pilot_rtol must be in \(0, 1\)",
    ),
    (lambda: jc.simulate_ensemble(STACKED, 1.0), ValueError, r"members \[0, 1\] end"),
    # ---------------------------------------------------------------- design
    (lambda: DesignSpace("tmpl", LO, HI), TypeError, "template must be a jc.ToothProfile"),
    (
        lambda: DesignSpace(jc.FreeformProfile.from_iso(jc.ToothProfile.iso606("08B", 18)), LO, HI),
        TypeError,
        "has no .*flank_radius",
    ),
    (lambda: DesignSpace(PROFILE, LO, HI + INF), ValueError, "lower and upper must be finite"),
    (lambda: DesignSpace(PROFILE, LO[:3], HI[:3]), ValueError, r"shape \(4,\)"),
    (
        lambda: DesignSpace(PROFILE, LO * 0.1, HI),
        ValueError,
        "the design box reaches outside valid tooth profiles: .*seating_radius must be in",
    ),
    (lambda: SPACE.profile(jnp.zeros(3)), ValueError, r"u must have shape \(4,\)"),
    (lambda: SPACE.profile(jnp.zeros((2, 4))), ValueError, "use jax.vmap over u"),
    (lambda: SPACE.values(0.0), ValueError, r"u must have shape \(4,\)"),
    (lambda: SPACE.coordinates([1.0, 2.0, 3.0]), ValueError, r"must have shape \(4,\)"),
    (
        lambda: SPACE.coordinates(jc.ToothProfile.iso606(CHAIN, 12)),
        ValueError,
        "not of this design space's sprocket",
    ),
    (lambda: SPACE.coordinates(PROFILE, margin=0.7), ValueError, r"margin must be in \(0, 0.5\)"),
    (lambda: soft_peak_force(SCENE, 1e-3, temperature=0.0), ValueError, "temperature must be > 0"),
    (lambda: soft_peak_force(SCENE, 1e-3, reference=NAN), ValueError, "reference must be a finite"),
    (lambda: soft_peak_force(SCENE, 1e-3, rise=-1e-4), ValueError, "rise must be >= 0 s"),
    (lambda: soft_peak_force(SCENE, 1e-3, t_start=2e-3), ValueError, r"t_start must be in \[0"),
    (lambda: soft_peak_force(SCENE, 1e-3, temperature=[5, 6]), TypeError, "temperature must be"),
    (lambda: soft_peak_force(SCENE, 1.0), ValueError, "past the scene's horizon"),
    (lambda: window_weight(0.4, 0.5, -0.1), ValueError, "rise must be >= 0 s"),
    (lambda: jc.observers.SoftPeak(temperature=0.0), ValueError, "SoftPeak.temperature must be"),
    (lambda: jc.observers.PeakRecord(samples=1), ValueError, "samples must be an int >= 2"),
    (lambda: jc.observers.SampledSoftPeak(samples=2.0), TypeError, "samples must be an integer"),
    (lambda: soft_peak_force(SCENE, 1e-3, samples=-1), ValueError, "samples must be an integer >="),
    (
        lambda: objective(objective=jc.observers.SoftPeak(), samples=8),
        ValueError,
        "an objective given .SoftPeak. carries its own: pass samples=0",
    ),
    (lambda: ProfileObjective("iso", lambda p: SCENE, t1=1e-3), TypeError, "space must be a jc"),
    (lambda: ProfileObjective(SPACE, None, t1=1e-3), TypeError, "build must be a function"),
    (lambda: objective(temperature="20"), TypeError, "temperature must be a real number"),
    (lambda: objective(take_up=-5.0), ValueError, "take_up must be >= 0 N"),
    (lambda: objective(sprocket=-1), ValueError, "sprocket must be an integer >= 0"),
    (lambda: objective(combine="min"), ValueError, "combine must be one of 'mean', 'max', 'worst'"),
    (lambda: objective(throw="yes"), TypeError, "throw must be True or False"),
    (lambda: objective(gradient="both"), ValueError, "gradient must be one of 'auto'"),
    (
        lambda: objective(gradient="forward", adjoint=diffrax.RecursiveCheckpointAdjoint()),
        ValueError,
        "is a reverse-mode one",
    ),
    (
        lambda: objective(gradient="reverse", adjoint=diffrax.ForwardMode()),
        ValueError,
        "cannot run through diffrax.ForwardMode",
    ),
    (lambda: objective(t1=NAN), ValueError, "t1 must be a finite number > 0"),
    (lambda: objective().value(jnp.zeros(3)), ValueError, r"u must have shape \(4,\)"),
    (lambda: objective().value(jnp.array([NAN, 0, 0, 0])), ValueError, "u must be finite"),
    (lambda: objective(sprocket=3).value(jnp.zeros(4)), ValueError, "sprocket=3 but the scenes"),
    (lambda: objective(t1=1.0).value(jnp.zeros(4)), ValueError, "past the scene's horizon"),
]


@pytest.mark.parametrize(("call", "error", "match"), BAD, ids=[f"bad{i}" for i in range(len(BAD))])
def test_a_bad_input_is_refused_with_what_to_change(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_the_table_covers_every_kind_of_input():
    """The issue's count: how many bad inputs are tried, and of which kind."""
    kinds = {}
    for _, error, _ in BAD:
        kinds[error.__name__] = kinds.get(error.__name__, 0) + 1
    print(f"{len(BAD)} bad inputs: {kinds}")
    assert len(BAD) >= 130 and set(kinds) == {"TypeError", "ValueError"}


def test_good_inputs_in_other_spellings_are_accepted():
    """What the checks must not refuse: a designation for a chain, NumPy integers and
    scalars, a scalar array."""
    assert jc.scenes.roller_law("08B", 0.7).clearance == jc.scenes.roller_law(CHAIN, 0.7).clearance
    assert jc.ToothProfile.iso606("08B", np.int64(18)).teeth == 18
    assert DesignSpace.iso606("08B", 18).template.teeth == 18
    assert jc.observers.PeakRecord(samples=np.int64(4)).samples == 4
    sc = engagement(speed_rpm=np.float64(900.0), tension=jnp.asarray(800.0), n_entry=3)
    assert float(sc.sprockets[0].speed) == pytest.approx(900 * 2 * math.pi / 60)


# ------------------------------------------------------------------ NaN in, NaN out
LAWS = [
    jc.scenes.roller_law(CHAIN, 0.7),
    jc.contact.LankaraniNikravesh(stiffness=1e10, exponent=1.5, restitution=0.7),
    jc.contact.HuntCrossley(stiffness=1e10, exponent=1.5, restitution=0.7),
    jc.contact.Flores(stiffness=1e10, exponent=1.5, restitution=0.7),
    jc.contact.Gonthier(stiffness=1e10, exponent=1.5, restitution=0.7),
]


@pytest.mark.parametrize("law", LAWS, ids=lambda law: type(law).__name__)
def test_a_nan_contact_input_gives_a_nan_force(law):
    """A NaN depth is not "out of contact": the force is NaN, not zero (nor a finite
    number); so for a NaN approach rate or impact speed."""
    for args in [(NAN, 0.1, 1.0), (1e-6, NAN, 1.0), (1e-6, 0.1, NAN), (NAN, NAN, NAN)]:
        assert np.isnan(float(law.normal_force(*args))), args
    assert np.isfinite(float(law.normal_force(-1e-3, 0.1, 1.0)))  # a real separation: 0


def test_a_nan_point_gives_a_nan_contact():
    for f in (jc.gap_contact, jc.signed_distance):
        depth, normal = f(PROFILE, jnp.array([NAN, 0.05]))
        assert np.isnan(float(depth)) and np.all(np.isnan(np.asarray(normal))), f.__name__
    assert np.isnan(float(jc.scenes.roller_law(CHAIN, 0.7).deflection(NAN)))
    assert np.all(np.isnan(np.asarray(SPACE.values(jnp.array([NAN, 0.0, 0.0, 0.0])))[:1]))
    friction = jc.contact.CoulombFriction(coefficient=0.1)
    assert np.isnan(float(friction.force(NAN, 0.1))) and np.isnan(float(friction.force(1.0, NAN)))
