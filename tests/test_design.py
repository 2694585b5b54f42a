"""Design: the ISO box reparametrization, the smooth peak measure, gradients through the
solve (against central finite differences of fixed-step solves), implicit statics."""

import itertools
import math

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain.design import DesignSpace, ProfileObjective, soft_peak_force, window_weight

from helpers import (
    count_objective_traces,
    count_vector_field_calls,
    fixed_step_joints,
    own_program_store,
)

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = 60.0 / (Z * RPM)
SPACE = DesignSpace.iso606(CHAIN, Z)


# the design model's roller law: contact onset regularized over 3 µm so that fixed steps
# of a few µs resolve it (the nominal 10 nm is crossed inside one step)
DESIGN_LAW = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)
# and its joint friction's creep band widened (measured with the nominal band at 4 µs:
# value 899 N, gradient 1e41; widened: AD = FD to 1e-7…8e-6 of |∇J|)
DESIGN_JOINTS = fixed_step_joints()


def _build(profile, law=DESIGN_LAW):
    return jc.scenes.engagement(
        CHAIN,
        Z,
        speed_rpm=RPM,
        profile=profile,
        n_entry=3,
        model=jc.scenes.ChainModel(roller_contact=law, joint_friction=DESIGN_JOINTS),
    )


@pytest.fixture(scope="module")
def short_objective():
    """One engagement: 2 tooth periods, window over the second; the soft peak sampled 8
    times per step (the design objective's form for fixed steps)."""
    return ProfileObjective(
        SPACE, _build, t1=2 * PERIOD, t_start=PERIOD, temperature=50.0, reference=2000.0,
        dt=4e-6, samples=8,
    )  # fmt: skip


# ------------------------------------------------------------------ design space
def test_design_space_stays_inside_iso_box():
    lim = jc.iso606_limits(CHAIN, Z)
    for u in [jnp.full(4, -1e3), jnp.full(4, 1e3), jnp.zeros(4), jnp.array([40.0, -40, 3, -3])]:
        x = SPACE.values(u)
        for i, name in enumerate(jc.design.PARAMETERS):
            lo, hi = lim[name]
            assert lo - 1e-15 <= float(x[i]) <= hi + 1e-15
    mid = jc.ToothProfile.iso606(CHAIN, Z, "mid")
    np.testing.assert_allclose(SPACE.coordinates(mid), 0.0, atol=1e-9)
    u = jnp.array([0.3, -1.2, 2.0, -0.1])
    np.testing.assert_allclose(SPACE.coordinates(SPACE.profile(u)), u, atol=1e-9)


def test_design_space_corners_are_valid_profiles():
    """Every corner of the ISO box is a closed, valid outline once the tip circle is
    lowered to where the flanks meet (some corners, e.g. the smallest flank radius with
    the largest tip diameter, have a pointed tooth: the geometry clamps the tip there,
    smoothly in every other parameter)."""
    from jaxchain._profiles.iso import flank_meeting_diameter

    lim = jc.iso606_limits(CHAIN, Z)
    clamped = 0
    for pick in itertools.product((0, 1), repeat=4):
        vals = {n: lim[n][i] for n, i in zip(jc.design.PARAMETERS, pick, strict=True)}
        kw = dict(teeth=Z, pitch=CHAIN.pitch, roller_diameter=CHAIN.roller_diameter, **vals)
        reach = flank_meeting_diameter(**kw)
        if vals["tip_diameter"] > reach:
            clamped += 1
            kw["tip_diameter"] = reach * (1 - 1e-9)
        jc.ToothProfile(**kw)  # concrete: runs the full validation
        # the design space's traced profile at that corner clamps the same way
        u = jnp.asarray([40.0 if i else -40.0 for i in pick])
        geo = SPACE.profile(u).geometry()
        assert float(geo.tip_radius) <= reach / 2 + 1e-12
        assert np.all(np.isfinite(np.asarray(SPACE.profile(u).outline(n=20))))
    assert clamped < 16


def test_design_space_rejects_bad_box():
    tpl = SPACE.template
    with pytest.raises(ValueError, match="upper must exceed lower"):
        DesignSpace(tpl, [1, 1, 1, 1], [2, 0.5, 2, 2])
    with pytest.raises(ValueError, match="shape"):
        DesignSpace(tpl, [1, 1, 1], [2, 2, 2])


