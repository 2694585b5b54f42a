"""Bush chains (ISO 606 04C and 06C, ANSI 25 and 35: no roller, the bush engages the
teeth): the standard's numbers and sprocket forms, the clearance chain as the source
paper's bushing chain (pin/bush joints only, no roller bodies), both fidelities settled
and running, the bush sliding on the tooth (its link's rotation in the slip, the
friction's moment on the link), save/load and DXF of their profiles, and bad input."""

import dataclasses
import math

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state, roller_kinematics
from jaxchain._elements.rollers import RollerTeeth, roller_contacts

from helpers import energy_balance_error, fixed_step_joints, tooth_period

# ISO 606:2015 table 1 (mm, kN), typed from the standard: pitch p, bush diameter d1 (max),
# inner width b1 (min), pin diameter d2 (max), bush bore d3 (min), inner plate depth h2
# (max), tensile strength Fu (min). ASME B29.1 chains 25 and 35 (0.130 / 0.200 in bushes).
ISO = {
    "04C": (6.35, 3.30, 3.10, 2.31, 2.34, 6.02, 3.5),
    "06C": (9.525, 5.08, 4.68, 3.60, 3.62, 9.05, 7.9),
}
# Typical catalogue mass per metre [kg/m] of the single-strand chains (RS25, RS35).
CATALOGUE_MASS = {"04C": 0.14, "06C": 0.33}
LOAD, PRETENSION = 5.0, 150.0  # the drives' load torque [N·m] and pretension [N]
FRICTION = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=1e-2)  # bush on tooth


@pytest.mark.parametrize("name", sorted(ISO))
def test_iso606_bush_chain_dimensions(name):
    c = jc.ChainSpec.iso606(name)
    p, d1, b1, d2, d3, h2 = (v * 1e-3 for v in ISO[name][:6])
    got = (c.pitch, c.roller_diameter, c.inner_width, c.pin_diameter, c.bush_bore, c.plate_height)
    for g, want in zip(got, (p, d1, b1, d2, d3, h2), strict=True):
        assert math.isclose(g, want, rel_tol=1e-12)
    assert math.isclose(c.tensile_strength, ISO[name][6] * 1e3, rel_tol=1e-12)
    assert math.isclose(c.pin_clearance, (d3 - d2) / 2, rel_tol=1e-12)
    # no roller: d1 is the bush's diameter, the bush is the inner link's
    assert c.kind == "bush" and not c.has_roller
    assert c.bush_diameter == c.roller_diameter == c.roller_bore
    assert c.roller_mass == 0.0 and c.roller_inertia == 0.0 and c.roller_clearance == 0.0
    assert math.isclose(
        c.mass_per_length, (c.roller_link_mass + c.pin_link_mass) / (2 * p), rel_tol=1e-12
    )
    assert jc.ChainSpec.iso606("08B").has_roller


@pytest.mark.parametrize("name", sorted(ISO))
def test_derived_mass_and_inertia_physical(name):
    """Masses from steel and geometry (ISO 606 gives none) land within 25 % of catalogue
    chains'; a link's polar inertia lies between 0.1·m·(p/2)² and m·(p/2 + h2/2)²."""
    c = jc.ChainSpec.iso606(name)
    rel = c.mass_per_length / CATALOGUE_MASS[name] - 1
    assert abs(rel) < 0.25, f"{name}: derived {c.mass_per_length:.3f} kg/m ({rel:+.0%})"
    for m, j in (
        (c.roller_link_mass, c.roller_link_inertia),
        (c.pin_link_mass, c.pin_link_inertia),
    ):
        assert 0.1 * m * (c.pitch / 2) ** 2 < j < m * (c.pitch / 2 + c.plate_height / 2) ** 2


