"""The 18-tooth engagement strand at 1000 rpm, settled: the peak-force record against its
independent read-back and under tolerance refinement, the settled start, exact contact
slots, failures as values, no retrace."""

import dataclasses
import math

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._dynamics import forces, initial_state

from helpers import (
    brute_parabola_max,
    count_vector_field_calls,
    fixed_step_joints,
    own_program_store,
    tooth_period,
)


def _with_slots(scene, slots):
    sprockets = tuple(
        dataclasses.replace(s, contact_slots=n) for s, n in zip(scene.sprockets, slots, strict=True)
    )
    return eqx.tree_at(lambda sc: sc.sprockets, scene, sprockets)


@pytest.fixture(scope="module")
def engagement18():
    return jc.scenes.engagement("08B", 18, speed_rpm=1000, n_entry=8)


def test_peak_force_self_converges(engagement18):
    """Peak roller/tooth force as the tolerance tightens, against rtol 1e-9: the default
    1e-6 within 0.1 %, 1e-4 within 1 % (measured −0.005 %, +0.42 %; 1e-8: +0.008 %). The
    step ends alone would miss the top of the impact by −0.28 % to −0.84 % at the
    default, depending on where ~1800 step ends fall on it."""
    T = tooth_period(1000, 18)
    peaks = {
        rtol: float(
            jc.simulate(engagement18, 2 * T, rtol=rtol, atol=rtol * 1e-3).peak_contact_force
        )
        for rtol in (1e-4, 1e-6, 1e-9)
    }
    ref = peaks[1e-9]
    assert abs(peaks[1e-6] - ref) < 1e-3 * ref
    assert abs(peaks[1e-4] - ref) < 1e-2 * ref


def test_peak_record_is_the_top_of_parabolas_through_quarter_step_samples(engagement18):
    """With fixed steps the recorded peak is the largest top of the parabolas through each
    step's consecutive samples at quarter steps (dense-output states), read back
    independently by saving at those times and maximizing each parabola by brute force.
    At this step (4.1 µs, through the first meshing impact, whose force rises over ~5 µs)
    the samples alone are 0.29 % below the top of this solve's own dense output (the
    best of them falls on a step end), the parabolas 0.14 % above (the pulse is
    lopsided); measured with the joints' friction (frictionless: samples 0.53 % below,
    parabolas 0.12 % above, step ends alone 5 % below)."""
    dt, n = 4.1e-6, 1000
    fixed = dict(solver=diffrax.Tsit5(), stepsize_controller=diffrax.ConstantStepSize(), dt0=dt)
    engagement18 = eqx.tree_at(lambda s: s.joint_friction.law, engagement18, fixed_step_joints())
    k = jc.observers.PeakRecord().samples
    # saving at the samples' own times adds only values the step tops already bound
    quarter = jc.simulate(engagement18, n * dt, ts=dt * np.arange(k * n + 1) / k, **fixed)
    f = np.asarray(quarter.roller_sprocket_force)  # (k n + 1, R)
    # each consecutive triple's parabola, maximized on its own span by brute force,
    # (k n - 1, R): triples centred on sample 1 … k n - 1
    tops = brute_parabola_max(f[:-2], f[1:-1], f[2:])
    inside = np.arange(1, k * n) % k != 0  # ... but never across a step's end
    recorded = float(quarter.peak_contact_force)
    np.testing.assert_allclose(recorded, tops[inside].max(), rtol=1e-8)
    # the top of this solve's dense output, on 4001 times across the best step
    j = int(np.argmax(tops[inside].max(axis=1)))
    step = np.flatnonzero(inside)[j] // k  # the step holding that triple's centre
    fine = jc.simulate(engagement18, n * dt, ts=dt * (step + np.linspace(0, 1, k * n + 1)), **fixed)
    top = float(np.asarray(fine.roller_sprocket_force).max())
    samples = f.max()
    assert abs(recorded / top - 1) < 2e-3
    assert top - samples > 1.5 * abs(top - recorded)
    assert recorded >= samples  # never below the samples


