"""Every failure mode is detected and reported as a result code with a message saying what
to change, never a silent NaN: explicit steps above the stability limit, an adaptive
solver starved by stiffness, an implicit solver's Newton iteration failing, float32,
a regularization too small to integrate or too wide to be accurate, and gradients over
long horizons. The stability study itself is ``benchmarks/stability.py``.

All on a small strand (3 entry, 9 wrapped, 2 exit rollers) started from its layout
(``settle=False``: no statics to compile) over half a tooth period, where the rollers
snap into their seats: a violent start, so every regime below is exercised quickly.
"""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest

import jaxchain as jc

PERIOD = 60.0 / 1000.0 / 18  # tooth period at 1000 rpm, z = 18 [s]
T1 = 0.5 * PERIOD
BUDGET = 6000  # max_steps of the adaptive solves (static: one compile for all of them)
EULER_STEPS = 10_000  # max_steps of the fixed-step Euler solves (static)


def small_engagement():
    sc = jc.scenes.engagement(
        "08B",
        18,
        speed_rpm=1000,
        n_entry=3,
        n_exit=2,
        wrap=9,
        model=jc.scenes.ChainModel(settle=False),
    )
    # the law's float fields as arrays, so that changing one is a new value, not a new
    # structure (no recompile between the tests)
    law = sc.roller_law
    names = ("width", "speed_floor", "clamp_width")
    arrays = tuple(jnp.asarray(getattr(law, n), dtype=float) for n in names)
    law = eqx.tree_at(lambda x: tuple(getattr(x, n) for n in names), law, arrays)
    return eqx.tree_at(lambda s: s.roller_law, sc, law)


@pytest.fixture(scope="module")
def scene():
    return small_engagement()


def with_law(scene, **fields):
    law = eqx.tree_at(
        lambda x: tuple(getattr(x, n) for n in fields),
        scene.roller_law,
        tuple(jnp.asarray(v, dtype=float) for v in fields.values()),
    )
    return eqx.tree_at(lambda s: s.roller_law, scene, law)


def stiffened(scene, s):
    """Contact modulus and link springs × s (a stiffer drive, same geometry)."""
    sc = with_law(scene, modulus=scene.roller_law.modulus * s)
    k = sc.pairs[0].element.stiffness
    return eqx.tree_at(lambda x: x.pairs[0].element.stiffness, sc, k * s)


def adaptive(scene, **kw):
    return jc.simulate(scene, T1, n_save=41, max_steps=BUDGET, throw=False, **kw)


def euler(scene, dt, throw=False):
    return jc.simulate(
        scene,
        T1,
        solver=diffrax.Euler(),
        stepsize_controller=diffrax.ConstantStepSize(),
        dt0=dt,
        max_steps=EULER_STEPS,
        n_save=41,
        throw=throw,
    )


def outputs_finite(sol) -> bool:
    leaves = [sol.roller_position, sol.roller_velocity, sol.roller_sprocket_force]
    leaves += [sol.link_tension, sol.peak_contact_force]
    return all(bool(jnp.all(jnp.isfinite(x))) for x in leaves)


def assert_reported(sol, code, *words):
    """The solve failed with ``code``, and its message names every one of ``words``."""
    assert sol.result == code, (sol.message, sol.stats)
    assert not sol.ok
    for w in words:
        assert w in sol.message, (w, sol.message)


@pytest.fixture(scope="module")
def nominal(scene):
    """The adaptive reference: default tolerances, and a converged one (rtol 1e-9)."""
    sol = adaptive(scene)
    tight = adaptive(scene, rtol=1e-9, atol=1e-12)
    assert sol.ok and tight.ok, (sol.message, tight.message)
    return sol, tight


# --------------------------------------------------------------------- explicit, fixed
def test_fixed_step_above_stability_limit_diverges(scene, nominal):
    """Euler's limit on this scene is ~6e-7 s (h·ω_max ≈ 0.2, set by the contact modes'
    damping; benchmarks/stability.py). At 4e-6 s the solve blows up within a few
    hundred steps: reported as diverged, naming the step to change; at 2e-7 s the same
    compiled solve succeeds and matches the adaptive peak within 10 %."""
    bad = euler(scene, 4e-6)
    assert_reported(bad, jc.Result.diverged, "dt0", "stability limit")
    with pytest.raises(RuntimeError, match="diverged.*reduce dt0"):
        euler(scene, 4e-6, throw=True)
    good = euler(scene, 2e-7)
    assert good.ok and outputs_finite(good)
    ref = float(nominal[1].peak_contact_force)
    assert abs(float(good.peak_contact_force) / ref - 1) < 0.1


