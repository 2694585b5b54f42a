"""The main job (`python -m optimize`): runs on its default scene in fast mode, writes its
results folder, survives an interrupt (--resume loses no iteration), rejects bad input."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._design.objective import ProfileObjective
from optimize.__main__ import main, parse


def test_interrupt_then_resume_then_results(tmp_path, monkeypatch):
    """The whole job on the ISO problem (its compiled objective is the design tests'),
    interrupted and resumed; the default problem's own pieces are checked below and its
    whole run in the slow test."""
    out = tmp_path / "run"
    real = ProfileObjective.value_and_grad
    calls = []

    def interrupted(self, u):
        calls.append(1)
        if len(calls) == 2:  # Ctrl-C during the second iteration
            raise KeyboardInterrupt
        return real(self, u)

    monkeypatch.setattr(ProfileObjective, "value_and_grad", interrupted)
    with pytest.raises(SystemExit) as e:
        main(["--problem", "iso", "--fast", "--quiet", "--out", str(out)])
    assert e.value.code == 130
    ck = json.loads((out / "checkpoint.json").read_text())
    assert len(ck["history"]) == 1  # the finished iteration was kept
    first = ck["history"][0]
    monkeypatch.setattr(ProfileObjective, "value_and_grad", real)

    res = main(["--problem", "iso", "--fast", "--quiet", "--out", str(out), "--resume"])
    hist = res["history"]
    assert [h["iteration"] for h in hist] == [0, 1, 2]
    assert hist[0] == first  # resumed, not restarted
    saved = json.loads((out / "results.json").read_text())
    summary = saved["summary"]
    for key in ("objective", "unit", "baseline", "baseline_value", "optimized_value"):
        assert key in summary
    assert summary["unit"] == "N" and summary["remeasured"] is True
    assert summary["improvement"] == pytest.approx(
        1 - summary["optimized_value"] / summary["baseline_value"]
    )
    assert max(m["optimized_N"] for m in summary["members"]) == summary["optimized_value"]
    # the delivered design is the better re-measured of the two optimizers' designs
    runs = {k: saved["remeasured"][k]["johnson"]["peak_N"] for k in ("gradient", "nelder_mead")}
    assert summary["optimized_value"] == min(runs.values())
    assert saved["optimized"]["method"] == min(runs, key=runs.get)
    assert summary["method"].lower().startswith(saved["optimized"]["method"].split("_")[0])
    assert set(saved["reduction_by_method"]) == {"gradient", "nelder_mead"}
    for key in (
        "settings",
        "versions",
        "baselines",
        "optimized",
        "remeasured",
        "history",
        "gradient_free",
        "timing",
        "reduction_vs_better_baseline",
        "soft_peak_bias",
    ):
        assert key in saved
    for name in ("profile.png", "forces.png", "spectra.png", "objective.png"):
        assert (out / name).stat().st_size > 10_000
    # the driver torque's spectra, both designs (the spectrum itself: test below)
    sp = saved["spectra"]
    assert sp["mesh_frequency_Hz"] == pytest.approx(18 * 1000 / 60 * sp["speed_factor"])
    for name in ("optimized", saved["better_baseline"]):
        assert sp[name]["largest_line"]["amplitude"] > 0
        assert all(v >= 0 for v in sp[name]["band_rms"].values())
    # the optimized design is inside its box, written as DXF arcs
    assert all(0 < f < 1 for f in saved["optimized"]["fraction_of_box"])
    assert saved["problem"] == "iso" and len(saved["optimized"]["u"]) == 4
    assert (out / "sprocket.dxf").stat().st_size > 10_000
    # the delivered design, saved as a profile that loads back with its parameters
    from optimize.problem import profile_values

    assert profile_values(jc.load_profile(out / "profile.json")) == saved["optimized"]["params"]
    # re-measured with both laws: the ISO minimum form's peaks against a re-measurement
    # at rtol 1e-8 (the job's compiled solves: a tolerance is no new program; 0.8 s each),
    # measured 5.6e-7 (Johnson) and 4.6e-8 (Hertz) apart at the job's rtol 1e-6
    from optimize.problem import iso_forms, make_problem, remeasure

    problem = make_problem(parse(["--problem", "iso", "--fast"])[0])
    for law in ("johnson", "hertz"):
        tight = remeasure(problem, iso_forms(problem)["min"], law=law, rtol=1e-8)["peak_N"]
        assert saved["remeasured"]["iso_min"][law]["peak_N"] == pytest.approx(tight, rel=2e-6)
    for design in saved["remeasured"].values():  # each the worst of its members
        for law in ("johnson", "hertz"):
            if "members" in design[law]:
                worst = max(m["peak_N"] for m in design[law]["members"])
                assert design[law]["peak_N"] == worst
    assert saved["timing"]["grad_over_forward"] > 1.0
    nm = saved["remeasured"]["nelder_mead"]  # the gradient-free design's own re-measurement
    assert saved["gradient_free"]["remeasured"] == {k: nm[k]["peak_N"] for k in nm}

    # a resume with other physics is refused with the differing settings named
    with pytest.raises(SystemExit, match="speed_rpm"):
        main(["--problem", "iso", "--fast", "--quiet", "--out", str(out), "--resume",
              "--speed", "900"])  # fmt: skip


@pytest.mark.slow
def test_default_problem_runs_end_to_end(tmp_path):
    """The default (gentle) problem in fast mode: a free-form design of 7 coordinates,
    re-measured, written with its summary, figures and DXF."""
    res = main(["--fast", "--quiet", "--out", str(tmp_path)])
    assert res["problem"] == "gentle" and len(res["optimized"]["u"]) == 7
    assert res["summary"]["remeasured"] is True
    for name in ("profile.png", "forces.png", "spectra.png", "objective.png", "sprocket.dxf"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert jc.load_profile(tmp_path / "profile.json").arcs == 2


@pytest.mark.slow
def test_clearance_remeasurement(tmp_path):
    """The fast run with the clearance-chain re-measurement on (4 engagements): per
    engagement statistics of both designs at the one operating point, the difference's
    interval, and the summary's fidelity, engagement count and interval per member."""
    res = main(["--fast", "--quiet", "--out", str(tmp_path), "--clearance-engagements", "4"])
    c = res["clearance"]
    assert c["fidelity"] == "clearance" and len(c["members"]) == 1
    m = c["members"][0]
    for name in ("optimized", c["baseline"]):
        assert m[name]["ok"], m[name]["message"]
        assert m[name]["n"] >= 3 and len(m[name]["peaks_N"]) == m[name]["n"]
        lo, hi = m[name]["ci95_N"]
        assert lo < m[name]["mean_N"] < hi
    d = m["optimized"]["difference"]
    assert d["ci95_N"][0] < d["mean_N"] < d["ci95_N"][1]
    row = res["summary"]["clearance"]["members"][0]
    assert row["optimized_engagements"] == m["optimized"]["n"]
    assert row["improvement"] == pytest.approx(-d["relative"])
    assert "clearance" in (tmp_path / "results.json").read_text()


@pytest.mark.slow
def test_quiet_problem_delivers_both_designs_and_resumes(tmp_path):
    """``--problem quiet`` in fast mode: the tooth and the tooth with its ring designed
    (lumped chain), the best ISO form and both measured in the clearance-joint chain dry
    and in oil (4 engagements), both roller populations told apart; the summary lists
    each design's files (the ring's read back by CushionRing.load) and the goals; a
    resume reads every finished solve back instead of solving it again."""
    res = main(["--problem", "quiet", "--fast", "--quiet", "--out", str(tmp_path)])
    designs = res["summary"]["designs"]
    assert set(designs) == {"tooth", "tooth_ring"}
    assert jc.load_profile(tmp_path / designs["tooth"]["profile"]).arcs == 2
    ring = jc.elements.CushionRing.load(tmp_path / designs["tooth_ring"]["cushion"])
    assert 0.0300 < float(ring.radius) < 0.0304
    table = res["clearance"]["table"]
    assert [(e["speed_factor"], e["lubrication"]) for e in table] == [(1.0, "dry"), (1.0, "oil")]
    for e in table:
        for name in ("tooth", "tooth_ring"):
            assert e[name]["ok"] and e[name]["n"] >= 3, e[name]["message"]
            d = e[name]["against_baseline"]
            assert d["p95_ci95_N"][0] <= d["p95_ci95_N"][1]
            assert {"first", "second"} <= set(e[name])
    assert set(res["summary"]["goals"]) == {"tooth", "tooth_ring"}
    assert (tmp_path / "peaks.png").stat().st_size > 10_000
    again = main(["--problem", "quiet", "--fast", "--quiet", "--out", str(tmp_path), "--resume"])
    assert again["clearance"]["table"] == table
    assert again["wall_s"] < 0.25 * res["wall_s"]  # nothing solved again


def test_quiet_refuses_options_it_does_not_use():
    with pytest.raises(SystemExit, match="does not use --dt, --learning-rate.*reads .*--speeds"):
        main(["--problem", "quiet", "--dt", "2e-6", "--learning-rate", "0.1", "--quiet"])
    with pytest.raises(SystemExit, match="--speeds is an option of --problem quiet"):
        main(["--speeds", "1,2", "--fast", "--quiet"])
    with pytest.raises(SystemExit, match=r"speeds must be factors in \[0.2, 5\]"):
        main(["--problem", "quiet", "--speeds", "9", "--quiet"])
    with pytest.raises(SystemExit, match=r"engagements must be in \[2, 1000\]"):
        main(["--problem", "quiet", "--clearance-engagements", "1", "--quiet"])


def test_options_a_problem_does_not_use_are_refused():
    with pytest.raises(SystemExit, match="--problem timing designs a timing drive.*--chain"):
        main(["--problem", "timing", "--chain", "06B", "--quiet"])
    with pytest.raises(SystemExit, match="--pretension sets the closed drive of --scene drive"):
        main(["--pretension", "300", "--fast", "--quiet"])
    with pytest.raises(SystemExit, match="--driven-teeth sets the closed drive"):
        main(["--driven-teeth", "40", "--fast", "--quiet"])


def test_torque_spectrum_reads_amplitudes_and_band_rms():
    """The spectra the main job writes: a Hann-windowed sine reads its amplitude at its
    frequency, and each band's RMS is the RMS of the sine inside it (A/√2), zero elsewhere."""
    from optimize.run import torque_spectrum

    ts = np.arange(20_000) * 0.5e-6  # 10 ms, as the re-measurement samples
    x = 3.0 + 0.8 * np.sin(2 * np.pi * 2500.0 * ts) + 0.05 * np.sin(2 * np.pi * 9e3 * ts)
    sp = torque_spectrum(ts, x)
    assert sp["largest_line"]["frequency_Hz"] == pytest.approx(2500.0, abs=sp["resolution_Hz"] / 8)
    assert sp["largest_line"]["amplitude"] == pytest.approx(0.8, rel=1e-3)
    rms = sp["band_rms"]
    assert rms["1-5 kHz"] == pytest.approx(0.8 / np.sqrt(2), rel=0.02)
    assert rms["5-20 kHz"] == pytest.approx(0.05 / np.sqrt(2), rel=0.02)
    assert rms["0-1 kHz"] < 1e-3


def test_the_gradient_cost_is_read_off_the_runs_own_calls():
    """Medians of the calls after each kind's first (which compiles); None without two."""
    from optimize.run import call_costs

    c = call_costs([60.0, 6.0, 5.0, 7.0], [14.0, 1.5, 2.5])
    assert c == {"forward_s": 2.0, "value_and_grad_s": 6.0, "grad_over_forward": 3.0}
    assert call_costs([60.0], [14.0, 2.0]) == {
        "forward_s": 2.0,
        "value_and_grad_s": None,
        "grad_over_forward": None,
    }


def test_problems_and_their_starts():
    """--problem iso designs in the ISO 606 box from its middle; the default (gentle)
    from the ISO minimum form's seat and flanks in a 7-coordinate free-form box."""
    from optimize.problem import make_problem
    from optimize.run import start_coordinates

    s, _ = parse(["--problem", "iso", "--fast"])
    iso = make_problem(s)
    assert iso.space.names == jc.design.PARAMETERS
    assert float(jnp.abs(start_coordinates(iso)).max()) == 0.0
    g = make_problem(parse(["--fast"])[0])
    assert g.space.size == 7 and g.settings.wear == (0.0,)
    u0 = start_coordinates(g)
    assert np.all(np.abs(np.asarray(u0)) < 4)  # inside the box, off its bounds
    full = parse([])[0]
    assert full.ensemble == (0.5, 1.0, 1.5) and full.wear == (0.0, 0.02)
    assert parse(["--scene", "drive"])[0].wear == (0.0,)


def test_bad_options_are_explained():
    with pytest.raises(SystemExit, match="chain"):
        main(["--chain", "99Z", "--fast", "--quiet"])
    with pytest.raises(SystemExit, match="warmup"):
        main(["--periods", "2", "--warmup", "2", "--quiet"])
    with pytest.raises(SystemExit, match="optax optimizer"):
        main(["--optimizer", "nonsense", "--quiet"])
    s, _ = parse(["--ensemble", "0.9,1,1.1"])
    assert s.ensemble == (0.9, 1.0, 1.1)


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--speed", "nan"], "speed_rpm must be a finite number, got nan"),
        (["--load", "inf"], "load must be a finite number, got inf"),
        (["--learning-rate", "-1"], "learning_rate must be > 0"),
        (["--baseline-budget", "-3"], "baseline_budget must be >= 0"),
        (["--clip", "nan"], r"clip must be a finite number >= 0 \(0: no clipping\), got nan"),
        (["--ensemble", "1,nan"], r"ensemble speed factors must be in \[0.2, 5\]"),
        (["--dt", "1e-3"], "dt must be <= 2e-5 s"),
        (["--clearance-engagements", "-1"], r"clearance_engagements must be in \[0, 1000\]"),
        (["--samples", "-1"], r"samples must be in \[0, 64\] \(0: the soft peak integrated"),
        (
            ["--scene", "drive", "--pretension", "-1"],
            r"pretension must be a finite number > 0 \[N\], got -1.0",
        ),
        # a drive whose load the pretension cannot carry: the builder's fix, in options
        (["--scene", "drive", "--load", "30"], r"pretension >= 206.4 N.*--pretension \[N\]"),
        (["--out", __file__], "test_main_job.py is a file; give a folder"),
        (["--out", "/proc/no/such"], "is not a writable folder"),
    ],
)
def test_user_errors_exit_with_a_message_not_a_traceback(argv, match):
    with pytest.raises(SystemExit, match=match) as e:
        main(["--fast", "--quiet", *argv])
    assert str(e.value).startswith("python -m optimize: error: ")


