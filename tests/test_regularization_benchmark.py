"""The regularization/fidelity benchmark runs end to end (slow: `python -m pytest -m slow`)."""

import json
import math

import pytest


@pytest.mark.slow
def test_regularization_benchmark_quick(tmp_path):
    from benchmarks.regularization import main

    main(["--quick", "--out", str(tmp_path)])
    res = json.loads((tmp_path / "regularization.json").read_text())
    reg = res["regularization"]

    # the nominal reference is converged: two tolerances agree far below the effects measured
    ref = reg["nominal_reference"]
    assert ref["check_peak_rel_err"] < 1e-6, ref

    rows = {(r["param"], r["value"]): r for r in reg["rows"] if "same_as" not in r}
    widths = sorted(v for p, v in rows if p == "width")
    nominal, widest = rows[("width", widths[0])], rows[("width", widths[-1])]
    assert nominal["nominal"] and nominal["bias"] == 0.0
    for r in rows.values():
        assert r["adaptive"]["ok"] and r["adaptive"]["steps"] > 0 and r["adaptive"]["wall_s"] > 0
        assert r["reference"]["check_peak_rel_err"] < 1e-6
        fs = r["fixed_search"]
        # the boundaries bracket: every run at or below the largest passing step passes
        for key, flag in (("largest_stable_dt", "stable"), ("largest_accurate_dt", "accurate")):
            assert fs[key] is not None, (r["param"], r["value"], fs)
            assert all(run[flag] for run in fs["runs"] if run["dt"] <= fs[key])
        assert fs["largest_accurate_dt"] <= fs["largest_stable_dt"]
        acc = r["fixed_at_accurate"]
        assert abs(acc["own_err"]) <= res["regularization"]["criteria"]["accurate_within"]
    # a 10 µm onset (wider than the contact deflections) lowers the peak by far more than
    # the nominal solve's own error; the nominal Tsit5 solve is within 1 %
    assert widest["bias"] < -0.1, widest["bias"]
    assert abs(nominal["adaptive"]["err"]) < 0.01
    # fewer steps with the wide onset (the force rises over a longer depth)
    assert widest["adaptive"]["steps"] < nominal["adaptive"]["steps"]

    fid = res["fidelity"]
    for v in fid["fidelities"].values():
        assert all(m["ok"] for m in v["members"]) and len(v["members"]) >= 2
        assert all(c["ok"] for c in v["solver_checks"])
        s = v["stats"]["window_peak_N"]
        assert 0 < s["min"] <= s["mean"] <= s["max"]
        # soft span springs: the tight span carries about its nominal 1000 N
        assert 0.9 < v["stats"]["tight_span_mean_N"]["mean"] / 1000.0 < 1.1
        assert v["cost"]["wall_s"] > 0 and v["cost"]["steps"] > 0
    c = fid["comparison"]
    assert math.isfinite(c["window_peak_ratio_clearance_over_lumped"])
    assert c["steps_ratio"] > 1  # the clearance joints cost steps
    assert (tmp_path / "regularization.png").stat().st_size > 10_000
