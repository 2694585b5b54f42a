"""The benchmark scripts run end to end (slow: `python -m pytest -m slow`)."""

import json
import math

import numpy as np
import pytest


@pytest.mark.slow
def test_dynamics_benchmark_quick(tmp_path):
    from benchmarks.dynamics import main

    main(["--quick", "--out", str(tmp_path)])
    res = json.loads((tmp_path / "dynamics.json").read_text())
    assert {"engagement", "compile", "fidelity", "clearance_drive_speed", "targets"} <= set(res)
    assert res["engagement_rollers"]["cost_ratio"] > 0
    for row in res["engagement"].values():
        assert row["steps"] > 0 and row["result"] == "successful"
    assert (tmp_path / "dynamics.png").stat().st_size > 10_000


@pytest.mark.slow
def test_stability_benchmark_quick(tmp_path):
    from benchmarks.stability import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = res["map"]["rows"]
    assert {r["method"] for r in rows} == {"Euler", "Heun", "Tsit5"}
    assert all(r["measured_dt"] for r in rows)
    # the measured boundary is the linear bound of the scene's modes (Heun, Tsit5)
    assert all(0.8 < r["measured_over_horizon_bound"] < 1.3 for r in rows if r["method"] != "Euler")
    assert (tmp_path / "stability.png").stat().st_size > 10_000


@pytest.mark.slow
def test_fidelity_benchmark_quick(tmp_path):
    from benchmarks.fidelity import main

    res = main(["--quick", "--out", str(tmp_path)])
    for v in res["variants"].values():
        assert all(m["ok"] for m in v["members"])
        # every variant starts settled: the entry span carries its 1000 N
        assert abs(v["tight_span_mean_N"]["mean"] / 1000.0 - 1) < 0.05
    assert res["rollers_fixed_vs_on_joint"]["cost_ratio"] > 0
    assert (tmp_path / "fidelity.png").stat().st_size > 10_000


@pytest.mark.slow
def test_tension_climb_benchmark_quick(tmp_path):
    from benchmarks.archive.tension_climb import main

    res = main(["--quick", "--out", str(tmp_path)])
    s = res["statics"]
    # the settled drive: the spans' mean the pretension, their difference the load over R2
    assert abs(s["settled_span_mean_N"] / s["pretension_N"] - 1) < 0.05
    assert abs(s["settled_difference_N"] / s["load_over_driven_radius_N"] - 1) < 0.02
    assert all(r["result"] == "successful" for r in res["mu_sweep"])
    # the driven sprocket turns at z1/z2 of the driver
    assert all(abs(r["speed_ratio"] / s["speed_ratio"] - 1) < 0.02 for r in res["mu_sweep"])
    assert (tmp_path / "tension_climb.png").stat().st_size > 10_000


@pytest.mark.slow
def test_geometry_benchmark_quick(tmp_path):
    from benchmarks.geometry import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = {(r["scene"], r["profile"]): r for r in res["rows"]}
    assert len(rows) == 6
    for r in rows.values():
        assert r["us_per_vf_call"] > 0 and r["compile_s"] > 0
    # free-form teeth (3 arcs a flank) cost more to touch than ISO's (a seat arc and a
    # flank arc a side): the contact evaluation timed alone, the steadiest of the timings
    # (the study ×1.48 and ×1.70; a quick run beside other work ×1.43 and ×1.63)
    iso = rows["engagement", "iso"]["us_per_contact"]
    for key in ("freeform_uniform", "freeform_per_gap"):
        assert rows["engagement", key]["us_per_contact"] > 1.15 * iso
    assert (tmp_path / "geometry.png").stat().st_size > 10_000


@pytest.mark.slow
def test_gradient_cost_benchmark_quick(tmp_path):
    from benchmarks.gradient_cost import main

    res = main(["--quick", "--out", str(tmp_path)])
    assert [r["dimension"] for r in res["rows"]] == [4, 72]
    for r in res["rows"]:
        assert r["grad_finite"] and r["ratio"] > 1.0 and r["gradient"] == "reverse"
        # the three ways to the gradient agree (checkpointed: the same discrete gradient;
        # forward mode: the same derivative, rounded otherwise)
        assert r["grad_difference_checkpointed"] < 1e-6 and r["grad_difference_forward"] < 1e-6
    assert (tmp_path / "gradient_cost.png").stat().st_size > 10_000