@pytest.mark.parametrize(
    "text, match",
    [
        ("{not json", r"checkpoint.json is not a readable checkpoint .*delete .*checkpoint"),
        ('{"weights": [1, 2]}', r"not a checkpoint of python -m optimize \(missing \['settings'"),
        ("", "is not a readable checkpoint"),
    ],
)
def test_a_damaged_or_foreign_checkpoint_is_named_with_the_fix(tmp_path, text, match):
    (tmp_path / "checkpoint.json").write_text(text)
    with pytest.raises(SystemExit, match=match):
        main(["--fast", "--quiet", "--out", str(tmp_path), "--resume"])


def test_fast_keeps_the_options_given():
    """--fast makes the run small, but an option given explicitly is not overridden."""
    s, _ = parse(["--fast"])
    assert (s.periods, s.iterations, s.ensemble, s.baseline_budget) == (2, 3, (1.0,), 4)
    s, _ = parse(["--fast", "--periods", "3", "--iterations", "5", "--ensemble", "0.9,1.1"])
    assert (s.periods, s.iterations, s.ensemble, s.baseline_budget) == (3, 5, (0.9, 1.1), 4)
    s, _ = parse([])
    assert (s.periods, s.iterations, s.ensemble) == (2, 10, (0.5, 1.0, 1.5))