@pytest.mark.parametrize("name", sorted(ISO))
@pytest.mark.parametrize("z", [9, 18, 40])
def test_sprocket_forms_take_the_bush_diameter(name, z):
    """ISO 606 tooth-gap forms with d1 the bush diameter (DESIGN.md's formulas, in mm)."""
    p, d1 = ISO[name][0], ISO[name][1]
    d = p / math.sin(math.pi / z)
    want = {
        "min": (0.505 * d1, 140 - 90 / z, 0.008 * d1 * (z**2 + 180), d + 1.25 * p - d1),
        "max": (
            0.505 * d1 + 0.069 * d1 ** (1 / 3),
            120 - 90 / z,
            0.12 * d1 * (z + 2),
            d + p * (1 - 1.6 / z) - d1,
        ),
    }
    chain = jc.ChainSpec.iso606(name)
    for form, (ri, alpha_deg, re, da) in want.items():
        prof = jc.ToothProfile.iso606(chain, z, form)
        np.testing.assert_allclose(float(prof.seating_radius) * 1e3, ri, rtol=1e-12)
        np.testing.assert_allclose(math.degrees(float(prof.seating_angle)), alpha_deg, rtol=1e-12)
        np.testing.assert_allclose(float(prof.flank_radius) * 1e3, re, rtol=1e-12)
        np.testing.assert_allclose(float(prof.tip_diameter) * 1e3, da, rtol=1e-12)
        np.testing.assert_allclose(float(prof.pitch_diameter) * 1e3, d, rtol=1e-12)


def test_profiles_save_load_and_dxf(tmp_path):
    """A bush chain's profiles save and load bit for bit and write their DXF outline."""
    iso = jc.ToothProfile.iso606("06C", 18, "mid")
    free = jc.FreeformProfile.from_iso(iso, 2)
    for k, prof in enumerate((iso, free)):
        back = jc.load_profile(prof.save(tmp_path / f"p{k}.json"))
        assert type(back) is type(prof)
        for name in ("pitch", "roller_diameter", "seating_radius", "tip_diameter"):
            np.testing.assert_array_equal(getattr(back, name), getattr(prof, name))
        assert float(back.roller_diameter) == 5.08e-3 and back.teeth == 18
    text = iso.to_dxf(tmp_path / "06C.dxf").read_text()
    assert text.count("ARC") >= 18


def test_custom_bush_chain():
    """``ChainSpec.bush_chain`` with 06C's dimensions gives 06C's masses and inertias; a
    chain of its own is a bush chain of the dimensions given."""
    c = jc.ChainSpec.iso606("06C")
    dims = {
        f: getattr(c, f)
        for f in (
            "pitch", "inner_width", "pin_diameter", "bush_bore", "plate_height",
            "plate_thickness", "tensile_strength",
        )
    }  # fmt: skip
    same = jc.ChainSpec.bush_chain(bush_diameter=c.roller_diameter, name="06C", **dims)
    assert same == c
    own = jc.ChainSpec.bush_chain(**{**dims, "bush_diameter": 5.5e-3, "pitch": 10e-3})
    assert own.kind == "bush" and own.roller_diameter == own.bush_diameter == 5.5e-3
    assert own.roller_link_mass > c.roller_link_mass  # a larger bush over the same bore
    prof = jc.ToothProfile.iso606(own, 18, "min")
    np.testing.assert_allclose(float(prof.seating_radius), 0.505 * 5.5e-3, rtol=1e-12)