def test_blow_up_is_reported_before_it_overflows(scene, nominal):
    """Just above Euler's limit the solution is still growing at t1: finite, with a peak
    force far above the true one. Such a solve must not pass as successful: the rollers
    then move far faster than the drive can move them (measured on this grid, true peak
    4.1 kN at ≤ 4.2 m/s roller speed: 7.2 / 13.9 / 21.1 / 298 kN at 9 / 16 / 30 / 46 m/s,
    then 5e9 N at 5e5 m/s and non-finite), which ``simulate`` reports as diverged."""
    ref = float(nominal[1].peak_contact_force)
    blown = []
    for dt in np.geomspace(6.5e-7, 7.3e-7, 6):
        sol = euler(scene, dt)
        if float(sol.peak_contact_force) > 5 * ref or not outputs_finite(sol):
            blown.append((float(dt), float(sol.peak_contact_force), sol.ok))
    assert blown  # the grid straddles the boundary
    assert not any(ok for _, _, ok in blown), blown


# ------------------------------------------------------------------ explicit, adaptive
def test_adaptive_solver_starved_by_stiffness(scene, nominal):
    """The same step budget that the nominal drive needs under half of, runs out when
    every contact and link is 100× stiffer (ω_max × 10): max_steps_reached, whose
    message names max_steps and the remedies (an implicit solver among them)."""
    base = nominal[0]
    assert int(base.stats["num_steps"]) < BUDGET // 2  # measured 1256 (rtol 1e-9: 4629)
    stiff = adaptive(stiffened(scene, 100.0))
    assert_reported(stiff, jc.Result.max_steps_reached, "max_steps", "implicit solver")
    assert int(stiff.stats["num_steps"]) == BUDGET
    with pytest.raises(RuntimeError, match="used up max_steps"):
        jc.simulate(stiffened(scene, 100.0), T1, n_save=41, max_steps=BUDGET)


# --------------------------------------------------------------------------- implicit
@pytest.mark.slow
def test_implicit_newton_failure_is_reported(scene):
    """An implicit solver whose Newton iteration may take only 2 steps (chord method, tight
    tolerance) converges while the rollers move freely and fails when they hit their
    seats: implicit_solver_failed, saying to reduce the step (throw=True raises it)."""
    solver = diffrax.ImplicitEuler(
        root_finder=diffrax.VeryChord(rtol=1e-8, atol=1e-11, norm=optx.max_norm),
        root_find_max_steps=2,
    )
    kw = dict(
        solver=solver,
        stepsize_controller=diffrax.ConstantStepSize(),
        dt0=PERIOD / 2000,
        max_steps=1000,
        n_save=41,
    )
    sol = jc.simulate(scene, T1, throw=False, **kw)
    assert_reported(sol, jc.Result.implicit_solver_failed, "Newton", "Reduce the step")
    assert int(sol.stats["num_accepted_steps"]) > 0  # it did step before failing
    with pytest.raises(RuntimeError, match="Newton iteration did not converge"):
        jc.simulate(scene, T1, throw=True, **kw)


# ---------------------------------------------------------------------------- float32
@pytest.fixture(scope="module")
def float32_run():
    """What a user gets who forgot ``jax_enable_x64``: the scene built and solved in
    float32 (the library never flips the flag itself)."""
    import warnings

    with jax.enable_x64(False), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = small_engagement()
        sol = adaptive(sc)
        allowed = adaptive(sc, allow_float32=True)
        dtype = sc.q0.dtype
    return sc, (sol, allowed), dtype, [str(w.message) for w in caught]


@pytest.mark.slow
def test_float32_failure_is_reported_not_silent(float32_run):
    """A float32 solve is reported as ``float32_state`` (its forces can be wrong while it
    looks successful) unless allowed. Allowed, this one still fails on its own: positions
    near 0.05 m are resolved to ~4e-9 m, below the default atol (1e-9 m) and comparable to
    contact deflections' regularization (1e-8 m), so the adaptive solve stalls — a failure
    code, not successful NaNs. (Measured: max_steps_reached after 6000 steps where float64
    needs 1256; the same scene at a fixed 4 µs Tsit5 step runs in float32 with a peak
    0.3 % off float64.)"""
    _, (sol, allowed), dtype, _ = float32_run
    assert dtype == jnp.float32
    assert_reported(sol, jc.Result.float32_state, "jax_enable_x64", "allow_float32=True")
    assert not allowed.ok
    assert allowed.result in (jc.Result.max_steps_reached, jc.Result.step_size_collapse)
    assert allowed.message


@pytest.mark.slow
def test_float32_warns_with_the_fix(float32_run):
    _, _, _, caught = float32_run
    assert any("jax_enable_x64" in m for m in caught), caught


