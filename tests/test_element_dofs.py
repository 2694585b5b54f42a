"""Force elements with coordinates of their own (``AbstractElement.n_dofs``): an idler on
a sprung linear slide, defined in this file alone, moves with the drive, settles with it
in the statics, keeps the energy balance closed and starts where it settled; the
tensioner arm is such an element too."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import FREE_DRIVE, energy_balance_error, modelled, tooth_period


class SlideIdler(jc.elements.AbstractElement):
    """A plain idler wheel of radius ``radius`` on a linear slide: its centre is
    c(s) = ``centre`` + s·``direction`` (s: its one coordinate [m]), pushed toward the
    chain by a preloaded spring, F = preload − stiffness·s − damping·ṡ [N]. The chain's
    rollers press on its rim through a Hertz-type law f = K·δ^1.5 (δ: overlap of roller
    and rim), without friction; the wheel's spin is not modelled."""

    centre: jax.Array
    direction: jax.Array
    radius: jax.Array
    mass: jax.Array
    stiffness: jax.Array
    damping: jax.Array
    preload: jax.Array
    contact: jax.Array
    start: jax.Array

    def n_dofs(self, scene):
        return 1

    def dof_inertia(self, scene):
        return self.mass[None]

    def dof_start(self, scene):
        return self.start[None], jnp.zeros(1)

    def with_dof_start(self, position):
        return eqx.tree_at(lambda e: e.start, self, position[0])

    def force_scale(self, scene):
        return self.preload

    def _contacts(self, y, scene, state):
        x, _ = jc.roller_kinematics(y, scene)
        d = x - (self.centre + state.position[0] * self.direction)
        gap = jnp.sqrt(jnp.sum(d * d, -1))
        n = d / gap[:, None]
        overlap = jnp.maximum(self.radius + scene.roller_radius - gap, 0.0)
        return x, n, overlap

    def effect(self, t, y, scene, state):
        x, n, overlap = self._contacts(y, scene, state)
        f = self.contact * overlap**1.5  # (R,) on each roller along n
        push = f[:, None] * n
        lever = x - y.q[scene.roller_body, :2]
        torque = lever[:, 0] * push[:, 1] - lever[:, 1] * push[:, 0]
        body = jnp.zeros_like(y.q)
        body = body.at[scene.roller_body, :2].add(push).at[scene.roller_body, 2].add(torque)
        spring = self.preload - self.stiffness * state.position - self.damping * state.rate
        on_wheel = -jnp.sum(push @ self.direction)
        return jc.elements.Effect(
            body=body, dof_force=spring + on_wheel, report={"idler_slide": state.position}
        )

    def energy(self, t, y, scene, state=None):
        _, _, overlap = self._contacts(y, scene, state)
        s = state.position[0]
        return (
            0.5 * self.stiffness * s**2
            - self.preload * s
            + jnp.sum(0.4 * self.contact * overlap**2.5)
        )

    def outputs(self, t, y, scene, effect):
        return {"idler_slide": effect.report["idler_slide"][0]}

    def max_stiffness(self, scene, force):
        return 1.5 * self.contact ** (2 / 3) * force ** (1 / 3)


RIM = 0.02  # m


def _idler(scene, *, damping=0.0, preload=10.0):
    """Under the lower strand of ``FREE_DRIVE``, 0.1 mm short of its rollers at the start,
    pushing up."""
    x, _ = jc.roller_kinematics(initial_state(scene), scene)
    below = x[6:18]  # the lower strand between the sprockets
    at = 0.085
    k = int(jnp.argmin(jnp.abs(below[:, 0] - at)))
    touch = below[k, 1] - RIM - scene.roller_radius
    return SlideIdler(
        centre=jnp.array([below[k, 0], touch - 1e-4]),
        direction=jnp.array([0.0, 1.0]),
        radius=jnp.asarray(RIM),
        mass=jnp.asarray(0.02),
        stiffness=jnp.asarray(1e3),
        damping=jnp.asarray(damping),
        preload=jnp.asarray(preload),
        contact=jnp.asarray(1e9),
        start=jnp.asarray(0.0),
    )


@pytest.fixture(scope="module")
def free_drive():
    return jc.scenes.drive("08B", **modelled(**FREE_DRIVE))