def test_bad_input():
    c = jc.ChainSpec.iso606("06C")
    fields = {f.name: getattr(c, f.name) for f in dataclasses.fields(c)}
    with pytest.raises(ValueError, match=r"roller_mass must be 0 in a bush chain"):
        jc.ChainSpec(**{**fields, "roller_mass": 1e-3})
    with pytest.raises(ValueError, match=r"roller_diameter must equal bush_diameter"):
        jc.ChainSpec(**{**fields, "roller_diameter": 5.5e-3})
    with pytest.raises(ValueError, match=r"kind must be 'roller'.*or 'bush'"):
        jc.ChainSpec(**{**fields, "kind": "silent"})
    roller = jc.ChainSpec.iso606("06B")
    with pytest.raises(ValueError, match=r"roller_mass must be > 0"):
        dataclasses.replace(roller, roller_mass=0.0)
    with pytest.raises(ValueError, match=r"unknown ISO 606 chain '08C'.*04C.*06C"):
        jc.ChainSpec.iso606("08C")
    dims = dict(
        pitch=8e-3, bush_diameter=4.5e-3, inner_width=4e-3, pin_diameter=2.8e-3,
        bush_bore=2.85e-3, plate_height=7.5e-3, plate_thickness=1e-3, tensile_strength=6e3,
    )  # fmt: skip
    with pytest.raises(ValueError, match=r"pitch must be > 0 m"):
        jc.ChainSpec.bush_chain(**{**dims, "pitch": -1.0})
    with pytest.raises(ValueError, match=r"needs roller_diameter < pitch"):
        jc.ChainSpec.bush_chain(**{**dims, "bush_diameter": 9e-3})
    with pytest.raises(ValueError, match=r"needs bush_bore < bush_diameter"):
        jc.ChainSpec.bush_chain(**{**dims, "bush_bore": 4.6e-3})
    with pytest.raises(TypeError, match=r"tensile_strength must be a real number"):
        jc.ChainSpec.bush_chain(**{**dims, "tensile_strength": "6 kN"})
    # a bush chain has no roller to put on a bush/roller joint
    for build in (jc.scenes.engagement, jc.scenes.drive):
        with pytest.raises(ValueError, match=r"bush chain .*no roller to put on a bush/roller"):
            model = jc.scenes.ChainModel(rollers_on_bush="joint", settle=False)
            build("04C", fidelity="clearance", model=model)
    with pytest.raises(ValueError, match=r"rollers_on_bush must be one of"):
        jc.scenes.engagement(
            "06C", model=jc.scenes.ChainModel(rollers_on_bush="bush", settle=False)
        )
    with pytest.raises(TypeError, match=r"friction must be a jc.contact.CoulombFriction"):
        jc.scenes.engagement("06C", model=jc.scenes.ChainModel(friction="coulomb", settle=False))


def test_clearance_model_is_the_papers_bush_chain():
    """The clearance bush chain: pin links and bushing links joined by pin/bush clearance
    joints only (no roller bodies, no bush/roller joints), each bush at ±p/2 on its
    bushing link, whose mass is the chain's own (no roller mass added); a roller chain of
    the same pitch has both."""
    chain = jc.ChainSpec.iso606("06C")
    sc = jc.scenes.engagement(
        chain, 18, fidelity="clearance", model=jc.scenes.ChainModel(settle=False)
    )
    assert sc.n_bodies == sc.n_links == sc.n_rollers - 1  # an open strand: links only
    assert len(sc.pairs) == 1 and sc.pairs[0].carries_tension  # pin/bush joints
    body = np.asarray(sc.roller_body)
    assert body.max() < sc.n_links and np.all(body % 2 == 0)  # on the bushing links
    np.testing.assert_allclose(np.abs(np.asarray(sc.roller_offset)[:, 0]), chain.pitch / 2)
    mass = np.asarray(sc.mass)
    np.testing.assert_allclose(mass[0::2], chain.roller_link_mass, rtol=1e-12)
    np.testing.assert_allclose(mass[1::2], chain.pin_link_mass, rtol=1e-12)
    link = np.asarray(sc.bush_link)  # each bush turns with its own bushing link
    np.testing.assert_array_equal(body[link[:, 0]], body)
    np.testing.assert_array_equal(body[link[:, 1]], body)
    # the bush slides on the tooth: Dahl friction by default (a roller chain: none)
    assert sc.friction == jc.scenes.BUSH_TOOTH_FRICTION
    same = jc.scenes.engagement(
        chain,
        18,
        fidelity="clearance",
        model=jc.scenes.ChainModel(rollers_on_bush="lumped", settle=False),
    )
    assert same.n_bodies == sc.n_bodies and len(same.pairs) == 1
    roller = jc.scenes.engagement(
        "06B", 18, fidelity="clearance", model=jc.scenes.ChainModel(settle=False)
    )
    assert roller.n_bodies == roller.n_links + roller.n_rollers and len(roller.pairs) == 2
    assert roller.bush_link is None
    # the lumped bush chain: points of half an inner and half an outer link each
    lumped = jc.scenes.engagement(chain, 18, model=jc.scenes.ChainModel(settle=False))
    half = 0.5 * (chain.roller_link_mass + chain.pin_link_mass)
    np.testing.assert_allclose(np.asarray(lumped.mass)[1:-1], half, rtol=1e-12)
    assert lumped.bush_link is not None and lumped.pairs[0].carries_tension


