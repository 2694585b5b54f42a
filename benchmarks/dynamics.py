"""Speed of the dynamics: per scene and fidelity, and the fidelity comparison.

    python -m benchmarks.dynamics            # full study (~15 min on 2 cores)
    python -m benchmarks.dynamics --quick    # smoke run (CI-sized)

Writes ``benchmarks/results/dynamics.json`` and ``dynamics.png``.

Notes: benchmarks/dynamics.md
"""

from __future__ import annotations

import json
import platform

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    FRICTIONLESS,
    compile_time,
    figure,
    modelled,
    parse,
    parser,
    probe_drive,
    timed_solve,
    vf_time,
    write_chart,
)

STAGES = 6  # new vector-field evaluations per Tsit5 step (FSAL)


def case(name, scene, t1, rev):
    """Cold and warm run over t1; per-revolution figures scaled by rev/t1."""
    _, cold, _ = timed_solve(scene, t1, n_save=51)
    sol, warm, _ = timed_solve(scene, t1, n_save=51)
    steps = int(sol.stats["num_steps"])
    us_step = warm / max(steps, 1) * 1e6
    vf = vf_time(scene)
    row = {
        "case": name,
        "bodies": scene.n_bodies,
        "rollers": scene.n_rollers,
        "simulated_s": t1,
        "steps": steps,
        "wall_warm_s": warm,
        "compile_s": cold - warm,
        "wall_per_rev_s": warm * rev / t1,
        "us_per_step": us_step,
        "us_per_vf_call": vf,
        "step_over_stages_x_vf": us_step / (STAGES * vf),
        "peak_force_N": float(sol.peak_contact_force),
        "result": sol.message or "successful",
    }
    print(
        f"  {name:32s} {steps:7d} steps  {us_step:7.0f} µs/step  vf {vf:6.1f} µs  "
        f"ratio {row['step_over_stages_x_vf']:.2f}  {row['wall_per_rev_s']:7.1f} s/rev  "
        f"compile {row['compile_s']:.1f} s"
    )
    return row, sol


def _compare(label, row, base):
    """Peak and cost of ``row`` relative to ``base`` (printed and returned)."""
    out = {
        "peak_change": row["peak_force_N"] / base["peak_force_N"] - 1,
        "cost_ratio": row["wall_per_rev_s"] / base["wall_per_rev_s"],
    }
    print(f"  engagement, {label}: peak {out['peak_change']:+.1%}, cost ×{out['cost_ratio']:.2f}")
    return out


def compile_times(fidelities, links=(50, 100, 200)):
    rows = []
    for fid in fidelities:
        for n in links:
            compile_s, _ = compile_time(probe_drive(n, fid))
            rows.append({"fidelity": fid, "links": n, "compile_s": compile_s})
            print(f"  compile {fid:10s} {n:4d} links: {compile_s:6.1f} s")
    return rows


def comparison_drive(n_links, fidelity, rollers_on_bush):
    """The settled 18/36 drive both drive studies use: 1000 rpm, 20 N·m, 200 N."""
    return jc.scenes.drive(
        "08B",
        **modelled(
            teeth=(18, 36),
            n_links=n_links,
            speed_rpm=1000,
            load_torque=20.0,
            pretension=200.0,
            fidelity=fidelity,
            **FRICTIONLESS,
            model=jc.scenes.ChainModel(rollers_on_bush=rollers_on_bush),
        ),
    )


