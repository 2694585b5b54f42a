"""How a design objective combines its members (jc.design reductions): each against its
closed form, the names ``combine`` takes, a reduction of the user's own, and the older
``member_temperature`` spelling (no solve: the reductions act on the members' values)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._design.objective import _combine

VALUES = jnp.asarray([1.0, 2.0, 4.0])


def test_each_reduction_is_its_closed_form():
    assert float(jc.design.Mean()(VALUES)) == pytest.approx(7.0 / 3.0, rel=1e-15)
    assert float(jc.design.Worst()(VALUES)) == 4.0
    tau = 0.7
    lme = tau * (math.log(sum(math.exp(v / tau) for v in (1.0, 2.0, 4.0))) - math.log(3.0))
    assert float(jc.design.SoftMax(tau)(VALUES)) == pytest.approx(lme, rel=1e-14)
    # its gradient: the members' softmax weights at τ
    weights = np.exp(np.asarray(VALUES) / tau)
    np.testing.assert_allclose(
        jax.grad(jc.design.SoftMax(tau))(VALUES), weights / weights.sum(), rtol=1e-13
    )
    # the two limits: the largest member (cold), the mean (hot, to first order in 1/τ)
    assert float(jc.design.SoftMax(1e-3)(VALUES)) == pytest.approx(4.0 - 1e-3 * math.log(3.0))
    assert float(jc.design.SoftMax(1e4)(VALUES)) == pytest.approx(7.0 / 3.0, abs=1e-3)


def _objective(**kwargs):
    space = jc.design.DesignSpace.iso606("08B", 18)
    return jc.design.ProfileObjective(space, lambda p: None, t1=1e-3, temperature=30.0, **kwargs)


def test_combine_takes_names_reductions_and_the_older_spelling():
    assert isinstance(_objective().config.reduction, jc.design.Mean)
    assert isinstance(_objective(combine="worst").config.reduction, jc.design.Worst)
    soft = _objective(combine="max").config.reduction
    assert isinstance(soft, jc.design.SoftMax) and float(soft.temperature) == 30.0
    own = _objective(combine=jc.design.SoftMax(0.5)).config.reduction
    assert float(own.temperature) == 0.5
    with pytest.warns(DeprecationWarning, match=r"combine=jc.design.SoftMax\(τ\)"):
        older = _objective(combine="max", member_temperature=0.5).config.reduction
    assert float(older.temperature) == 0.5
    with pytest.raises(ValueError, match="combine must be one of 'mean', 'max', 'worst'"):
        _objective(combine="min")
    with pytest.raises(TypeError, match="jc.design reduction"):
        _objective(combine=np.max)
    with pytest.raises(ValueError, match="SoftMax.temperature"):
        jc.design.SoftMax(-1.0)


class Weighted(jc.design.AbstractReduction):
    """A weighted mean: a reduction of the user's own."""

    weights: jax.Array

    def __call__(self, values):
        return jnp.sum(self.weights * values) / jnp.sum(self.weights)


def test_a_reduction_of_ones_own_combines_the_members():
    obj = _objective(combine=Weighted(jnp.asarray([1.0, 0.0, 1.0])))
    assert float(_combine(VALUES, obj.config)) == 2.5