@pytest.fixture(scope="module", params=["lumped", "clearance"])
def drive(request):
    """A settled 06C drive, 12/24 teeth, 40 links."""
    return jc.scenes.drive(
        "06C",
        teeth=(12, 24),
        n_links=40,
        load_torque=LOAD,
        pretension=PRETENSION,
        fidelity=request.param,
    )


def test_drive_settles(drive):
    """Both fidelities start in static equilibrium: every body balanced, the driven
    sprocket carrying its load and the driver that load times z1/z2, the tight − slack
    tension load/R2 across the spans."""
    y = initial_state(drive)
    y = y._replace(v=jnp.zeros_like(y.v), omega=jnp.zeros_like(y.omega))
    fr = forces(0.0, y, drive)
    r2 = float(drive.sprockets[1].profile.pitch_radius)
    assert float(jnp.max(jnp.abs(fr.body[:, :2]))) <= 1e-6 * LOAD / r2
    np.testing.assert_allclose(float(fr.sprocket_torque[1]), LOAD, rtol=1e-6)
    # the driver holds the load times z1/z2 (measured within 0.6 %: the polygons' lever
    # arms at the start's phase are not quite the pitch radii)
    np.testing.assert_allclose(float(fr.sprocket_torque[0]), -LOAD * 12 / 24, rtol=1e-2)
    x, _ = roller_kinematics(y, drive)
    x = np.asarray(x)
    # the straight spans run from x ≈ 0 to x ≈ C: links a pitch clear of both wraps
    p, c2 = 9.525e-3, float(drive.sprockets[1].centre[0])
    span = (x[:, 0] > p) & (x[:, 0] < c2 - p)
    tension = np.asarray(drive.link_weights) @ np.asarray(fr.element_tension)
    link_x = 0.5 * (x + np.roll(x, -1, axis=0))
    span = span & np.roll(span, -1)
    top, bottom = span & (link_x[:, 1] > 0), span & (link_x[:, 1] < 0)
    assert top.sum() >= 3 and bottom.sum() >= 3
    np.testing.assert_allclose(tension[top].mean() - tension[bottom].mean(), LOAD / r2, rtol=0.03)


def test_drive_runs_with_defaults(drive):
    """Running: over the second driver tooth period the mean speed ratio is z1/z2."""
    period = tooth_period(1000, 12)
    sol = jc.simulate(drive, 2 * period, n_save=201)
    assert sol.ok and np.all(np.isfinite(np.asarray(sol.link_tension)))
    assert 0.0 < float(sol.peak_contact_force) < drive.tensile_strength
    late = np.asarray(sol.ts) >= period
    w = np.asarray(sol.sprocket_speed)[late][:-1].mean(axis=0)  # one whole period
    np.testing.assert_allclose(w[1] / w[0], 12 / 24, rtol=5e-3)


def test_engagement_runs_with_defaults():
    """``jc.scenes.engagement("06C", 18)``: the design scene settles and meshes."""
    sc = jc.scenes.engagement("06C", 18, n_entry=2)
    sol = jc.simulate(sc, 0.5 * tooth_period(1000, 18), n_save=11)
    assert sol.ok and float(sol.peak_contact_force) > 100.0


