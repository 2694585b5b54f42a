"""Manufacturing tolerance: does the optimized tooth keep its advantage when every gap is
cut with scatter? Sampled sprockets of the ISO minimum form and the main job's design,
every gap with its own offsets of ±δ, re-measured at the worst operating point.

    python -m benchmarks.tolerance                      # full study (see --help)
    python -m benchmarks.tolerance --processes 16       # the same, 16 solves at a time
    python -m benchmarks.tolerance --quick              # smoke run (6 re-measurements)
    (also --deltas, --samples, --points worst|all, --seed)

Writes ``benchmarks/results/tolerance.json`` and ``tolerance.png`` (finished jobs kept in
``tolerance.partial.json`` meanwhile: the same command resumes a run cut off).

Notes: benchmarks/tolerance.md
"""

from __future__ import annotations

import functools
import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from benchmarks.common import figure, finish, parse, parser, single_thread_env, write_chart

DESIGNS = ("iso_min", "optimized")
DELTAS_UM = (5.0, 10.0, 20.0)
SAMPLES = 16
FLANK_RADIUS_PER_DELTA = 80.0  # flank radius tolerance as a multiple of δ (the notes)
WORST_POINT = (1.5, 0.02)  # where both nominal designs peak (main job's results)
OPTIMIZED = Path(__file__).parent / "results" / "optimize_noclip" / "results.json"
PARTIAL = "tolerance.partial.json"


# ------------------------------------------------------------------------ the designs
@functools.cache
def _problem():
    import jax

    jax.config.update("jax_enable_x64", True)
    from optimize.problem import Settings, make_problem

    return make_problem(Settings())


def nominal(design: str):
    """The nominal free-form profile of ``design`` (two arcs per flank, scalar leaves)."""
    import jax.numpy as jnp

    import jaxchain as jc
    from optimize.problem import iso_forms

    problem = _problem()
    if design == "iso_min":
        return jc.FreeformProfile.from_iso(iso_forms(problem)["min"], 2)
    if design == "optimized":
        u = json.loads(OPTIMIZED.read_text())["optimized"]["u"]
        if len(u) != problem.space.size:
            raise ValueError(
                f"{OPTIMIZED} holds {len(u)} coordinates; the default problem has "
                f"{problem.space.size}: re-run `python -m optimize` first"
            )
        return problem.space.profile(jnp.asarray(u))
    raise ValueError(f"design must be one of {DESIGNS}, got {design!r}")


def unit_offsets(seed: int, sample: int, teeth: int) -> np.ndarray:
    """Sample ``sample``'s offsets in units of δ, uniform in [−1, 1], shape (z, 6):
    columns seating radius, cw / ccw seat angle, cw / ccw flank radius, phase."""
    return np.random.default_rng([seed, sample]).uniform(-1.0, 1.0, (teeth, 6))


def scattered(base, delta: float, unit: np.ndarray):
    """``base`` (a free-form profile with scalar leaves) with every gap's parameters
    offset by ``delta`` [m] times ``unit`` (z, 6) as the notes describe;
    raises ``ValueError`` where the result is not a valid profile."""
    import jaxchain as jc

    z = base.teeth
    r_roller = float(base.roller_diameter) / 2
    radius = float(base.pitch) / (2 * math.sin(math.pi / z))

    def gaps(x):
        return np.broadcast_to(np.asarray(x, dtype=float), (z,))

    def flank(f, u_angle, u_radius):
        kappa = np.broadcast_to(np.asarray(f.curvature, dtype=float), (z, f.arcs))
        rho = 1.0 / kappa + FLANK_RADIUS_PER_DELTA * delta * u_radius[:, None]
        breaks = np.broadcast_to(np.asarray(f.breaks, dtype=float), (z, f.arcs - 1))
        return jc.Flank(gaps(f.seat_angle) + delta / r_roller * u_angle, 1.0 / rho, breaks)

    return jc.FreeformProfile(
        teeth=z,
        pitch=base.pitch,
        roller_diameter=base.roller_diameter,
        seating_radius=gaps(base.seating_radius) + delta * unit[:, 0],
        tip_diameter=base.tip_diameter,
        cw=flank(base.cw, unit[:, 1], unit[:, 3]),
        ccw=flank(base.ccw, unit[:, 2], unit[:, 4]),
        seat_offset=gaps(base.seat_offset),
        phase=gaps(base.phase) + delta / radius * unit[:, 5],
        min_tip_width=base.min_tip_width,
    )


