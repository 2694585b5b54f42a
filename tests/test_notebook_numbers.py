"""The numbers the notebooks' text quotes (notebooks/0N_*.ipynb, the markdown cells of the
committed, executed notebooks) are their sources': a committed study result
(benchmarks/results/) or an output printed by a code cell of the same notebook. Each
number is read from the text beside its claim and compared with its source at the
precision the text gives it (tests/_numbers.py), so a re-run study or a re-executed
notebook cannot leave stale text behind. Numbers that define a scene (tooth counts,
speeds, chain names, settings) are not checked; a few claims written in words ("several
hundred", "half a decibel") are checked against their source's range. Notebook 04 types
no number into its text: its rendered table and printed ratios are checked against the
JSON files they are computed from.

Reads files only (no JAX). A failure names the phrase, the number written and its
source's value: correct the text in the notebook's generator (notebooks/_make_0N_*.py)
and in the committed notebook, or re-execute it."""

import json
import math
import re
from collections.abc import Callable
from functools import cache
from pathlib import Path

import pytest
from _numbers import NUMBER, same

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
NOTEBOOKS = ROOT / "notebooks"
FLOAT = r"([−+-]?\d+(?:\.\d+)?(?:e[+-]?\d+)?)"  # a number as a code cell prints it


@cache
def notebook(number: str) -> dict:
    (path,) = NOTEBOOKS.glob(f"{number}_*.ipynb")
    return json.loads(path.read_text())


@cache
def markdown(number: str) -> str:
    """The notebook's markdown cells, one text, every run of whitespace one space."""
    cells = notebook(number)["cells"]
    return " ".join(
        " ".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown").split()
    )


@cache
def output(number: str) -> str:
    """What the notebook's code cells printed or displayed as text (streams, text/plain,
    text/markdown), in order."""
    parts = []
    for cell in notebook(number)["cells"]:
        for out in cell.get("outputs", []):
            if out["output_type"] == "stream":
                parts.append("".join(out["text"]))
            for kind in ("text/plain", "text/markdown"):
                parts.append("".join(out.get("data", {}).get(kind, "")))
    return "\n".join(parts)


def code(number: str, pattern: str) -> float:
    """The one number ``pattern`` (a regex with one group) finds in the notebook's code."""
    cells = notebook(number)["cells"]
    source = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "code")
    (found,) = re.findall(pattern, source)
    return float(found)


def printed(number: str, pattern: str) -> tuple[float, ...]:
    """The numbers ``pattern`` (``{}`` for each, any run of spaces for a space) finds at the
    one place it occurs in the notebook's output."""
    regex = re.escape(" ".join(pattern.split())).replace(r"\{\}", FLOAT).replace(r"\ ", r"\s+")
    found = re.findall(regex, output(number))
    assert len(found) == 1, f"{pattern!r} is printed {len(found)} times"
    groups = found[0] if isinstance(found[0], tuple) else (found[0],)
    return tuple(float(g.replace("−", "-")) for g in groups)


@cache
def result(name: str) -> dict:
    return json.loads((RESULTS / name).read_text())


# where the numbers read from the text are (recorded for test_a_changed_number_fails)
_read: list[tuple[int, int]] | None = None


def read(text: str, pattern: str) -> tuple[str, ...]:
    """The numbers ``pattern`` (``{}`` for each) finds at the one place it occurs in
    ``text``, as written."""
    regex = re.escape(pattern).replace(r"\{\}", NUMBER)
    found = list(re.finditer(regex, text))
    assert len(found) == 1, f"{pattern!r} occurs {len(found)} times in the text"
    if _read is not None:
        _read.extend(found[0].span(i + 1) for i in range(len(found[0].groups())))
    return found[0].groups()


def says(text: str, pattern: str, *values: float, step: float | None = None) -> None:
    """The numbers at ``pattern`` in ``text`` are ``values``, rounded as written."""
    numbers = read(text, pattern)
    assert len(numbers) == len(values), (pattern, numbers)
    for n, v in zip(numbers, values, strict=True):
        assert same(v, n, step), f"{pattern!r}: the text says {n}, its source {v:.6g}"


def pct(new: float, old: float) -> float:
    """``new`` against ``old`` [%]."""
    return 100 * (new / old - 1)


# 01 ─ drive walkthrough: the lumped drive's link and span tensions (printed), the bush
# chain study (bush_chain.json) and the main job on a bush chain (optimize_bush)


def nb01(md: str) -> None:
    lo, hi, span_lo, span_hi = printed("01", "link tensions {} … {} N; span tensions {} … {} N")
    says(
        md,
        "Single links reach {} N, and up to {} N, where the spans stay between {} and {} N",
        lo,
        hi,
        span_lo,
        span_hi,
    )
    says(md, "(the slack span's {} N is its least)", span_lo)
    below, on = printed("01", "{} % of the link samples below −10 N, {} % of them on a sprocket")
    says(
        md,
        "Below −10 N are {} % of the link samples, and {} % of those are links on a sprocket",
        below,
        on,
    )

    r = result("bush_chain.json")
    drive = {(d["chain"], d["rpm"]): d for d in r["drive"]}
    rpms = sorted({rpm for _, rpm in drive})
    points = [100 * (drive["06B", n]["efficiency"] - drive["06C", n]["efficiency"]) for n in rpms]
    line = [
        drive["06C", n]["speed_mesh_line_pct"] / drive["06B", n]["speed_mesh_line_pct"]
        for n in rpms
    ]
    teeth = [100 * drive["06C", n]["teeth_loss"] for n in rpms]
    says(md, "The bush chain loses {}–{} points of efficiency", min(points), max(points))
    assert "half a percent of the driver's work" in md and round(sum(teeth) / 3, 1) == 0.5
    says(md, "carries a {}–{}× stronger mesh-order line", min(line), max(line))
    d = r["bush_minus_roller"]
    says(md, "its meshing peaks are {} % higher on average", 100 * d["relative"])
    assert "(an interval clear of zero)" in md and d["excludes_zero"]
    bush = result("optimize_bush/results.json")["summary"]
    says(md, "the designed tooth's {} % under its own contact law", -100 * bush["improvement"])


