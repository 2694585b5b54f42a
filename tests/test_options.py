"""The one set of solve options, its checks, and the result names and messages (no solves:
what every entry point shares)."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._solve.options import with_options
from jaxchain._solve.result import RESULT_NAMES


def test_every_result_has_a_name_and_a_message_with_a_fix():
    assert len(RESULT_NAMES) == len(jc.Result)
    for name in RESULT_NAMES:
        item = getattr(jc.Result, name)
        assert jc.result_names(item) == [name]
        message = jc.result_messages(item)[0]
        assert (message == "") == (name == "successful"), name


def test_result_names_of_a_batch():
    """A member axis, as ensembles and design objectives return results."""
    pick = lambda ok: jc.Result.where(ok, jc.Result.successful, jc.Result.max_steps_reached)
    batch = jax.vmap(pick)(jnp.array([True, False, True]))
    assert jc.result_names(batch) == ["successful", "max_steps_reached", "successful"]
    messages = jc.result_messages(batch)
    assert messages[0] == messages[2] == "" and "max_steps" in messages[1]


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        (dict(rtol=0.0), ValueError, r"rtol must be a finite number in \(0, 1\), got 0.0"),
        (dict(rtol=2.0), ValueError, r"rtol must be a finite number in \(0, 1\), got 2.0"),
        (dict(atol=float("nan")), ValueError, r"atol must be a finite number > 0"),
        (dict(max_steps=0), ValueError, r"max_steps must be a positive integer \(or None.*got 0"),
        (dict(max_steps=10.5), ValueError, r"max_steps must be a positive integer"),
        (dict(max_steps=True), ValueError, r"max_steps must be a positive integer"),
        (dict(dt0=-1e-6), ValueError, r"dt0 must be finite and > 0 s"),
        (dict(dt=0.0), ValueError, r"dt must be > 0 s"),
        (dict(dt=float("inf")), ValueError, r"dt must be a finite number of seconds"),
        (dict(dt=1e-6, dt0=1e-6), ValueError, r"give dt \(fixed steps\) or dt0"),
        # what only adaptive steps use is refused with fixed ones, not ignored
        (dict(n_steps=10, rtol=1e-3), ValueError, r"rtol=0.001 set.*n_steps=.*ignored"),
        (dict(dt=1e-6, atol=1e-6), ValueError, r"atol=1e-06 set.*with fixed steps \(dt="),
        (dict(n_steps=10, max_steps=5), ValueError, r"max_steps=5 set.*drop them"),
        (
            dict(stepsize_controller=diffrax.ConstantStepSize()),
            ValueError,
            r"ConstantStepSize\) needs dt0 > 0",
        ),
        (dict(solver="tsit5"), TypeError, r"solver must be a diffrax solver"),
        (dict(stepsize_controller=1e-6), TypeError, r"stepsize_controller must be a diffrax"),
        (dict(adjoint="checkpoint"), TypeError, r"adjoint must be a diffrax adjoint"),
        (dict(progress="yes"), TypeError, r"progress must be True or False"),
        (dict(allow_float32=1), TypeError, r"allow_float32 must be True or False"),
        (
            dict(solver=diffrax.Euler()),
            ValueError,
            r"Euler gives no error estimate for adaptive steps: use fixed steps \(dt=...\)",
        ),
    ],
)
def test_bad_options_say_what_is_wrong(kwargs, error, match):
    with pytest.raises(error, match=match):
        jc.SolveOptions(**kwargs)


def test_keyword_options_set_or_override_the_options_object():
    base = jc.SolveOptions(rtol=1e-7, max_steps=1000)
    assert with_options(None, {}, "simulate") == jc.SolveOptions()
    assert with_options(base, {}, "simulate") is base
    both = with_options(base, {"max_steps": 50}, "simulate")
    assert (both.rtol, both.max_steps) == (1e-7, 50)
    with pytest.raises(TypeError, match=r"unexpected keyword argument\(s\) \['rtl'\].*'rtol'"):
        with_options(None, {"rtl": 1e-6}, "simulate")
    with pytest.raises(TypeError, match="options must be a jaxchain.SolveOptions"):
        with_options({"rtol": 1e-6}, {}, "simulate")


def test_fixed_steps_from_dt():
    opts = jc.SolveOptions(dt=4e-6)
    assert opts.fixed and opts.steps(0.0, 1e-4) == 25
    assert opts.steps(0.0, 1.0001e-4) == 26  # ⌈span/dt⌉
    r = opts.resolve(0.0, 1e-4)
    assert isinstance(r.controller, diffrax.ConstantStepSize)
    assert r.max_steps == 25 and np.isclose(r.dt0, 4e-6)
    assert isinstance(r.adjoint, jc.StepResidualsAdjoint)  # every step's residuals kept
    adaptive = jc.SolveOptions().resolve(0.0, 1e-4)
    # adaptive: the first step 0.1 µs (inside every contact's explicit stability limit), or
    # the span where shorter
    assert isinstance(adaptive.controller, diffrax.PIDController)
    assert float(adaptive.dt0) == jc.DEFAULT_DT0 == 1e-7
    assert float(jc.SolveOptions().resolve(0.0, 3e-8).dt0) == 3e-8


def test_fixed_step_count_with_a_traced_span():
    """``n_steps``: exactly that many equal steps, the span traced: one compiled solve for
    every horizon (a jitted objective over speeds), the same answer as ``dt`` where the
    two give the same steps."""
    opts = jc.SolveOptions(n_steps=25)
    assert opts.fixed
    r = opts.resolve(0.0, jnp.asarray(1e-4))
    assert isinstance(r.controller, diffrax.ConstantStepSize) and r.max_steps == 25
    assert isinstance(r.adjoint, jc.StepResidualsAdjoint)
    scene = jc.scenes.drive("08B", teeth=(18, 36), load_torque=20.0, fidelity="spans")
    traces = []

    @jax.jit
    def final_speed(t1):
        traces.append(1)
        sol = jc.simulate(scene, t1, ts=jnp.stack([t1]), n_steps=40, throw=False)
        return sol.span_tension[-1, 1]

    a, b = final_speed(2e-4), final_speed(3e-4)
    assert len(traces) == 1
    ref = jc.simulate(scene, 3e-4, ts=[3e-4], dt=3e-4 / 40).span_tension[-1, 1]
    np.testing.assert_allclose(b, ref, rtol=1e-12)
    assert float(a) != float(b)
    with pytest.raises(ValueError, match="give n_steps"):
        jc.SolveOptions(n_steps=10, dt=1e-6)
    with pytest.raises(ValueError, match="n_steps must be a positive integer"):
        jc.SolveOptions(n_steps=0)


def test_time_span_and_save_times_are_checked():
    scene = jc.scenes.engagement(
        "08B", 18, n_entry=3, n_exit=2, wrap=9, model=jc.scenes.ChainModel(settle=False)
    )
    for kwargs, match in [
        (dict(t1=0.0), r"t1 must be > t0"),
        (dict(t1=float("nan")), r"t0 and t1 must be finite"),
        (dict(t1=1e-3, ts=[0.0, 2e-3]), r"ts must lie within \[t0, t1\]"),
        (dict(t1=1e-3, ts=[5e-4, 1e-4]), r"ts must be non-decreasing"),
        (dict(t1=1e-3, ts=[[0.0, 1e-4]]), r"ts must be a 1-D array"),
        (dict(t1=1e-3, n_save=1), r"n_save must be an integer >= 2"),
        (dict(t1=[1e-3, 2e-3]), r"t1 must be a scalar time"),
    ]:
        with pytest.raises(ValueError, match=match):
            jc.simulate(scene, **kwargs)


# ------------------------------------------------------------------ the fixed-step adjoint
def _oscillator(k, adjoint, n=40, controller=None):
    """x'' = −k x − 0.1 x' from (1, 0) over 2 s in ``n`` fixed Tsit5 steps: x(2)."""
    term = diffrax.ODETerm(lambda t, y, k: jnp.stack([y[1], -k * y[0] - 0.1 * y[1]]))
    sol = diffrax.diffeqsolve(
        term, diffrax.Tsit5(), 0.0, 2.0, 2.0 / n, jnp.array([1.0, 0.0]), args=k,
        stepsize_controller=controller or diffrax.ConstantStepSize(), max_steps=n,
        adjoint=adjoint,
    )  # fmt: skip
    return sol.ys[-1, 0]