def test_gradient_mode_forward_for_a_few_coordinates_on_fixed_steps():
    """gradient="auto" differentiates forward (one tangent per coordinate through
    diffrax's ForwardMode) for fixed steps and at most FORWARD_UP_TO coordinates, in
    reverse otherwise or where an adjoint is given; only the gradient's solve changes its
    adjoint."""
    from jaxchain._design.objective import FORWARD_UP_TO

    kw = dict(t1=2 * PERIOD, t_start=PERIOD)
    fwd = ProfileObjective(SPACE, _build, dt=4e-6, **kw)
    assert fwd.gradient == "forward" and SPACE.size <= FORWARD_UP_TO
    assert isinstance(fwd._grad_config.options.adjoint, diffrax.ForwardMode)
    assert fwd.config.options.adjoint is None  # the value's solve is left as it was
    assert ProfileObjective(SPACE, _build, **kw).gradient == "reverse"  # adaptive steps
    given = diffrax.RecursiveCheckpointAdjoint()
    assert ProfileObjective(SPACE, _build, dt=4e-6, adjoint=given, **kw).gradient == "reverse"
    wide = jc.FreeformProfile.from_iso(jc.ToothProfile.iso606(CHAIN, Z, "mid"), 1)
    r = float(wide.seating_radius) * np.ones(Z)
    per_gap = DesignSpace.select(wide, {"seating_radius": (r - 1e-5, r + 1e-5)})
    assert per_gap.size == Z > FORWARD_UP_TO
    assert ProfileObjective(per_gap, _build, dt=4e-6, **kw).gradient == "reverse"
    assert ProfileObjective(per_gap, _build, dt=4e-6, gradient="forward", **kw).gradient == (
        "forward"
    )


# ------------------------------------------------------------------ smooth peak
def test_window_weight_integral_and_smoothness():
    t = np.linspace(0.0, 1.0, 200_001)
    w = np.asarray(window_weight(jnp.asarray(t), 0.4, 0.1))
    assert abs(np.trapezoid(w, t) - 0.6) < 1e-8
    dw = np.diff(w) / np.diff(t)
    assert np.max(np.abs(np.diff(dw))) < 1e-2  # C¹: no jump in the slope


def test_soft_peak_of_an_impact_pulse_matches_laplace():
    """The soft peak of one Gaussian force pulse (height A, width σ) over a window W,
    integrated from the observer's integrand: Laplace's method gives
    P = A + τ·log(σ·√(2πτ/A) / W) (to O(τ²/A)); its bias falls with τ as −τ·log(W/δ),
    δ = σ·√(2πτ/A) the time spent near the peak, and P never exceeds A + τ·log(rollers)."""
    from types import SimpleNamespace

    from jaxchain.observers import SoftPeak

    a, sigma, t0, w = 1000.0, 20e-6, 0.6e-3, 1e-3
    t = np.linspace(0.0, w, 400_001)
    force = a * np.exp(-0.5 * ((t - t0) / sigma) ** 2)
    quiet = np.full_like(t, 0.3 * a)  # a second roller, well below the peak
    for tau in (2.0, 10.0, 50.0):
        obs = SoftPeak(t_start=0.0, rise=0.0, temperature=tau, reference=a)
        rate = jax.jit(
            jax.vmap(
                lambda ti, f, o=obs: o.integrand(ti, None, None, SimpleNamespace(roller_normal=f))
            )
        )(jnp.asarray(t), jnp.stack([force, quiet], -1)[:, None, :])
        integral = np.trapezoid(np.asarray(rate), t)
        p = float(obs.value(jnp.asarray(integral), 0.0, w))
        laplace = a + tau * math.log(sigma * math.sqrt(2 * math.pi * tau / a) / w)
        assert abs(p - laplace) < tau * (0.002 + tau / a), (tau, p, laplace)  # O(τ²/A)
        assert p <= a + tau * math.log(2)


