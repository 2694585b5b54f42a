"""The normal contact law protocol: a law defined in this file alone, which gives only its
normal force, acts at a drive's rollers; its stored energy (the protocol's default
potential) closes the energy balance and the statics settle on it. (Friction laws:
``test_friction_protocol.py``.)"""

import jax
import jax.numpy as jnp
import numpy as np

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import FREE_DRIVE, energy_balance_error, modelled, tooth_period


class Quadratic(jc.contact.AbstractContactLaw):
    """F = K·δ² for δ > 0, undamped: a law that gives only its normal force."""

    stiffness: jax.Array

    def normal_force(self, depth, depth_rate, impact_speed):
        return self.stiffness * jnp.maximum(jnp.asarray(depth), 0.0) ** 2


def test_a_normal_law_of_its_own_keeps_the_energy_and_settles():
    """Undamped, the rollers' stored energy (``potential``'s default quadrature of the
    law's force, ∫K·δ² = K·δ³/3) closes the energy balance to 2e-4 of the work (the
    drive's own closes to 6e-5 over these 8001 saves); the statics settle the drive on it
    (their stable step from the law's tangent stiffness)."""
    law = Quadratic(jnp.asarray(1e13))
    np.testing.assert_allclose(law.potential(jnp.asarray(2e-5)), 1e13 * 8e-15 / 3, rtol=1e-12)
    np.testing.assert_allclose(law.potential(jnp.asarray(-1e-6)), 0.0, atol=0)
    scene = jc.scenes.drive(
        "08B", **modelled(**FREE_DRIVE, model=jc.scenes.ChainModel(roller_contact=law))
    )
    assert isinstance(scene.roller_law, Quadratic)
    err, scale = energy_balance_error(scene, 0.5 * tooth_period(600, 9), 8001)
    assert scale > 1e-3
    assert err < 2e-4, err
    y = initial_state(scene)
    body = jax.jit(forces)(0.0, y, scene).body
    assert float(jnp.abs(body[:, :2]).max()) < 1e-3  # N: settled by its builder