DAHL = jc.contact.DahlFriction(coefficient=0.1)  # bush on tooth, with pre-sliding states


@pytest.mark.parametrize("law", [FRICTION, DAHL], ids=["coulomb", "dahl"])
def test_bush_slides_with_its_link(drive, law):
    """The tooth friction's power on chain and sprockets is Σ F_t·s over the contacts,
    s the sliding of the bush's surface over the tooth's: in the clearance chain the
    velocity of the bush's link (a rigid body) at the contact point, in the lumped chain
    the point's velocity plus the inner link's rotation ω at the bush radius (ω the rate of
    the line between its two bushes). F_t is the law's traction: −μ·F_n·tanh(s/v_s), or
    Dahl's −μ·F_n·(z + τ·ż)/x_s with the contact's own state z (one per sprocket and
    bush) moving at the law's rate times F_n/(F_n + 1 N), and held still off load. At a
    random velocity state, every body's own spin set too (the lumped points' spin must not
    count), the Dahl states random within ±x_s."""
    rng = np.random.default_rng(0)
    scene = dataclasses.replace(drive, friction=law)
    y = initial_state(scene)
    v = rng.normal(size=y.v.shape) * np.array([0.3, 0.3, 100.0])
    y = y._replace(v=jnp.asarray(v))
    ns, n_r = len(scene.sprockets), scene.n_rollers
    z = np.zeros((ns, n_r))
    if law is DAHL:
        before = initial_state(dataclasses.replace(drive, friction=None)).bristle
        assert y.bristle.shape[0] - (0 if before is None else before.shape[0]) == ns * n_r
        z = rng.uniform(-1, 1, size=(ns, n_r)) * float(law.presliding)
        y = y._replace(bristle=y.bristle.at[-ns * n_r :].set(jnp.asarray(z.reshape(-1))))
    teeth = RollerTeeth(scene.roller_law, law)
    state = None if law is FRICTION else y.bristle[-ns * n_r :]
    e = teeth.effect(0.0, y, scene, state)
    got = float(jnp.sum(e.body * y.v) + jnp.sum(e.sprocket_torque * y.omega))
    bare = RollerTeeth(scene.roller_law, None).effect(0.0, y, scene, None)
    got -= float(jnp.sum(bare.body * y.v) + jnp.sum(bare.sprocket_torque * y.omega))
    normal = np.asarray(roller_contacts(y, scene, scene.roller_law, None).normal)  # (S, R)
    x, xd = (np.asarray(a) for a in roller_kinematics(y, scene))
    q, qd = np.asarray(y.q), np.asarray(y.v)
    r = 0.5 * drive_chain_d1(scene)
    want, contacts = 0.0, 0
    rates = np.zeros((ns, n_r))
    for k, spr in enumerate(scene.sprockets):
        th, om, c = float(y.theta[k]), float(y.omega[k]), np.asarray(spr.centre)
        rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
        for i in np.nonzero(normal[k] > 0)[0]:
            _, n_local = jc.gap_contact(spr.profile, jnp.asarray(rot.T @ (x[i] - c)))
            n = rot @ np.asarray(n_local)
            t = np.array([-n[1], n[0]])
            xc = x[i] - r * n
            if scene.fidelity == "clearance":
                h = int(scene.roller_body[i])
                arm = xc - q[h, :2]
                vb = qd[h, :2] + qd[h, 2] * np.array([-arm[1], arm[0]])
            else:
                a = i - i % 2
                b = (a + 1) % n_r
                d, dd = x[b] - x[a], xd[b] - xd[a]
                w = (d[0] * dd[1] - d[1] * dd[0]) / (d @ d)
                vb = xd[i] - r * w * t
            vt = om * np.array([-(xc - c)[1], (xc - c)[0]])
            s = t @ (vb - vt)
            mu, fn = float(law.coefficient), normal[k, i]
            if law is FRICTION:
                ft = -mu * fn * math.tanh(s / float(law.slip_velocity))
            else:
                xs, eps = float(law.presliding), float(law.creep_velocity)
                tau = float(law.damping)
                zdot = s - math.sqrt(s * s + eps * eps) * z[k, i] / xs
                ft = -mu * fn * (z[k, i] + tau * zdot) / xs
                rates[k, i] = zdot * fn / (fn + 1.0)
            want += ft * s
            contacts += 1
    assert contacts >= 5
    assert want < 0 or law is DAHL  # sliding dissipates (a random Dahl state may push)
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # what the element reports (and saves as tooth_friction_power) is that power
    np.testing.assert_allclose(float(jnp.sum(e.report["tooth_friction_power"])), want, rtol=1e-9)
    if law is DAHL:  # loaded contacts move at the gated rate; the others hold
        np.testing.assert_allclose(
            np.asarray(e.state_rate).reshape(ns, n_r), rates, rtol=1e-9, atol=1e-12
        )
        assert np.count_nonzero(rates) == contacts


