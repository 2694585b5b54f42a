"""Mesh-order noise of a closed drive over a speed band: uniform and per-tooth sprockets.

    python -m benchmarks.quiet_drive                  # full study (45 solves, ~1.5 CPU-hours)
    python -m benchmarks.quiet_drive --processes 15   # the same, 15 solves at a time
    python -m benchmarks.quiet_drive --quick          # smoke run (2 short solves)

Writes ``benchmarks/results/quiet_drive.json`` and ``quiet_drive.png``. Each solve runs in
a process of its own (single-threaded XLA), so ``--processes`` spreads the study over the
cores of a machine; finished solves are kept in ``quiet_drive.partial.json`` (written
atomically: a kill never leaves half a file) and a rerun with the same settings skips them.
Other options: ``--revs``, ``--designs``, ``--speeds``.

Notes: benchmarks/quiet_drive.md
"""

from __future__ import annotations

import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from benchmarks.common import (
    DRIVE_CHAIN,
    DRIVE_Z,
    DRIVE_Z_DRIVEN,
    finish,
    header,
    parse,
    parser,
    quiet_drive_scene,
    single_thread_env,
    write_atomic,
)

CHAIN, Z, Z_DRIVEN = DRIVE_CHAIN, DRIVE_Z, DRIVE_Z_DRIVEN
ORDERS = np.arange(0.0, 73.0)
BAND = (9.0, 63.0)  # 0.5–3.5 mesh orders
SIGNALS = (("bearing", 1), ("torque", 1))
DESIGNS = ("iso_min", "iso_max", "gentle", "random_radius", "random_flanks")
SPEEDS = tuple(float(s) for s in np.arange(500.0, 1501.0, 125.0))
GENTLE = Path(__file__).parent / "results" / "optimize_noclip" / "results.json"


def profile(design: str):
    """The z = 18 driver's tooth profile of ``design`` (the notes list the designs)."""
    import jaxchain as jc

    chain = jc.ChainSpec.iso606(CHAIN)
    iso = {f: jc.ToothProfile.iso606(chain, Z, f) for f in ("min", "max")}
    if design in ("iso_min", "iso_max"):
        return jc.FreeformProfile.from_iso(iso[design[4:]], 2)
    if design not in DESIGNS:
        raise ValueError(f"design must be one of {DESIGNS}, got {design!r}")
    tip = jc.iso606_limits(chain, Z)["tip_diameter"][0]
    start = jc.FreeformProfile.from_iso(iso["min"], 2, tip_diameter=tip)
    rng = np.random.default_rng(0)
    deg = math.radians
    if design == "gentle":
        p = json.loads(GENTLE.read_text())["optimized"]["params"]
        changes = dict(
            seating_radius=p["seating_radius"],
            cw=jc.Flank(p["cw.seat_angle"], p["cw.curvature"], start.cw.breaks),
            ccw=jc.Flank(p["ccw.seat_angle"], p["ccw.curvature"], start.ccw.breaks),
        )
    elif design == "random_radius":
        lo, hi = (float(iso[f].seating_radius) for f in ("min", "max"))
        changes = dict(seating_radius=rng.uniform(lo, hi, Z))
    else:  # random_flanks
        changes = dict(
            cw=jc.Flank(rng.uniform(deg(62), deg(78), Z), start.cw.curvature, start.cw.breaks),
            ccw=jc.Flank(rng.uniform(deg(57), deg(68), Z), start.ccw.curvature, start.ccw.breaks),
        )
    return jc.FreeformProfile.from_iso(iso["min"], 2, tip_diameter=tip, **changes)


