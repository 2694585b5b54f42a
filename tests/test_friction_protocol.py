"""The friction-law protocol: a law defined in this file alone, behind
``jc.contact.AbstractFrictionLaw``, drives the joints of both chain fidelities exactly as
the built-in law it re-implements (its states kept and integrated by the joints), and a
law with two states per contact is routed through the drive state too; so is a user's law
with states at the roller/tooth contacts."""

import dataclasses
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

DAHL = jc.scenes.CLEARANCE_JOINT_FRICTION


class MyDahl(jc.contact.AbstractFrictionLaw):
    """Dahl's law with LuGre's bristle damping, written from its formula (not the
    library's code): F = −μ·N·(z + τ·ż)/x_s, ż = v − √(v² + ε²)·z/x_s."""

    mu: float
    xs: float
    eps: float
    tau: float
    states_per_contact: ClassVar[int] = 1

    def state_rate(self, state, slip_velocity):
        return slip_velocity - jnp.sqrt(slip_velocity**2 + self.eps**2) * state / self.xs

    def traction(self, normal_force, slip_velocity, state):
        zdot = self.state_rate(state, slip_velocity)
        return -self.mu * normal_force * (state + self.tau * zdot) / self.xs


class TwoCopies(jc.contact.AbstractFrictionLaw):
    """Two states per contact: the Dahl deflection and a copy of it integrated alongside;
    the force is the mean of the two (equal when both start at zero)."""

    inner: MyDahl
    states_per_contact: ClassVar[int] = 2

    def state_rate(self, state, slip_velocity):
        return jnp.stack([self.inner.state_rate(state[:, i], slip_velocity) for i in (0, 1)], -1)

    def traction(self, normal_force, slip_velocity, state):
        f = [self.inner.traction(normal_force, slip_velocity, state[:, i]) for i in (0, 1)]
        return 0.5 * (f[0] + f[1])


MINE = MyDahl(mu=0.1, xs=5e-6, eps=1e-4, tau=5e-6)


@eqx.filter_jit
def _forces(scene, y):
    f = forces(0.0, y, scene)
    return f.body, f.bristle_rate, f.joint_friction_power


def _with_law(scene, law):
    """``scene`` with ``law`` as its joints' friction (lumped: the joint friction
    element; clearance: every clearance joint's contacts)."""
    if scene.joint_friction is not None:
        return eqx.tree_at(lambda s: s.joint_friction.law, scene, law)
    return dataclasses.replace(
        scene, pairs=tuple(eqx.tree_at(lambda g: g.element.friction, g, law) for g in scene.pairs)
    )


def _sliding(scene, seed=0):
    """The scene's start with its bodies turning at random rates and the joints' states
    loaded at random within the pre-sliding range."""
    y = initial_state(scene)
    key1, key2 = jax.random.split(jax.random.PRNGKey(seed))
    nb = y.bristle.shape[0]
    spin = 30.0 * jax.random.normal(key1, (y.v.shape[0],))
    if scene.fidelity == "lumped":  # point masses: turn the links by moving the rollers
        y = y._replace(v=y.v.at[:, 1].add(spin * 1e-2))
    else:
        y = y._replace(v=y.v.at[:, 2].add(spin))
    return y._replace(bristle=4e-6 * jax.random.uniform(key2, (nb,), minval=-1.0, maxval=1.0))


@pytest.mark.parametrize(
    "fidelity", ["lumped", pytest.param("clearance", marks=pytest.mark.slow)]
)  # the clearance joints' forces compile for ~14 s; their Dahl path: test_dahl_friction
def test_users_law_equals_builtin(fidelity):
    """At a state with sliding joints and loaded states, the user's law gives the built-in
    law's forces and state rates (lumped chain: the joints' friction moments; clearance
    chain: the pin/bush and bush/roller contacts), and their friction takes power."""
    scene = jc.scenes.engagement(
        "08B", 18, fidelity=fidelity, n_entry=3, model=jc.scenes.ChainModel(joint_friction=DAHL)
    )
    y = _sliding(scene)
    b_ref, r_ref, p_ref = _forces(scene, y)
    b_mine, r_mine, p_mine = _forces(_with_law(scene, MINE), y)
    assert float(p_ref) < -1e-3  # the joints' friction is in play at this state
    np.testing.assert_allclose(np.asarray(b_mine), np.asarray(b_ref), rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(np.asarray(r_mine), np.asarray(r_ref), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(float(p_mine), float(p_ref), rtol=1e-10)


def test_two_states_per_contact():
    """A law with two states per contact gets twice the drive-state entries, them as
    (contacts, 2) and its rates back in the drive state's layout: with both copies equal
    it matches the one-state law."""
    scene = jc.scenes.engagement(
        "08B", 18, n_entry=3, model=jc.scenes.ChainModel(joint_friction=DAHL)
    )
    y = _sliding(scene, 1)
    two = _with_law(scene, TwoCopies(MINE))
    y2 = y._replace(bristle=jnp.repeat(y.bristle, 2))
    b1, r1, _ = _forces(_with_law(scene, MINE), y)
    b2, r2, _ = _forces(two, y2)
    np.testing.assert_allclose(np.asarray(b2), np.asarray(b1), rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(np.asarray(r2), np.repeat(np.asarray(r1), 2), rtol=1e-12)
    assert initial_state(two).bristle.shape == (2 * y.bristle.shape[0],)


def test_stateful_law_at_the_teeth():
    """A user's law with states acts at the roller/tooth contacts too (one state per
    sprocket and roller): at a state with sliding rollers and loaded states it gives the
    built-in law's roller forces and state rates, and its friction takes power."""
    base = jc.scenes.engagement("08B", 18, n_entry=3, model=jc.scenes.ChainModel(friction=DAHL))
    y = _sliding(base)
    mine = eqx.tree_at(lambda s: s.friction, base, MINE)
    ref, got = _forces(base, y), _forces(mine, y)
    assert y.bristle.shape == (base.n_rollers,)  # the joints' Coulomb law keeps none
    np.testing.assert_allclose(np.asarray(got[0]), np.asarray(ref[0]), rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(np.asarray(got[1]), np.asarray(ref[1]), rtol=1e-10, atol=1e-14)
    assert float(jax.jit(forces)(0.0, y, mine).tooth_friction_power) < -1e-3
    with pytest.raises(TypeError, match="AbstractFrictionLaw"):
        jc.scenes.engagement("08B", 18, model=jc.scenes.ChainModel(joint_friction=0.1))
