"""The peak record samples a step's interior only where the record can be reached (its
gate), and reads the same peak as sampling every step."""

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc

from helpers import tooth_period

GATED = jc.observers.PeakRecord()


def needed(f_last, f0, f1, peak, h=1.0, h_last=1.0):
    """The gate for one roller whose force was f_last, f0, f1 at t0 − h_last, t0, t0 + h."""
    state = (jnp.asarray(peak), jnp.asarray([f0]), jnp.asarray([f_last]), jnp.asarray(h_last))
    return bool(GATED.interior_needed(jnp.asarray(h), jnp.asarray([f1]), state))


def test_the_gate_samples_where_a_parabola_through_the_ends_can_reach_the_record():
    # a force on the parabola f(t) = 100 − 20 (t − 0.5)²: 95 at t = −1... it peaks at
    # t = 0.5 inside the step [0, 1] at 100, above both ends (95); f'' = −40, so the
    # interior exceeds the ends by |f''|·h²/8 = 5 N
    f = lambda t: 100 - 20 * (t - 0.5) ** 2
    assert needed(f(-1.0), f(0.0), f(1.0), peak=99.0)  # top 100 > record 99
    assert needed(f(-1.0), f(0.0), f(1.0), peak=115.0)  # within the 8× safety: 95 + 40
    assert not needed(f(-1.0), f(0.0), f(1.0), peak=140.0)  # out of reach even with it
    # a seated roller: steady force far below the record
    assert not needed(300.0, 300.0, 300.0, peak=1000.0)
    assert needed(300.0, 300.0, 1000.0, peak=1000.0)  # an end at the record
    assert needed(300.0, 300.0, 300.0, peak=1000.0, h_last=0.0)  # the first step
    assert needed(300.0, 300.0, float("nan"), peak=1000.0)  # NaN is read, never skipped


@pytest.fixture(scope="module")
def strand():
    sc = jc.scenes.engagement("08B", 18, n_entry=3, n_exit=2, wrap=9)
    return sc, 1.5 * tooth_period(1000.0, 18)  # an engagement's impact and its top


@pytest.mark.slow  # a solve program of its own (the every-step record): ~10 s
def test_the_gated_peak_is_the_every_step_peak(strand):
    """On the meshing strand the gated record reads the peak that sampling every step
    reads (both 1686.256 N over 6 tooth periods in ``benchmarks/step_cost.py``, with 39
    of 9104 steps sampled)."""
    sc, t1 = strand
    gated = jc.simulate(sc, t1, n_save=2)
    every = jc.simulate(sc, t1, n_save=2, observers=(jc.observers.PeakRecord(gate=False),))
    assert every.observed[0] == every.peak_contact_force  # the record given is the one read
    assert int(gated.stats["num_steps"]) == int(every.stats["num_steps"])
    np.testing.assert_allclose(
        float(gated.peak_contact_force),
        float(every.peak_contact_force),
        rtol=1e-10,  # rounding
    )