def outline_deviation(design: str, delta: float) -> dict:
    """How far each parameter's full offset (u = +1) moves gap 0's outline at tolerance
    ``delta`` [m]: the largest distance [µm] of the moved outline from the nominal one."""
    from scipy.spatial import cKDTree

    base = nominal(design)
    z = base.teeth
    ref = cKDTree(scattered(base, 0.0, np.zeros((z, 6))).outline(4000, 0))
    out = {}
    names = ("seating_radius", "cw.seat_angle", "ccw.seat_angle", "cw.flank_radius",
             "ccw.flank_radius", "phase")  # fmt: skip
    for col, name in enumerate(names):
        u = np.zeros((z, 6))
        u[:, col] = 1.0
        dist, _ = ref.query(scattered(base, delta, u).outline(4000, 0))
        out[name] = float(dist.max() * 1e6)
    return out


class _AtPoint:
    """The problem as ``remeasure`` reads it, restricted to one operating point (the
    scene, its window and its chain strand stay those of the whole problem)."""

    def __init__(self, problem, point: tuple[float, float]):
        self._problem = problem
        self.operating_points = [point]

    def __getattr__(self, name):
        return getattr(self._problem, name)


# ------------------------------------------------------------------------ one job
def solve(design: str, delta_um: float, sample: int, point: tuple[float, float], seed: int):
    """Re-measure sample ``sample`` of ``design`` at tolerance ``delta_um`` [µm] at one
    operating point (speed factor, wear): its peak, the solver's result and wall time."""
    from optimize.problem import remeasure

    problem = _problem()
    base = nominal(design)
    row = {
        "design": design,
        "delta_um": delta_um,
        "sample": sample,
        "speed_factor": point[0],
        "wear": point[1],
    }
    try:
        profile = scattered(base, delta_um * 1e-6, unit_offsets(seed, sample, base.teeth))
    except ValueError as err:
        return row | {"valid": False, "ok": False, "message": str(err), "peak_N": None}
    t = time.perf_counter()
    m = remeasure(_AtPoint(problem, point), profile)["members"][0]
    return row | {
        "valid": True,
        "ok": bool(m["ok"]),
        "message": m["message"],
        "peak_N": m["peak_N"] if m["ok"] else None,
        "steps": m["steps"],
        "wall_s": time.perf_counter() - t,
    }


# ------------------------------------------------------------------------ statistics
def _stats(values) -> dict:
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return {"n": 0}
    return {
        "n": int(v.size),
        "min_N": float(v.min()),
        "median_N": float(np.median(v)),
        "p90_N": float(np.percentile(v, 90)),
        "max_N": float(v.max()),
        "mean_N": float(v.mean()),
    }


