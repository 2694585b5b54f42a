"""Cushion rings (``jc.elements.CushionRing``): a ring out of the plates' reach changes
nothing; the statics of one link on a ring against its closed form, in both fidelities;
the ring's forces are the gradient of its energy, and its work over a solve is its
energy's change; gradients through fixed-step solves against central differences; the
builders, specs, files and errors."""

import json
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import DriveState, forces, initial_state
from jaxchain._scenes.build import assemble, roller_law
from jaxchain._scenes.fidelity import chain_bodies
from jaxchain._scenes.statics import equilibrate

from helpers import central_fd, fixed_step_joints, modelled, tooth_period

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = tooth_period(RPM, Z)
H2 = CHAIN.plate_height / 2
RING = jc.elements.CushionRing(radius=0.0302)
# 08B on 18 teeth: the seated links' plate edges at r_p·cos(π/z) − h/2 = 30.108 mm
SEATED_EDGE = CHAIN.pitch / (2 * math.sin(math.pi / Z)) * math.cos(math.pi / Z) - H2


def _ring(scene):
    """The scene's cushion element."""
    (el,) = [e for e in scene.elements if isinstance(e, jc.elements.CushionContacts)]
    return el


@pytest.fixture(scope="module")
def plain():
    """The default engagement (tests/test_engagement.py's: its solve is compiled once)."""
    return jc.scenes.engagement("08B", Z, speed_rpm=RPM)


@pytest.fixture(scope="module")
def cushioned():
    """The default engagement with the 30.2 mm ring (interfering ≈ 0.1 mm when seated)."""
    return jc.scenes.engagement("08B", Z, speed_rpm=RPM, model=jc.scenes.ChainModel(cushion=RING))


# ------------------------------------------------------------------ no reach, no change
def test_ring_out_of_reach_changes_nothing(plain):
    """A ring 1.1 mm below the seated plate edges (29.0 mm; no edge of the strand comes
    nearer the axis than a seated one) adds exactly zero force: the settled start and a
    tooth period's solve match the scene without it to rounding (both solves with
    ``simulate``'s defaults)."""
    assert 0.029 < SEATED_EDGE - 1e-3
    low = jc.scenes.engagement(
        "08B", Z, speed_rpm=RPM, model=jc.scenes.ChainModel(cushion=jc.elements.CushionRing(0.029))
    )
    np.testing.assert_allclose(low.q0, plain.q0, rtol=0, atol=1e-13)
    a = jc.simulate(plain, PERIOD)
    b = jc.simulate(low, PERIOD)
    assert float(np.max(np.asarray(b.element_outputs["cushion_force"]))) == 0.0
    np.testing.assert_allclose(b.roller_position, a.roller_position, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        b.roller_sprocket_force, a.roller_sprocket_force, rtol=1e-9, atol=1e-6
    )
    np.testing.assert_allclose(b.peak_contact_force, a.peak_contact_force, rtol=1e-9)


# ------------------------------------------------------------------ statics
def _one_link(fidelity: str, pull: float, ring: jc.elements.CushionRing) -> jc.Scene:
    """One link (two rollers) lying level above the axis of a held 18-tooth sprocket, its
    rollers over two gaps (gaps centred at 80° and 100°), each roller pulled toward the
    axis (−y) by ``pull`` [N] by an anchor, its plate edge on ``ring``; settled."""
    p = CHAIN.pitch
    y0 = float(ring.radius) + H2  # edge touching the ring
    rollers = np.array([[-p / 2, y0], [p / 2, y0]])
    bodies = chain_bodies(
        CHAIN, rollers, np.zeros((2, 2)), closed=False, fidelity=fidelity, restitution=0.7
    )
    anchors = jc.Anchors(
        body=jnp.asarray(bodies.roller_body),
        origin=jnp.asarray(rollers),
        direction=jnp.asarray([[0.0, -1.0], [0.0, -1.0]]),
        speed=jnp.zeros(2),
        tension=jnp.full(2, pull),
        stiffness=jnp.full(2, 1e4),
        damping=jnp.full(2, 1.0),
    )
    sprocket = jc.Sprocket(
        jc.ToothProfile.iso606(CHAIN, Z, "mid"), [0.0, 0.0], 0.0, angle0=math.radians(80.0)
    )
    scene = assemble(
        bodies,
        sprockets=(sprocket,),
        anchors=anchors,
        roller_contact=roller_law(CHAIN, 0.7),
        friction=None,
        impact_speed=1.0,
        fidelity=fidelity,
        tensile_strength=CHAIN.tensile_strength,
    )
    return equilibrate(jc.elements.CushionContacts.attach(scene, ring, CHAIN))


