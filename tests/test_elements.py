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

from helpers import FREE_DRIVE, energy_balance_error, modelled, tooth_period


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
    return jc.scenes.drive("08B", **modelled(**FREE))


def _tether(scene, k, c, a=3, b=10):
    """Between rollers a and b, stretched 0.1 mm beyond their start distance."""
    d = scene.q0[b, :2] - scene.q0[a, :2]
    rest = float(jnp.sqrt(jnp.sum(d * d))) - 1e-4
    return Tether(a, b, jnp.asarray(k), jnp.asarray(c), jnp.asarray(rest))


def test_forces_are_the_sum_of_the_elements(free_drive):
    """The scene's forces sum its elements, each part against a value found another way:
    on the settled drive the links' and the teeth's forces (hundreds of N a roller)
    cancel, and what the teeth push on the chain the sprockets take back (action and
    reaction); gravity adds m·g on every body; an added tether exactly its spring-damper
    force k·(ℓ − ℓ₀) + c·ℓ̇ along its line, computed here by hand."""
    y = initial_state(free_drive)
    names = [type(e).__name__ for e in free_drive.force_elements]
    assert names == ["PairGroup", "RollerTeeth", "Gravity"]
    eff = jax.jit(effects)(0.0, y, free_drive)  # one program, not op by op
    fr = forces(0.0, y, free_drive)
    body = np.asarray(fr.body)
    # links and teeth each push rollers with up to 461 N; their sum on the settled drive
    # is the statics' residual (measured 5.3e-8 N: roundoff of the 300 N tensions)
    assert min(float(jnp.abs(e.body).max()) for e in eff[:2]) > 400.0
    assert np.abs(body).max() < 1e-6
    # the chain's net force is minus the sprockets' (no gravity here): measured to 1e-13 N
    np.testing.assert_allclose(body[:, :2].sum(0), -np.asarray(fr.sprocket_force).sum(0), atol=1e-9)
    # gravity: m·g on each body, nothing else changes
    g = np.array([0.0, -9.81])
    heavy = eqx.tree_at(lambda s: s.gravity, free_drive, jnp.asarray(g))
    weight = np.asarray(forces(0.0, y, heavy).body) - body
    np.testing.assert_allclose(weight[:, :2], np.asarray(free_drive.mass)[:, None] * g, atol=1e-12)
    assert not weight[:, 2].any()

    tether = _tether(free_drive, 2e5, 50.0)
    with_tether = free_drive.add_elements(tether)
    assert with_tether.force_elements[-1] is tether
    v = np.random.default_rng(0).normal(scale=0.1, size=y.v.shape)
    yv = y._replace(v=jnp.asarray(v))
    added = np.asarray(forces(0.0, yv, with_tether).body - forces(0.0, yv, free_drive).body)
    # by hand: rollers 3 and 10 of the start, stretched 0.1 mm by construction
    q = np.asarray(y.q)
    d = q[10, :2] - q[3, :2]
    u = d / np.linalg.norm(d)
    f = (2e5 * 1e-4 + 50.0 * u @ (v[10, :2] - v[3, :2])) * u
    want = np.zeros_like(added)
    want[3, :2], want[10, :2] = f, -f
    # (the difference of two 461 N sums: roundoff ~1e-13 N)
    np.testing.assert_allclose(added, want, atol=1e-9)
    assert np.abs(f).max() > 10.0  # N: it does act
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
    # the tether's 20 N unsettle the start (19.5 N on a roller); settled, the residual
    # scales with the statics' tolerance: measured 4.9e-8 N at its default 1e-6, 1.5e-7 N
    # at 3e-6, 5.0e-7 N at 1e-5 (a statics stopping 3× early fails here)
    assert float(jnp.abs(forces(0.0, initial_state(scene), scene).body[:, :2]).max()) > 10.0
    assert float(jnp.abs(forces(0.0, y0, settled).body[:, :2]).max()) < 1.2e-7
    sol = jc.simulate(settled, tooth_period(600, 9), n_save=11)
    assert sol.result == jc.Result.successful
    assert sol.element_outputs["tether_tension"].shape == (11,)
    assert float(sol.element_outputs["tether_tension"][0]) > 0.0
