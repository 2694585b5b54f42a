"""The re-measurement library (``jc.design``): the second law's stiffness, the tight solve's
sharp peak against the solve's own exact peak record, an ensemble's worst member, and a
strand's per-engagement peaks."""

import math

import numpy as np
import pytest

import jaxchain as jc

from helpers import tooth_period


def test_the_second_law_is_hertz_on_a_flat_with_one_stiffness():
    """K = (4/3)·E*·√r, E* = E/(2(1 − ν²)) for steel on steel, r the roller radius."""
    law = jc.design.second_law("08B")
    e, nu = float(jc.STEEL.youngs_modulus), float(jc.STEEL.poisson_ratio)
    r = float(jc.ChainSpec.iso606("08B").roller_diameter) / 2
    k = 4 / 3 * e / (2 * (1 - nu**2)) * math.sqrt(r)
    np.testing.assert_allclose(float(law.stiffness), k, rtol=1e-12)
    assert float(law.exponent) == 1.5 and float(law.restitution) == 0.7


@pytest.fixture(scope="module")
def strand():
    # the main job's --fast re-measurement (its ISO problem in tests/test_main_job.py):
    # the same scene structure, window and saves, so one compiled solve serves both
    return jc.scenes.engagement("08B", 18, n_entry=3), tooth_period(1000.0, 18)


def test_the_sharp_peak_reads_the_top_the_solve_records(strand):
    """The dense saves' largest force over the window (≤ 0.5 µs apart, Dopri8) against the
    peak record of the same solve (parabolas through each step's samples, over the whole
    solve): the window holds the solve's top here, within 0.5 % (the most a top can fall
    between saves 0.5 µs apart), never above it."""
    sc, period = strand
    tight = jc.design.sharp_peak(sc, 2 * period, t_start=period, rtol=1e-6)
    assert tight["ok"] and tight["force"].shape == tight["ts"].shape
    assert np.diff(tight["ts"]).max() <= 0.5e-6 * (1 + 1e-9)
    assert tight["peak_N"] <= tight["record_N"] * (1 + 1e-12)
    np.testing.assert_allclose(tight["peak_N"], tight["record_N"], rtol=5e-3)
    both = jc.design.remeasure([sc, lambda: sc], 2 * period, t_start=period, rtol=1e-6)
    assert [m["peak_N"] for m in both["members"]] == [tight["peak_N"]] * 2  # bit for bit
    assert both["peak_N"] == both["mean_peak_N"] == tight["peak_N"]
    with pytest.raises(TypeError, match="sequence of scenes"):
        jc.design.remeasure(sc, 2 * period)


def test_a_strand_sample_holds_one_peak_per_engagement(strand):
    sc, _ = strand  # 3 entry rollers: the first period discarded, 1 engagement, 1 closing
    sample = jc.design.engagement_sample(sc, discard=1)
    assert sample["ok"], sample["message"]
    assert len(sample["peaks_N"]) == len(sample["populations"]) >= 1
    assert all(p > 0 for p in sample["peaks_N"])
    with pytest.raises(ValueError, match="meshing strand"):
        jc.design.engagement_sample(jc.scenes.drive(model=jc.scenes.ChainModel(settle=False)))