def fidelity_comparison(t_frac, n_links):
    """Same drive, lumped vs clearance (rollers on joints, and fixed to the bushes)."""
    rev = 60 / 1000
    out = {}
    sols = {}
    for fid, rob in (("lumped", "joint"), ("clearance", "lumped"), ("clearance", "joint")):
        sc = comparison_drive(n_links, fid, rob)
        key = fid if fid == "lumped" else f"clearance/rollers-{rob}"
        row, sol = case(f"drive {n_links} links {key}", sc, t_frac * rev, rev)
        tension = np.asarray(sol.link_tension)
        row["mean_max_tension_N"] = float(tension.max(axis=1).mean())
        out[key] = row
        sols[key] = sol
    base = out["lumped"]
    for key, row in out.items():
        row["peak_vs_lumped"] = row["peak_force_N"] / base["peak_force_N"] - 1
        row["tension_vs_lumped"] = row["mean_max_tension_N"] / base["mean_max_tension_N"] - 1
        row["cost_vs_lumped"] = row["wall_per_rev_s"] / base["wall_per_rev_s"]
        print(
            f"  {key:28s} peak {row['peak_force_N']:7.0f} N ({row['peak_vs_lumped']:+.1%})  "
            f"max tension {row['mean_max_tension_N']:7.0f} N ({row['tension_vs_lumped']:+.1%})  "
            f"cost ×{row['cost_vs_lumped']:.1f}"
        )
    return out, sols


def clearance_drive_speed(t_frac, n_links, settings):
    """The clearance drive (rollers on their joints, settled) at several solver settings:
    wall per driver revolution against the error of the peak roller force over the same
    window, relative to Tsit5 at rtol 1e-9. Tolerances as in ``simulate``: atol = 1e-3·rtol.
    """
    import diffrax

    rev = 60 / 1000
    sc = comparison_drive(n_links, "clearance", "joint")
    t1 = t_frac * rev
    solvers = {"Tsit5": diffrax.Tsit5(), "Bosh3": diffrax.Bosh3(), "Dopri5": diffrax.Dopri5()}
    ref, _, _ = timed_solve(sc, t1, n_save=3, rtol=1e-9, atol=1e-12, max_steps=2_000_000)
    peak_ref = float(ref.peak_contact_force)
    steps = int(ref.stats["num_steps"])
    print(f"  reference (Tsit5 rtol 1e-9): peak {peak_ref:.1f} N, {steps} steps")
    rows = []
    for name, rtol in settings:
        kw = dict(solver=solvers[name], rtol=rtol, atol=rtol * 1e-3, n_save=3, max_steps=1_000_000)
        timed_solve(sc, t1, **kw)  # compile
        sol, wall, _ = min((timed_solve(sc, t1, **kw) for _ in range(2)), key=lambda r: r[1])
        row = {
            "solver": name,
            "rtol": rtol,
            "steps": int(sol.stats["num_steps"]),
            "wall_per_rev_s": wall * rev / t1,
            "peak_N": float(sol.peak_contact_force),
            "peak_err": float(sol.peak_contact_force) / peak_ref - 1,
            "result": sol.message or "successful",
        }
        rows.append(row)
        print(
            f"  {name:7s} rtol {rtol:.0e}: {row['steps']:7d} steps, {row['wall_per_rev_s']:6.1f} "
            f"s/rev, peak {row['peak_N']:.1f} N ({row['peak_err']:+.2%})",
            flush=True,
        )
    return {"t1_s": t1, "n_links": n_links, "reference_peak_N": peak_ref, "rows": rows}


