"""Speed of drives as engineers build them: a timing drive against a two-sprocket drive,
and compile time against the number of sprockets.

    python -m benchmarks.drives            # full study (~25 min on a loaded 2-core CPU)
    python -m benchmarks.drives --quick    # smoke run (CI-sized)

Writes ``benchmarks/results/drives.json`` and ``drives.png``.

Notes: benchmarks/drives.md
"""

from __future__ import annotations

import math
import os
import time

import jax

jax.config.update("jax_enable_x64", True)
# compile times are measured: nothing may come from the persistent cache
jax.config.update("jax_enable_compilation_cache", False)


import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    compile_time,
    figure,
    finish,
    header,
    modelled,
    parse,
    parser,
    timed_solve,
    write_chart,
)

CHAIN = "06B"
RPM = 3000.0
REV = 60.0 / RPM  # one crank revolution [s]
COMMON = dict(speed_rpm=RPM, load_torque=2.0, pretension=150.0)
TIMING_CENTRES = ((0.0, 0.0), (0.06, 0.32), (-0.1, 0.32))
#: the timing drive: crank, two cams; tensioner on the slack span, guide on the tight one
TIMING = dict(
    teeth=(21, 42, 42),
    centres=TIMING_CENTRES,
    n_links=120,
    tensioner=jc.scenes.Tensioner(span=0, shoe_radius=0.12, damping=0.02),
    guides=(jc.scenes.Guide(span=2, length=0.12),),
)
#: drives without shoes for the compile time against the sprocket count (about 120 links)
BY_SPROCKETS = {
    2: dict(teeth=(21, 42), n_links=120),
    3: dict(teeth=(21, 42, 42), centres=TIMING_CENTRES, n_links=120),
    5: dict(
        teeth=(21, 17, 42, 42, 17),
        centres=((0.0, 0.0), (0.12, 0.12), (0.06, 0.32), (-0.1, 0.32), (-0.12, 0.12)),
        load_torque=(0.0, 2.0, 2.0, 0.0),  # two idlers, two cams
        n_links=126,
    ),
}


def build(name: str, fidelity: str = "lumped", settle: bool = True):
    """The scene ``name``: "timing", "two_100", "two_120", or "sprockets_<n>"."""
    if name == "timing":
        kw = TIMING
    elif name.startswith("two_"):
        kw = dict(teeth=(21, 42), n_links=int(name[4:]))
    else:
        kw = BY_SPROCKETS[int(name.split("_")[1])]
    return jc.scenes.drive(
        CHAIN,
        **modelled(
            **{**COMMON, **kw}, fidelity=fidelity, model=jc.scenes.ChainModel(settle=settle)
        ),
    )


def load() -> float:
    """The 1-minute load average (what ``uptime`` shows first)."""
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def cost(names: list[str], fidelity: str, window_rev: float, repeats: int) -> dict:
    """Warm wall time of each scene over ``window_rev`` crank revolutions, the scenes taking
    turns ``repeats`` times; the least of each, and ratios to the two-sprocket drives."""
    t = time.perf_counter()
    scenes = {n: build(n, fidelity) for n in names}
    print(f"  built and settled {len(names)} {fidelity} scenes in {time.perf_counter() - t:.0f} s")
    t1 = window_rev * REV
    for sc in scenes.values():  # compile (the window is traced: a short one will do)
        timed_solve(sc, 1e-5, n_save=11)
    runs = {n: [] for n in names}
    for rep in range(repeats):
        for n, sc in scenes.items():
            before = load()
            sol, wall, cpu = timed_solve(sc, t1, n_save=11)
            runs[n].append(
                {
                    "wall_s": wall,
                    "cpu_s": cpu,
                    "load_before": before,
                    "load_after": load(),
                    "steps": int(sol.stats["num_steps"]),
                    "result": sol.result_name,
                }
            )
            print(
                f"  {fidelity:9s} {n:8s} rep {rep}: {wall:6.2f} s (CPU {cpu:6.2f} s), "
                f"{runs[n][-1]['steps']:6d} steps, load {before:.1f}",
                flush=True,
            )
    rows = {}
    for n, sc in scenes.items():
        best = min(runs[n], key=lambda r: r["wall_s"])
        cpu = min(r["cpu_s"] for r in runs[n])
        rows[n] = {
            "links": sc.n_links,
            "bodies": sc.n_bodies,
            "sprockets": len(sc.sprockets),
            "window_s": t1,
            "wall_s": best["wall_s"],
            "wall_per_rev_s": best["wall_s"] * REV / t1,
            "wall_per_simulated_s": best["wall_s"] / t1,
            "cpu_per_simulated_s": cpu / t1,
            "cpu_per_rev_s": cpu * REV / t1,
            "steps": best["steps"],
            "steps_per_rev": best["steps"] * REV / t1,
            "us_per_step": best["wall_s"] / best["steps"] * 1e6,
            "result": best["result"],
            "runs": runs[n],
        }
    out = {"window_rev": window_rev, "repeats": repeats, "rows": rows, "ratios": {}}
    for base in [n for n in names if n.startswith("two_")]:
        b, r = rows[base], rows["timing"]
        q = out["ratios"][f"timing_over_{base}"] = {
            "cost_per_simulated_s": r["wall_per_simulated_s"] / b["wall_per_simulated_s"],
            "cpu_per_simulated_s": r["cpu_per_simulated_s"] / b["cpu_per_simulated_s"],
            "steps": r["steps"] / b["steps"],
            "us_per_step": r["us_per_step"] / b["us_per_step"],
        }
        print(
            f"  {fidelity}: timing / {base}: cost per simulated second ×"
            f"{q['cost_per_simulated_s']:.2f}, CPU time ×{q['cpu_per_simulated_s']:.2f} "
            f"(steps ×{q['steps']:.2f}, per step ×{q['us_per_step']:.2f})",
            flush=True,
        )
    return out


