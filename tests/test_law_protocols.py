"""Contact and friction laws through their protocols: a normal law and a friction law with
a state of its own, each defined in this file alone, act in a drive. The normal law's
stored energy (the protocol's default potential) closes the energy balance and the
statics settle on it; the friction law runs in the joints exactly as the built-in law it
restates."""

from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import FREE_DRIVE, energy_balance_error, tooth_period


class Quadratic(jc.contact.AbstractContactLaw):
    """F = K·δ² for δ > 0, undamped: a law that gives only its normal force."""

    stiffness: jax.Array

    def normal_force(self, depth, depth_rate, impact_speed):
        return self.stiffness * jnp.maximum(jnp.asarray(depth), 0.0) ** 2


class Bristle(jc.contact.AbstractFrictionLaw):
    """Dahl's law with one state per contact: F = −μ·N·z/x_s, ż = v − √(v² + ε²)·z/x_s."""

    mu: jax.Array
    length: jax.Array
    creep: jax.Array
    states_per_contact: ClassVar[int] = 1

    def traction(self, normal_force, slip_velocity, state):
        return -self.mu * normal_force * state / self.length

    def state_rate(self, state, slip_velocity):
        return slip_velocity - jnp.sqrt(slip_velocity**2 + self.creep**2) * state / self.length


def test_a_normal_law_of_its_own_keeps_the_energy_and_settles():
    """Undamped, the rollers' stored energy (``potential``'s default quadrature of the
    law's force, ∫K·δ² = K·δ³/3) closes the energy balance to 2e-4 of the work (the
    drive's own closes to 6e-5 over these 8001 saves); the statics settle the drive on it
    (their stable step from the law's tangent stiffness)."""
    law = Quadratic(jnp.asarray(1e13))
    np.testing.assert_allclose(law.potential(jnp.asarray(2e-5)), 1e13 * 8e-15 / 3, rtol=1e-12)
    np.testing.assert_allclose(law.potential(jnp.asarray(-1e-6)), 0.0, atol=0)
    scene = jc.scenes.drive("08B", **FREE_DRIVE, roller_contact=law)
    assert isinstance(scene.roller_law, Quadratic)
    err, scale = energy_balance_error(scene, 0.5 * tooth_period(600, 9), 8001)
    assert scale > 1e-3
    assert err < 2e-4, err
    y = initial_state(scene)
    body = jax.jit(forces)(0.0, y, scene).body
    assert float(jnp.abs(body[:, :2]).max()) < 1e-3  # N: settled by its builder


def test_a_friction_law_of_its_own_acts_in_the_joints():
    """In the lumped chain's joints, a user's law with a state of its own gets its states
    (one per joint, integrated with its rate) and gives the same forces and state rates as
    the built-in law it restates (``DahlFriction`` without bristle damping), at a state
    with every joint sliding and deflected; a short simulation runs on it."""
    mu, xs, eps = 0.12, 4e-6, 1e-4
    mine = Bristle(jnp.asarray(mu), jnp.asarray(xs), jnp.asarray(eps))
    builtin = jc.contact.DahlFriction(mu, presliding=xs, creep_velocity=eps, damping=0.0)
    common = dict(FREE_DRIVE, joint_friction=None)
    a = jc.scenes.drive("08B", **dict(common, joint_friction=mine))
    b = jc.scenes.drive("08B", **dict(common, joint_friction=builtin))
    y = initial_state(a)
    assert y.bristle.shape == (a.n_links,)
    rng = np.random.default_rng(1)
    y = y._replace(
        v=jnp.asarray(rng.normal(scale=0.3, size=y.v.shape)),
        bristle=jnp.asarray(rng.uniform(-xs, xs, size=y.bristle.shape)),
    )
    fa, fb = jax.jit(forces)(0.0, y, a), jax.jit(forces)(0.0, y, b)
    assert float(jnp.abs(fa.joint_friction_power)) > 1e-3  # W: the friction acts
    np.testing.assert_allclose(fa.body, fb.body, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(fa.bristle_rate, fb.bristle_rate, rtol=1e-12, atol=1e-12)
    sol = jc.simulate(a, 0.2 * tooth_period(600, 9), n_save=3)
    assert sol.result == jc.Result.successful