# 02 ─ the ISO-box loop (printed) and the committed runs it cites (optimize_iso,
# design_space.json, optimize_default)


def nb02(md: str) -> None:
    nb02_radius_gradients(md)
    out = output("02")
    loop = [float(v) for v in re.findall(r"^\s*\d+\s+objective\s+" + FLOAT + " N", out, re.M)]
    grads = [float(v) for v in re.findall(r"\|grad\|\s+" + FLOAT, out)]
    says(md, "stops after {} iterations short of it", len(loop))
    says(
        md,
        "The objective falls from {} N at the middle of the box to {} N in {} iterations",
        loop[0],
        loop[-1],
        len(loop),
    )
    says(md, "({} N in the last, |grad| {} N)", loop[-2] - loop[-1], grads[-1])
    (at_min,) = printed("02", "objective at the ISO minimum form: {} N")
    says(md, "where the objective is lower still, {} N", at_min)
    fraction = {
        name: printed("02", f"{name} at {{}} % of its ISO range")[0]
        for name in ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")
    }
    says(
        md,
        "the seating angle ({} % of its range) and the flank radius ({} %)",
        fraction["seating_angle"],
        fraction["flank_radius"],
    )
    says(md, "the seating radius ({} %) towards its smallest", fraction["seating_radius"])
    says(md, "it stays at {} %", fraction["tip_diameter"])
    gradient = [float(g) for g in re.search(r"mid form: .* gradient \[([^]]*)\]", out)[1].split()]
    says(md, "a sizeable gradient ({} N per unit of `u` at the start", gradient[1])
    assert gradient[3] == 0.0 and "The tip diameter's gradient is exactly zero" in md
    (change,) = printed("02", "optimized against the ISO minimum form: {} % (1000 rpm)")
    says(md, "N, {} % *above* the ISO minimum form's", change)
    # (1325 and 1316 N are the figure's legend, printed nowhere: at least their ratio)
    peaks = read(
        md, "the optimized profile peaks at {} N, 0.7 % *above* the ISO minimum form's {} N"
    )
    assert same(change, f"{pct(*map(float, peaks)):.1f}")
    says(md, "its {} % fall in the objective", -pct(loop[-1], loop[0]))
    says(md, "and the {} % left is", change)

    iso = result("optimize_iso/results.json")
    s = iso["summary"]
    g = iso["remeasured"]["gradient"]["johnson"]["peak_N"]
    says(
        md,
        "the gradient result re-measures {} % *above* the minimum form's worst peak ({} "
        "against {} N)",
        pct(g, s["baseline_value"]),
        g,
        s["baseline_value"],
    )
    says(
        md,
        "the gradient-free search's {} % above ({} N)",
        -100 * s["improvement"],
        s["optimized_value"],
    )
    a = result("design_space.json")["analysis"]
    best = a["best"]
    says(
        md,
        "of {} designs across the box none beats its minimum form by more than {} %",
        a["designs_total"],
        100 * best["reduction_vs_min_form"],
    )
    says(
        md,
        "over {} designs in the box the best is {} % below the minimum form ({} against {} N)",
        a["designs_total"],
        100 * best["reduction_vs_min_form"],
        best["peak_N"],
        a["baseline_min_form_N"],
    )
    space = result("design_space.json")["design_space"]
    angle = a["main_effects"]["seating_angle"]["peak_N"]
    says(
        md,
        "({}° → {}°: {} → {} N)",
        math.degrees(space["lower"][1]),
        math.degrees(space["upper"][1]),
        angle[0],
        angle[-1],
    )

    s = result("optimize_default/results.json")["summary"]
    (c,) = s["clearance"]["members"]
    says(md, "box, lowers the worst meshing peak by {} %.", 100 * s["improvement"])
    says(
        md,
        "lowers the worst peak by {} % ({} → {} N), by {} % under a second contact law, and "
        "by {} % in the clearance-joint chain",
        100 * s["improvement"],
        s["baseline_value"],
        s["optimized_value"],
        100 * (1 - s["second_law"]["optimized_value"] / s["second_law"]["baseline_value"]),
        100 * c["improvement"],
    )
    says(md, "(95 % interval of the difference {} to {} N)", *c["difference_ci95_N"])


def nb02_radius_gradients(md: str) -> None:
    """The seating and flank radii's gradients at the start ("against 0.41 and −0.34 for
    the two radii")."""
    out = output("02")
    gradient = [float(g) for g in re.search(r"mid form: .* gradient \[([^]]*)\]", out)[1].split()]
    says(md, "against {} and {} for the two radii", gradient[0], gradient[2])


# 03 ─ stability: the map the notebook prints (its full-mode run) and the linearization
# of the committed study (stability.json)