def compile_times(names: list[str], fidelity: str, repeats: int) -> dict:
    """Compile time of ``simulate`` (cold minus warm call over 20 µs) per scene, jax's
    caches cleared before each cold call, the scenes taking turns; the least of each."""
    scenes = {n: build(n, fidelity, settle=False) for n in names}
    # a throwaway compile first: the process's one-off start-up costs stay out of the rows
    timed_solve(build("two_100", fidelity, settle=False), 2e-5, n_save=3)
    runs = {n: [] for n in names}
    for rep in range(repeats):
        for n, sc in scenes.items():
            jax.clear_caches()
            before = load()
            wall, cpu = compile_time(sc)
            runs[n].append({"compile_s": wall, "compile_cpu_s": cpu, "load_before": before})
            print(
                f"  {fidelity:9s} compile {n:12s} rep {rep}: {wall:5.1f} s "
                f"(CPU {cpu:5.1f} s), load {before:.1f}",
                flush=True,
            )
    rows = {
        n: {
            "sprockets": len(sc.sprockets),
            "links": sc.n_links,
            "shoes": 0 if sc.shoes is None else int(sc.shoes.mid.shape[0]),
            "compile_s": min(r["compile_s"] for r in runs[n]),
            "compile_cpu_s": min(r["compile_cpu_s"] for r in runs[n]),
            "runs": runs[n],
        }
        for n, sc in scenes.items()
    }
    ratios = {}
    for key, suffix in (("compile_s", ""), ("compile_cpu_s", "_cpu")):
        c = {n: r[key] for n, r in rows.items()}
        for a, b in ((3, 2), (5, 2), (5, 3)):
            ratios[f"{a}_over_{b}{suffix}"] = c[f"sprockets_{a}"] / c[f"sprockets_{b}"]
        if "timing" in c:
            ratios["timing_over_3" + suffix] = c["timing"] / c["sprockets_3"]
    print(
        f"  {fidelity}: compile 2 → 3 → 5 sprockets ×{ratios['3_over_2']:.2f} "
        f"×{ratios['5_over_2']:.2f} (CPU time ×{ratios['3_over_2_cpu']:.2f} "
        f"×{ratios['5_over_2_cpu']:.2f})" + (
            f"; with tensioner and guide ×{ratios['timing_over_3']:.2f} of 3"
            if "timing" in c else ""
        ),
        flush=True,
    )  # fmt: skip
    return {"repeats": repeats, "rows": rows, "ratios": ratios}


def chart(res: dict, path) -> None:
    fig, ax = figure(1, 2, figsize=(12, 4.2))
    colours = {"lumped": "tab:blue", "clearance": "tab:orange"}
    labels, values, cols, notes = [], [], [], []
    for fid, c in res["cost"].items():
        base = c["rows"]["two_120"]["cpu_per_simulated_s"]
        for n, r in c["rows"].items():
            labels.append(f"{fid}\n{n.replace('_', ' ')} ({r['links']} links)")
            values.append(r["cpu_per_simulated_s"] / base)
            cols.append(colours[fid])
            notes.append(
                f" ×{values[-1]:.2f}  ({r.get('cpu_per_rev_s', float('nan')):.3g} s CPU, "
                f"{r['wall_per_rev_s']:.3g} s wall per rev)"
            )
    ax[0].barh(labels, values, color=cols)
    ax[0].axvline(1.5, color="k", ls="--", lw=0.8, label="goal: 1.5× at the same link count")
    for i, (v, note) in enumerate(zip(values, notes, strict=True)):
        ax[0].text(
            v, i, note, va="center", fontsize=8, bbox={"fc": "white", "ec": "none", "pad": 0.5}
        )
    ax[0].set_xlim(0, 1.35 * max(values))
    ax[0].invert_yaxis()
    ax[0].set_xlabel("CPU time per simulated second / the 120-link two-sprocket drive's")
    ax[0].set_title(f"timing drive vs two sprockets ({RPM:.0f} rpm crank, warm)")
    ax[0].legend(fontsize=8, loc="lower right")
    top = 0.0
    for fid, c in res["compile"].items():
        rows = [r for n, r in c["rows"].items() if n.startswith("sprockets_")]
        top = max([top] + [r["compile_cpu_s"] for r in c["rows"].values()])
        ax[1].plot(
            [r["sprockets"] for r in rows],
            [r["compile_cpu_s"] for r in rows],
            "o-",
            color=colours[fid],
            label=f"{fid}, no shoes",
        )
        if "timing" in c["rows"]:
            r = c["rows"]["timing"]
            ax[1].plot(
                [r["sprockets"]],
                [r["compile_cpu_s"]],
                "s",
                color=colours[fid],
                mfc="none",
                ms=9,
                label=f"{fid}, timing drive (tensioner + guide)",
            )
    ax[1].set_xticks([2, 3, 5])
    ax[1].set_ylim(0, 1.4 * top)
    ax[1].set_xlabel("sprockets")
    ax[1].set_ylabel("compile time of simulate, CPU [s]")
    ax[1].set_title("compile time against the number of sprockets")
    ax[1].legend(fontsize=8, loc="lower right")
    m = res["machine"]
    title = f"{res['command']}, {res['date']}, {m['cpu_count']}-core CPU, load average "
    write_chart(fig, path, title + f"{m['loadavg_at_start'][0]:.1f} at start", fontsize=9)


