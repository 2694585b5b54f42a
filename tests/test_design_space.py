"""The design-space study (`python -m benchmarks.design_space --quick`) runs end to end and
its re-measured ISO forms are exactly the main job's `remeasure` (slow: -m slow)."""

import json
import math

import pytest


@pytest.mark.slow
def test_design_space_quick(tmp_path):
    from benchmarks.design_space import main, plan, settings_for
    from optimize.problem import iso_forms, make_problem, remeasure

    res = main(["--quick", "--out", str(tmp_path)])
    saved = json.loads((tmp_path / "design_space.json").read_text())
    assert saved["stage"] == "done" and saved["quick"] is True
    assert (tmp_path / "design_space.png").stat().st_size > 10_000
    assert saved["machine"]["loadavg_at_start"] and saved["machine"]["loadavg_at_end"]

    p = plan(quick=True)
    n_speeds = len(p["ensemble"])
    rows = {r["name"]: r for r in saved["designs"]}
    groups = [r["group"] for r in saved["designs"]]
    assert groups[:3] == ["iso", "iso", "iso"]
    assert groups.count("sobol") == p["sobol"]
    # corners of 2 parameters: 4, one of which is the min form (listed under it)
    corners = [n for n in rows if n.startswith("corner_")]
    assert len(corners) + sum(a.startswith("corner_") for a in rows["iso_min"]["aliases"]) == 4
    for r in saved["designs"]:
        assert len(r["member_peaks_N"]) == n_speeds == len(r["objective_member_soft_N"])
        assert all(0 <= f <= 1 for f in r["fraction"])
        assert r["peak_N"] == max(r["member_peaks_N"])
        assert math.isfinite(r["objective_N"]) and not r["objective_failures"]
        assert all(r["member_ok"])

    a = saved["analysis"]
    assert a["designs_total"] == len(rows)
    assert a["best"]["peak_N"] == min(r["peak_N"] for r in rows.values())
    assert math.isclose(
        a["best"]["reduction_vs_min_form"], 1 - a["best"]["peak_N"] / rows["iso_min"]["peak_N"]
    )
    assert -1 <= a["spearman"]["objective_vs_worst_peak"]["rho"] <= 1
    (line,) = a["main_effects"].values()
    assert len(line["peak_N"]) == p["effect_points"]
    assert line["peak_N"][0] == rows["iso_min"]["peak_N"]  # the line starts at the min form
    assert {a["best"]["name"], "iso_min"} <= set(saved["hertz"])
    assert res["analysis"]["best"] == a["best"]
    (beyond,) = saved["beyond_box"]  # the seating angle past the standard's maximum
    assert beyond["params"]["seating_angle"] > saved["design_space"]["upper"][1]
    assert all(0 <= at <= 1 for r in saved["designs"] for at in r["member_peak_at"])

    # the ISO forms' values are the main job's re-measurement, called directly
    problem = make_problem(settings_for(quick=True))
    for form, prof in iso_forms(problem).items():
        direct = remeasure(problem, prof)
        row = rows[f"iso_{form}"]
        assert math.isclose(row["peak_N"], direct["peak_N"], rel_tol=1e-9)
        assert row["member_peaks_N"] == pytest.approx(
            [m["peak_N"] for m in direct["members"]], rel=1e-9
        )
    assert math.isclose(
        saved["hertz"]["iso_min"]["peak_N"],
        remeasure(problem, iso_forms(problem)["min"], law="hertz")["peak_N"],
        rel_tol=1e-9,
    )