def summarize(rows: list[dict], settings: dict) -> dict:
    """Per design and δ: each sample's worst peak over the measured operating points,
    the distribution, invalid and failed samples, and the comparisons with ISO."""
    points = [tuple(p) for p in settings["points"]]
    by = {}
    for r in rows:
        by.setdefault((r["design"], r["delta_um"], r["sample"]), []).append(r)

    def sample_peak(design, delta, i):
        """(state, worst peak): 'ok', 'invalid', 'failed' or 'missing'."""
        mine = by.get((design, delta, i), [])
        if any(not r["valid"] for r in mine):
            return "invalid", None
        if any(not r["ok"] for r in mine):
            return "failed", None
        if len(mine) < len(points):
            return "missing", None
        return "ok", max(r["peak_N"] for r in mine)

    out = {"nominal": {}, "tolerance": {}}
    for d in settings["designs"]:
        state, peak = sample_peak(d, 0.0, 0)
        out["nominal"][d] = {"state": state, "peak_N": peak}
    iso_nominal = out["nominal"].get("iso_min", {}).get("peak_N")
    for delta in settings["deltas_um"]:
        row = {}
        peaks = {}
        for d in settings["designs"]:
            states = [sample_peak(d, delta, i) for i in range(settings["samples"])]
            peaks[d] = {i: p for i, (s, p) in enumerate(states) if s == "ok"}
            row[d] = _stats(list(peaks[d].values())) | {
                "peaks_N": [p for _, p in states],
                "invalid": [i for i, (s, _) in enumerate(states) if s == "invalid"],
                "failed": [i for i, (s, _) in enumerate(states) if s == "failed"],
                "missing": [i for i, (s, _) in enumerate(states) if s == "missing"],
            }
            nom = out["nominal"][d]["peak_N"]
            if nom is not None and row[d]["n"]:
                row[d]["median_over_nominal"] = row[d]["median_N"] / nom - 1
        opt, iso = peaks.get("optimized", {}), peaks.get("iso_min", {})
        if opt and iso_nominal is not None:
            row["optimized_below_iso_nominal"] = float(
                np.mean([p < iso_nominal for p in opt.values()])
            )
        paired = sorted(set(opt) & set(iso))
        if paired:
            gain = [1 - opt[i] / iso[i] for i in paired]
            row["paired"] = {
                "n": len(paired),
                "optimized_below_iso": float(np.mean([g > 0 for g in gain])),
                "reduction_median": float(np.median(gain)),
                "reduction_min": float(np.min(gain)),
            }
        out["tolerance"][f"{delta:g}"] = row
    return out


