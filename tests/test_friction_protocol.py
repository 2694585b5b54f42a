"""The friction-law protocol: a law defined in this file alone, behind
``jc.contact.AbstractFrictionLaw``, drives the joints of both chain fidelities exactly as
the built-in law it re-implements (its states kept and integrated by the joints), and a
law with two states per contact is routed through the drive state too."""

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


def _run(fidelity, law):
    scene = jc.scenes.engagement(
        "08B", 18, speed_rpm=1000.0, fidelity=fidelity, joint_friction=law, n_entry=3
    )
    return jc.simulate(scene, 2.0e-4, n_save=5)


def test_users_law_equals_builtin_lumped():
    """The same formula through the protocol gives the built-in law's solution (to the
    rounding of the two implementations), and the two-state law the one-state law's."""
    ref, mine = _run("lumped", DAHL), _run("lumped", MINE)
    assert ref.ok and mine.ok, (ref.message, mine.message)
    assert float(jnp.max(jnp.abs(ref.roller_velocity[-1] - ref.roller_velocity[0]))) > 0.1
    np.testing.assert_allclose(
        np.asarray(mine.roller_position), np.asarray(ref.roller_position), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        np.asarray(mine.link_tension), np.asarray(ref.link_tension), rtol=1e-8, atol=1e-6
    )
    two = _run("lumped", TwoCopies(MINE))
    np.testing.assert_allclose(
        np.asarray(two.roller_position), np.asarray(mine.roller_position), atol=1e-12
    )


@eqx.filter_jit
def _forces(scene, y):
    f = forces(0.0, y, scene)
    return f.body, f.bristle_rate


def test_users_law_equals_builtin_clearance_joints():
    """Clearance chain (pin/bush and bush/roller contacts): at a state with sliding joints
    and loaded bristles, the user's law gives the built-in law's forces and state rates."""
    scene = jc.scenes.engagement("08B", 18, fidelity="clearance", joint_friction=DAHL, n_entry=3)
    y = initial_state(scene)
    key1, key2 = jax.random.split(jax.random.PRNGKey(0))
    nb = y.bristle.shape[0]
    y = y._replace(
        v=y.v.at[:, 2].add(30.0 * jax.random.normal(key1, (y.v.shape[0],))),
        bristle=4e-6 * jax.random.uniform(key2, (nb,), minval=-1.0, maxval=1.0),
    )
    mine = eqx.tree_at(lambda s: s.pairs, scene, replace_fn=lambda ps: tuple(
        eqx.tree_at(lambda g: g.element.friction, g, MINE) for g in ps
    ))  # fmt: skip
    (b_ref, r_ref), (b_mine, r_mine) = _forces(scene, y), _forces(mine, y)
    friction_scale = float(jnp.max(jnp.abs(b_ref - _forces(_frictionless(scene), y)[0])))
    assert friction_scale > 1.0  # the joints' friction is in play at this state
    np.testing.assert_allclose(np.asarray(b_mine), np.asarray(b_ref), rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(np.asarray(r_mine), np.asarray(r_ref), rtol=1e-10, atol=1e-14)


def _frictionless(scene):
    return eqx.tree_at(lambda s: s.pairs, scene, replace_fn=lambda ps: tuple(
        eqx.tree_at(lambda g: g.element.friction, g, None, is_leaf=lambda x: x is None)
        for g in ps
    ))  # fmt: skip


def test_stateful_law_refused_at_rollers():
    """Roller/tooth contacts keep no states: a stateful law there is refused by name."""
    with pytest.raises(ValueError, match="keeps no friction states|keep no friction states"):
        jc.scenes.engagement("08B", 18, friction=MINE)
    with pytest.raises(TypeError, match="AbstractFrictionLaw"):
        jc.scenes.engagement("08B", 18, joint_friction=0.1)