def test_an_optimizer_must_be_an_optax_optimizer():
    for name in ("chain", "tree_utils", "nonsense", "GradientTransformation"):
        with pytest.raises(SystemExit, match="optimizer must name an optax optimizer"):
            main(["--optimizer", name, "--quiet", "--fast"])
    s, _ = parse(["--optimizer", "adamw"])
    s.validate()


@pytest.mark.parametrize(
    "u, match",
    [([0.0, 0.0, 0.0], r"damaged \(u of shape \(3,\)"), (["zero"] * 4, "non-numeric values")],
)
def test_a_checkpoint_with_damaged_values_is_refused(tmp_path, u, match):
    """The checkpoint carries this run's settings; only its values are damaged."""
    from optimize.run import CHECKPOINT

    s, _ = parse(["--fast"])
    ck = dict(settings=s.as_dict(), u=u, opt_state=[], history=[], baselines={}, evaluations=0)
    (tmp_path / CHECKPOINT).write_text(json.dumps(ck | {"timing": {}}))
    with pytest.raises(SystemExit, match=match):
        main(["--fast", "--quiet", "--out", str(tmp_path), "--resume"])


def test_jaxchain_fast_is_read_as_the_notebooks_read_it(monkeypatch):
    monkeypatch.setenv("JAXCHAIN_FAST", "0")
    assert parse([])[0].iterations == 10
    monkeypatch.setenv("JAXCHAIN_FAST", "1")
    assert parse([])[0].iterations == 3


