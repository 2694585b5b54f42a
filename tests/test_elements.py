"""Force elements (``jc.elements``): a drive's forces are the sum of its elements, and an
element defined in this file alone (a spring-damper between two bodies) acts in the
dynamics, the energy, the outputs and the statics with no change anywhere else."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import effects, forces, initial_state

from helpers import FREE_DRIVE, energy_balance_error, tooth_period


class Tether(jc.elements.AbstractElement):
    """A linear spring-damper between the centres of bodies ``a`` and ``b``: tension
    k·(ℓ − ℓ₀) + c·ℓ̇ [N], energy ½k(ℓ − ℓ₀)², its tension saved as ``tether_tension``."""

    a: int = eqx.field(static=True)
    b: int = eqx.field(static=True)
    stiffness: jax.Array
    damping: jax.Array
    rest_length: jax.Array

    def _stretch(self, y):
        d = y.q[self.b, :2] - y.q[self.a, :2]
        length = jnp.sqrt(jnp.sum(d * d))
        u = d / length
        return length, u, jnp.dot(u, y.v[self.b, :2] - y.v[self.a, :2])

    def effect(self, t, y, scene, state):
        length, u, rate = self._stretch(y)
        f = (self.stiffness * (length - self.rest_length) + self.damping * rate) * u
        body = jnp.zeros_like(y.q).at[self.a, :2].add(f).at[self.b, :2].add(-f)
        return jc.elements.Effect(body=body)

    def energy(self, t, y, scene):
        length, _, _ = self._stretch(y)
        return 0.5 * self.stiffness * (length - self.rest_length) ** 2

    def outputs(self, t, y, scene, effect):
        length, u, rate = self._stretch(y)
        return {"tether_tension": self.stiffness * (length - self.rest_length)}

    def max_stiffness(self, scene, force):
        return self.stiffness


FREE = FREE_DRIVE


@pytest.fixture(scope="module")
def free_drive():
    return jc.scenes.drive("08B", **FREE)


def _tether(scene, k, c, a=3, b=10):
    """Between rollers a and b, stretched 0.1 mm beyond their start distance."""
    d = scene.q0[b, :2] - scene.q0[a, :2]
    rest = float(jnp.sqrt(jnp.sum(d * d))) - 1e-4
    return Tether(a, b, jnp.asarray(k), jnp.asarray(c), jnp.asarray(rest))


def test_forces_are_the_sum_of_the_elements(free_drive):
    """Every element's effect sums to the scene's forces; an added element adds its own."""
    y = initial_state(free_drive)
    names = [type(e).__name__ for e in free_drive.force_elements]
    assert names[0] == "PairGroup" and "RollerTeeth" in names and names[-1] == "Gravity"
    eff = jax.jit(effects)(0.0, y, free_drive)  # one program, not op by op
    total = sum(e.body for e in eff)
    # (a settled drive: the forces cancel to roundoff of its 300 N tensions)
    np.testing.assert_allclose(forces(0.0, y, free_drive).body, total, rtol=1e-10, atol=1e-7)
    tether = _tether(free_drive, 2e5, 50.0)
    with_tether = free_drive.add_elements(tether)
    assert with_tether.force_elements[-1] is tether
    v = jnp.asarray(np.random.default_rng(0).normal(scale=0.1, size=y.v.shape))
    yv = y._replace(v=v)
    added = forces(0.0, yv, with_tether).body - forces(0.0, yv, free_drive).body
    own = jax.jit(lambda y, s: tether.effect(0.0, y, s, None).body)(yv, with_tether)
    np.testing.assert_allclose(added, own, atol=1e-9)
    assert float(jnp.abs(added[3, :2]).max()) > 10.0  # N: it does act
    # its damper takes power out
    damper = _tether(free_drive, 0.0, 50.0)
    assert float(jax.jit(lambda y, s: damper.power(0.0, y, s))(yv, with_tether)) < 0.0
    with pytest.raises(TypeError, match="AbstractElement"):
        free_drive.add_elements("a spring")


def test_user_element_in_the_dynamics_energy_and_outputs(free_drive):
    """An undamped tether stores energy: the energy balance still closes (the stored
    energy includes its own); its outputs are saved; the statics settle against it and a
    simulation with it runs to the end."""
    tether = _tether(free_drive, 2e5, 0.0)
    scene = free_drive.add_elements(tether)
    err, scale = energy_balance_error(scene, 0.5 * tooth_period(600, 9), 2001)
    assert scale > 1e-3
    assert err < 1e-3, err
    settled = jc.scenes.equilibrate(scene)
    y0 = initial_state(settled)
    assert float(jnp.abs(forces(0.0, y0, settled).body[:, :2]).max()) < 1.0
    sol = jc.simulate(settled, tooth_period(600, 9), n_save=11)
    assert sol.result == jc.Result.successful
    assert sol.element_outputs["tether_tension"].shape == (11,)
    assert float(sol.element_outputs["tether_tension"][0]) > 0.0