def test_engagement_starts_in_equilibrium(engagement18):
    """Settled start: the anchors pull with exactly their tensions, rollers are seated (in
    contact) on the wrap, and the first tooth period has no start-up shock."""
    sc = engagement18
    fr = forces(0.0, initial_state(sc), sc)  # moving: transport velocities, guides moving
    # what is left is damping from the transport velocities' polygonal mismatch, and the
    # friction of the joints articulating where the spans meet the wrap (running, not a
    # shock): at most μ·T·r/p per link end, 17 N at 1000 N, on each of a joint's links
    frictionless = eqx.tree_at(lambda s: s.joint_friction, sc, None)
    rest = forces(0.0, initial_state(sc), frictionless)
    assert float(jnp.max(jnp.abs(rest.body))) < 0.02 * 1000.0
    couple = 0.1 * 1000.0 * jc.ChainSpec.iso606("08B").pin_diameter / 2 / 0.0127
    assert float(jnp.max(jnp.abs(fr.body - rest.body))) < 3 * couple
    tension = np.asarray(fr.element_tension)
    np.testing.assert_allclose(tension[0], 1000.0, rtol=0.02)
    np.testing.assert_allclose(tension[-1], 100.0, rtol=0.05)
    assert int(jnp.sum(fr.roller_normal > 1.0)) >= 3


def test_failures_are_values(engagement18):
    """Bad options are refused before anything is traced; failed solves come back as
    result codes (every failure mode, on a strand small enough to compile quickly, and the
    same codes from the design objective's solve: tests/test_failures.py)."""
    T = tooth_period(1000, 18)
    with pytest.raises(ValueError, match="dt0"):
        jc.simulate(engagement18, T, stepsize_controller=diffrax.ConstantStepSize())
    with pytest.raises(ValueError, match="t1 must be > t0"):
        jc.simulate(engagement18, 0.0)


def test_second_call_does_not_retrace(engagement18, monkeypatch, tmp_path):
    """A new speed and end time reuse the first call's program: the second call traces
    nothing (checked against a program store of its own: a retraced program another run
    stored would be read back unseen)."""
    calls = count_vector_field_calls(monkeypatch)
    T = tooth_period(1000, 18)
    sc2 = jax.tree_util.tree_map(lambda x: x, engagement18)
    sc2 = eqx.tree_at(lambda s: s.sprockets[0].speed, sc2, jnp.asarray(110.0))
    # (weakly typed on purpose: simulate canonicalizes dtypes so this does not retrace)
    # default options: the solve test_peak_force_self_converges compiles
    jc.simulate(engagement18, 0.2 * T)
    own_program_store(monkeypatch, tmp_path)
    n = len(calls)
    jc.simulate(sc2, 0.3 * T)  # new speed, new t1: same structure
    assert len(calls) == n


def test_contact_slots_are_exact_and_checked(engagement18):
    """Checking only the nearest rollers changes nothing (the others' force is exactly 0);
    too few slots is reported, not silently wrong."""
    T = tooth_period(1000, 18)
    # every roller checked is the scene as built (the solve test_peak_force_self_converges
    # compiles: default options)
    assert engagement18.sprockets[0].contact_slots is None
    b = jc.simulate(engagement18, T)
    # the forces with 12 slots and with every roller, at the start, at the end of a tooth
    # period, and with the teeth turned a quarter and a half gap under the rollers (the
    # field, not a solve: one compile less, the same claim at every state a solve visits)
    y0 = initial_state(engagement18)
    turned = [
        y._replace(theta=y.theta + f * 2 * math.pi / 18) for y in (y0, b.y1) for f in (0, 0.25, 0.5)
    ]
    ys = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *turned)
    field = jax.jit(jax.vmap(lambda y, sc: forces(0.0, y, sc), in_axes=(0, None)))
    few, every = field(ys, _with_slots(engagement18, [12])), field(ys, engagement18)
    assert float(jnp.max(every.roller_normal)) > 100.0  # rollers are in contact
    np.testing.assert_array_equal(few.roller_normal, every.roller_normal)
    np.testing.assert_allclose(few.body, every.body, rtol=0, atol=1e-9)
    bad = jc.simulate(_with_slots(engagement18, [3]), T, throw=False)
    assert bad.result == jc.Result.contact_slots_exceeded
    assert "contact_slots" in bad.message