def test_speed_groups_combine_as_one_objective_over_all_members():
    """``--horizon own`` solves each speed as its own objective; combined, they are the
    one objective over all members: the soft maximum of equal-sized groups' log-mean-exp
    values is the log-mean-exp of every member (the mean of means the mean), and the
    gradient follows by the same weights. The groups run side by side in threads.
    Checked on stand-in groups with known members."""
    import threading
    import time

    import jax

    from jaxchain.design import Observed
    from optimize.problem import SpeedGroups

    tau = 20.0
    members = jnp.array([[1500.0, 1530.0], [1480.0, 1400.0], [1600.0, 1590.0]])  # (speed, wear)
    grads = jnp.arange(12.0).reshape(3, 2, 2)  # each member's gradient in a 2-vector u

    def lme(v):
        return tau * (jax.nn.logsumexp(v / tau) - jnp.log(v.size))

    solved_in = set()  # the threads the groups of one call ran in

    class Group:
        evaluations = 0

        def __init__(self, k, combine):
            self.k, self.combine = k, combine

        def _value(self, v):
            return lme(v) if self.combine == "max" else jnp.mean(v)

        def value(self, u):
            solved_in.add(threading.get_ident())
            time.sleep(0.05)  # each group's solve long enough for the threads to share them
            v = members[self.k]
            return self._value(v), Observed(v, jnp.zeros(2, int), jnp.ones(2, int))

        def value_and_grad(self, u):
            v = members[self.k]
            g = jax.grad(lambda x: self._value(x))(v) @ grads[self.k]
            return self._value(v), g, self.value(u)[1]

    for combine, tau_groups in (("max", tau), ("mean", None)):
        combined = SpeedGroups([Group(k, combine) for k in range(3)], tau_groups, threads=2)
        solved_in.clear()  # (a finished thread's identifier may be given to a later one)
        value, grad, out = combined.value_and_grad(jnp.zeros(2))
        assert len(solved_in) == 2
        flat = members.reshape(-1)
        whole = lme if combine == "max" else jnp.mean
        one, one_grad = whole(flat), jax.grad(whole)(flat)
        assert abs(float(value) - float(one)) < 1e-9
        np.testing.assert_allclose(grad, one_grad @ grads.reshape(6, 2), rtol=1e-12)
        np.testing.assert_array_equal(out.value, flat)  # speeds outer, as operating_points
        assert float(combined.value(jnp.zeros(2))[0]) == float(value)
    combined.evaluations = 42  # a resumed run restores its count
    assert combined.evaluations == 42


