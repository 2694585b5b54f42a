"""The headline figures README.md and docs/figures.md quote are the committed results'
(benchmarks/results/): each number is read from the text beside its claim and compared
with the value computed from the result file, at the precision the text gives it. A study
run again leaves no stale number behind, and a number edited by hand fails here. Covered:
the main job (lumped, second law, clearance chain, Nelder–Mead), the timing design, the
bush chain and the main job on it, SciPy, the gradient cost, the Dahl law's step cost,
compile time against link count, free-form geometry cost, the stability boundary, the
cheapest solver and the span model. (The results themselves are checked by the studies'
slow tests, e.g. tests/test_dahl_friction.py, tests/test_spans.py and
tests/test_xla_flags.py, and by the default run's cheap checks.)"""

import json
from pathlib import Path

import pytest
from _numbers import check, quoted, same

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
README = (ROOT / "README.md").read_text()
FIGURES = (ROOT / "docs" / "figures.md").read_text()


def result(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


def row(text: str, study: str) -> str:
    """The one table row of ``text`` that links to ``study``'s section."""
    rows = [line for line in text.splitlines() if line.startswith("| ") and f"#{study})" in line]
    assert len(rows) == 1, f"{len(rows)} table rows link to #{study}"
    return rows[0]


def test_the_checks_fail_on_a_changed_number():
    """What the checks below rest on: a number the results do not round to fails."""
    assert same(20.48, "20.5") and same(-3.31, "−3.3") and same(1792.9, "1793")
    assert not same(20.44, "20.5") and not same(3.31, "−3.3") and not same(1791.4, "1793")
    with pytest.raises(AssertionError, match="the text says 20.6"):
        check("by 20.6 % (1793", "by {} % ({}", 20.48, 1792.9)


def test_main_job():
    """`python -m optimize` (benchmarks/results/optimize_default): the lumped chain's
    −20.5 % (Johnson) and −3.1 % (Hertz), Nelder–Mead's −18.7 %, and the clearance-joint
    chain's −3.3 % with its interval, in README's table and docs/figures.md."""
    r = result("optimize_default/results.json")
    s = r["summary"]
    johnson = 100 * s["improvement"]
    hertz = 100 * (1 - s["second_law"]["optimized_value"] / s["second_law"]["baseline_value"])
    (c,) = s["clearance"]["members"]
    base = c["baseline_mean_N"]
    clearance = -100 * c["improvement"]
    lo, hi = (100 * d / base for d in c["difference_ci95_N"])
    assert johnson == pytest.approx(100 * (1 - s["optimized_value"] / s["baseline_value"]))
    nelder_mead = 100 * r["reduction_by_method"]["nelder_mead"]["johnson"]

    readme = row(README, "optimize_default")
    check(readme, "wear {} % below the best ISO 606 form", johnson)
    check(readme, "{} % under a second law", hertz)
    check(readme, "in the clearance-joint chain {} %", clearance)
    check(readme, "(95 % CI {} to {} %)", lo, hi)

    fig = row(FIGURES, "optimize_default")
    check(
        fig, "by {} % ({} against {} N, Johnson", johnson, s["optimized_value"], s["baseline_value"]
    )
    check(fig, "and by {} % under a second law", hertz)
    check(fig, "the job {} s from an empty", r["timing"]["total_s"])
    check(fig, "reached in {} iterations", r["optimized"]["iteration"])
    check(fig, "(Nelder–Mead's on the same objective {} %)", -nelder_mead)
    n = c["optimized_engagements"]
    assert c["baseline_engagements"] == n
    check(fig, "({} engagements each) {} %", n, clearance)
    check(fig, "the 95 % interval on the difference {} to {} %", lo, hi)
    freedoms = row(FIGURES, "design_freedoms")
    check(freedoms, "tooth {} % (Adam) and {} % (Nelder–Mead)", -johnson, -nelder_mead)


def test_timing_design():
    """`python -m optimize --problem timing`: the worst 2nd order 179 → 106 N (−41 %), the
    worst peak-to-peak 603 → 493 N (−18 %), the span model's 400 → 184 N (−54 %), the
    cam timing error."""
    s = result("optimize_timing/results.json")["summary"]
    o2, span = s["order2"], s["span_model"]
    order2 = 100 * (1 - o2["optimized_value"] / o2["baseline_value"])
    assert order2 == pytest.approx(100 * o2["improvement"])
    p2p = 100 * s["improvement"]
    on_span = 100 * (1 - span["optimized_value"] / span["baseline_value"])

    readme = row(README, "optimize_timing")
    check(readme, "tight-span tension {} % over", order2)
    check(readme, "peak-to-peak 13–{} % (by sampling)", p2p)  # (13 %: a finer re-measurement)
    check(readme, "(span model: {} %)", on_span)

    fig = row(FIGURES, "optimize_timing")
    check(
        fig,
        "2nd order from {} to {} N ({} %)",
        o2["baseline_value"],
        o2["optimized_value"],
        -order2,
    )
    check(
        fig, "peak-to-peak from {} to {} N ({} %", s["baseline_value"], s["optimized_value"], -p2p
    )
    check(fig, "design model {} → {} N ({} %)", span["baseline_value"], span["optimized_value"],
          -on_span)  # fmt: skip
    check(fig, "cam timing error ≤ {}°", s["timing_error_deg"])


def test_scipy_ratio():
    """32–34× the best SciPy method at 1 % and 0.1 % peak error."""
    rows = {c["error"]: c for c in result("scipy_engagement.json")["comparison"]}
    low, high = (rows[e]["speedup_vs_best_scipy"] for e in (0.01, 0.001))
    assert rows[0.01]["scipy_best"] == rows[0.001]["scipy_best"] == "LSODA"
    check(row(README, "scipy_engagement"), "{}–{}× faster than SciPy's best", low, high)
    check(row(FIGURES, "scipy_engagement"), "{}–{}× faster than the best SciPy", low, high)
    assert "(LSODA)" in row(FIGURES, "scipy_engagement")


def test_gradient_cost():
    """Value + gradient 3.9× / 4.4× / 4.1× the value at 4 / 36 / 72 coordinates, 4.4–5.1×
    checkpointed, 2.9× in forward mode at 4."""
    rows = {r["dimension"]: r for r in result("gradient_cost.json")["rows"]}
    assert sorted(rows) == [4, 36, 72]
    ratio = {d: r["ratio"] for d, r in rows.items()}
    checkpointed = [r["ratio_checkpointed"] for r in rows.values()]
    forward = rows[4]["ratio_forward"]
    check(row(README, "gradient_cost"), "gradient {}–{}× the value in reverse mode",
          min(ratio.values()), max(ratio.values()))  # fmt: skip
    check(row(README, "gradient_cost"), "; {}× in forward mode at 4", forward)
    fig = row(FIGURES, "gradient_cost")
    check(fig, "costs {}× the value at 4 coordinates, {}× at 36 and {}× at 72", *ratio.values())
    check(fig, "; {}–{}× with every step checkpointed", min(checkpointed), max(checkpointed))
    check(fig, "forward mode {}× at 4", forward)


def test_dahl_step_cost():
    """The Dahl law at 0.73–1.03× the frictionless chain's steps (every scene and speed),
    the regularized Coulomb law 8.6–13× (the strand's speeds it finished)."""
    cost = result("joint_friction.json")["cost"]
    dahl = [v["Dahl"]["steps_ratio"] for d in cost.values() for v in d.values()]
    coulomb = [
        v[k]["steps_ratio"]
        for v in cost["strand"].values()
        for k in v
        if k.startswith("tanh") and v[k]["ok"]
    ]
    assert all(v["Dahl"]["ok"] for d in cost.values() for v in d.values())
    check(row(README, "joint_friction"), "at {}–{}× the frictionless", min(dahl), max(dahl))
    check(row(README, "joint_friction"), "Coulomb law {}–{}×", min(coulomb), max(coulomb))
    fig = row(FIGURES, "joint_friction")
    check(fig, "constant cost {}–{}× the steps", min(coulomb), max(coulomb))
    check(fig, "frictionless chain's steps ({}–{}×", min(dahl), max(dahl))


def test_bush_chain():
    """06C against 06B: 0.6–0.8 points less efficient, 0.5 % lost at the teeth, a 2–5×
    mesh-order speed line, peaks +14 % [+8, +20 %]; the main job on the bush chain."""
    r = result("bush_chain.json")
    drive = {(d["chain"], d["rpm"]): d for d in r["drive"]}
    rpms = sorted({rpm for _, rpm in drive})
    points = [100 * (drive["06B", n]["efficiency"] - drive["06C", n]["efficiency"]) for n in rpms]
    teeth = [100 * drive["06C", n]["teeth_loss"] for n in rpms]
    line = [drive["06C", n]["speed_mesh_line_pct"] / drive["06B", n]["speed_mesh_line_pct"]
            for n in rpms]  # fmt: skip
    d = r["bush_minus_roller"]
    roller = d["difference"] / d["relative"]  # the roller chain's mean peak
    fig = row(FIGURES, "bush_chain")
    check(fig, "{}–{} points less efficient", min(points), max(points))
    # (the mean over the three speeds: 0.50, 0.50 and 0.56 %)
    check(fig, "({} % of the driver's work lost at the teeth)", sum(teeth) / len(teeth))
    check(fig, "a {}–{}× mesh-order speed line", min(line), max(line))
    check(fig, "meshing peaks {} % [{}, {} %]", 100 * d["relative"], 100 * d["ci_low"] / roller,
          100 * d["ci_high"] / roller)  # fmt: skip
    assert d["excludes_zero"]

    s = result("optimize_bush/results.json")["summary"]
    hertz = 100 * (s["second_law"]["optimized_value"] / s["second_law"]["baseline_value"] - 1)
    (c,) = s["clearance"]["members"]
    fig = row(FIGURES, "optimize_bush")
    check(fig, "{} % against the best ISO form under its own law", -100 * s["improvement"])
    check(fig, "{} % under the Hertz law", hertz)
    check(fig, "{} % [{}, {} N] in the clearance-joint chain", -100 * c["improvement"],
          *c["difference_ci95_N"])  # fmt: skip


def test_compile_time_and_geometry_and_stability():
    """`simulate`'s compile time 50 → 200 links ×0.95 lumped (4.8 s) and ×0.93 clearance
    (4.9 s), the meshing scene's 0.86 / 7.1 s per revolution; free-form teeth ×1.35 /
    ×1.16 the ISO profile's vector field (meshing scene / 100-link drive), compile
    ×1.05–1.17; the fixed-step stability boundary 0.97–1.20 of the linear prediction
    (Heun, Tsit5)."""
    compile_s = {
        (r["fidelity"], r["links"]): r["compile_s"] for r in result("dynamics.json")["compile"]
    }
    lumped = compile_s["lumped", 200] / compile_s["lumped", 50]
    clearance = compile_s["clearance", 200] / compile_s["clearance", 50]
    check(row(README, "dynamics"), "50 → 200 links ×{} lumped, ×{} clearance", lumped, clearance)
    fig = [line for line in FIGURES.splitlines() if "Compile time of `simulate`" in line][0]
    check(fig, "×{} (lumped, {} s) / ×{} (clearance, {} s)", lumped, compile_s["lumped", 200],
          clearance, compile_s["clearance", 200])  # fmt: skip
    engagement = result("dynamics.json")["engagement"]
    fig = [line for line in FIGURES.splitlines() if "Meshing scene (08B" in line][0]
    check(fig, "{} s per revolution lumped, {} s clearance", engagement["lumped"]["wall_per_rev_s"],
          engagement["clearance"]["wall_per_rev_s"])  # fmt: skip

    rows = {(r["scene"], r["profile"]): r for r in result("geometry.json")["rows"]}
    per_gap = [rows[s, "freeform_per_gap"] for s in ("engagement", "drive100")]
    fig = row(FIGURES, "geometry")
    check(fig, "cost ×{} the ISO profile's vector field on the meshing scene, ×{} on",
          *(r["vf_ratio"] for r in per_gap))  # fmt: skip
    compiles = [r["compile_ratio"] for r in per_gap]
    check(fig, "compile ×{}–{}", min(compiles), max(compiles))

    bounds = [
        r["measured_over_horizon_bound"]
        for r in result("stability.json")["map"]["rows"]
        if r["method"] != "Euler"
    ]
    check(row(README, "stability"), "within {}–{} of the linear", min(bounds), max(bounds))
    check(row(FIGURES, "stability"), "within {}–{} of the linear", min(bounds), max(bounds))


def test_tsit5_is_the_cheapest_method():
    """Tsit5 the cheapest solver down to 1e-5 peak error (0.1 % in 0.24 s, 1e-5 in 0.77 s
    over 4 tooth periods), not below it; the implicit solvers 110–165× its cost at the
    same error (where all three reach it: 10 % to 0.1 %)."""
    w = result("work_precision.json")["engagement"]
    best = {b["error"]: b for b in w["best_peak"]}
    down_to = min(
        e for e, b in best.items() if all(best[f]["best"] == "Tsit5" for f in best if f >= e)
    )
    implicit = [
        b["per_solver"][k]["wall_s"] / b["per_solver"]["Tsit5"]["wall_s"]
        for b in best.values()
        for k in ("Kvaerno3", "Kvaerno5", "KenCarp4")
        if all(k in b["per_solver"] for k in ("Kvaerno3", "Kvaerno5", "KenCarp4"))
    ]
    assert down_to == 1e-5 and w["tooth_periods"] == 4
    for text in (row(README, "work_precision"), row(FIGURES, "work_precision")):
        assert "Tsit5" in text and "cheapest" in text and "down to 1e-5 peak error" in text
        low, high = (float(n) for n in quoted(text, "implicit solvers {}–{}× slower"))
        # (written to two or three figures: within 1 of the ratios)
        assert abs(min(implicit) - low) < 1 and abs(max(implicit) - high) < 1, implicit
    fig = row(FIGURES, "work_precision")
    check(fig, "0.1 % in {} s, 1e-5 in {} s ({} tooth periods)", best[1e-3]["best_wall_s"],
          best[1e-5]["best_wall_s"], w["tooth_periods"])  # fmt: skip


def test_span_model():
    """The span-level chain: 16–68 ms per revolution, 300–739× less than the lumped chain;
    an oval crank's 2nd-order tension and speed swing within 10 % and 1 % of the lumped
    chain's at 1000 rpm, 21 % and 18 % apart at 2000 rpm."""
    compare = result("spans.json")["compare"]
    ms = [1e3 * c["spans"]["wall_per_revolution_s"] for c in compare.values()]
    less = [c["lumped"]["wall_per_revolution_s"] / c["spans"]["wall_per_revolution_s"]
            for c in compare.values()]  # fmt: skip

    def apart(rpm, key):
        c = compare[f"{rpm} rpm, 0.2 mm"]
        return 100 * abs(c["lumped"][key] / c["spans"][key] - 1)

    keys = ("tight_order2_N", "driven_speed_order2_rad_s")
    fig = row(FIGURES, "spans")
    check(fig, "{}–{} ms per revolution", min(ms), max(ms))
    check(fig, "revolution of an 18/36 drive, {}–{}× less", min(less), max(less))
    limits = quoted(fig, "within {} % and {} % of the lumped chain's at 1000 rpm")
    assert all(apart(1000, k) < float(n) for k, n in zip(keys, limits, strict=True))
    check(fig, "({} % and {} % at 2000 rpm)", *(apart(2000, k) for k in keys))
    readme = row(README, "spans")
    check(readme, "{}–{}× cheaper", min(less), max(less))
    assert apart(1000, keys[0]) < float(quoted(readme, "2nd order within {} % of it")[0])


def test_peers():
    """EXUDYN's wall and CPU time over jaxchain's (matched law) at 300 and 600 rpm, and
    the largest closed-form error of either code at either speed, in README's table and
    docs/figures.md."""
    runs = [result(f) for f in ("peers.json", "peers_600rpm.json")]
    wall = [r["ratio"]["wall_exudyn_over_jaxchain_matched"] for r in runs]
    cpu = [r["ratio"]["cpu_exudyn_over_jaxchain_matched"] for r in runs]
    keys = ("speed_ratio_error", "driven_torque_error", "tension_error")
    worst = max(
        100 * abs(r["runs"][code]["metrics"][k])
        for r in runs
        for code in ("jaxchain_matched", "exudyn")
        for k in keys
    )
    readme = row(README, "peers")
    check(readme, "both within {} % of the closed forms", worst)
    check(readme, "EXUDYN takes {}× jaxchain's wall time at 300 rpm and {}× at 600 rpm", *wall)
    check(readme, "(CPU time {}× and {}×)", *cpu)
    fig = row(FIGURES, "peers")
    check(fig, "both within {} % of the closed forms", worst)
    check(fig, "EXUDYN takes {}× / {}× jaxchain's wall time and {}× / {}× its CPU", *wall, *cpu)