def test_sampled_soft_peak_resolves_a_spike_shorter_than_the_step(monkeypatch):
    """An impact pulse F = A·exp(−(t − t0)²/2s²), s = 5 µs, A = 1500 N, τ = 16 N (the
    main job's): the soft maximum's integrand is a spike of width σ = s·√(τ/A) = 0.52 µs,
    an eighth of a 4 µs step. The trapezoid rule on 8 parts of each step gives Laplace's
    P = A + τ·log(σ√(2π)/W) wherever the pulse falls between steps (the quadrature error
    ~2·exp(−2π²σ²/h²) is 1e-9 at h = 0.5 µs); on the step ends alone (samples=1) the
    value swings with the pulse's position by several τ — the ripple in the design
    parameters that the stage-integrated :class:`SoftPeak` shows at such a step."""
    import jaxchain._observers.base as observers

    monkeypatch.setattr(observers, "_roller_forces", lambda y, scene: y)  # states = forces
    a, s, tau, h, w = 1500.0, 5e-6, 16.0, 4e-6, 200e-6
    sigma = s * math.sqrt(tau / a)
    laplace = a + tau * math.log(sigma * math.sqrt(2 * math.pi) / w)

    def force(t, t0):  # (…, R): the pulse on one roller, a quiet second roller
        p = a * jnp.exp(-0.5 * ((t - t0) / s) ** 2)
        return jnp.stack([p, 0.3 * a + 0 * p], -1)

    def soft(samples, t0):
        obs = jc.observers.SampledSoftPeak(0.0, 0.0, tau, a, samples=samples)
        starts = jnp.arange(0.0, w, h)

        def step(state, t):
            dense = lambda ts: force(ts, t0)  # noqa: E731
            state = obs.step(t, t + h, None, force(t + h, t0), dense, None, state)
            return state, None

        state, _ = jax.lax.scan(step, obs.init(0.0, force(0.0, t0), None), starts)
        return float(obs.value(state, 0.0, w))

    shifts = [100e-6 + k * h / 8 for k in range(9)]  # the pulse's top across one step
    sampled = [soft(8, t0) for t0 in shifts]
    ends = [soft(1, t0) for t0 in shifts]
    # measured: within 0.065 N of Laplace (its own error is O(τ²/A) = 0.17 N), the same
    # to 5e-13 N wherever the pulse falls; on the step ends 104 N apart (6.5 τ)
    assert max(abs(p - laplace) for p in sampled) < tau**2 / a, (sampled, laplace)
    assert np.ptp(sampled) < 1e-6 * tau, sampled
    assert np.ptp(ends) > 2 * tau, ends
    with pytest.raises(ValueError, match="samples must be an integer >= 1"):
        jc.observers.SampledSoftPeak(samples=0)


@pytest.mark.slow
def test_soft_peak_approaches_sharp_peak_as_temperature_falls():
    """Bias of the soft maximum against the sharp maximum of the same fixed-step solve
    (the per-step force maximum in the window): it falls with the temperature τ and
    stays within the stated bounds, −τ·log(window/time near the peak) … +τ·log(R)."""
    scene = _build(SPACE.profile(jnp.zeros(4)))
    t1, t0, dt = 2 * PERIOD, PERIOD, 2e-6
    n = round(t1 / dt)
    ts = np.linspace(0, t1, n + 1)
    sol = jc.simulate(
        scene,
        t1,
        solver=jc_tsit5(),
        dt0=t1 / n,
        max_steps=n,
        stepsize_controller=constant(),
        ts=ts,
    )
    f = np.asarray(sol.roller_sprocket_force)[ts >= t0]
    sharp = f.max()
    biases = []
    for tau in (200.0, 50.0, 10.0, 2.0):
        soft = soft_peak_force(
            scene, t1, t_start=t0, rise=1e-9, temperature=tau, reference=sharp, dt=dt
        ).soft
        biases.append(float(soft) - sharp)
        assert float(soft) <= sharp + tau * np.log(scene.n_rollers) + 1e-6
    # measured: τ = 200, 50, 10, 2 N -> −272, −337, −78, −18 N (sharp 977 N). Below about
    # 50 N the bias falls with τ (≈ −τ·log(window/δ), δ ≈ 0.4 µs: a sharp impact spike);
    # above, the soft maximum is an average over the window and stops tracking the peak
    assert all(b < 0 for b in biases)
    assert abs(biases[1]) > abs(biases[2]) > abs(biases[3])
    assert abs(biases[-1]) < 0.025 * sharp  # τ = 2 N: within 2.5 %


def jc_tsit5():
    import diffrax

    return diffrax.Tsit5()