def stability_map() -> list[dict]:
    """The printed table: method, scale, ω_max, ..., hω, /hor, /bilat, /rule, accurate."""
    keys = (
        "omega_max",
        "rule",
        "linear",
        "horizon",
        "bilateral",
        "measured",
        "h_omega",
        "over_horizon",
        "over_bilateral",
        "over_rule",
        "accurate",
    )
    rows = re.findall(r"^(Euler|Heun|Tsit5) +([\d.]+) +(.*)$", output("03"), re.M)
    assert len(rows) >= 12
    return [
        dict(method=m, scale=float(s), **dict(zip(keys, map(float, rest.split()), strict=True)))
        for m, s, rest in rows
    ]


def nb03(md: str) -> None:
    nb03_printed_ranges(md)
    (omega,) = printed("03", "scale 1: ω_max {} rad/s")
    says(md, "ring at ω ≈ {}·10⁵ rad/s", omega / 1e5)
    lin = result("stability.json")["map"]["linearization"]["1.0"]
    (grams,) = read(md, "on rollers of ~{} g")
    assert round(math.log10(1e3 * lin["m_min_kg"])) == math.log10(float(grams)), lin["m_min_kg"]
    assert "links of ~10⁸–10⁹ N/m" in md
    assert all(1e8 <= lin[k] <= 1e9 for k in ("k_contact_N_per_m", "k_link_N_per_m"))

    rows = stability_map()
    limits = {m: printed("03", f"{m} real-axis limit {{}},")[0] for m in ("Heun", "Tsit5")}
    (written,) = read(md, "h·ω_max ≈ {} for Tsit5")
    assert all(same(r["h_omega"], written) for r in rows if r["method"] == "Tsit5"), written
    says(md, "(near its real-axis limit {}:", limits["Tsit5"])
    says(md, "(far below its real-axis limit {}:", limits["Heun"])
    ratios = [r["over_horizon"] for r in rows if r["method"] != "Euler"]
    says(md, "matches within about {} %", 100 * max(abs(v - 1) for v in ratios), step=10)
    (written,) = read(md, "its boundary is h·ω_max ≈ {},")
    assert all(same(r["h_omega"], written) for r in rows if r["method"] == "Euler"), written
    (euler,) = re.findall(r"^Euler +s=1 +.*least stable modes: (.*)$", output("03"), re.M)
    least = min(float(z) for z in re.findall(r"ζ (\S+) \(", euler))
    says(md, "lightly loaded seat contacts (ζ ≈ {} %)", 100 * least)


def nb03_printed_ranges(md: str) -> None:
    """The damping of the modes that limit Tsit5 and Heun's h·ω_max at the boundary, against
    the map printed above the text."""
    rows = stability_map()
    zeta = [float(z) for z in re.findall(r"^scale .*\(ζ ([\d.]+)\)", output("03"), re.M)]
    says(md, "those modes are damped by ζ ≈ {}–{} %", 100 * min(zeta), 100 * max(zeta))
    heun = [r["h_omega"] for r in rows if r["method"] == "Heun"]
    says(md, "and ≈ {}–{} for Heun", min(heun), max(heun))


# 04 ─ speed and accuracy: its text types no number; its table and printed ratios are
# computed from work_precision.json, regularization.json and scipy_engagement.json


def nb04(text: str) -> None:
    sp = result("scipy_engagement.json")
    for c in sp["comparison"]:
        says(
            text,
            f"peak error ≤ {c['error']:.0e}: jaxchain {c['jaxchain_best']} "
            f"{c['jaxchain_wall_s']:.2f} s, SciPy {c['scipy_best']} {c['scipy_wall_s']:.2f} s: "
            "{}× faster",
            c["speedup_vs_best_scipy"],
        )
    c = sp["comparison"][0]
    says(
        text,
        f"| porting from SciPy | jaxchain {c['jaxchain_best']} | {{}}× faster than SciPy's "
        f"best ({c['scipy_best']}) at {c['error']:.0e} peak error",
        c["speedup_vs_best_scipy"],
    )

    eng = result("work_precision.json")["engagement"]
    best = {b["error"]: b for b in eng["best_peak"]}
    says(
        text,
        "(screening, sweeps, design loops) | adaptive Tsit5 | {} s for {} ms",
        best[1e-2]["best_wall_s"],
        1e3 * eng["t1_s"],
    )
    family = {r["solver"]: r["family"] for r in eng["rows"]}
    walls = best[1e-2]["per_solver"]
    implicit = min(v["wall_s"] for k, v in walls.items() if family[k] in ("implicit", "imex"))
    explicit = min(v["wall_s"] for k, v in walls.items() if family[k] == "explicit")
    says(text, "{}× slower than the best explicit solver at 1e-2", implicit / explicit)

    reg = result("regularization.json")
    nominal = next(
        r for r in reg["regularization"]["rows"] if r["param"] == "width" and r["nominal"]
    )
    fs, fc = nominal["fixed_search"], nominal["fixed_common"]
    says(
        text,
        "fixed-step Tsit5, dt ≤ {} µs | stable to {} µs; at 4 µs the peak is {}% off",
        1e6 * fs["largest_accurate_dt"],
        1e6 * fs["largest_stable_dt"],
        100 * fc["err"],
    )
    comparison = reg["fidelity"]["comparison"]
    says(
        text,
        "clearance costs ×{} wall (×{} steps); its mean peak ×{} the lumped one",
        comparison["wall_ratio"],
        comparison["steps_ratio"],
        comparison["window_peak_ratio_clearance_over_lumped"],
    )


# 05 ─ timing drive: the chain's speed and the animation's frames, from the drive's
# definition and the printed run