def main(argv=None) -> dict:
    args = parse(parser(__doc__), argv)
    start = time.perf_counter()
    quick = args.quick
    res = {
        "study": "drives",
        **header("drives", ["--quick"] if quick else []),
        "quick": quick,
        "scenes": {
            "chain": CHAIN,
            **COMMON,
            "timing": {
                **{k: TIMING[k] for k in ("teeth", "centres", "n_links")},
                "tensioner": "Tensioner(span=0, shoe_radius=0.12, damping=0.02)",
                "guide": "Guide(span=2, length=0.12)",
            },
            "by_sprockets": {str(k): {**v} for k, v in BY_SPROCKETS.items()},
        },
        "cost": {},
        "compile": {},
    }
    print("cost, lumped (Tsit5 rtol 1e-6, from the settled start):", flush=True)
    res["cost"]["lumped"] = cost(
        ["timing", "two_100", "two_120"], "lumped", 0.05 if quick else 1.0, 1 if quick else 3
    )
    print("compile time against sprockets, lumped:", flush=True)
    names = ["sprockets_2", "sprockets_3", "sprockets_5", "timing"]
    res["compile"]["lumped"] = compile_times(names, "lumped", 1 if quick else 3)
    if not quick:
        print("cost, clearance:", flush=True)
        res["cost"]["clearance"] = cost(["timing", "two_100", "two_120"], "clearance", 0.05, 2)
        print("compile time against sprockets, clearance:", flush=True)
        res["compile"]["clearance"] = compile_times(names, "clearance", 3)
    lumped = res["cost"]["lumped"]
    same, fewer = lumped["ratios"]["timing_over_two_120"], lumped["ratios"]["timing_over_two_100"]
    res["targets"] = {
        "timing_wall_per_crank_rev_s": lumped["rows"]["timing"]["wall_per_rev_s"],
        "timing_cpu_per_crank_rev_s": lumped["rows"]["timing"]["cpu_per_rev_s"],
        "cost_ratio_same_links": same["cost_per_simulated_s"],
        "cost_ratio_same_links_cpu": same["cpu_per_simulated_s"],
        "cost_ratio_100_links": fewer["cost_per_simulated_s"],
        "cost_ratio_100_links_cpu": fewer["cpu_per_simulated_s"],
        "cost_goal": 1.5,
        "compile_goal": 1.5,
    }
    for fid, c in res["compile"].items():
        for key in ("3_over_2", "5_over_2", "3_over_2_cpu", "5_over_2_cpu"):
            res["targets"][f"compile_{key}_{fid}"] = c["ratios"][key]
    if "clearance" in res["cost"]:
        q = res["cost"]["clearance"]["ratios"]["timing_over_two_120"]
        res["targets"]["cost_ratio_same_links_clearance"] = q["cost_per_simulated_s"]
        res["targets"]["cost_ratio_same_links_clearance_cpu"] = q["cpu_per_simulated_s"]
    for suffix, tail in (("wall", ""), ("cpu", "_cpu")):
        res["targets"][f"met_{suffix}"] = bool(
            res["targets"]["cost_ratio_same_links" + tail] <= 1.5
            and all(
                c["ratios"][k + tail] <= 1.5
                for c in res["compile"].values()
                for k in ("3_over_2", "5_over_2")
            )
        )
    print(
        "targets: "
        + ", ".join(
            f"{k} {v:.3g}" if isinstance(v, float) and not math.isnan(v) else f"{k} {v}"
            for k, v in res["targets"].items()
        ),
        flush=True,
    )
    return finish(res, args.out, "drives", chart, start)


if __name__ == "__main__":
    main()