@pytest.mark.slow
def test_methods_benchmark_quick(tmp_path):
    from benchmarks.methods import main

    res = main(["--quick", "--out", str(tmp_path)])
    assert [r["dimension"] for r in res["rows"]] == [4, 36]
    for row in res["rows"]:
        assert row["ratio"] > 1.0
        runs = {r["method"]: r for r in row["runs"]}
        assert set(runs) == {"Adam", "L-BFGS", "CMA-ES", "Nelder-Mead"}
        for r in row["runs"]:
            assert r["failed_solves"] == 0
            assert 0 < r["simulation_equivalents"] <= row["budget"] + 1e-9
            best = [b for _, b in r["curve"]]
            assert np.all(np.diff(best) <= 0)
        # a value + gradient is charged the measured ratio
        adam = runs["Adam"]
        assert adam["simulation_equivalents"] == pytest.approx(adam["evaluations"] * row["ratio"])
        # Adam and Nelder-Mead evaluate the start first; Adam's steps lower the objective
        assert adam["curve"][0] == [pytest.approx(row["ratio"]), pytest.approx(row["start_N"])]
        assert adam["best_N"] < row["start_N"] and runs["Nelder-Mead"]["best_N"] <= row["start_N"]
        assert row["target_N"] < row["start_N"]
        lbfgs = runs["L-BFGS"]
        assert lbfgs["simulation_equivalents"] == pytest.approx(lbfgs["evaluations"] * row["ratio"])
        assert lbfgs["best_N"] < row["start_N"]
        assert set(row["speedup_over_cma"]) == {"Adam", "L-BFGS"}
    assert res["settings"]["samples"] == 8
    assert (tmp_path / "methods.png").stat().st_size > 10_000


@pytest.mark.slow
def test_quiet_drive_benchmark_quick(tmp_path):
    from benchmarks.quiet_drive import main

    res = main(["--quick", "--processes", "2", "--out", str(tmp_path)])
    summ = res["summary"]
    assert set(summ) == {"iso_min", "random_radius"}
    for v in summ.values():
        assert not v["failed"] and 0 < v["worst_peak_N"] < 20_000
        assert -40 < v["signals"]["bearing1"]["worst_dB"] < 100
    assert summ["iso_min"]["vs_iso_min"]["worst_peak"] == 0.0
    assert (tmp_path / "quiet_drive.png").stat().st_size > 10_000
    assert not (tmp_path / "quiet_drive.partial.json").exists()


def test_quiet_drive_refuses_bad_options(tmp_path):
    from benchmarks.quiet_drive import main

    for argv, match in [
        (["--designs", "iso_min,square"], "unknown"),
        (["--speeds", "1000,fast"], "numbers"),
        (["--speeds", "50"], "100–5000"),
        (["--revs", "0.4"], "exceed 0.5"),
        (["--processes", "0"], "≥ 1"),
    ]:
        with pytest.raises(SystemExit, match=match):
            main([*argv, "--out", str(tmp_path)])


@pytest.mark.slow
def test_tolerance_benchmark_quick(tmp_path):
    from benchmarks.tolerance import main

    res = main(["--quick", "--processes", "1", "--out", str(tmp_path)])
    summ, main_job = res["summary"], res["main_job"]
    # δ = 0 reproduces the main job's re-measured peaks (its worst operating point)
    assert summ["nominal"]["iso_min"]["peak_N"] == pytest.approx(main_job["iso_min_N"], rel=1e-4)
    assert summ["nominal"]["optimized"]["peak_N"] == pytest.approx(
        main_job["optimized_N"], rel=1e-4
    )
    row = summ["tolerance"]["20"]
    for d in ("iso_min", "optimized"):
        assert row[d]["n"] == 2 and not (row[d]["invalid"] or row[d]["failed"])
        assert 0.5 * main_job["optimized_N"] < row[d]["median_N"] < 2 * main_job["iso_min_N"]
    assert 0 <= row["optimized_below_iso_nominal"] <= 1 and row["paired"]["n"] == 2
    # the seating radius offset moves the seat by δ
    dev = res["outline_deviation_um"]["20"]["iso_min"]
    assert dev["seating_radius"] == pytest.approx(20.0, rel=0.02)
    assert (tmp_path / "tolerance.png").stat().st_size > 10_000
    assert not (tmp_path / "tolerance.partial.json").exists()


