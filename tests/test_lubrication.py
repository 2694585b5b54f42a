"""Lubricated clearance joints (``lubrication=jc.contact.OilFilm(...)`` on the builders):
the film's forces on a joint's two bodies conserve momentum and angular momentum and only
dissipate, a lubricated scene settles where the dry one does (a film carries no load at
rest), the film damps a joint's approach where the dry joint rattles, and the builders
refuse a film where there is no clearance joint. The film law itself is checked against
the Reynolds equation in ``test_oil_film.py``."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces
from jaxchain._elements.pairs import ClearanceJoints, PairGroup

from helpers import modelled

OIL = jc.contact.OilFilm(viscosity=0.01)
C, R, L = 25e-6, 2.2e-3, 11e-3  # 08B pin in its bush [m]


def _joint(n_pairs=1):
    """A pin (body 0, at +x of its origin) in a hole (body 1, at its origin): film only
    (the dry law's clearance is so large that the contact never closes)."""
    law = jc.contact.JohnsonCylinder(
        clearance=jnp.asarray(1.0), length=jnp.asarray(L), modulus=jnp.asarray(1.1e11),
        restitution=jnp.asarray(0.7),
    )  # fmt: skip
    el = ClearanceJoints(
        law=law, clearance=jnp.asarray(C), radius=jnp.asarray(R), film=OIL,
        length=jnp.asarray(L),
    )  # fmt: skip
    return PairGroup(
        a=jnp.zeros(n_pairs, int), b=jnp.ones(n_pairs, int),
        ra=jnp.tile(jnp.array([[3e-3, 0.0]]), (n_pairs, 1)), rb=jnp.zeros((n_pairs, 2)),
        element=el, carries_tension=False,
    )  # fmt: skip


def _random_state(key):
    """Two bodies with the pin inside the clearance (|e| < c) and random velocities."""
    k1, k2, k3, k4 = jax.random.split(key, 4)
    phi = jax.random.uniform(k1, (2,), minval=-3.0, maxval=3.0)
    ecc = C * jax.random.uniform(k2, (), minval=0.05, maxval=0.85)
    ang = jax.random.uniform(k3, (), minval=-np.pi, maxval=np.pi)
    pin = jnp.array([3e-3 * jnp.cos(phi[0]), 3e-3 * jnp.sin(phi[0])])  # body 0's pin arm
    hole = jnp.array([0.01, -0.02])
    x0 = hole + ecc * jnp.array([jnp.cos(ang), jnp.sin(ang)]) - pin
    q = jnp.stack([jnp.concatenate([x0, phi[:1]]), jnp.concatenate([hole, phi[1:]])])
    v = jax.random.normal(k4, (2, 3)) * jnp.array([0.05, 0.05, 200.0])
    return q, v


def test_film_conserves_momentum_and_dissipates():
    """Over random states: the film's generalized forces on the pin's and the hole's bodies
    sum to zero force and zero moment about the origin (action = reaction, with the
    moments balanced by the shear torques), and their power is never positive."""
    group = _joint()
    film = eqx.filter_jit(lambda g, q, v: g.film_forces(2, g.state(q, v, 1.0)))
    powers = []
    for i in range(40):
        q, v = _random_state(jax.random.PRNGKey(i))
        gen = film(group, q, v)
        np.testing.assert_allclose(np.asarray(gen[:, :2].sum(0)), 0.0, atol=1e-9)
        moment = jnp.sum(q[:, 0] * gen[:, 1] - q[:, 1] * gen[:, 0] + gen[:, 2])
        scale = float(jnp.max(jnp.abs(gen[:, :2]))) * 0.03 + float(jnp.max(jnp.abs(gen[:, 2])))
        assert abs(float(moment)) <= 1e-9 * scale
        powers.append(float(jnp.sum(gen * v)))
    powers = np.asarray(powers)
    assert np.all(powers <= 1e-12 * np.abs(powers).max()), powers.max()
    assert powers.min() < -1e-3  # the film does dissipate


def test_film_is_blind_to_rigid_rotation():
    """The pin and its bush turning together as one rigid body (about any point, at 300
    rad/s) squeeze and shear nothing: no film force or torque, while the same pin
    spinning alone in a still bush does feel it."""
    group = _joint()
    for i in range(5):
        q, _ = _random_state(jax.random.PRNGKey(100 + i))
        pivot, rate = jnp.array([0.02, 0.01]), 300.0
        rel = q[:, :2] - pivot
        v = jnp.concatenate(
            [rate * jnp.stack([-rel[:, 1], rel[:, 0]], -1), jnp.full((2, 1), rate)], -1
        )
        gen = group.film_forces(2, group.state(q, v, 1.0))
        assert float(jnp.max(jnp.abs(gen))) < 1e-9
        alone = group.film_forces(2, group.state(q, v.at[1].set(0.0).at[0, :2].set(0.0), 1.0))
        assert float(jnp.max(jnp.abs(alone[:, :2]))) > 1e-3


def test_film_damps_approach_like_a_squeeze_film():
    """A pin approaching the bush wall radially at 0.1 m/s (no spin) through the middle of
    its clearance meets a force against its approach of the film's damping times that
    speed (the law's own squeeze damping at that eccentricity: the joint passes it on
    unchanged), on the pin and the opposite on the bush."""
    group = _joint()
    e = 0.3 * C
    q = jnp.array([[0.01 + e - 3e-3, 0.0, 0.0], [0.01, 0.0, 0.0]])
    v = jnp.array([[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]])
    gen = group.film_forces(2, group.state(q, v, 1.0))
    want = float(OIL.damping(0.3, C, R, L)) * 0.1
    np.testing.assert_allclose(float(-gen[0, 0]), want, rtol=1e-3)
    assert 0.5e3 * 0.1 < want < 5e3 * 0.1  # N: kN·s/m at ε = 0.3, 08B pin/bush
    np.testing.assert_allclose(float(gen[1, 0]), -float(gen[0, 0]), rtol=1e-12)


@pytest.fixture(scope="module")
def strands():
    kw = dict(speed_rpm=1000.0, fidelity="clearance", n_entry=4)
    return (
        jc.scenes.engagement("08B", 18, **modelled(**kw)),
        jc.scenes.engagement(
            "08B", 18, **modelled(**kw, model=jc.scenes.ChainModel(lubrication=OIL))
        ),
    )


def test_lubricated_strand_settles_where_the_dry_one_does(strands):
    """A film carries no load at rest: the lubricated strand's settled start is the dry
    strand's, and its joints carry the film (pin/bush and bush/roller, each with its own
    length)."""
    dry, wet = strands
    np.testing.assert_array_equal(np.asarray(wet.q0), np.asarray(dry.q0))
    films = [g.element.film for g in wet.pairs]
    assert len(films) == 2 and all(isinstance(f, jc.contact.OilFilm) for f in films)
    assert all(float(f.viscosity) == 0.01 for f in films)
    lengths = sorted(float(g.element.length) for g in wet.pairs)
    chain = jc.ChainSpec.iso606("08B")
    np.testing.assert_allclose(lengths[0], 0.95 * chain.inner_width)
    np.testing.assert_allclose(lengths[1], chain.inner_width + 2 * chain.plate_thickness)
    assert all(g.element.film is None for g in dry.pairs)


def test_lubricated_strand_runs_and_the_film_takes_power(strands):
    """A short lubricated solve succeeds with simulate's defaults, and at its end the
    joints' losses (contact friction and film) take power from the chain."""
    _, wet = strands
    sol = jc.simulate(wet, 2e-4, n_save=3)
    assert sol.ok, sol.message
    power = float(eqx.filter_jit(forces)(0.0, sol.y1, wet).joint_friction_power)
    assert power < 0.0


def test_builders_refuse_a_film_without_clearance_joints():
    with pytest.raises(ValueError, match="lubrication.*fidelity='clearance'"):
        jc.scenes.engagement("08B", 18, model=jc.scenes.ChainModel(lubrication=OIL))
    with pytest.raises(ValueError, match="lubrication"):
        jc.scenes.drive("08B", fidelity="spans", model=jc.scenes.ChainModel(lubrication=OIL))
    with pytest.raises(TypeError, match="lubrication"):
        jc.scenes.engagement(
            "08B", 18, fidelity="clearance", model=jc.scenes.ChainModel(lubrication=0.01)
        )