def test_remeasurement_solves_side_by_side_are_those_solved_one_by_one():
    """The re-measurement runs its independent solves in threads (one per core): the
    results are bit for bit those of one solve after the other, and the solve holds no
    custom call (a batched LAPACK kernel inside two executions at once can take every
    thread of XLA's pool and wait for itself)."""
    import re

    import diffrax
    import jax

    from optimize.__main__ import fast_settings
    from optimize.problem import Settings, iso_forms, make_problem, remeasure_many, second_law

    s = fast_settings(Settings())
    s.wear = (0.0, 0.02)
    problem = make_problem(s)
    forms = iso_forms(problem)
    (one,) = remeasure_many(problem, [(forms["min"], "hertz")], threads=1)
    (two,) = remeasure_many(problem, [(forms["min"], "hertz")], threads=2)
    assert one["peak_N"] == two["peak_N"]
    assert [r["wear"] for r in two["members"]] == [0.0, 0.02]
    for a, b in zip(one["members"], two["members"], strict=True):
        assert a["ok"] and a["steps"] == b["steps"]
        np.testing.assert_array_equal(a["force"], b["force"])
        np.testing.assert_array_equal(a["torque"], b["torque"])

    scene = problem.build(forms["min"], 1.0, roller_contact=second_law(problem.chain))
    solve = jax.jit(
        lambda sc: (
            jc.simulate(
                sc, problem.t1, solver=diffrax.Dopri8(), n_save=3, max_steps=10, throw=False
            ).roller_sprocket_force
        )
    )
    assert not re.findall(r"custom_call", solve.lower(scene).as_text())