# --------------------------------------------------------------------- regularization
def test_damping_regularization_too_small_stalls(scene, nominal):
    """The contact damping F·χ·δ̇/v⁻ is regularized by the impact speed v⁻ (the scene's
    reference, floored by the law's speed_floor). Both at 1e-5 m/s make the damping
    coefficient ~1e5 × larger: a stiff (overdamped) contact that starves the adaptive
    solver, reported as max_steps_reached."""
    sc = with_law(scene, speed_floor=1e-5)
    sc = eqx.tree_at(lambda s: s.impact_speed, sc, jnp.asarray(1e-5))
    sol = adaptive(sc)
    assert_reported(sol, jc.Result.max_steps_reached, "max_steps")
    assert int(nominal[0].stats["num_steps"]) < BUDGET // 2


def test_penetration_width_to_zero_does_not_stall(scene, nominal):
    """The penetration regularization is not what limits the step: Johnson's law has
    zero stiffness at contact onset, so even width = 0 (a bare max(δ, 0)) integrates
    with the same steps (±5 %) and peak (±0.5 %) as the default 1e-8 m."""
    base = nominal[0]
    sol = adaptive(with_law(scene, width=0.0))
    assert sol.ok, sol.message
    steps, steps0 = int(sol.stats["num_steps"]), int(base.stats["num_steps"])
    assert abs(steps / steps0 - 1) < 0.05, (steps, steps0)
    peak, peak0 = float(sol.peak_contact_force), float(base.peak_contact_force)
    assert abs(peak / peak0 - 1) < 5e-3, (peak, peak0)


def test_penetration_width_too_wide_is_inaccurate(scene, nominal):
    """A regularization width comparable to the contact deflections (~1e-6 m here)
    changes the peak: against the converged nominal run (rtol 1e-9), width 1e-9 m and
    1e-7 m stay within 0.5 %, 1e-5 m is more than 10 % off (measured about −30 %)."""
    ref = float(nominal[1].peak_contact_force)
    change = {}
    for w in (1e-9, 1e-7, 1e-5):
        sol = adaptive(with_law(scene, width=w), rtol=1e-9, atol=1e-12)
        assert sol.ok, sol.message
        change[w] = float(sol.peak_contact_force) / ref - 1
    assert abs(change[1e-9]) < 5e-3 and abs(change[1e-7]) < 5e-3, change
    assert abs(change[1e-5]) > 0.1, change


# ------------------------------------------------------------------------- gradients
@pytest.mark.slow
def test_gradient_over_two_tooth_periods_is_finite(scene, record_property):
    """∂(soft peak)/∂u for the four tooth-profile coordinates, fixed-step Tsit5 (4 µs)
    through two tooth periods: finite and not zero; its norm is reported. Finite is not
    the same as useful: from this rattling layout start the norm is ~1.7e8 N, and central
    differences reach it only at ε ≈ 1e-10 (−890 N at 1e-4, −1.6e5 at 1e-6, −2.1e7 at
    1e-8): the discrete map varies on scales of 1e-9 in u. Growth with the horizon on the
    settled scene, checked against finite differences, is in benchmarks/stability.py."""
    space = jc.design.DesignSpace.iso606(jc.ChainSpec.iso606("08B"), 18)
    u0 = space.coordinates(scene.sprockets[0].profile)

    def soft_peak(u):
        sc = eqx.tree_at(lambda s: s.sprockets[0].profile, scene, space.profile(u))
        out = jc.design.soft_peak_force(
            sc, 2 * PERIOD, t_start=PERIOD, temperature=80.0, reference=4000.0, dt=4e-6
        )
        return out.soft, out.result

    (value, result), grad = jax.value_and_grad(soft_peak, has_aux=True)(u0)
    assert result == jc.Result.successful and np.isfinite(float(value))
    g = np.asarray(grad)
    norm = float(np.linalg.norm(g))
    record_property("grad_norm_N", norm)
    print(f"soft peak {float(value):.1f} N, ∂P/∂u = {g}, |∂P/∂u| = {norm:.4g} N")
    assert np.all(np.isfinite(g)) and norm > 0


# ------------------------------------------------------- one classification, every path
def _modes(scene):
    """(name, scene, solve options, expected result) of every failure mode above that runs
    in the default suite, and the nominal success."""
    euler_opts = dict(
        solver=diffrax.Euler(),
        stepsize_controller=diffrax.ConstantStepSize(),
        max_steps=EULER_STEPS,
    )
    slow_damping = eqx.tree_at(
        lambda s: s.impact_speed, with_law(scene, speed_floor=1e-5), jnp.asarray(1e-5)
    )
    # the same strand with a chain of 500 N tensile strength: its 1000 N entry span breaks it
    weak = eqx.tree_at(lambda s: s.tensile_strength, scene, jnp.asarray(500.0))
    return [
        ("nominal", scene, dict(max_steps=BUDGET), jc.Result.successful),
        ("fixed step above the limit", scene, dict(euler_opts, dt0=4e-6), jc.Result.diverged),
        ("blow-up still growing", scene, dict(euler_opts, dt0=7.3e-7), jc.Result.diverged),
        ("fixed step below the limit", scene, dict(euler_opts, dt0=2e-7), jc.Result.successful),
        ("stiffness starves", stiffened(scene, 100.0), dict(max_steps=BUDGET), None),
        ("damping floor too small", slow_damping, dict(max_steps=BUDGET), None),
        ("chain overloaded", weak, dict(max_steps=BUDGET), jc.Result.chain_overloaded),
    ]