def constant():
    import diffrax

    return diffrax.ConstantStepSize()


def test_soft_peak_validation():
    scene = _build(SPACE.profile(jnp.zeros(4)))
    with pytest.raises(ValueError, match="temperature"):
        soft_peak_force(scene, 1e-3, temperature=0.0)
    with pytest.raises(ValueError, match="t_start"):
        soft_peak_force(scene, 1e-3, t_start=2e-3)
    with pytest.raises(ValueError, match="dt"):
        soft_peak_force(scene, 1e-3, dt=-1.0)


# ------------------------------------------------------------------ implicit statics
def test_resettle_follows_the_equilibrium():
    """resettle's derivative is the implicit-function derivative: a small parameter change
    moves the settled state as re-solving the statics does (to the statics' tolerance),
    with the Jacobian at the changed parameters or the settled scene's (statics_jacobian,
    as the design objective passes it)."""
    p0 = jc.ToothProfile.iso606(CHAIN, Z, "mid")
    base = _build(p0)
    jac = jc.scenes.statics_jacobian(base)
    steps = {"seating_radius": 5e-9, "seating_angle": 1e-5, "flank_radius": 1e-5}
    for name, h in steps.items():
        p1 = eqx.tree_at(lambda p, n=name: getattr(p, n), p0, getattr(p0, name) + h)
        exact = _build(p1)
        changed = eqx.tree_at(lambda s: s.sprockets[0].profile, base, p1)
        moved = np.abs(np.asarray(exact.q0 - base.q0)).max()
        for lin in (jc.scenes.resettle(changed), jc.scenes.resettle(changed, jacobian=jac)):
            err = np.abs(np.asarray(exact.q0 - lin.q0)).max()
            assert err < 3e-9, (name, moved, err)  # statics solved to ~2e-9 m
    # unchanged parameters: it only polishes the solve
    same = jc.scenes.resettle(base)
    np.testing.assert_allclose(same.q0, base.q0, atol=3e-9)  # the statics residual only


# ------------------------------------------------------------------ gradients
def test_gradient_matches_central_differences(short_objective):
    """Reverse mode through the fixed-step solve (every step's residuals kept)
    and the implicit statics, against central differences of the same fixed-step
    objective (scenes held at the base point's equilibrium, as the gradient sees them),
    along a random direction of the three coordinates the solve sees: every one of their
    derivatives enters the one comparison."""
    obj = short_objective
    u = jnp.array([0.2, 0.5, -0.3, 0.1])
    scenes = obj.scenes(u)
    value, grad, _ = obj.value_and_grad_on(u, scenes)
    assert np.all(np.isfinite(np.asarray(grad)))
    assert float(grad[3]) == 0.0  # no roller reaches the tip: the value does not depend on it
    scale = float(jnp.linalg.norm(grad))
    # |AD − FD| / |∇J| at h = 1e-5, measured per component: 1.0e-5, 8.8e-7, 7.1e-7 (at h =
    # 1e-4: 5.9e-7, 2.0e-7, 6.4e-7); the integrated soft peak (samples=0) 1.3e-5, 4.7e-6,
    # 5.0e-6 at 1e-5; along this direction 1.1e-6 (at 1e-4: 1.4e-7)
    h = 1e-5
    d = np.random.default_rng(0).normal(size=4) * [1, 1, 1, 0]
    d /= np.linalg.norm(d)
    # (the values from the compiled value-and-gradient: one compile, not two)
    hi = obj.value_and_grad_on(u + h * d, scenes)[0]
    lo = obj.value_and_grad_on(u - h * d, scenes)[0]
    fd = (float(hi) - float(lo)) / (2 * h)
    err = abs(float(jnp.dot(grad, d)) - fd) / scale
    assert err < 1e-4, err


def _grad_at(dt, build=_build, u=(0.2, 0.5, -0.3, 0.1), samples=0):
    obj = ProfileObjective(
        SPACE, build, t1=2 * PERIOD, t_start=PERIOD, temperature=50.0, reference=2000.0, dt=dt,
        samples=samples,
    )  # fmt: skip
    return np.asarray(obj.value_and_grad(jnp.asarray(u))[1])