def nb05(md: str) -> None:
    rpm = code("05", r"\nrpm = ([\d.]+)")
    (radius,) = printed("05", "sprocket 0: z = 21, axis (0.0, 0.0) mm, pitch radius {} mm")
    says(md, "The rollers run over the shoe at {} m/s", 2 * math.pi * rpm / 60 * radius / 1e3)
    (swing,) = printed("05", "arm swing {}°")
    assert "turns by hundredths of a degree" in md and 0.01 <= swing < 0.1, swing

    t1_ms, _ = printed("05", "{} ms simulated ({} crank revolutions)")
    stride = code("05", r"stride=\d+ if FAST else (\d+)")
    saves = code("05", r"jc.simulate\(timing, t1, n_save=(\d+)\)")
    says(md, "Every {}th save of the three revolutions", stride)
    apart = t1_ms * stride / (saves - 1)
    turn = 360 * rpm / 60 * apart / 1e3
    says(
        md,
        "{} ms apart, the crank turning {}° ({} teeth) between frames",
        apart,
        turn,
        turn / (360 / 21),
    )


# 06 ─ quiet drive: quiet_drive.json, its 31.25 rpm grid (quiet_drive_fine/) and
# drive_gradient.json


def nb06(md: str) -> None:
    (ideal,) = printed("06", "(ideal spread over 18 lines: {} dB)")
    says(md, "10·log10(z) = {} dB lower at z = 18", ideal)
    q, fine = result("quiet_drive.json"), result("quiet_drive_fine/quiet_drive.json")
    says(md, "ran {} solves (five drivers × nine speeds)", len(q["runs"]))
    runs = {(r["design"], r["rpm"]): r for r in q["runs"] + fine["runs"]}

    def db(design, rpm, order):
        return 20 * math.log10(runs[design, rpm]["bearing1"][order])

    iso = q["summary"]["iso_min"]["signals"]["bearing1"]
    assert iso["worst_rpm"] == 1000.0
    order = int(iso["order"][q["summary"]["iso_min"]["speeds"].index(1000.0)])
    says(md, "its second mesh harmonic ({} Hz)", 1000.0 / 60 * order)
    around = sorted(fine["settings"]["speeds"], key=lambda n: abs(n - 1000.0))[:2]
    says(
        md,
        "builds up and stands about {} dB above its level {} % slower or faster",
        db("iso_min", 1000.0, order) - max(db("iso_min", n, order) for n in around),
        100 * abs(around[0] / 1000.0 - 1),
    )
    gentle = fine["summary"]["gentle"]["signals"]["bearing1"]
    says(md, "on a {} rpm grid", fine["settings"]["speeds"][1] - fine["settings"]["speeds"][0])
    says(
        md,
        "the free-form tooth peaks at {} rpm with {} dB",
        gentle["worst_rpm"],
        gentle["worst_dB"],
    )
    assert "above the ISO form's worst here" in md and gentle["worst_dB"] > iso["worst_dB"]
    mesh = [db(d, 1500.0, 18) for d in q["settings"]["designs"] if d != "iso_max"]
    says(
        md,
        "the mesh line itself is within about {} dB for every driver but the ISO maximum",
        max(mesh) - min(mesh),
    )
    says(
        md,
        "the free-form `gentle` tooth of `python -m optimize` is {} % below the ISO minimum "
        "form's worst peak",
        -100 * q["summary"]["gentle"]["vs_iso_min"]["worst_peak"],
    )

    dg = result("drive_gradient.json")
    assert "grows by a factor of several hundred per tooth period" in md
    assert 100 <= dg["growth_per_period"]["drive"] < 1000
    values = [v for f in dg["band"]["finite_differences"] for v in (f["plus"], f["minus"])]
    assert "jumps by up to half a decibel" in md and round(max(values) - min(values), 1) == 0.5


# 07 ─ non-circular sprocket: the re-measurement on the lumped chain
# (optimize_timing/results.json) and the span model's live solve (printed)


def nb07(md: str) -> None:
    run = result("optimize_timing/results.json")
    s = run["summary"]
    rows = list(zip(run["lumped"]["baseline"], run["lumped"]["optimized"], strict=True))
    order2 = [-pct(d["orders"][0], b["orders"][0]) for b, d in rows]
    says(
        md,
        "falls by {} % in the worst case on the lumped chain ({}–{} % at every speed)",
        100 * s["order2"]["improvement"],
        min(order2),
        max(order2),
    )
    worst = max(rows, key=lambda bd: bd[0]["p2p"])
    says(
        md,
        "The peak-to-peak falls by {} % in the worst case ({} → {} N at {} rpm)",
        100 * s["improvement"],
        s["baseline_value"],
        s["optimized_value"],
        worst[0]["rpm"],
    )
    fell = [(b, d) for b, d in rows if d["p2p"] < b["p2p"]]
    p2p = [-pct(d["p2p"], b["p2p"]) for b, d in fell]
    says(
        md, "and by {}–{} % at {}–{} rpm", min(p2p), max(p2p), fell[0][0]["rpm"], fell[-1][0]["rpm"]
    )
    (b, d), *_ = [(b, d) for b, d in rows if d["p2p"] > b["p2p"]]
    says(
        md,
        "**at {} rpm it rises**, from {} to {} N ({} %)",
        b["rpm"],
        b["p2p"],
        d["p2p"],
        pct(d["p2p"], b["p2p"]),
    )
    says(
        md,
        "the 2nd order halved ({} → {} N) and the 4th tripled ({} → {} N)",
        b["orders"][0],
        d["orders"][0],
        b["orders"][1],
        d["orders"][1],
    )
    says(md, "(at {} rpm from {} to {} N)", b["rpm"], b["orders"][1], d["orders"][1])
    timing = [max(d["timing"]) / max(b["timing"]) for b, d in rows]
    says(
        md,
        "{}–{}× on the lumped chain (the worse cam's {} → {} crank deg at {} rpm)",
        min(timing),
        max(timing),
        max(b["timing"]),
        max(d["timing"]),
        b["rpm"],
    )
    before = printed(
        "07", "circular crank: tight span {}…{} N (p2p {} N), timing error p2p {} / {}"
    )
    after = printed("07", "designed crank: tight span {}…{} N (p2p {} N), timing error p2p {} / {}")
    spans = [a / c for a, c in zip(after[3:], before[3:], strict=True)]
    (rpm,) = printed("07", "{} rpm: baseline ok True, design ok True")
    says(
        md,
        "and {}–{}× in the span model at {} rpm (section 4: {} → {} and {} deg;",
        min(spans),
        max(spans),
        rpm,
        max(before[3:]),
        *after[3:],
    )
    says(
        md,
        "the worst, {} deg, stays well inside the design's {} deg limit",
        s["timing_error_deg"],
        s["timing_limit_deg"],
    )