@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
def test_settled_link_on_the_ring_matches_the_closed_form(fidelity):
    """One link pressed onto a ring by two anchors pulling P = 50 N each toward the axis
    (rollers lifted out of their seats: no tooth force). By symmetry the edge touches
    the ring at its middle, straight above the axis, so the ring pushes straight up, and
    the vertical balance of the link gives the ring force F = 2P = 100 N. The law
    F = faces·K·δⁿ (δ ≥ width: no onset blend) then gives the compression
    δ = (2P/(faces·K))^{1/n} = 0.1 mm (K = 5·10⁷ N/m^1.5, n = 1.5, two faces), so the
    link's pitch line settles at y = R + h/2 − δ (R = 30.5 mm, h/2 = 5.905 mm: y =
    36.305 mm, 0.3 mm above the seated line). Measured: within 6e-15 m in both
    fidelities; the axis carries −2P."""
    pull, ring = 50.0, jc.elements.CushionRing(0.0305)
    scene = _one_link(fidelity, pull, ring)
    y = initial_state(scene)
    y = y._replace(v=jnp.zeros_like(y.v))
    f = forces(0.0, y, scene)
    assert float(jnp.max(f.roller_normal)) == 0.0  # lifted clear of the teeth
    q = np.asarray(scene.q0)
    pitch_line = q[0, 1] if fidelity == "clearance" else q[:2, 1].mean()  # link body / rollers
    delta = (2 * pull / (2 * 5e7)) ** (1 / 1.5)
    np.testing.assert_allclose(pitch_line, 0.0305 + H2 - delta, rtol=0, atol=1e-10)
    np.testing.assert_allclose(f.sprocket_force[0], [0.0, -2 * pull], rtol=1e-6, atol=1e-6)
    force = _ring(scene).outputs(0.0, y, scene, _ring(scene).effect(0.0, y, scene, None))
    np.testing.assert_allclose(force["cushion_force"], [2 * pull], rtol=1e-6)


# ------------------------------------------------------------------ energy
def _perturbed_states(scene, n: int, seed: int = 0):
    """``n`` states of ``scene`` near its start: positions moved by up to ±0.3 mm and
    link angles by ±0.02 rad (random), velocities random (≈ 0.3 m/s)."""
    rng = np.random.default_rng(seed)
    q0, y0 = np.asarray(scene.q0), initial_state(scene)
    out = []
    for _ in range(n):
        dq = rng.uniform(-1, 1, q0.shape) * [3e-4, 3e-4, 0.02]
        dv = rng.normal(scale=0.3, size=q0.shape) * [1, 1, 30]
        out.append(y0._replace(q=jnp.asarray(q0 + dq), v=jnp.asarray(dv)))
    return out


