"""The NumPy port of the engagement field (benchmarks/scipy_engagement.py) is faithful:
it equals ``jc.vector_field`` to 1e-9 on states near the settled start, and its gap
geometry equals ``jc.gap_contact`` over every region of the tooth outline."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.flatten_util import ravel_pytree

import jaxchain as jc
from benchmarks.scipy_engagement import NumpyField, _Gap
from jaxchain._dynamics import initial_state


@pytest.fixture(scope="module")
def scene():
    # the port is of the frictionless-joint field
    return jc.scenes.engagement(
        "08B", 18, speed_rpm=1000, model=jc.scenes.ChainModel(joint_friction=None)
    )


def test_gap_geometry_matches(scene):
    prof = scene.sprockets[0].profile
    gap = _Gap(prof)
    for mine, ref in zip(gap.geometry(), prof.geometry()[:5], strict=True):
        np.testing.assert_allclose(mine, np.asarray(ref), rtol=1e-13, atol=1e-16)
    # points over a ring around the pitch circle, covering seat, flanks, tips, both
    # halves of every gap and the switch of nearest gap
    rng = np.random.default_rng(0)
    ang = rng.uniform(-np.pi, np.pi, 4000)
    rad = float(prof.pitch_radius) + rng.uniform(-1.5, 1.5, 4000) * float(prof.seating_radius)
    pts = np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1)
    depth, normal = jax.jit(jax.vmap(jc.gap_contact, in_axes=(None, 0)))(prof, pts)
    d2, nx, ny = gap.contact(pts[:, 0], pts[:, 1])
    np.testing.assert_allclose(d2, np.asarray(depth), rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.stack([nx, ny], -1), np.asarray(normal), rtol=0, atol=1e-12)


def test_vector_field_matches(scene):
    field = NumpyField(scene)
    y0 = initial_state(scene)
    flat0, unravel = ravel_pytree(y0)
    assert flat0.shape == (field.n_state,)
    jfield = jax.jit(lambda t, x: ravel_pytree(jc.vector_field(t, unravel(x), scene))[0])
    n = scene.n_bodies
    rng = np.random.default_rng(1)
    states, times = [np.asarray(flat0)], [0.0]
    for _ in range(12):
        x = np.asarray(flat0).copy()
        # positions ±30 µm (seat clearance is ~0.1 mm: contacts open, close, go deep),
        # velocities ±0.5 m/s, sprocket angle ±0.02 rad
        x[: 3 * n] += rng.normal(0, 3e-5, 3 * n)
        x[3 * n : 6 * n] += rng.normal(0, 0.5, 3 * n)
        x[6 * n] += rng.normal(0, 0.02)
        states.append(x)
        times.append(float(rng.uniform(0, 5e-3)))
    batch = field.rhs(0.0, np.stack(states[:1]))  # the batched form agrees with single
    np.testing.assert_array_equal(batch[0], field.rhs(0.0, states[0]))
    in_contact = 0
    for t, x in zip(times, states, strict=True):
        ref = np.asarray(jfield(jnp.asarray(t), jnp.asarray(x)))
        got = field.rhs(t, x)
        # per block (velocities, accelerations, sprocket rates): relative to its size
        for sl in (slice(0, 3 * n), slice(3 * n, 6 * n), slice(6 * n, None)):
            scale = max(np.max(np.abs(ref[sl])), 1e-300)
            np.testing.assert_allclose(got[sl], ref[sl], rtol=0, atol=1e-9 * scale)
        q = x[: 3 * n].reshape(n, 3)
        v = x[3 * n : 6 * n].reshape(n, 3)
        _, normal, _ = field.forces(t, q[None], v[None], x[None, 6 * n : 6 * n + 1], x[None, -1:])
        in_contact += int(np.sum(normal > 0))
    assert in_contact > 20  # the states do exercise the contact law