def test_design_freedoms_reads_both_runs(tmp_path):
    """The design-freedoms table from the two committed main-job runs (no simulation):
    every design's worst peak as its run re-measured it, against the ISO minimum form;
    runs made on different operating points are refused."""
    from benchmarks.archive.design_freedoms import FREEFORM, ISO, main

    res = main(["--out", str(tmp_path)])
    rows = {(r["freedom"], r["design"]): r for r in res["table"]["rows"]}
    free = json.loads(FREEFORM.read_text())
    assert rows[("ISO 606 form", "min form")]["vs_iso_min"]["johnson"] == 0.0
    nm = rows[("free-form asymmetric", "nelder_mead")]
    assert nm["johnson"] == free["remeasured"]["nelder_mead"]["johnson"]["peak_N"]
    assert nm["vs_iso_min"]["johnson"] == pytest.approx(
        nm["johnson"] / free["remeasured"]["iso_min"]["johnson"]["peak_N"] - 1
    )
    assert {d for f, d in rows if f == "ISO 606 box"} == {"adam", "nelder_mead"}
    assert (tmp_path / "design_freedoms.png").stat().st_size > 10_000
    other = json.loads(ISO.read_text())
    other["settings"]["speed_rpm"] = 900.0
    (tmp_path / "other.json").write_text(json.dumps(other))
    with pytest.raises(ValueError, match="speed_rpm"):
        main(["--out", str(tmp_path), "--iso", str(tmp_path / "other.json")])


@pytest.mark.slow
def test_job_threads_quick(tmp_path):
    """The threads study's quick run on the main job's default objective: both ways timed,
    the same value and gradient bit for bit, three speed groups."""
    from benchmarks.job_threads import main

    res = main(["--quick", "--out", str(tmp_path)])
    assert res["bit_for_bit"] and res["groups"] == 3
    assert {(r["way"], r["call"]) for r in res["rows"]} == {
        (w, c) for w in ("one by one", "threads") for c in ("value_and_grad", "value")
    }
    assert all(r["wall_s"] > 0 for r in res["rows"])
    assert (tmp_path / "job_threads.png").stat().st_size > 10_000


@pytest.mark.slow
def test_step_convergence_quick(tmp_path):
    """The step study's quick run (4 and 2 µs at the box middle of the main job's default
    objective in the job's form: sampled soft peak, each member over its own periods):
    each row's value and gradient against the finest step's, the values within 1 % of
    each other (the gradients are the study's finding, not a bound)."""
    from benchmarks.step_convergence import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = {r["dt"]: r for r in res["rows"]}
    assert set(rows) == {4e-6, 2e-6}
    assert rows[2e-6]["value_change"] == 0.0 and rows[2e-6]["gradient_distance"] == 0.0
    assert abs(rows[4e-6]["value_change"]) < 0.01
    assert all(np.all(np.isfinite(r["gradient"])) for r in rows.values())
    assert (tmp_path / "step_convergence.png").stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the 4-period drive gradient blows up (|grad| 1.4e9) in the quick run, also with "
    "the library of 2026-12-07's start; the committed run had 1077 N/u: cause not found",
)
def test_drive_gradient_quick(tmp_path):
    """The closed-drive gradient study's quick run (2 and 4 tooth periods, 4 µs): finite,
    successful rows, the gradient larger over the longer solve, the fitted growth per
    period from them, the chart written."""
    from benchmarks.drive_gradient import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = {r["periods"]: r for r in res["rows"]}
    assert set(rows) == {2, 4}
    assert all(r["result"] == "successful" and np.isfinite(r["grad_norm"]) for r in rows.values())
    assert rows[4]["grad_norm"] > rows[2]["grad_norm"]
    expected = (rows[4]["grad_norm"] / rows[2]["grad_norm"]) ** 0.5
    assert res["growth_per_period"]["drive"] == pytest.approx(expected, rel=1e-9)
    assert res["growth_per_period"]["engagement"] is None and res["band"] is None
    assert (tmp_path / "drive_gradient.png").stat().st_size > 10_000