@pytest.mark.slow
def test_gradient_converges_as_the_step_shrinks():
    """With the onset resolved (3 µm) and the soft peak sampled 8 times per step, the
    fixed-step gradient converges as the step shrinks. Measured at u = (0.2, 0.5, −0.3,
    0.1): [2.985, −69.957, −0.35838] (4 µs), [0.688, −69.039, −0.35429] (2 µs), [0.124,
    −68.833, −0.35336] (1 µs): 4.5 % and 0.9 % of the norm from the 1 µs one. The soft
    peak integrated by the solver's stages gives [27.0, −78.4, −0.396] at 4 µs, 41 %
    away (2 and 1 µs: [0.261, −68.872, −0.35355], [0.124, −68.832, −0.35335]): its
    integrand's spike (~0.5 µs wide) falls between the stages of a 4 µs step. A
    convergence study (four gradient compiles): marked slow."""
    u = (0.2, 0.5, -0.3, 0.1)
    g4, g2, g1 = (_grad_at(dt, u=u, samples=8) for dt in (4e-6, 2e-6, 1e-6))
    scale = np.linalg.norm(g1)
    assert np.linalg.norm(g4 - g1) < 0.06 * scale, (g4, g1)
    assert np.linalg.norm(g2 - g1) < 0.015 * scale, (g2, g1)
    integrated = _grad_at(4e-6, u=u)
    assert np.linalg.norm(integrated - g1) > 0.3 * scale, integrated


@pytest.mark.slow
def test_gradient_convergence_needs_a_resolved_contact_onset():
    """The nominal law (onset regularized over 10 nm, crossed inside one step) gives a
    gradient that does not settle as the step shrinks (measured: seating-radius component
    10.09, 11.29, 12.11 at 1, 0.5, 0.25 µs, a spread of 18 % of its mean); widened to
    3 µm (soft peak integrated by the solver's stages) it agrees within 1 % between 2 and
    1 µs."""
    nominal = jc.scenes.roller_law(CHAIN, 0.7)
    g = [_grad_at(dt, lambda p: _build(p, nominal)) for dt in (1e-6, 5e-7, 2.5e-7)]
    spread = np.ptp(np.stack(g), axis=0)
    assert spread[0] > 0.1 * np.abs(np.mean([x[0] for x in g]))
    g3 = [_grad_at(dt) for dt in (2e-6, 1e-6)]
    assert np.linalg.norm(g3[0] - g3[1]) < 0.01 * np.linalg.norm(g3[1])


def test_soft_peak_gradient_is_finite_beyond_any_force():
    """The soft maximum's exponent saturates above reference + EXP_CAP·τ: a trial step an
    adaptive controller rejects may see absurd forces, and its discarded value must not
    poison the gradient (0·inf in the backward pass of the accept/reject select). Below
    the cap the integrand is the plain exponential."""
    from types import SimpleNamespace

    sp = jc.observers.SoftPeak(t_start=0.0, rise=0.0, temperature=50.0, reference=2000.0)

    def term(f, keep):
        forces = SimpleNamespace(roller_normal=f[None, :])  # one contact slot, 3 rollers
        return jnp.where(keep, sp.integrand(1.0, None, None, forces), 0.0)

    absurd = jnp.array([1.5e3, 1e12, 1e300])
    for keep in (False, True):
        value, grad = jax.value_and_grad(term)(absurd, keep)
        assert np.isfinite(float(value)) and np.all(np.isfinite(np.asarray(grad))), keep
    plain = jnp.array([1.5e3, 2.0e3, 2.5e3])
    want = np.exp((np.asarray(plain) - 2000.0) / 50.0).sum()
    assert float(term(plain, True)) == pytest.approx(want, rel=1e-12)


@pytest.mark.slow
def test_adaptive_solve_gradient_is_finite():
    """Through adaptive steps too (trial steps the controller rejects can see absurd
    forces; the soft maximum's exponent is capped so they never poison the gradient). One
    gradient compile of an adaptive solve (20 s on 2 cores): marked slow; the cap itself
    is tested above."""
    obj = ProfileObjective(
        SPACE,
        _build,
        t1=2 * PERIOD,
        t_start=PERIOD,
        temperature=50.0,
        reference=2000.0,
        rtol=1e-6,
        atol=1e-9,
        max_steps=20_000,
    )
    value, grad, out = obj.value_and_grad(jnp.array([0.2, 0.5, -0.3, 0.1]))
    assert np.isfinite(float(value)) and np.all(np.isfinite(np.asarray(grad)))