def test_step_residuals_adjoint_is_the_checkpointed_gradient():
    """The same discrete gradient as diffrax's every-step checkpointing (and the same
    value), also vmapped; fixed steps only."""
    ks = jnp.array([1.0, 2.5, 7.0])
    batch = lambda adjoint: jax.jit(jax.vmap(jax.value_and_grad(lambda k: _oscillator(k, adjoint))))
    mine = batch(jc.StepResidualsAdjoint())
    v, g = mine(ks)
    v_ref, g_ref = batch(diffrax.RecursiveCheckpointAdjoint(checkpoints=40))(ks)
    np.testing.assert_allclose(v, v_ref, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(g, g_ref, rtol=1e-12, atol=1e-14)
    # and central differences of the same 40-step solve (the same compiled batch)
    (hi, lo, _), _ = mine(jnp.array([2.5 + 1e-6, 2.5 - 1e-6, 7.0]))
    assert abs(float(g[1]) - float(hi - lo) / 2e-6) < 1e-6
    with pytest.raises(ValueError, match="needs fixed steps"):
        _oscillator(1.0, jc.StepResidualsAdjoint(), controller=diffrax.PIDController(1e-6, 1e-9))


def test_step_residuals_adjoint_checkpoints_past_its_memory_limit():
    """Where the residuals would pass ``memory_limit``, the gradient comes from recursive
    checkpointing instead: each step's input kept where that fits, diffrax's default
    checkpoints where not — the same gradient, less memory."""
    n = 500  # state: 2 float64 (16 B); residuals reckoned at 24 states: 192 kB

    def temp_and_grad(limit):
        f = jax.jit(jax.grad(lambda k: _oscillator(k, jc.StepResidualsAdjoint(limit), n=n)))
        return f.lower(2.5).compile().memory_analysis().temp_size_in_bytes, f(2.5)

    kept, g_kept = temp_and_grad(None)
    every, g_every = temp_and_grad(2e4)  # each step's input (8 kB) fits
    few, g_few = temp_and_grad(4e3)  # it does not: ~√(2n) checkpoints
    np.testing.assert_allclose([g_every, g_few], [g_kept, g_kept], rtol=1e-12)
    assert kept > 2 * every > 4 * few, (kept, every, few)
    assert jc.StepResidualsAdjoint().memory_limit == 1e9


def test_the_default_step_budget_follows_the_horizon():
    """max_steps None (the default): the horizon over 0.5 µs, rounded up to a power of two,
    at least 200 000 — a default 06B 21/42 drive at 1000 rpm takes about 1.6 µs steps and
    ran out of a fixed 200 000 after 0.29 s; a set max_steps is kept as given."""
    budget = lambda t1, **kw: jc.SolveOptions(**kw).resolve(0.0, t1).max_steps
    assert budget(0.05) == 200_000  # short solves: the minimum (one compiled solve)
    assert budget(0.29) == 2**20  # 580 000 steps of 0.5 µs, rounded up
    assert budget(1.0) == 2**21  # 2 000 000 → 2 097 152
    assert budget(1.0, max_steps=1000) == 1000
    assert budget(jnp.asarray([0.1, 0.6])) == 2**21  # an ensemble's longest member
    traced = jax.jit(lambda t1: jnp.asarray(jc.SolveOptions().resolve(0.0, t1).max_steps))
    assert int(traced(1.0)) == 200_000  # a traced span: the minimum
    with pytest.raises(ValueError, match="max_steps must be a positive integer"):
        jc.SolveOptions(max_steps=0)