@pytest.mark.slow
def test_pattern_remeasure_quick(tmp_path):
    """The per-tooth designs' re-measurement, quick (the uniform start and Adam's pattern
    from the committed every-gap result, rtol 1e-7): six members each, finite peaks under
    both laws, the changes against the start computed from them, the chart written."""
    from benchmarks.archive.pattern_remeasure import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = {r["design"]: r for r in res["rows"]}
    assert set(rows) == {"start (uniform ISO mid)", "Adam"}
    for r in rows.values():
        for law in ("johnson", "hertz"):
            assert r[law]["ok"] and len(r[law]["members_N"]) == 6
            assert 100 < r[law]["peak_N"] == max(r[law]["members_N"]) < 20_000
    start = rows["start (uniform ISO mid)"]
    assert start["change_vs_start"] == {"johnson": 0.0, "hertz": 0.0}
    # the uniform start's six turned members are one solve turned by whole pitches (equal
    # to the adaptive solves' tolerance: measured 1.4e-6 of the peak at rtol 1e-7)
    assert np.ptp(start["johnson"]["members_N"]) < 1e-5 * start["johnson"]["peak_N"]
    adam = rows["Adam"]["change_vs_start"]["johnson"]
    assert adam == pytest.approx(rows["Adam"]["johnson"]["peak_N"] / start["johnson"]["peak_N"] - 1)
    assert (tmp_path / "pattern_remeasure.png").stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.parametrize("robust", [False, True])
def test_pattern_design_quick(tmp_path, robust):
    """The per-tooth design around the ISO minimum form, quick (2 Adam steps from the
    perturbed start, re-measured at rtol 1e-7): the history, the three re-measured designs
    with six members under both laws, the changes against the uniform form, the chart;
    robust: both design laws' values in every step, the uniform form's objective 1."""
    from benchmarks.archive.pattern_design import main

    res = main(["--quick", "--out", str(tmp_path), *(["--robust"] if robust else [])])
    assert res["form"] == "min" and [h["step"] for h in res["history"]] == [0, 1]
    assert res["start"]["objective"] == res["history"][0]["objective"]
    if robust:
        assert res["uniform"]["objective"] == pytest.approx(1.0, abs=1e-12)
        for h in res["history"]:
            assert len(h["johnson_members_N"]) == len(h["hertz_members_N"]) == 6
            relative = [h[f"{law}_N"] / res["uniform"][f"{law}_N"] for law in ("johnson", "hertz")]
            # the soft maximum lies between the larger and the larger − τ·log 2
            assert max(relative) - 0.01 * math.log(2) - 1e-12 <= h["objective"] <= max(relative)
    else:
        assert len(res["history"][0]["members_N"]) == 6
    for name in ("uniform", "start", "designed"):
        for law in ("johnson", "hertz"):
            r = res[name]["remeasured"][law]
            assert r["ok"] and len(r["members_N"]) == 6 and r["peak_N"] == max(r["members_N"])
    base = res["uniform"]["remeasured"]["johnson"]["peak_N"]
    got = res["designed"]["remeasured"]["johnson"]["peak_N"]
    assert res["change_vs_uniform"]["designed"]["johnson"] == pytest.approx(got / base - 1)
    name = "pattern_design_min" + ("_robust" if robust else "")
    assert (tmp_path / f"{name}.png").stat().st_size > 10_000