def drive_chain_d1(scene) -> float:
    return float(scene.sprockets[0].profile.roller_diameter)


def test_tooth_friction_with_states_runs_and_differentiates():
    """The bush chain's engagement with its default Dahl friction at the teeth runs with
    ``simulate``'s defaults (lumped; its states move only under load, so the drive is no
    stiffer), and the derivative of the bushes' total tooth force after half a tooth
    period in μ, through a fixed-step solve (4 µs Tsit5 steps; joints' creep band
    widened as for every fixed-step design solve), agrees with central differences of
    the same solve. Measured at 1000 rpm: 148.0014 N per unit μ, FD 148.0013 (h = 1e-4);
    the regularized Coulomb law at the teeth (v_s = 1 cm/s) gives an AD of 1.8e29 there."""
    import jax

    period = tooth_period(1000, 18)
    scene = jc.scenes.engagement(
        "06C",
        18,
        n_entry=2,
        model=jc.scenes.ChainModel(
            joint_friction=fixed_step_joints(),
            roller_contact=jc.scenes.roller_law(jc.ChainSpec.iso606("06C"), 0.7, width=3e-6),
        ),
    )
    assert scene.friction == jc.scenes.BUSH_TOOTH_FRICTION == DAHL
    n = int(round(0.5 * period / 4e-6))

    def total(mu):
        sc = dataclasses.replace(scene, friction=dataclasses.replace(DAHL, coefficient=mu))
        sol = jc.simulate(sc, 0.5 * period, n_steps=n, n_save=2, throw=False)
        return jnp.sum(sol.roller_sprocket_force[-1])

    both = jax.jit(jax.value_and_grad(total))  # one program for the AD and the FD points
    ad = float(both(0.1)[1])
    h = 1e-4
    fd = (float(both(0.1 + h)[0]) - float(both(0.1 - h)[0])) / (2 * h)
    assert abs(fd) > 10.0  # N per unit μ: the friction matters
    np.testing.assert_allclose(ad, fd, rtol=1e-5)


@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
def test_energy_balance_without_dissipation(fidelity):
    """Restitution 1, undamped links, frictionless joints and teeth, no load: the bush
    chain's kinetic and stored energy (links or pin/bush joints, bush/tooth contacts)
    changes exactly by the driver's work, to the trapezoid rule's error over the saves."""
    sc = jc.scenes.drive(
        "06C",
        teeth=(12, 24),
        n_links=40,
        speed_rpm=1000,
        load_torque=0.0,
        pretension=150.0,
        fidelity=fidelity,
        model=jc.scenes.ChainModel(
            restitution=1.0, link_damping=0.0, joint_friction=None, friction=None
        ),
    )
    err, scale = energy_balance_error(sc, 0.5 * tooth_period(1000, 12), 8001)
    assert scale > 1e-3  # the driver does work (J)
    assert err < 2e-4, err