# 08 ─ quiet sprocket: optimize_quiet (results.json and the clearance solves it reads),
# clearance_peak.json, and the ring's printed statics


def populations(name: str) -> tuple[float, float]:
    """The mean per-engagement peak of the first and the second roller of a link [N]."""
    run = json.loads((RESULTS / "optimize_quiet" / "clearance" / name).read_text())
    peaks = list(zip(run["peaks_N"], run["populations"], strict=True))
    return tuple(
        sum(p for p, k in peaks if k == pop) / sum(1 for _, k in peaks if k == pop)
        for pop in (1, 2)
    )


def quiet_cells(design: str) -> dict:
    """``{(rpm, lubrication): (mean change, p95 change)}`` [%] against the ISO form."""
    cells = result("optimize_quiet/results.json")["summary"]["goals"][design]["cells"]
    return {
        (1000 * c["speed_factor"], c["lubrication"]): (
            -100 * c["mean_reduction"],
            -100 * c["p95_reduction"],
        )
        for c in cells
    }


def nb08(md: str) -> None:
    nb08_ring_dry_range(md)
    ratios = []

    def collect(values):
        for v in values.values() if isinstance(values, dict) else values:
            if isinstance(v, dict):
                ratios.extend(x for k, x in v.items() if k == "peak_over_approach_mean_Ns_m")
                collect(v)

    collect(result("clearance_peak.json")["variants"])
    says(md, "per unit of approach speed are {}–{} kN·s/m", min(ratios) / 1e3, max(ratios) / 1e3)
    radius, reach = printed("08", "ring radius {} mm ({} mm into the seated plates)")
    says(md, "r_p·cos(π/z) − h/2 = {} mm on this sprocket", radius - reach)

    first, second = populations("iso_min_1x_dry.json")
    says(md, "({} against {} N at 1000 rpm)", second, first)
    first, second = populations("iso_min_1x_oil.json")
    says(md, "takes that difference away ({} against {} N)", second, first)

    goals = result("optimize_quiet/results.json")["summary"]["goals"]
    tooth = quiet_cells("tooth")
    says(md, "**The tooth alone** misses its {} %", 100 * goals["tooth"]["goal"])
    says(md, "the tooth alone ≥ {} % lower mean and p95", 100 * goals["tooth"]["goal"])
    says(md, "the tooth with its ring ≥ {} %", 100 * goals["tooth_ring"]["goal"])
    assert not goals["tooth"]["met"] and not goals["tooth_ring"]["met"]
    dry = [m for (rpm, lub), (m, _) in tooth.items() if lub == "dry"]
    says(md, "dry it moves the mean by {} to {} %", max(dry), min(dry))
    unresolved = sorted(
        {
            1000 * c["speed_factor"]
            for c in goals["tooth"]["cells"]
            if c["lubrication"] == "dry" and not c["resolved"]
        }
    )
    says(md, "within the scatter at {} and {} rpm", *unresolved)
    oil = {rpm: v for (rpm, lub), v in tooth.items() if lub == "oil" and rpm >= 1000}
    says(
        md,
        "in oil by {} to {} % at {}–{} rpm",
        max(m for m, _ in oil.values()),
        min(m for m, _ in oil.values()),
        min(oil),
        max(oil),
    )
    says(
        md,
        "with the p95 by only {} to {} %",
        max(p for _, p in oil.values()),
        min(p for _, p in oil.values()),
    )
    lumped = [
        100 * m["change"] for m in goals["tooth"]["lumped_members"] if m["speed_factor"] == 0.5
    ]
    says(
        md,
        "**worse at 500 rpm**: {} % in oil, {}–{} % on the lumped chain already",
        tooth[500.0, "oil"][0],
        min(lumped),
        max(lumped),
    )

    ring = quiet_cells("tooth_ring")
    oil = [-v for (rpm, lub), vs in ring.items() if lub == "oil" and rpm >= 1000 for v in vs]
    says(md, "% dry and {}–{} % in oil at 1000–2500 rpm", min(oil), max(oil))
    says(
        md,
        "and by {} % dry but {} % in oil at 500 rpm",
        -ring[500.0, "dry"][0],
        -ring[500.0, "oil"][0],
    )

    (unworn,) = printed("08", "chain elongation 0 %: at rest the ring takes {} N")
    says(md, "At rest the ring takes {} N of the wrap's radial load", unworn)
    lines = re.findall(
        r"the wrap's rollers on their teeth with the ring\s*: \[([^]]*)\]", output("08")
    )
    on_teeth = [int(f) for f in lines[0].split()]
    assert "three of the seven seated rollers float off" in md
    assert (len(on_teeth), on_teeth.count(0)) == (7, 3), on_teeth
    (worn,) = printed("08", "chain elongation 2 %: at rest the ring takes {} N")
    says(md, "leaves the ring ({} N at rest)", worn)
    # a chain worn by w seats w·p/(2 sin(π/z)) further out (08B: p = 12.7 mm; z = 18)
    wear, shift = read(md, "A chain worn {} % seats about {} mm further out")
    assert same(float(wear) / 100 * 12.7 / (2 * math.sin(math.pi / 18)), shift), shift