def main(argv=None):
    ap = parser(__doc__)
    args = parse(ap, argv)
    quick = args.quick
    rev = 60 / 1000
    results = {
        "machine": {"platform": platform.platform(), "cpu_count": __import__("os").cpu_count()},
        "versions": {"jax": jax.__version__, "jaxchain": jc.__version__},
        "quick": quick,
    }
    print("scenes (1000 rpm, 08B, default tolerances rtol 1e-6 / atol 1e-9):")
    eng = {}
    t_eng = (1 if quick else 4) * rev / 18
    for key, fid, rob in (
        ("lumped", "lumped", "joint"),
        ("clearance", "clearance", "joint"),
        ("clearance/rollers-lumped", "clearance", "lumped"),
    ):
        sc = jc.scenes.engagement(
            "08B",
            18,
            **modelled(
                speed_rpm=1000,
                n_entry=8,
                fidelity=fid,
                **FRICTIONLESS,
                model=jc.scenes.ChainModel(rollers_on_bush=rob),
            ),
        )
        eng[key], _ = case(f"engagement z18 {key}", sc, t_eng, rev)
    results["engagement"] = eng
    # both start settled; the second: roller fixed to its bush vs on its own joint
    results["engagement_fidelity"] = _compare(
        "clearance vs lumped", eng["clearance"], eng["lumped"]
    )
    results["engagement_rollers"] = _compare(
        "roller fixed to bush vs on its joint", eng["clearance/rollers-lumped"], eng["clearance"]
    )
    print("compile time of simulate against link count:")
    results["compile"] = compile_times(
        ("lumped",) if quick else ("lumped", "clearance"), (50, 100) if quick else (50, 100, 200)
    )
    print("lumped vs clearance on one drive:")
    comp, sols = fidelity_comparison(0.01 if quick else 0.1, 50 if quick else 100)
    results["fidelity"] = comp
    print("clearance drive (rollers on joints), solver settings against a tight reference:")
    results["clearance_drive_speed"] = clearance_drive_speed(
        0.01 if quick else 0.1,
        50 if quick else 100,
        [("Tsit5", 1e-4)] if quick else [("Tsit5", 1e-6), ("Tsit5", 1e-5), ("Tsit5", 1e-4)],
    )
    comp_rows = results["compile"]
    for fid in {r["fidelity"] for r in comp_rows}:
        c = {r["links"]: r["compile_s"] for r in comp_rows if r["fidelity"] == fid}
        if 200 in c and 50 in c:
            results.setdefault("targets", {})[f"compile_growth_50_to_200_{fid}"] = c[200] / c[50]
    ratios = [r["step_over_stages_x_vf"] for r in list(eng.values()) + list(comp.values())]
    results.setdefault("targets", {})["max_step_over_stages_x_vf"] = max(ratios)
    if "clearance/rollers-joint" in comp:
        results["targets"]["clearance_drive_s_per_rev_rollers_joint"] = comp[
            "clearance/rollers-joint"
        ]["wall_per_rev_s"]
        results["targets"]["clearance_drive_s_per_rev_rollers_lumped"] = comp[
            "clearance/rollers-lumped"
        ]["wall_per_rev_s"]
    fast = [
        r
        for r in results["clearance_drive_speed"]["rows"]
        if r["wall_per_rev_s"] <= 60.0 and abs(r["peak_err"]) <= 0.02
    ]
    results["targets"]["clearance_drive_60s_met_at"] = (
        {k: fast[0][k] for k in ("solver", "rtol", "wall_per_rev_s", "peak_err")} if fast else None
    )
    print("targets:", json.dumps(results["targets"], indent=1))
    (args.out / "dynamics.json").write_text(json.dumps(results, indent=1))
    _chart(results, sols, args.out / "dynamics.png")
    print(f"wrote {args.out / 'dynamics.json'} and dynamics.png")


def _chart(results, sols, path):
    fig, ax = figure(1, 3, figsize=(15, 4))
    comp = results["compile"]
    for fid in sorted({r["fidelity"] for r in comp}):
        rows = [r for r in comp if r["fidelity"] == fid]
        ax[0].plot([r["links"] for r in rows], [r["compile_s"] for r in rows], "o-", label=fid)
    ax[0].set_xlabel("links")
    ax[0].set_ylabel("compile time of simulate [s]")
    ax[0].set_ylim(bottom=0)
    ax[0].legend()
    ax[0].set_title("compile time vs model size")
    rows = list(results["engagement"].values()) + list(results["fidelity"].values())
    names = [r["case"].replace("drive ", "").replace("engagement ", "eng. ") for r in rows]
    ax[1].barh(names, [r["wall_per_rev_s"] for r in rows])
    ax[1].set_xlabel("wall time per driver revolution at 1000 rpm [s]")
    ax[1].set_title("cost per revolution (warm)")
    for key, sol in sols.items():
        ax[2].plot(
            np.asarray(sol.ts) * 1e3,
            np.asarray(jnp.max(sol.roller_sprocket_force, axis=1)),
            label=key,
        )
    ax[2].set_xlabel("time [ms]")
    ax[2].set_ylabel("largest roller–sprocket force [N]")
    ax[2].set_title("same drive, three fidelities")
    ax[2].legend(fontsize=8)
    write_chart(fig, path)


if __name__ == "__main__":
    main()