def test_simulate_and_the_design_objective_report_every_failure_identically(scene):
    """``simulate`` and the design objective's solve (``design.soft_peak_force``) run the
    one solve path with its one classification: on the same scene and options every
    failure mode comes back as the same result code (and a failed design solve never as
    a plausible number: its result says so)."""
    seen = {}
    for name, sc, opts, expected in _modes(scene):
        sim = jc.simulate(sc, T1, n_save=41, throw=False, **opts)
        des = jc.design.soft_peak_force(sc, T1, temperature=50.0, reference=2000.0, **opts)
        seen[name] = (sim.result_name, jc.result_names(des.result)[0])
        assert sim.result == des.result, (name, seen[name])
        if expected is not None:
            assert sim.result == expected, (name, seen[name], sim.message)
    assert seen["stiffness starves"][0] == "max_steps_reached", seen
    assert seen["damping floor too small"][0] == "max_steps_reached", seen


# ------------------------------------------------------ wrong runs that look successful
def test_link_tension_beyond_the_tensile_strength_is_reported(scene, nominal):
    """A link tension above the chain's ISO 606 tensile strength is ``chain_overloaded``
    (the solve keeps the largest link tension in its stats); the nominal strand carries
    about 1.2 kN, far below 08B's 17.8 kN."""
    sol, _ = nominal
    assert float(scene.tensile_strength) == jc.ChainSpec.iso606("08B").tensile_strength
    peak = float(sol.stats["peak_link_tension"])
    assert 1000.0 < peak < 0.2 * float(scene.tensile_strength), peak
    weak = eqx.tree_at(lambda s: s.tensile_strength, scene, jnp.asarray(0.9 * peak))
    out = adaptive(weak)
    assert_reported(out, jc.Result.chain_overloaded, "tensile strength", "larger chain")
    with pytest.raises(jc.SolveError, match="chain_overloaded"):
        jc.simulate(weak, T1, n_save=41, max_steps=BUDGET)


def test_a_solve_past_the_scene_horizon_is_refused(scene):
    """The strand has 3 entry rollers: 3 tooth periods of meshing. A longer solve raises
    before anything is traced, at every entry point, saying what to change."""
    assert float(scene.horizon) == pytest.approx(3 * PERIOD, rel=1e-12)
    match = r"(?s)past the scene's horizon.*larger n_entry"
    with pytest.raises(ValueError, match=match):
        jc.simulate(scene, 4 * PERIOD)
    with pytest.raises(ValueError, match=r"members \[1\] end"):
        late = eqx.tree_at(lambda s: s.horizon, scene, jnp.asarray(0.1 * PERIOD))
        jc.simulate_ensemble([scene, late], T1)
    with pytest.raises(ValueError, match=match):
        jc.design.soft_peak_force(scene, 4 * PERIOD)
    assert np.isinf(
        float(
            jc.scenes.drive(
                "08B", (9, 9), n_links=20, model=jc.scenes.ChainModel(settle=False)
            ).horizon
        )
    )


def test_the_classification_orders_causes_first():
    """A solve past its horizon or in float32 is reported as that cause whatever followed
    from it; a diverged solve is ``diverged`` even when its tensions also broke the chain
    (the flags each come from the solve's health observer or its configuration)."""
    from jaxchain._solve.result import classify

    ok, bad = diffrax.RESULTS.successful, diffrax.RESULTS.max_steps_reached
    t, f = jnp.asarray(True), jnp.asarray(False)
    cases = [
        (dict(), ok, t, t, jc.Result.successful),
        (dict(within_strength=f), ok, t, t, jc.Result.chain_overloaded),
        (dict(within_strength=f), ok, f, t, jc.Result.diverged),
        (dict(within_strength=f), ok, t, f, jc.Result.chain_overloaded),
        (dict(), ok, t, f, jc.Result.contact_slots_exceeded),
        (dict(float_ok=False), bad, t, t, jc.Result.float32_state),
        (dict(within_horizon=f, float_ok=False), bad, f, t, jc.Result.past_horizon),
        (dict(within_horizon=f), ok, t, t, jc.Result.past_horizon),
    ]
    for flags, dr, healthy, slots, expected in cases:
        got = classify(dr, healthy, slots, **flags)
        assert got == expected, (flags, jc.result_names(got), jc.result_names(expected))