def nb08_ring_dry_range(md: str) -> None:
    """The ring's gain dry at 1000–2500 rpm (mean and p95)."""
    ring = quiet_cells("tooth_ring")
    dry = [-v for (rpm, lub), vs in ring.items() if lub == "dry" and rpm >= 1000 for v in vs]
    says(md, "lowers the mean and p95 by {}–{} % dry", min(dry), max(dry))


# 09 ─ the main job's free-form tooth: optimize_default/results.json, and the live check
# of section 5 (printed)


def main_job() -> dict:
    return result("optimize_default/results.json")


def johnson_changes() -> dict[float, list[float]]:
    """The delivered tooth against the ISO minimum form per speed [%], Johnson law."""
    rem = main_job()["remeasured"]
    changes: dict[float, list[float]] = {}
    for o, b in zip(
        rem["optimized"]["johnson"]["members"], rem["iso_min"]["johnson"]["members"], strict=True
    ):
        changes.setdefault(1000 * o["speed_factor"], []).append(pct(o["peak_N"], b["peak_N"]))
    return changes


def nb09(md: str) -> None:
    nb09_per_point_gain(md)
    nb09_clipped(md)
    nb09_live_medians(md)
    run = main_job()
    s = run["settings"]
    (c,) = run["clearance"]["members"]
    opt, iso = c["optimized"], c[run["clearance"]["baseline"]]
    assert opt["n"] == iso["n"]
    says(md, "the ISO minimum form over {} engagements each", opt["n"])
    says(md, "each design is compared over {} engagements at the ISO", opt["n"])

    # 1. the design space
    start, end = run["history"][0]["params"], run["optimized"]["params"]
    fraction = dict(zip(("radius", "cw", "ccw"), run["optimized"]["fraction_of_box"], strict=False))
    upper = run["design_space"]["upper"]
    says(
        md,
        "out of the ISO range to {}° (the minimum form, ISO's largest: {}°)",
        math.degrees(end["cw.seat_angle"]),
        math.degrees(start["cw.seat_angle"]),
    )
    says(
        md,
        "its lower flank arc flatter ({} against {} 1/m)",
        end["cw.curvature"][0],
        start["cw.curvature"][0],
    )
    says(md, "the counter-clockwise lower arc flatter too ({} 1/m)", end["ccw.curvature"][0])
    says(
        md,
        "seat angle to {} % of its box, pressed against its upper bound ({}°)",
        100 * fraction["ccw"],
        math.degrees(upper[2]),
    )
    says(
        md,
        "The seating radius stays near ISO's smallest ({} → {} % of its range)",
        100 * run["history"][0]["fraction"][0],
        100 * fraction["radius"],
    )
    outer = {end["cw.curvature"][1], end["ccw.curvature"][1], start["cw.curvature"][1]}
    assert len(outer) == 1
    says(md, "Both outer arcs end where they started ({} 1/m)", *outer)

    # 2. the history
    hist = run["history"]
    obj = [h["objective_N"] for h in hist]
    grad = [h["grad_norm_N"] for h in hist]
    best = run["optimized"]
    assert best["iteration"] == obj.index(min(obj))
    falls = [a - b for a, b in zip(obj[:6], obj[1:7], strict=True)]
    says(md, "falls steadily, by {}–{} N an iteration", min(falls), max(falls))
    says(
        md,
        "flattens: {}, {}, {} N at iterations {}–{} and back up to {} N at iteration {}.",
        *obj[6:9],
        6,
        8,
        obj[9],
        len(obj) - 1,
    )
    says(
        md,
        "The best iterate is iteration {}, with the gradient down to {} N",
        best["iteration"],
        grad[best["iteration"]],
    )
    says(md, "N from about {} N; the job keeps it", grad[0], step=10)
    says(md, "it stops at its budget of {} iterations", s["iterations"])
    spike = grad.index(max(grad))
    says(md, "at iteration {} the gradient jumped to {} N", spike, grad[spike])
    says(md, "so Adam saw them clipped to {} N", s["clip"])
    gf = run["gradient_free"]
    so_far, per = gf["best_so_far_N"], gf["simulations_per_evaluation"]
    first = so_far.index(so_far[2])  # the plateau
    last = len(so_far) - 1 - so_far[::-1].index(so_far[2])
    says(
        md,
        "finds a plateau at {} N after {} simulations, stays there for {},",
        so_far[2],
        per * (first + 1),
        per * (last - first),
    )
    says(
        md,
        "and ends {} N above Adam's best after {} simulations: it never reaches it",
        gf["best_N"] - best["objective_N"],
        gf["simulations"],
    )
    assert gf["simulations_to_target"] is None
    sims = hist[best["iteration"]]["simulations"]
    ratio = run["timing"]["grad_over_forward"]
    says(md, "But Adam's {} simulations to its best", sims)
    says(md, "each costing {} forward calls", ratio)
    says(
        md,
        "about {} forward-simulation equivalents against Nelder–Mead's {}.",
        sims * ratio,
        gf["simulations"],
    )
    says(
        md,
        "the gradient bought {} N ({} %) for about {} % more compute",
        gf["best_N"] - best["objective_N"],
        -pct(best["objective_N"], gf["best_N"]),
        pct(sims * ratio, gf["simulations"]),
    )
    bias = -100 * run["soft_peak_bias"]
    says(md, "the objective lies {} % below the re-measured peak (section 3)", bias)

    # 3. the re-measurement
    rem = run["remeasured"]
    j = {k: rem[k]["johnson"]["peak_N"] for k in ("iso_min", "iso_max", "optimized", "nelder_mead")}
    h = {k: rem[k]["hertz"]["peak_N"] for k in ("iso_min", "optimized", "nelder_mead")}
    gain = -pct(j["optimized"], j["iso_min"])
    says(
        md,
        "lowers the worst peak from the minimum form's {} N to {} N, {} %;",
        j["iso_min"],
        j["optimized"],
        gain,
    )
    assert run["better_baseline"] == "iso_min" and j["iso_max"] == max(j.values())
    says(md, "the maximum form the worst ({} N)", j["iso_max"])
    changes = johnson_changes()
    slow = sorted(changes[500.0])
    (tooth,) = {round(m["peak_N"]) for m in rem["optimized"]["johnson"]["members"][:2]}
    says(
        md,
        "*worse* than the minimum form by {}–{} % ({} against {}–{} N)",
        *slow,
        tooth,
        *sorted(m["peak_N"] for m in rem["iso_min"]["johnson"]["members"][:2]),
    )
    hertz = {}
    for o, b in zip(
        rem["optimized"]["hertz"]["members"], rem["iso_min"]["hertz"]["members"], strict=True
    ):
        hertz.setdefault(1000 * o["speed_factor"], []).append(pct(o["peak_N"], b["peak_N"]))
    says(
        md,
        "tooth gains only {} % in the worst member ({} against {} N)",
        -pct(h["optimized"], h["iso_min"]),
        h["optimized"],
        h["iso_min"],
    )
    says(md, "and only at {} rpm ({} to {} %)", 1500, max(hertz[1500.0]), min(hertz[1500.0]))
    worse = hertz[500.0] + hertz[1000.0]
    assert all(v > 0 for v in worse)
    says(md, "at 500 and 1000 rpm it is {}–{} % *worse*", min(worse), max(worse))
    says(
        md,
        "re-measures {} % higher under Johnson ({} N) and the same under Hertz",
        pct(j["nelder_mead"], j["optimized"]),
        j["nelder_mead"],
    )
    assert round(pct(h["nelder_mead"], h["optimized"])) == 0  # "the same": 0 % apart
    bands = {k: run["spectra"][k]["band_rms"] for k in ("optimized", "iso_min")}
    assert bands["optimized"]["0-1 kHz"] < bands["iso_min"]["0-1 kHz"]
    assert all(bands["optimized"][b] > bands["iso_min"][b] for b in ("1-5 kHz", "5-20 kHz"))

    # 4. the clearance-joint chain
    d = opt["difference"]
    says(
        md, "mean peak is {} N ({} %) below the minimum form's", -d["mean_N"], -100 * d["relative"]
    )
    says(
        md,
        "difference runs from {} to {} N and **crosses zero**: over {} engagements",
        *d["ci95_N"],
        opt["n"],
    )
    assert not d["excludes_zero"]
    says(
        md,
        "({}–{} N delivered, {}–{} N ISO)",
        min(opt["peaks_N"]),
        max(opt["peaks_N"]),
        min(iso["peaks_N"]),
        max(iso["peaks_N"]),
    )
    says(md, "the delivered tooth's highest is {} N below", iso["max_N"] - opt["max_N"])
    says(md, "(standard deviation {}–{} N)", *sorted((opt["std_N"], iso["std_N"])))
    point = pct(
        rem["optimized"]["johnson"]["members"][-1]["peak_N"],
        rem["iso_min"]["johnson"]["members"][-1]["peak_N"],
    )
    assert (
        (c["speed_factor"], c["wear"])
        == (1.5, 0.02)
        == tuple(rem["iso_min"]["johnson"]["members"][-1][k] for k in ("speed_factor", "wear"))
    )
    says(md, "The lumped chain's {} % at this point", point)

    # 5. the live check (printed)
    diffs = [abs(float(v)) for v in re.findall(r"relative difference " + FLOAT, output("09"))]
    assert len(diffs) == 2 and max(diffs) < 1e-5 and "to a few parts in 10⁶" in md
    iso_periods, delivered = live_periods()
    assert len(iso_periods) == len(delivered) == 3 and "Three rollers mesh in the window" in md
    lower = [a[0] - b[0] for a, b in zip(iso_periods, delivered, strict=True)]
    says(
        md,
        "the delivered tooth's impact peak is {}–{} N lower (full mode)",
        min(lower),
        max(lower),
        step=10,
    )
    higher = [b[1] - a[1] for a, b in zip(iso_periods, delivered, strict=True)]
    says(md, "period is about {}–{} N higher", min(higher), max(higher), step=10)
    medians = [a[1] for a in iso_periods]
    says(md, "against {}–{} N), it carries more", min(medians), max(medians))

    # conclusions
    says(
        md,
        "(seat angle {}° against the minimum form's {}°",
        math.degrees(end["cw.seat_angle"]),
        math.degrees(start["cw.seat_angle"]),
    )
    says(md, "ends against its upper bound ({} % of the box)", 100 * fraction["ccw"])
    says(
        md,
        "Adam lowers the design objective {} % ({} → {} N) in {} evaluations",
        -pct(best["objective_N"], obj[0]),
        obj[0],
        best["objective_N"],
        best["iteration"] + 1,
    )
    says(
        md,
        "the best is iteration {}, the last iteration rises {} N",
        best["iteration"],
        obj[-1] - best["objective_N"],
    )
    says(md, "a gradient spike at iteration {} shows", spike)
    says(
        md,
        "Nelder–Mead gets within {} N in {} forward simulations, fewer than the {} forward",
        gf["best_N"] - best["objective_N"],
        gf["simulations"],
        sims * ratio,
    )
    says(
        md,
        "the worst peak falls {} % ({} → {} N) against the best ISO form",
        gain,
        j["iso_min"],
        j["optimized"],
    )
    says(md, "at 500 rpm the tooth is {}–{} % *worse*", *slow)
    says(
        md,
        "Under the Hertz law the gain is {} %, at {} rpm only: at 500 and 1000 rpm it is "
        "{}–{} % worse",
        -pct(h["optimized"], h["iso_min"]),
        1500,
        min(worse),
        max(worse),
    )
    says(md, "The design objective is {} % below the re-measured peak", bias)
    says(
        md,
        "**Clearance chain (section 4).** {} % in the mean peak, with a 95 % interval of {} "
        "to {} N",
        100 * d["relative"],
        *d["ci95_N"],
    )
    says(md, "a robust {} % cut of the worst meshing peak", gain)
    says(md, "It shrinks to {} % under another contact law", -pct(h["optimized"], h["iso_min"]))
    (written, *_) = read(md, "costs {} % at the lowest speed ({}–{} % at 500 and 1000 rpm")
    assert any(same(v, written) for v in slow), (written, slow)
    says(
        md,
        "at the lowest speed ({}–{} % at 500 and 1000 rpm under the Hertz law)",
        min(worse),
        max(worse),
    )