def test_the_idler_moves_and_keeps_the_energy_balance(free_drive):
    """Undamped, the idler's spring, contacts and motion are in the stored and kinetic
    energy: Δ(energy) = driver work − load work to 2e-4 of the work (the drive's own
    balance, from the trapezoid rule over 8001 saves, closes to 6e-5), over half a tooth
    period in which the idler, preloaded and free, moves up to the strand and pushes it.
    Without its kinetic energy or its own energy the balance misses by far more."""
    scene = free_drive.add_elements(_idler(free_drive))
    y0 = initial_state(scene)
    assert y0.dof.shape == (1,) and float(y0.dof[0]) == 0.0
    err, scale = energy_balance_error(scene, 0.5 * tooth_period(600, 9), 8001)
    assert scale > 1e-3
    assert err < 2e-4, err
    # the preload, unopposed at the start (0.1 mm short of the strand), accelerates it
    rate = jax.jit(jc.vector_field)(0.0, y0, scene)
    np.testing.assert_allclose(rate.dof_rate, [10.0 / 0.02], rtol=1e-12)
    np.testing.assert_allclose(rate.dof, [0.0], atol=0)


def test_the_idler_settles_with_the_chain_and_starts_there(free_drive):
    """The statics move the idler with the chain: settled, its spring balances the
    strand's push (its coordinate's force ≈ 0), the idler carries its preload less the
    spring's give, and that push is the resultant of the two span tensions beside it,
    |T₁·u₁ − T₂·u₂| (the closed form of a frictionless pulley); the scene starts there.
    (The test above runs the idler in the drive's dynamics.)"""
    scene = jc.scenes.equilibrate(free_drive.add_elements(_idler(free_drive, damping=20.0)))
    idler = scene.elements[-1]
    y = initial_state(scene)
    s = float(y.dof[0])
    assert s > 1e-4  # it moved up into the strand (from 0.1 mm short of it)
    np.testing.assert_allclose(float(idler.start), s, rtol=0)
    fr = jax.jit(forces)(0.0, y, scene)
    push = 10.0 - 1e3 * s  # the spring's force at rest
    assert abs(float(fr.dof_force[0])) < 1e-4 * push
    # the strand's resultant on the idler from the links beside its contacts
    tension = np.asarray(scene.link_weights @ fr.element_tension)
    x = np.asarray(jc.roller_kinematics(y, scene)[0])
    gap = np.hypot(*(x - np.asarray(idler.centre + s * idler.direction)).T)
    touching = np.flatnonzero(gap < RIM + float(scene.roller_radius))
    assert touching.size >= 1
    a, b = touching.min(), touching.max()  # link i joins rollers i and i + 1
    u_in = (x[a] - x[a - 1]) / np.linalg.norm(x[a] - x[a - 1])
    u_out = (x[b + 1] - x[b]) / np.linalg.norm(x[b + 1] - x[b])
    resultant = np.linalg.norm(tension[b] * u_out - tension[a - 1] * u_in)
    np.testing.assert_allclose(resultant, push, rtol=2e-3)


def test_an_element_with_coordinates_must_say_their_inertia(free_drive):
    """An element that declares coordinates but no inertia is told what to add."""

    class Bare(jc.elements.AbstractElement):
        def n_dofs(self, scene):
            return 2

        def effect(self, t, y, scene, state):
            return jc.elements.Effect(body=jnp.zeros_like(y.q))

    scene = free_drive.add_elements(Bare())
    with pytest.raises(TypeError, match="initial_state: Bare declares .*dof_inertia"):
        initial_state(scene)


def test_old_state_names_still_work_with_a_warning():
    """``DriveState.arm``/``arm_rate`` are the former names of ``dof``/``dof_rate``."""
    z = jnp.zeros((1, 3))
    with pytest.warns(DeprecationWarning, match="DriveState.dof"):
        y = jc.DriveState(z, z, jnp.zeros(1), jnp.zeros(1), arm=jnp.ones(2))
    np.testing.assert_array_equal(y.dof, [1.0, 1.0])
    with pytest.warns(DeprecationWarning, match="dof_rate"):
        assert y.arm_rate is None
    with pytest.raises(TypeError, match="not both"), pytest.warns(DeprecationWarning):
        jc.DriveState(z, z, jnp.zeros(1), jnp.zeros(1), dof=jnp.ones(1), arm=jnp.ones(1))