def solve(design: str, rpm: float, revs: float) -> dict:
    """One solve of the drive with ``design`` at ``rpm`` over ``revs`` driver revolutions:
    the signals' order lines, the peak force, the solver's statistics and its wall time."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxchain as jc
    from jaxchain.observers import OrderSpectrum

    t = time.perf_counter()
    scene = quiet_drive_scene(profile(design), rpm)
    build_s = time.perf_counter() - t
    observers = tuple(
        OrderSpectrum(ORDERS, 0.25, revs - 0.05, signal=s, sprocket=k, reference=0)
        for s, k in SIGNALS
    )
    t = time.perf_counter()
    sol = jc.simulate(scene, revs * 60.0 / rpm, n_save=400, observers=observers, max_steps=400_000)
    jax.block_until_ready(sol.observed)
    row = {
        "design": design,
        "rpm": rpm,
        "result": jc.result_names(sol.result)[0],
        "peak_N": float(sol.peak_contact_force),
        "num_steps": int(sol.stats["num_steps"]),
        "build_s": build_s,
        "solve_s": time.perf_counter() - t,
    }
    for (s, k), lines in zip(SIGNALS, sol.observed, strict=True):
        row[f"{s}{k}"] = np.asarray(lines).tolist()
    return row


def band_max(lines) -> tuple[float, float]:
    """The largest line in the band [dB re 1 signal unit] and its order."""
    lines = np.asarray(lines)
    inside = (ORDERS >= BAND[0]) & (ORDERS <= BAND[1])
    i = int(np.argmax(np.where(inside, lines, -np.inf)))
    return 20 * math.log10(max(lines[i], 1e-12)), float(ORDERS[i])


def summarize(rows: list[dict], designs, speeds) -> dict:
    """Per design: the largest band line at each speed, its worst over the band, the peak
    force's worst; and the differences to the uniform ISO minimum form."""
    out = {}
    for d in designs:
        mine = {r["rpm"]: r for r in rows if r["design"] == d}
        ok = [s for s in speeds if s in mine and mine[s]["result"] == "successful"]
        if not ok:
            continue
        per = {}
        for sig in (f"{s}{k}" for s, k in SIGNALS):
            levels = [band_max(mine[s][sig]) for s in ok]
            worst = int(np.argmax([v for v, _ in levels]))
            per[sig] = {
                "largest_line_dB": [v for v, _ in levels],
                "order": [o for _, o in levels],
                "worst_dB": levels[worst][0],
                "worst_rpm": ok[worst],
            }
        peaks = [mine[s]["peak_N"] for s in ok]
        out[d] = {
            "speeds": ok,
            "failed": [s for s in speeds if s in mine and s not in ok],
            "signals": per,
            "peak_N": peaks,
            "worst_peak_N": max(peaks),
        }
    base = out.get("iso_min")
    if base:
        for v in out.values():
            v["vs_iso_min"] = {
                "worst_line_dB": {
                    sig: v["signals"][sig]["worst_dB"] - base["signals"][sig]["worst_dB"]
                    for sig in v["signals"]
                },
                "worst_peak": v["worst_peak_N"] / base["worst_peak_N"] - 1,
            }
    return out


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summ, rows = results["summary"], results["runs"]
    sig = "bearing1"
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.8))
    for d, v in summ.items():
        style = "o-" if d.startswith(("iso", "gentle")) else "s--"
        ax[0].plot(v["speeds"], v["signals"][sig]["largest_line_dB"], style, label=d)
        ax[1].plot(v["speeds"], v["peak_N"], style, label=d)
    ax[0].set(
        xlabel="driver speed [rpm]",
        ylabel="largest line, orders 9–63 [dB re 1 N]",
        title="Driven sprocket's bearing force: largest line in 0.5–3.5 mesh orders",
    )
    ax[1].set(xlabel="driver speed [rpm]", ylabel="peak roller/tooth force [N]", title="Peak force")
    if "iso_min" in summ:
        rpm = summ["iso_min"]["signals"][sig]["worst_rpm"]
        others = [d for d in summ if d != "iso_min"]
        best = min(others, key=lambda d: summ[d]["signals"][sig]["worst_dB"], default=None)
        for d in ("iso_min", best) if best else ("iso_min",):
            r = next(r for r in rows if r["design"] == d and r["rpm"] == rpm)
            lv = 20 * np.log10(np.maximum(np.asarray(r[sig]), 1e-3))
            ax[2].plot(ORDERS[1:], lv[1:], ".-", label=f"{d} at {rpm:.0f} rpm")
        ax[2].axvspan(*BAND, color="0.92", zorder=0)
        ax[2].set(
            xlabel="order of the driver's rotation (mesh order 18)",
            ylabel="line [dB re 1 N]",
            title="Spectra where the ISO minimum form is loudest",
        )
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.suptitle(
        f"{results['command']} — {results['date']}, {results['machine']['cpu_count']} cores",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> dict:
    ap = parser(__doc__, "two designs, one speed, a short window")
    ap.add_argument("--processes", type=int, default=max(1, (os.cpu_count() or 2) - 1))
    ap.add_argument("--revs", type=float, default=2.3, help="driver revolutions per solve")
    ap.add_argument(
        "--designs", default=",".join(DESIGNS), help="comma-separated (default: %(default)s)"
    )
    ap.add_argument(
        "--speeds",
        default=",".join(f"{s:g}" for s in SPEEDS),
        help="driver speeds [rpm], comma-separated (default: %(default)s)",
    )
    args = parse(ap, argv)
    if args.processes < 1:
        raise SystemExit(f"--processes must be ≥ 1, got {args.processes}")
    if args.revs <= 0.5:
        raise SystemExit(f"--revs must exceed 0.5 (the window starts at 0.25), got {args.revs}")
    designs = tuple(d.strip() for d in args.designs.split(","))
    bad = [d for d in designs if d not in DESIGNS]
    if bad:
        raise SystemExit(f"--designs: unknown {bad}; choose from {', '.join(DESIGNS)}")
    try:
        speeds = tuple(float(v) for v in args.speeds.split(","))
    except ValueError:
        raise SystemExit(f"--speeds must be numbers [rpm], got {args.speeds!r}") from None
    if not all(100.0 <= v <= 5000.0 for v in speeds):
        raise SystemExit(f"--speeds must lie in 100–5000 rpm, got {args.speeds}")
    revs = args.revs
    if args.quick:
        designs, speeds, revs = ("iso_min", "random_radius"), (1000.0,), 0.6
    settings = {"designs": list(designs), "speeds": list(speeds), "revs": revs}
    partial = args.out / "quiet_drive.partial.json"
    rows = []
    if partial.exists():
        saved = json.loads(partial.read_text())
        if saved["settings"] == settings:
            rows = saved["runs"]
    done = {(r["design"], r["rpm"]) for r in rows}
    jobs = [(d, s) for s in speeds for d in designs if (d, s) not in done]
    print(f"{len(jobs)} solves to run ({len(done)} kept from {partial.name}), "
          f"{args.processes} at a time")  # fmt: skip
    start = time.perf_counter()
    single_thread_env()
    import multiprocessing as mp

    with ProcessPoolExecutor(args.processes, mp_context=mp.get_context("spawn")) as pool:
        futures = {pool.submit(solve, d, s, revs): (d, s) for d, s in jobs}
        for f in as_completed(futures):
            row = f.result()
            rows.append(row)
            write_atomic(partial, json.dumps({"settings": settings, "runs": rows}))
            print(
                f"  {row['design']:14s} {row['rpm']:6.0f} rpm: {row['result']}, "
                f"{row['num_steps']} steps, {row['solve_s']:.0f} s, peak {row['peak_N']:.0f} N"
            )
    results = {
        **header("quiet_drive", argv),
        "settings": settings | {"processes": args.processes, "orders": ORDERS.tolist()},
        "summary": summarize(rows, designs, speeds),
        "runs": sorted(rows, key=lambda r: (r["design"], r["rpm"])),
    }
    for d, v in results["summary"].items():
        b = v["signals"]["bearing1"]
        print(
            f"{d:14s} worst largest line {b['worst_dB']:6.2f} dB at {b['worst_rpm']:.0f} rpm; "
            f"worst peak {v['worst_peak_N']:.0f} N"
            + (f"; failed at {v['failed']}" if v["failed"] else "")
        )
    out = finish(results, args.out, "quiet_drive", chart, start)
    partial.unlink(missing_ok=True)
    return out


if __name__ == "__main__":
    main()