def live_periods() -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """Section 5's printed tooth periods, ISO minimum form and delivered tooth: (peak,
    median) [N] each."""
    out = output("09")
    iso, delivered = out.split("ISO 606 min form  peak")[1].split("delivered tooth   peak")
    period = r"tooth period \d+: peak " + FLOAT + r" N at \S+ ms, median " + FLOAT + " N"
    return (
        [(float(p), float(m)) for p, m in re.findall(period, text)] for text in (iso, delivered)
    )


def nb09_per_point_gain(md: str) -> None:
    """The gain at 1000 and 1500 rpm (the Johnson law, four members)."""
    changes = johnson_changes()
    gains = changes[1000.0] + changes[1500.0]
    says(md, "The gain is all at 1000 and 1500 rpm ({} to {} %)", max(gains), min(gains))


def nb09_clipped(md: str) -> None:
    """The iterations whose gradient was below the clipping norm."""
    run = main_job()
    below = [h["iteration"] for h in run["history"] if h["grad_norm_N"] <= run["settings"]["clip"]]
    written = read(
        md, "Every gradient but those of iterations {}, {} and {} were above the clipping"
    )
    assert [int(w) for w in written] == below, f"the text says {written}, the run {below}"


def nb09_live_medians(md: str) -> None:
    """The delivered tooth's median force per tooth period in the live check."""
    _, delivered = live_periods()
    medians = [m for _, m in delivered]
    says(md, "N higher ({}–{} against", min(medians), max(medians))


