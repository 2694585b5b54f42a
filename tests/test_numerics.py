"""The peak record's per-step estimate, :func:`jaxchain._numerics.parabola_max`, against a
brute-force maximum; continuous where its two forms meet, finite gradients everywhere,
NaN kept; the recorder's sample count checked."""

import jax
import numpy as np
import pytest

from jaxchain._numerics import parabola_max
from jaxchain.observers import PeakRecord

from helpers import brute_parabola_max

_grad = jax.jit(jax.vmap(jax.grad(lambda f: parabola_max(f[0], f[1], f[2]))))


def test_equals_the_parabola_maximum_and_never_below_a_sample():
    f = np.random.default_rng(0).normal(size=(3, 4000))
    got = np.asarray(parabola_max(*f))
    # grid error ≤ |a| (1e-4)² for a ~ 1
    np.testing.assert_allclose(got, brute_parabola_max(*f, n=20001), atol=1e-7)
    assert np.all(got >= f.max(axis=0))


def test_a_sampled_smooth_peak_converges_as_h_cubed():
    """f(t) = exp(−t²/2) − t³/6 around its top; samples at spacing h, the top's grid
    position offset: the samples' error falls as h², the parabola's as h³."""
    f = lambda t: np.exp(-0.5 * t**2) - t**3 / 6  # noqa: E731
    t_fine = np.linspace(-0.5, 0.5, 200001)
    top = f(t_fine).max()
    errs = {}
    for h in (0.4, 0.2, 0.1):
        c = 0.37 * h  # the top sits off-centre in the triple
        samples = f(np.array([-h, 0.0, h]) - c)
        errs[h] = (top - samples.max(), abs(float(parabola_max(*samples)) - top))
    (s4, p4), (s2, p2), (s1, p1) = errs[0.4], errs[0.2], errs[0.1]
    assert 3.0 < s4 / s2 < 5.0 and 3.0 < s2 / s1 < 5.0  # h²
    assert 6.0 < p4 / p2 < 10.0 and 6.0 < p2 / p1 < 10.0  # h³
    assert p1 < 0.1 * s1  # measured 0.084 at h = 0.1


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_continuous_where_the_vertex_leaves_the_step(side):
    """At −2a = |b| the vertex sits on the step's end: both forms give that end's value;
    values and gradients on either side of the switch differ by O(distance)."""
    b, fm = side * 0.8, 1.0
    a = -abs(b) / 2 + np.array([-1e-9, 0.0, 1e-9])  # vertex inside, on the end, outside
    f0, f1 = fm - b + a, fm + b + a  # fm + b s + a s² at s = ∓1
    v = np.asarray(parabola_max(f0, np.full(3, fm), f1))
    assert np.ptp(v) < 1e-8
    g = np.asarray(_grad(np.stack([f0, np.full(3, fm), f1], axis=1)))
    assert np.max(np.abs(g[0] - g[2])) < 1e-6


def test_gradients_finite_everywhere_and_match_central_differences():
    rng = np.random.default_rng(1)
    f = rng.normal(size=(2000, 3))
    special = np.array(
        [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.5, 1.0], [1.0, 0.0, 1.0]]
    )
    g = np.asarray(_grad(np.concatenate([f, special])))
    assert np.all(np.isfinite(g)) and np.max(np.abs(g)) <= 1.0 + 1e-12
    # central differences away from the kinks (max of the end samples, form switch)
    eps = 1e-6
    fd = np.stack(
        [
            (
                np.asarray(parabola_max(*(f + eps * np.eye(3)[i]).T))
                - np.asarray(parabola_max(*(f - eps * np.eye(3)[i]).T))
            )
            / (2 * eps)
            for i in range(3)
        ],
        axis=1,
    )
    b = 0.5 * (f[:, 2] - f[:, 0])
    a = 0.5 * (f[:, 0] + f[:, 2]) - f[:, 1]
    smooth = (np.abs(-2 * a - np.abs(b)) > 1e-3) & (np.abs(f[:, 0] - f[:, 2]) > 1e-3)
    np.testing.assert_allclose(g[: len(f)][smooth], fd[smooth], atol=1e-6)


def test_nan_in_any_sample_is_kept():
    for i in range(3):
        f = [0.0, 1.0, 0.5]
        f[i] = np.nan
        assert np.isnan(parabola_max(*f))


def test_peak_record_needs_a_start_an_interior_and_an_end_sample():
    assert PeakRecord(samples=2).samples == 2
    for bad in (1, 0, 2.0):
        with pytest.raises(ValueError, match="samples must be an int >= 2"):
            PeakRecord(samples=bad)