def test_design_programs_hold_no_library_call(monkeypatch):
    """The speed groups run side by side in threads (``SpeedGroups``): what runs there —
    the relaxation settling the scenes, the statics Jacobians, the design objective's
    program — holds no custom call (the statics step multiplies by the Jacobian's
    inverse, inverted on the host; the Newton polish, which has LAPACK calls, runs one at
    a time). Lowered only, from the relaxation's arguments (caught before it runs)."""
    import re

    from jaxchain._design import objective as design
    from jaxchain._scenes import statics
    from optimize.__main__ import fast_settings
    from optimize.problem import Settings, make_problem
    from optimize.run import start_coordinates

    class Caught(Exception):
        pass

    relaxed = []

    def caught(*args):
        relaxed.append(args)
        raise Caught

    relax = statics._relax
    monkeypatch.setattr(statics, "_relax", caught)
    problem = make_problem(fast_settings(Settings()))
    group = problem.make_objective(1000.0).groups[0]
    u = start_coordinates(problem)
    with pytest.raises(Caught):
        group.scenes(u)
    scene, x0 = relaxed[0][0], relaxed[0][2]  # a member at rest, the statics unknowns
    scenes = jc.scenes.stack([scene])
    inverses = jnp.zeros((1, x0.size, x0.size))
    for program, args in (
        (relax.__wrapped__, relaxed[0]),
        (design._jacobians.__wrapped__, (scenes, group.config.take_up)),
        (design._value.__wrapped__, (u, group.space, scenes, inverses, group.config)),
    ):
        assert not re.findall(r"custom_call", program.lower(*args).as_text())