@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
def test_ring_forces_are_the_gradient_of_its_energy(fidelity):
    """Elastic ring (α = 0), a 30.8 mm ring on the laid-out strand (seated links
    compressed ≈ 0.7 mm, the links leaving and entering the wrap touching it at their
    ends, where the lever rule alone would not carry the force's moment): at random
    states near the start, the generalized forces on the bodies are −∂V/∂q of the ring's
    stored energy (AD of :meth:`energy`, the potential in closed form; torques on the
    clearance chain's links included), and the force on the axis is −∂V/∂c."""
    ring = jc.elements.CushionRing(0.0308, damping=0.0)
    scene = jc.scenes.engagement(
        "08B",
        Z,
        speed_rpm=RPM,
        fidelity=fidelity,
        model=jc.scenes.ChainModel(settle=False, cushion=ring),
    )
    el = _ring(scene)

    @jax.jit
    def check(y, scene):
        el = _ring(scene)
        e = el.effect(0.0, y, scene, None)
        grad_q = jax.grad(lambda q: el.energy(0.0, y._replace(q=q), scene))(y.q)

        def energy_at(c):
            moved = eqx.tree_at(lambda s: s.sprockets[0].centre, scene, c)
            return _ring(moved).energy(0.0, y, moved)

        grad_c = jax.grad(energy_at)(scene.sprockets[0].centre)
        depth, _, _, s = el._contacts(y, scene)[:4]
        return e.body, grad_q, e.sprocket_force[0], grad_c, depth[0], s[0]

    ends = 0
    for y in _perturbed_states(scene, 4):
        body, grad_q, axis, grad_c, depth, s = check(y, scene)
        scale = float(jnp.max(jnp.abs(body)))
        assert scale > 50.0  # the ring carries the links
        np.testing.assert_allclose(body, -grad_q, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(axis, -grad_c, rtol=0, atol=1e-9 * scale)
        touching = np.asarray(depth) > 0
        ends += int(np.sum(touching & ((np.asarray(s) == 0) | (np.asarray(s) == 1))))
    assert ends > 0  # contacts at a segment's end were among them
    assert el.sides == (1,)


def test_ring_work_over_a_solve_is_its_energy_change(cushioned):
    """With an elastic ring (α = 0) the work its forces do on the chain over a tooth
    period, ∫ power dt up to every other save (Simpson's rule over the solve's 501 saves),
    is minus the change of its stored energy since the start. Measured: within 6.0e-4 of
    the energy's swing (4.5 mJ); forces 1 % off the energy's gradient: 9e-3. Lumped
    chain: bodies are the rollers, so the saved roller positions and velocities are the
    state the ring sees."""
    elastic = eqx.tree_at(lambda s: _ring(s).rings[0].damping, cushioned, jnp.asarray(0.0))
    sol = jc.simulate(elastic, PERIOD)  # the defaults run's solve (same structure)
    el = _ring(elastic)

    @jax.jit
    def energy_and_power(x, v, theta, omega):
        zeros = jnp.zeros(x.shape[:1] + (1,), x.dtype)
        y = DriveState(
            q=jnp.concatenate([x, zeros], -1),
            v=jnp.concatenate([v, zeros], -1),
            theta=theta,
            omega=omega,
        )
        return el.energy(0.0, y, elastic), el.power(0.0, y, elastic)

    e, p = jax.vmap(energy_and_power)(
        sol.roller_position, sol.roller_velocity, sol.sprocket_angle, sol.sprocket_speed
    )
    e, p, ts = np.asarray(e), np.asarray(p), np.asarray(sol.ts)
    # the work up to every other save: Simpson's rule on each pair of intervals
    h = ts[1] - ts[0]
    pairs = h / 3 * (p[:-2:2] + 4 * p[1:-1:2] + p[2::2])
    work = np.concatenate([[0.0], np.cumsum(pairs)])
    change = e[::2] - e[0]
    swing = e.max() - e.min()
    assert swing > 1e-4  # J: the ring's energy moves (links meshing and leaving)
    err = np.abs(work + change).max()
    assert err < 2e-3 * swing, (err, swing)


# ------------------------------------------------------------------ gradients
def test_ring_force_gradients_match_central_differences():
    """At a moving state, d(total ring force)/d(radius, stiffness, damping) by AD equals
    central differences (the law and the geometry are smooth in the ring's leaves)."""
    scene = jc.scenes.engagement(
        "08B", Z, speed_rpm=RPM, model=jc.scenes.ChainModel(settle=False, cushion=RING)
    )
    y = _perturbed_states(scene, 1, seed=3)[0]
    p0 = np.array([0.0302, 5e7, 0.5])

    @jax.jit
    def total(p):
        moved = eqx.tree_at(
            lambda s: (lambda r: (r.radius, r.stiffness, r.damping))(_ring(s).rings[0]),
            scene,
            (p[0], p[1], p[2]),
        )
        el = _ring(moved)
        return jnp.sum(el.outputs(0.0, y, moved, el.effect(0.0, y, moved, None))["cushion_force"])

    ad = np.asarray(jax.grad(total)(jnp.asarray(p0)))
    for i, h in enumerate((1e-8, 1e3, 1e-4)):
        fd = central_fd(lambda x, i=i: total(jnp.asarray(p0).at[i].set(x)), p0[i], h)
        np.testing.assert_allclose(ad[i], fd, rtol=1e-6)
    assert ad[0] > 0 and ad[1] > 0  # a larger, stiffer ring pushes harder


@pytest.mark.slow
def test_peak_gradient_through_fixed_steps_matches_central_differences():
    """d(peak roller/tooth force)/d(ring radius, stiffness) through a fixed-step solve (4 µs
    Tsit5 steps over one tooth period, forward mode) against central differences of the
    same solve, the settled start held (as the gradient sees it). The roller law's onset
    is resolved over 3 µm and the joints' creep band widened so the steps resolve them
    (tests/test_design.py), in the scene as settled. Measured: −1.08872e6 N/m and
    −1.26175e-6 N/(N/m^1.5), AD = FD to 3e-7 and 1e-7 (h = 2.5e-8 m, 1.25e5 N/m^1.5)."""
    import diffrax

    scene = jc.scenes.engagement(
        "08B",
        Z,
        speed_rpm=RPM,
        model=jc.scenes.ChainModel(
            cushion=RING,
            roller_contact=jc.scenes.roller_law(CHAIN, 0.7, width=3e-6),
            joint_friction=fixed_step_joints(),
        ),
    )
    n = int(round(PERIOD / 4e-6))

    def peak(p, **kw):
        leaves = lambda s: (_ring(s).rings[0].radius, _ring(s).rings[0].stiffness)
        sc = eqx.tree_at(leaves, scene, (p[0], p[1]))
        sol = jc.simulate(sc, PERIOD, n_steps=n, n_save=2, throw=False, **kw)
        return sol.peak_contact_force

    p0 = jnp.array([0.0302, 5e7])
    value = jax.jit(peak)
    assert 100.0 < float(value(p0)) < 5000.0
    ad = np.asarray(jax.jit(jax.jacfwd(lambda p: peak(p, adjoint=diffrax.ForwardMode())))(p0))
    assert ad[0] < 0 and ad[1] != 0  # a larger ring holds the strand off the teeth
    for i, h in enumerate((2.5e-8, 1.25e5)):
        e = np.zeros(2)
        e[i] = h
        fd = (float(value(p0 + e)) - float(value(p0 - e))) / (2 * h)
        np.testing.assert_allclose(ad[i], fd, rtol=1e-5)


# ------------------------------------------------------------------ runs
def test_default_engagement_with_a_ring_runs(cushioned):
    """The default-built engagement with a ring runs with ``simulate``'s defaults over two
    tooth periods (lumped; both fidelities at 100 and 3000 rpm: the slow test below), and
    the ring carries the wrap's links."""
    sol = jc.simulate(cushioned, 2 * PERIOD)
    assert sol.ok and float(sol.peak_contact_force) > 0, sol.message
    force = np.asarray(sol.element_outputs["cushion_force"])
    assert force.shape == (sol.ts.shape[0], cushioned.n_links)
    assert 50.0 < force.max() < 500.0
    assert np.sum(force[0] > 0) >= 5  # the seated links rest on it


@pytest.mark.slow
@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
@pytest.mark.parametrize("rpm", [100.0, 3000.0])
def test_ring_defaults_run(fidelity, rpm):
    sc = jc.scenes.engagement(
        speed_rpm=rpm, fidelity=fidelity, model=jc.scenes.ChainModel(cushion=RING)
    )
    sol = jc.simulate(sc, 2 * tooth_period(rpm, Z))
    assert sol.ok and float(sol.peak_contact_force) > 0, sol.message


@pytest.mark.slow
def test_ring_lowers_the_lumped_peak(plain, cushioned):
    """Over the engagement's horizon (8 meshings, ``simulate``'s defaults) the 30.2 mm ring
    lowers the lumped chain's peak roller/tooth force: measured 1686.4 → 1478.2 N
    (−12.3 %)."""
    a = jc.simulate(plain, float(plain.horizon))
    b = jc.simulate(cushioned, float(cushioned.horizon))
    assert float(b.peak_contact_force) < 0.95 * float(a.peak_contact_force)


# ------------------------------------------------------------------ builders and specs
def test_drive_rings_press_on_the_side_facing_each_sprocket():
    """A loop over three sprockets, the 12-tooth one outside (the chain's back on it):
    rings on the driver and on the outside idler compress the plate edges facing each
    axis by about 0.1 mm at the layout (the edges on the far side are a plate height
    away, ≈ −11.7 mm); the span-level chain refuses rings."""
    teeth = (18, 12, 27)
    edge = {
        z: CHAIN.pitch / (2 * math.sin(math.pi / z)) * math.cos(math.pi / z) - H2 for z in teeth
    }
    rings = (
        jc.elements.CushionRing(edge[18] + 1e-4),
        jc.elements.CushionRing(edge[12] + 1e-4),
        None,
    )
    kw = dict(
        teeth=teeth,
        centres=((0.0, 0.0), (0.26, 0.12), (0.22, -0.18)),
        outside=(1,),
        load_torque=(0.0, 15.0),
        pretension=150.0,
    )
    scene = jc.scenes.drive(
        "08B", **modelled(**kw, model=jc.scenes.ChainModel(settle=False, cushion=rings))
    )
    el = _ring(scene)
    assert el.sprockets == (0, 1) and el.sides == (1, -1)
    depth = np.asarray(el._contacts(initial_state(scene), scene)[0])
    for k in range(2):
        assert 0.0 < depth[k].max() < 2e-4, depth[k].max()
    spec = jc.scenes.DriveSpec.of("08B", cushion=rings, settle=False, **kw)
    assert spec.sprockets[1].cushion is rings[1] and spec.sprockets[2].cushion is None
    assert spec.arguments()["model"].cushion == rings
    assert _ring(spec.build()).sides == (1, -1)
    with pytest.raises(ValueError, match="fidelity='lumped' or 'clearance'"):
        jc.scenes.drive(
            "08B", **modelled(fidelity="spans", **kw, model=jc.scenes.ChainModel(cushion=rings))
        )


def test_strand_spec_carries_the_ring():
    s = jc.scenes.SprocketSpec(Z, load=None, cushion=RING)
    assert jc.scenes.StrandSpec(sprocket=s).arguments()["model"].cushion is RING
    assert jc.scenes.StrandSpec(cushion=RING).arguments()["model"].cushion is RING
    assert jc.scenes.StrandSpec().arguments()["model"].cushion is None
    with pytest.raises(ValueError, match="one of the two places"):
        jc.scenes.StrandSpec(sprocket=s, cushion=jc.elements.CushionRing(0.03))
    with pytest.raises(TypeError, match="CushionRing or None"):
        jc.scenes.StrandSpec(cushion=0.0302)
    with pytest.raises(TypeError, match="CushionRing or None"):
        jc.scenes.SprocketSpec(Z, cushion="ring")


# ------------------------------------------------------------------ files and errors
def test_save_load_round_trip(tmp_path):
    ring = jc.elements.CushionRing(0.0301234567891, stiffness=3.3e7, damping=0.25, faces=1)
    path = ring.save(tmp_path / "cushion.json")
    back = jc.elements.CushionRing.load(path)
    assert back.faces == 1
    for name in ("radius", "stiffness", "exponent", "damping", "width"):
        assert float(getattr(back, name)) == float(getattr(ring, name)), name
    data = json.loads(path.read_text())
    assert data["format"] == "jaxchain.cushion" and data["radius"] == 0.0301234567891


def test_file_errors_name_the_path(tmp_path):
    missing = tmp_path / "nope.json"
    with pytest.raises(FileNotFoundError, match="nope.json"):
        jc.elements.CushionRing.load(missing)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="bad.json.*not JSON"):
        jc.elements.CushionRing.load(bad)
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"format": "jaxchain.profile", "version": 1}))
    with pytest.raises(ValueError, match="other.json.*not a jaxchain cushion ring"):
        jc.elements.CushionRing.load(other)
    RING.save(tmp_path / "ring.json")
    data = json.loads((tmp_path / "ring.json").read_text())
    data["radius"] = -0.03
    (tmp_path / "neg.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="neg.json.*radius must be > 0"):
        jc.elements.CushionRing.load(tmp_path / "neg.json")
    del data["width"]
    (tmp_path / "short.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="short.json.*missing \\['width'\\]"):
        jc.elements.CushionRing.load(tmp_path / "short.json")


def test_bad_inputs_raise_with_the_fix():
    with pytest.raises(ValueError, match="radius must be > 0 m"):
        jc.elements.CushionRing(0.0)
    with pytest.raises(ValueError, match="faces must be 1 or 2"):
        jc.elements.CushionRing(0.03, faces=3)
    with pytest.raises(TypeError, match="faces must be the integer 1 or 2"):
        jc.elements.CushionRing(0.03, faces=2.0)
    with pytest.raises(TypeError, match="stiffness must be a real number"):
        jc.elements.CushionRing(0.03, stiffness="soft")
    with pytest.raises(ValueError, match="exponent must be in \\[1, 3\\]"):
        jc.elements.CushionRing(0.03, exponent=0.5)
    with pytest.raises(ValueError, match="width must be in \\(0, 1e-4\\]"):
        jc.elements.CushionRing(0.03, width=0.0)
    with pytest.raises(ValueError, match="damping must be >= 0"):
        jc.elements.CushionRing(0.03, damping=-1.0)
    with pytest.raises(ValueError, match="must be a scalar"):
        jc.elements.CushionRing(jnp.array([0.03, 0.031]))
    with pytest.raises(TypeError, match="cushion must be a jc.elements.CushionRing"):
        jc.scenes.engagement("08B", Z, model=jc.scenes.ChainModel(cushion=0.0302))
    with pytest.raises(ValueError, match="reaches the pitch line"):
        jc.scenes.engagement(
            "08B", Z, model=jc.scenes.ChainModel(cushion=jc.elements.CushionRing(0.037))
        )
    with pytest.raises(TypeError, match=r"cushion=\(ring, None\)"):
        jc.scenes.drive("08B", model=jc.scenes.ChainModel(cushion=RING))
    with pytest.raises(ValueError, match="must hold 2 entries"):
        jc.scenes.drive("08B", model=jc.scenes.ChainModel(cushion=(RING,)))
    with pytest.raises(ValueError, match="fidelity='lumped' or 'clearance'"):
        jc.scenes.drive("08B", fidelity="spans", model=jc.scenes.ChainModel(cushion=(RING, None)))
    laid = jc.scenes.engagement("08B", Z, model=jc.scenes.ChainModel(settle=False, cushion=RING))
    with pytest.raises(ValueError, match="cushion rings already"):
        jc.elements.CushionContacts.attach(laid, RING, CHAIN)