@pytest.mark.slow
def test_design_fidelity_quick(tmp_path):
    """Two random per-tooth patterns, each member's change under the design model and
    re-measured under the nominal one, both laws; the agreement figures and the chart."""
    from benchmarks.design_fidelity import main

    res = main(["--quick", "--out", str(tmp_path)])
    assert len(res["patterns"]) == 2
    for p in res["patterns"]:
        for law in ("johnson", "hertz"):
            e = p[law]
            assert e["nominal"]["ok"] and len(e["design_change"]) == len(e["nominal_change"]) == 6
            base = res["uniform"][law]["nominal"]["peak_N"]
            assert e["nominal_worst_change"] == pytest.approx(e["nominal"]["peak_N"] / base - 1)
    for law in ("johnson", "hertz"):
        a = res["agreement"][law]["members"]
        assert a["points"] == 12 and -1 <= a["correlation"] <= 1
    assert (tmp_path / "design_fidelity.png").stat().st_size > 10_000


@pytest.mark.slow
def test_clearance_peak_quick(tmp_path):
    """Every variant runs, the study's impact observer sees the onsets and peaks that
    EngagementPeaks sees, the decomposition approach = bush approach + rattle holds, and
    the statistics, comparisons and chart are written."""
    from benchmarks.clearance_peak import DEFAULT, PAIRS, VARIANTS, main

    res = main(["--quick", "--out", str(tmp_path)])
    by = res["runs"]["1250"]
    assert set(by) == set(VARIANTS)
    for row in by.values():
        assert row["ok"] and row["n"] >= 2
        assert row["onset_difference_us"] < 1.0
        lo, hi = row["top_over_peak"]
        assert 0.95 < lo <= hi <= 1.0 + 1e-9  # step ends never above the parabola tops
        on = row["records"]["onset"]
        if on["rattle_n"][0] is not None:
            got = np.asarray(on["bush_approach"]) + np.asarray(on["rattle_n"])
            np.testing.assert_allclose(got, on["approach"], atol=1e-9)
    # only the clearance chain with rollers on their joints has a rattle
    assert by[DEFAULT]["records"]["onset"]["rattle"][0] is not None
    assert by["roller fixed to bush"]["records"]["onset"]["rattle"][0] is None
    v = res["variants"]["1250"]
    assert len(v["pairs"]) == len(PAIRS)
    for name in VARIANTS:
        s = v[name]["statistics"]
        assert s["ci_low"] <= s["mean"] <= s["ci_high"] and s["max"] >= s["p95"]
    assert (tmp_path / "clearance_peak.png").stat().st_size > 10_000


@pytest.mark.slow
def test_clearance_design_quick(tmp_path):
    """Two ISO forms in both chains: per-engagement statistics for each, the difference
    against the better ISO form with its interval, and the chart."""
    from benchmarks.clearance_design import main

    res = main(["--quick", "--out", str(tmp_path)])
    rows = res["designs"]
    assert set(rows) == {"ISO min", "ISO max"}
    for row in rows.values():
        for fidelity in ("clearance", "lumped"):
            assert row[f"{fidelity}_run"]["ok"]
            s = row[fidelity]
            assert s["n"] >= 2 and s["ci"][0] < s["mean"] < s["ci"][1]
    other = next(n for n in rows if n != res["best_iso_clearance"])
    d = rows[other]["against_best_iso"]
    assert d["ci"][0] < d["difference_N"] < d["ci"][1]
    assert (tmp_path / "clearance_design.png").stat().st_size > 10_000


@pytest.mark.slow
def test_startup_quick(tmp_path):
    """Two fresh processes share one compilation cache: the second finds the solve there
    (no program refused) and gets to its first result sooner, sooner still with the
    traced programs kept beside the cache."""
    from benchmarks.startup import main

    res = main(["--quick", "--out", str(tmp_path)])
    first, second = res["processes"]["first process"], res["processes"]["second process"]
    assert first["refused"] == [] and second["refused"] == []
    assert second["times_s"]["first simulate"] < first["times_s"]["first simulate"]
    # the traced programs kept beside the cache take the second process's tracing away
    assert res["second_over_first"] < res["second_over_first_no_store"]
    assert (tmp_path / "startup.json").exists() and (tmp_path / "startup.png").exists()