# ------------------------------------------------------------------------ chart
def chart(results: dict, path: Path) -> None:
    s, summ = results["settings"], results["summary"]
    deltas = s["deltas_um"]
    colors = {"iso_min": "tab:blue", "optimized": "tab:orange"}
    labels = {"iso_min": "ISO 606 minimum form", "optimized": "optimized free-form"}
    fig, ax = figure(1, 2, figsize=(13, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    rng = np.random.default_rng(0)
    for j, d in enumerate(s["designs"]):
        off = (j - 0.5) * 0.32
        data = [
            [p for p in summ["tolerance"][f"{x:g}"][d]["peaks_N"] if p is not None] for x in deltas
        ]
        pos = np.arange(len(deltas)) + off
        keep = [k for k, v in enumerate(data) if v]
        if keep:
            ax[0].boxplot(
                [data[k] for k in keep],
                positions=pos[keep],
                widths=0.26,
                whis=(0, 100),
                patch_artist=True,
                boxprops={"facecolor": colors[d], "alpha": 0.25},
                medianprops={"color": colors[d]},
            )
        for k in keep:
            x = pos[k] + rng.uniform(-0.07, 0.07, len(data[k]))
            ax[0].plot(x, data[k], ".", color=colors[d], ms=5)
        nom = summ["nominal"][d]["peak_N"]
        if nom is not None:
            ax[0].axhline(nom, color=colors[d], ls="--", lw=1, label=f"{labels[d]}, nominal")
        ax[0].plot([], [], "s", color=colors[d], alpha=0.5, label=f"{labels[d]}, sampled")
    where = "worst over the 6 operating points" if s["point_set"] == "all" else (
        f"{s['points'][0][0]:g} × {s['speed_rpm']:g} rpm, {100 * s['points'][0][1]:g} % wear"
    )  # fmt: skip
    ax[0].set(
        xlabel="tooth-form tolerance δ (every gap its own errors)",
        ylabel="re-measured peak roller/tooth force [N]",
        title=f"Peak force of sampled sprockets ({where})",
    )
    ax[0].legend(fontsize=8)
    for k, x in enumerate(deltas):
        row = summ["tolerance"][f"{x:g}"]
        opt = row.get("optimized", {}).get("peaks_N", [])
        iso = row.get("iso_min", {}).get("peaks_N", [])
        gain = [100 * (1 - a / b) for a, b in zip(opt, iso, strict=False) if a is not None and b]
        if gain:
            ax[1].plot(k + rng.uniform(-0.1, 0.1, len(gain)), gain, "o", color="tab:green")
    n0 = summ["nominal"]
    if n0.get("optimized", {}).get("peak_N") and n0.get("iso_min", {}).get("peak_N"):
        g0 = 100 * (1 - n0["optimized"]["peak_N"] / n0["iso_min"]["peak_N"])
        ax[1].axhline(g0, color="tab:green", ls="--", lw=1, label=f"nominal ({g0:.1f} %)")
        ax[1].legend(fontsize=8)
    ax[1].axhline(0, color="k", lw=0.8)
    ax[1].set(
        xlabel="tooth-form tolerance δ",
        ylabel="peak reduction, optimized vs ISO min [%]",
        title="Same manufacturing errors on both designs",
    )
    for a in ax:
        a.set_xticks(np.arange(len(deltas)), [f"±{x:g} µm" for x in deltas])
        a.set_xlim(-0.5, len(deltas) - 0.5)
        a.grid(alpha=0.3)
    title = (
        f"{results['command']} — {results['date']}, {results['machine']['cpu_count']} cores, "
        f"{s['samples']} samples per δ and design"
    )
    write_chart(fig, path, title, fontsize=9)


# ------------------------------------------------------------------------ main

#: Settings that define what a job measures: a row of an earlier run is reused only if
#: these match (the designs, δs, samples and points only choose which jobs run).
MODEL_KEYS = ("seed", "flank_radius_per_delta", "speed_rpm", "remeasure_rtol")


def _key(design: str, delta_um: float, sample: int, point) -> tuple:
    return (design, float(delta_um), int(sample), float(point[0]), float(point[1]))


def _row_key(r: dict) -> tuple:
    return _key(r["design"], r["delta_um"], r["sample"], (r["speed_factor"], r["wear"]))


def _kept_rows(out: Path, settings: dict) -> dict:
    """Finished jobs of earlier runs in ``out`` (its results file, then the partial file
    of a run cut off) whose model settings match, by job."""
    rows = {}
    for path in (out / "tolerance.json", out / PARTIAL):
        if path.exists():
            saved = json.loads(path.read_text())
            if all(saved["settings"].get(k) == settings[k] for k in MODEL_KEYS):
                rows.update({_row_key(r): r for r in saved["runs"]})
    return rows


def _numbers(text: str, option: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise SystemExit(f"{option} must be comma-separated numbers, got {text!r}") from None


def main(argv=None) -> dict:
    from benchmarks.common import header, write_atomic

    ap = parser(__doc__, "one δ (20 µm), 2 samples, the worst operating point")
    ap.add_argument("--processes", type=int, default=min(16, os.cpu_count() or 1))
    ap.add_argument(
        "--deltas",
        default=",".join(f"{d:g}" for d in DELTAS_UM),
        help="tolerances δ [µm], comma-separated (default: %(default)s)",
    )
    ap.add_argument("--samples", type=int, default=SAMPLES, help="per δ and design")
    ap.add_argument("--points", choices=("worst", "all"), default="worst")
    ap.add_argument("--seed", type=int, default=0)
    args = parse(ap, argv)
    for name in ("processes", "samples"):
        if getattr(args, name) < 1:
            raise SystemExit(f"--{name} must be ≥ 1, got {getattr(args, name)}")
    deltas = _numbers(args.deltas, "--deltas")
    if not all(0 < d <= 100 for d in deltas):
        raise SystemExit(f"--deltas must lie in (0, 100] µm, got {args.deltas}")
    samples, point_set = args.samples, args.points
    if args.quick:
        deltas, samples, point_set = (20.0,), 2, "worst"
    from optimize.problem import Settings

    defaults = Settings()
    all_points = [(f, e) for f in defaults.ensemble for e in defaults.wear]
    points = [WORST_POINT] if point_set == "worst" else all_points
    settings = {
        "designs": list(DESIGNS),
        "deltas_um": list(deltas),
        "samples": samples,
        "point_set": point_set,
        "points": [list(p) for p in points],
        "seed": args.seed,
        "flank_radius_per_delta": FLANK_RADIUS_PER_DELTA,
        "speed_rpm": defaults.speed_rpm,
        "remeasure_rtol": defaults.remeasure_rtol,
    }
    partial = args.out / PARTIAL
    jobs = [(d, 0.0, 0, p) for d in DESIGNS for p in points]  # the nominal designs first
    jobs += [(d, x, i, p) for x in deltas for i in range(samples) for d in DESIGNS for p in points]
    kept = _kept_rows(args.out, settings)
    rows = [kept[_key(*j)] for j in jobs if _key(*j) in kept]
    n_kept = len(rows)
    jobs = [j for j in jobs if _key(*j) not in kept]
    print(f"{len(jobs)} re-measurements to run ({len(rows)} kept from earlier runs), "
          f"{args.processes} at a time")  # fmt: skip
    head = header("tolerance", argv or None)  # the command, the date, the machine
    start = time.perf_counter()
    single_thread_env()
    import multiprocessing as mp

    with ProcessPoolExecutor(args.processes, mp_context=mp.get_context("spawn")) as pool:
        futures = [pool.submit(solve, d, x, i, p, args.seed) for d, x, i, p in jobs]
        for f in as_completed(futures):
            row = f.result()
            rows.append(row)
            write_atomic(partial, json.dumps({"settings": settings, "runs": rows}))
            peak = "invalid" if not row["valid"] else (
                f"{row['peak_N']:.0f} N" if row["ok"] else f"failed: {row['message']}"
            )  # fmt: skip
            print(f"  {row['design']:9s} δ {row['delta_um']:4g} µm sample {row['sample']:2d} "
                  f"at {row['speed_factor']:g}×/{row['wear']:g}: {peak}", flush=True)  # fmt: skip
    main_job = json.loads(OPTIMIZED.read_text())["summary"]
    results = {
        **head,
        "settings": settings | {"processes": args.processes},
        "main_job": {
            "iso_min_N": main_job["baseline_value"],
            "optimized_N": main_job["optimized_value"],
            "members": main_job["members"],
        },
        "outline_deviation_um": {
            f"{x:g}": {d: outline_deviation(d, x * 1e-6) for d in DESIGNS} for x in deltas
        },
        "summary": summarize(rows, settings),
        "reused_runs": n_kept,
        "runs": sorted(rows, key=_row_key),
    }
    summ = results["summary"]
    for d, v in summ["nominal"].items():
        print(f"nominal {d:9s}: {v['peak_N']:.1f} N" if v["peak_N"] else f"nominal {d}: {v}")
    for x, row in summ["tolerance"].items():
        for d in DESIGNS:
            r = row[d]
            if r["n"]:
                print(f"±{x} µm {d:9s}: n {r['n']}, median {r['median_N']:.0f} N, p90 "
                      f"{r['p90_N']:.0f} N, max {r['max_N']:.0f} N; invalid "
                      f"{len(r['invalid'])}, failed {len(r['failed'])}")  # fmt: skip
        if "optimized_below_iso_nominal" in row:
            print(f"±{x} µm optimized below the nominal ISO min form: "
                  f"{100 * row['optimized_below_iso_nominal']:.0f} %")  # fmt: skip
    out = finish(results, args.out, "tolerance", chart, start)
    partial.unlink(missing_ok=True)
    return out


if __name__ == "__main__":
    main()