CHECKS: dict[str, Callable[[str], None]] = {
    "01": nb01,
    "02": nb02,
    "03": nb03,
    "04": nb04,
    "05": nb05,
    "06": nb06,
    "07": nb07,
    "08": nb08,
    "09": nb09,
}


def text(number: str) -> str:
    """What a notebook's checks read: its markdown; notebook 04's rendered table and printed
    lines (its markdown quotes no number)."""
    return output(number) if number == "04" else markdown(number)


@pytest.mark.parametrize("number", CHECKS)
def test_notebook_text_quotes_its_sources(number):
    """Every number a notebook's text quotes is its source's, rounded as written."""
    CHECKS[number](text(number))


def changed(written: str) -> str:
    """A number far from ``written``, written the same way (sign and decimals)."""
    sign = written[0] if written[0] in "−+-" else ""
    digits = written[len(sign) :]
    decimals = len(digits.split(".")[1]) if "." in digits else 0
    return f"{sign}{2 * float(digits) + 7:.{decimals}f}"


@pytest.mark.parametrize("number", CHECKS)
def test_a_changed_number_fails(number):
    """Each number a notebook's checks read, changed alone in a copy of the text, fails
    them: no check passes whatever the text says."""
    global _read
    original = text(number)
    _read = []
    try:
        CHECKS[number](original)
        spans = sorted(set(_read))
    finally:
        _read = None
    assert len(spans) >= 5, spans
    for start, end in spans:
        copy = original[:start] + changed(original[start:end]) + original[end:]
        with pytest.raises(AssertionError):
            CHECKS[number](copy)


def test_the_reading_rests_on():
    """Unique phrases, numbers as the text writes them, printed numbers with exponents."""
    assert re.fullmatch(FLOAT, "3.128e+05") and not re.fullmatch(NUMBER, "3.128e+05")
    with pytest.raises(AssertionError, match="occurs 2 times"):
        read("by 3 % and by 3 %", "by {} %")
    assert read("lower by −3.3 % (a)", "by {} % (") == ("−3.3",)
    assert changed("−3.3") == "−13.6" and changed("+24") == "+55" and changed("0.18") == "7.36"
    with pytest.raises(AssertionError, match="the text says 1.3, its source 1.202"):
        says("≈ 1.0–1.3 for Heun", "≈ {}–{} for Heun", 1.028, 1.202)