# corners of the ISO box (u = ±5: each parameter 0.7 % from its bound): the minimum and
# maximum tooth-gap forms, and the two corners pairing the smallest flank radius with the
# largest tip diameter (a pointed tooth, its tip clamped where the flanks meet) and the
# reverse
CORNERS = [(-5.0, 5.0, 5.0, 5.0), (5.0, -5.0, -5.0, -5.0), (-5.0, -5.0, -5.0, 5.0), (5, 5, 5, -5)]


def _finite_at(objective, corners):
    """Finite objective and gradient at each u, each from the strand settled at its own
    profile (solved instead on the strand settled at the mid form and resettled to first
    order, a corner's solve is reported diverged: the first-order move of the equilibrium
    does not reach that far)."""
    for pick in corners:
        value, grad, out = objective.value_and_grad(jnp.asarray(pick, dtype=float))
        assert np.isfinite(float(value)) and np.all(np.isfinite(np.asarray(grad))), pick


def test_no_nan_gradients_at_the_corners_of_the_box(short_objective):
    """The ISO forms' corners, the pointed-tooth corners and far outside (u = ±40)."""
    _finite_at(short_objective, CORNERS + [(40.0, -40.0, 40.0, -40.0)])


@pytest.mark.slow
def test_no_nan_gradients_at_any_corner_of_the_box(short_objective):
    """All 16 corners (the default run takes the 4 above: 17 settled builds and gradients
    cost ~45 s)."""
    _finite_at(short_objective, [p for p in itertools.product((-5.0, 5.0), repeat=4)])


def test_a_failed_member_is_never_a_value():
    """A fixed step far above the stability limit (200 µs) diverges: the objective raises
    naming the member and the fix, or with ``throw=False`` returns NaN and the codes —
    never a plausible number an optimizer would take for a result."""
    kw = dict(t1=2 * PERIOD, t_start=PERIOD, temperature=50.0, reference=2000.0, dt=2e-4)
    with pytest.raises(RuntimeError, match=r"(?s)1 of 1 members failed .*diverged.*reduce dt0"):
        ProfileObjective(SPACE, _build, **kw).value(jnp.zeros(4))
    value, out = ProfileObjective(SPACE, _build, throw=False, **kw).value(jnp.zeros(4))
    assert np.isnan(float(value)) and jc.result_names(out.result) == ["diverged"]


def test_second_call_does_not_retrace(short_objective, monkeypatch, tmp_path):
    """A new design point (new profile, new scenes) reuses the first point's program:
    nothing traced (against a program store of its own, which a retraced program stored
    by another run cannot hide in)."""
    calls = count_vector_field_calls(monkeypatch)
    members = count_objective_traces(monkeypatch)
    short_objective.value_and_grad(jnp.array([0.1, 0.1, 0.1, 0.1]))
    own_program_store(monkeypatch, tmp_path)
    n, m = len(calls), len(members)
    short_objective.value_and_grad(jnp.array([0.4, -0.2, 0.1, 0.3]))  # new profile, new scenes
    assert (len(calls), len(members)) == (n, m)


# ------------------------------------------------------------------ gradient blow-up
def test_a_blown_up_gradient_is_a_failure_with_the_fix(short_objective):
    """A gradient a million times the objective's size per unit of u, from a solve that
    succeeded, is refused: raised with the fix (throw=True) or NaN (throw=False); a
    gradient of the measured sizes passes."""
    obj = short_objective
    u = jnp.array([0.2, 0.5, -0.3, 0.1])  # (the gradient test's compiled program)
    members = obj.value_and_grad_on(u, obj.scenes(u))[2]
    value = jnp.asarray(1100.0)
    assert obj._checked(value, jnp.array([5.0, -77.0, 0.4, 0.0]), members)[1] is not None
    huge = jnp.array([2.9e35, -5.7e34, -2.1e32, 0.0])
    with pytest.raises(jc.SolveError, match="gradient blew up.*slip_velocity=2e-2"):
        obj._checked(value, huge, members)
    obj.throw = False
    try:
        v, g = obj._checked(value, huge, members)
        assert np.isnan(float(v)) and np.all(np.isnan(np.asarray(g)))
    finally:
        obj.throw = True
