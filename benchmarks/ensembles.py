"""Ensembles and scale: vmapped batches, the waste of batched adaptive solves and grouping,
sharding across devices, gradient cost, compile times.

    python -m benchmarks.ensembles            # full study (~20 min on 2 shared cores)
    python -m benchmarks.ensembles --quick    # smoke run (a few minutes)
    python -m benchmarks.ensembles --compile-only   # (e) alone → ensembles_compile.json

Writes ``benchmarks/results/ensembles.json`` and ``ensembles.png``.

Notes: benchmarks/ensembles.md
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pickle
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    FRICTIONLESS,
    figure,
    loadavg,
    modelled,
    parse,
    parser,
    probe_drive,
    write_chart,
)

Z = 18
RPM = 1000.0
PERIOD = 60.0 / RPM / Z  # tooth period [s]
TARGETS = {"grad_over_forward": 4.0, "compile_forward_s": 20.0, "compile_gradient_s": 60.0}


def machine():
    return {
        "platform": platform.platform(),
        "cpu_count": os.cpu_count(),
        "loadavg": loadavg(),
        "devices": [str(d) for d in jax.devices()],
    }


def block(x):
    return jax.block_until_ready(x)


def timed(fn, repeats=1):
    """(last result, first call's wall time, min wall time of ``repeats`` further calls)."""
    t = time.perf_counter()
    out = block(fn())
    first = time.perf_counter() - t
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        out = block(fn())
        best = min(best, time.perf_counter() - t)
    return out, first, best


def members(speeds, **kw):
    """Settled meshing scenes at the given speeds (statics compiled once)."""
    return [
        jc.scenes.engagement(
            "08B", Z, **modelled(speed_rpm=float(r), n_entry=8, **kw, **FRICTIONLESS)
        )
        for r in speeds
    ]


def spread_speeds(n, spread):
    return RPM * (1 + spread * np.linspace(-1, 1, n)) if n > 1 else np.array([RPM])


# ------------------------------------------------------------------------- (a) throughput
def throughput(sizes, t1, kw, repeats):
    pool = members(spread_speeds(max(sizes), 0.1))
    rows = []
    for b in sizes:
        idx = np.round(np.linspace(0, len(pool) - 1, b)).astype(int)
        scs = [pool[i] for i in idx]
        ens, first, warm = timed(
            lambda scs=scs: jc.simulate_ensemble(scs, t1, group_waste=None, **kw), repeats
        )
        rows.append(
            {
                "batch": b,
                "wall_s": warm,
                "compile_s": first - warm,
                "members_per_s": b / warm,
                # members differ in steps (speeds ± 10 %): steps per second compares fairly
                "member_steps_per_s": float(np.sum(ens.steps)) / warm,
                "mean_steps": float(np.mean(ens.steps)),
                "max_steps": int(np.max(ens.steps)),
                "waste": float(ens.waste),
                "all_successful": ens.ok,
            }
        )
        print(
            f"  batch {b:3d}: {b / warm:7.2f} members/s  ({warm:6.2f} s warm, "
            f"{rows[-1]['member_steps_per_s']:6.0f} member-steps/s, compile "
            f"{first - warm:5.1f} s, waste {float(ens.waste):.2f})",
            flush=True,
        )
    # one member at a time with simulate (the baseline): the batch-of-one member
    sc = pool[0]
    sol, first, warm = timed(lambda: jc.simulate(sc, t1, **kw), repeats)
    single = {
        "wall_s": warm,
        "compile_s": first - warm,
        "members_per_s": 1 / warm,
        "member_steps_per_s": int(sol.stats["num_steps"]) / warm,
        "steps": int(sol.stats["num_steps"]),
    }
    print(
        f"  simulate, one member: {1 / warm:7.2f} members/s ({warm:.2f} s, "
        f"{single['member_steps_per_s']:.0f} steps/s)",
        flush=True,
    )
    best = max(rows, key=lambda r: r["member_steps_per_s"])
    return {
        "scene": f"engagement 08B z={Z} lumped settled, {RPM:.0f} rpm ± 10 %",
        "t1_s": t1,
        "rows": rows,
        "simulate_one_at_a_time": single,
        "best_batch": best["batch"],
        "best_speedup_over_simulate": best["member_steps_per_s"] / single["member_steps_per_s"],
    }


# ------------------------------------------------------------------------- (b) waste
WASTE_VARIANTS = (  # (key, label, group_waste, cost from the one-batch run)
    ("one_batch", "one batch", None, False),
    ("pilot_1.5", "grouped, pilot, group_waste 1.5", 1.5, False),
    ("pilot_1.2", "grouped, pilot, group_waste 1.2", 1.2, False),
    ("cost_1.2", "grouped, known cost, group_waste 1.2", 1.2, True),
)


def waste_study(n, spreads, t1, kw, repeats):
    """One batch against grouping (the pilot's prediction, or a known cost: the step
    counts of a previous run, free in an optimization loop), at the default
    ``group_waste`` and a tighter one. Wall times include the pilot."""
    rows = []
    for s in spreads:
        speeds = spread_speeds(n, s)
        scs = members(speeds)
        row = {"spread": s, "speeds_rpm": [float(speeds.min()), float(speeds.max())]}
        row["members"] = n
        runs = {}
        for key, _, gw, use_cost in WASTE_VARIANTS:
            known = np.asarray(runs["one_batch"].steps, dtype=float) if use_cost else None
            ens, first, warm = timed(
                lambda scs=scs, gw=gw, known=known: jc.simulate_ensemble(
                    scs, t1, group_waste=gw, cost=known, **kw
                ),
                repeats,
            )
            runs[key] = ens
            row[f"waste_{key}"] = float(ens.waste)
            row[f"wall_{key}_s"] = min(first, warm)  # sizes compiled in (a): first is warm
            row[f"groups_{key}"] = [len(g) for g in ens.groups]
            row[f"steps_executed_{key}"] = int(ens.steps_executed)
        one = runs["one_batch"]
        steps = np.asarray(one.steps, dtype=float)
        pred = np.asarray(runs["pilot_1.5"].predicted_steps)
        row["steps_min_max"] = [int(steps.min()), int(steps.max())]
        row["pilot_rank_correlation"] = float(
            np.corrcoef(np.argsort(np.argsort(pred)), np.argsort(np.argsort(steps)))[0, 1]
        )
        row["pilot_steps_over_steps"] = [float(x) for x in (pred / steps).round(3)]
        row["max_rel_diff_peak_grouped_vs_one"] = float(
            max(
                np.max(np.abs(np.asarray(e.peak_contact_force / one.peak_contact_force) - 1))
                for e in runs.values()
            )
        )
        row["all_successful"] = all(e.ok for e in runs.values())
        rows.append(row)
        print(
            f"  spread ±{s:.0%}: steps {row['steps_min_max']}, pilot rank corr. "
            f"{row['pilot_rank_correlation']:.2f}",
            flush=True,
        )
        for key, label, _, _ in WASTE_VARIANTS:
            print(
                f"    {label:40s} waste {row[f'waste_{key}']:.2f}  {row[f'wall_{key}_s']:6.1f} s"
                f"  groups {row[f'groups_{key}']}",
                flush=True,
            )
    return {"t1_s": t1, "variants": [v[:3] for v in WASTE_VARIANTS], "rows": rows}


# ------------------------------------------------------------------------- (c) sharding
def sharding_worker(path):
    """Runs in a subprocess with 4 forced host devices: the same ensemble sharded over
    4 devices and on one device."""
    with open(path, "rb") as f:
        job = pickle.load(f)
    scs, t1, kw, repeats = job["scenes"], job["t1"], job["kw"], job["repeats"]
    assert jax.device_count() == 4, jax.devices()
    res = {}
    for name, opts in (("one_device", {}), ("sharded", {"sharding": "auto"})):
        for grouped in (False, True):
            gw = 1.5 if grouped else None
            ens, first, warm = timed(
                lambda o=opts, gw=gw: jc.simulate_ensemble(scs, t1, group_waste=gw, **o, **kw),
                repeats,
            )
            key = name + ("_grouped" if grouped else "")
            res[key] = {
                "wall_s": warm,
                "compile_s": first - warm,
                "members_per_s": len(scs) / warm,
                "waste": float(ens.waste),
                "steps_executed": int(ens.steps_executed),
                "n_devices": ens.n_devices,
                "output_devices": len(ens.peak_contact_force.sharding.device_set),
                "peak": np.asarray(ens.peak_contact_force).tolist(),
                "steps": np.asarray(ens.steps).tolist(),
                "batch_sizes": list(ens.batch_sizes),
            }
    res["loadavg"] = loadavg()
    print("RESULT " + json.dumps(res))


def sharding(n, t1, kw, repeats, spread):
    scs = members(spread_speeds(n, spread))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "job.pkl"
        with open(path, "wb") as f:
            pickle.dump({"scenes": scs, "t1": t1, "kw": kw, "repeats": repeats}, f)
        env = dict(os.environ)
        env["XLA_FLAGS"] = (
            env.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=4"
        ).strip()
        env["JAX_PLATFORMS"] = "cpu"
        out = subprocess.run(
            [sys.executable, "-m", "benchmarks.ensembles", "--sharding-worker", str(path)],
            env=env,
            cwd=Path(__file__).resolve().parents[1],
            capture_output=True,
            text=True,
        )
    if out.returncode != 0:
        raise RuntimeError(f"sharding worker failed:\n{out.stderr[-4000:]}")
    line = [ln for ln in out.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    res = json.loads(line[len("RESULT ") :])
    one, sh = res["one_device"], res["sharded"]
    peaks1, peaks4 = np.asarray(one["peak"]), np.asarray(sh["peak"])
    summary = {
        "members": n,
        "spread": spread,
        "devices": sh["n_devices"],
        "output_devices": sh["output_devices"],
        "speedup_sharded_over_one_device": one["wall_s"] / sh["wall_s"],
        "speedup_sharded_grouped_over_one_device": one["wall_s"] / res["sharded_grouped"]["wall_s"],
        "max_rel_diff_peak": float(np.max(np.abs(peaks4 / peaks1 - 1))),
        "members_same_steps": int(np.sum(np.asarray(one["steps"]) == np.asarray(sh["steps"]))),
        "runs": res,
        "note": (
            "4 forced host devices share this machine's cores: the speed-up measures what "
            "splitting the member axis (each device its own while loop, less waste) gives "
            "here, not what 4 real devices would"
        ),
    }
    for key in ("one_device", "one_device_grouped", "sharded", "sharded_grouped"):
        r = res[key]
        print(
            f"  {key:20s} {r['members_per_s']:6.2f} members/s  ({r['wall_s']:.2f} s, waste "
            f"{r['waste']:.2f}, batches {r['batch_sizes']}, output on {r['output_devices']} "
            f"devices)",
            flush=True,
        )
    print(
        f"  sharded vs one device: ×{summary['speedup_sharded_over_one_device']:.2f}, peaks "
        f"differ by ≤ {summary['max_rel_diff_peak']:.1e} (relative)",
        flush=True,
    )
    return summary


# ------------------------------------------------------------------------- (d) gradient
def gradient_study(n, t1, dt, repeats, default_adjoint=True):
    """d(mean peak over members)/d(seating radius) through ``simulate_ensemble`` (called
    inside ``jax.value_and_grad``: one vmapped batch), fixed steps, with diffrax's
    default recursive checkpointing (~√(2n) checkpoints, some steps recomputed) and with
    every step checkpointed (no step recomputed from an earlier checkpoint, each run forward
    once more before its own pullback; memory ~ steps × state). ``SolveOptions(dt=...)``
    keeps every step's residuals instead (``jc.StepResidualsAdjoint``, ``gradient_cost``)."""
    scs = members(spread_speeds(n, 0.1))
    stacked = jc.scenes.stack(scs)
    steps = int(math.ceil(t1 / dt))
    kw = dict(
        solver=diffrax.Tsit5(),
        stepsize_controller=diffrax.ConstantStepSize(),
        dt0=dt,
        max_steps=steps + 1,
        n_save=3,
        group_waste=None,
        throw=False,
    )

    def objective(r, adjoint=None):
        sc = eqx.tree_at(lambda s: s.sprockets[0].profile.seating_radius, stacked, jnp.full(n, r))
        return jnp.mean(jc.simulate_ensemble(sc, t1, adjoint=adjoint, **kw).peak_contact_force)

    full = diffrax.RecursiveCheckpointAdjoint(checkpoints=steps + 1)
    fwd = eqx.filter_jit(objective)  # the forward solve does not depend on the adjoint
    vg = eqx.filter_jit(jax.value_and_grad(objective))
    r0 = stacked.sprockets[0].profile.seating_radius[0]
    calls = {"forward": lambda: fwd(r0), "full": lambda: vg(r0, full)}
    if default_adjoint:
        calls["default"] = lambda: vg(r0)
    first, best, out_ = {}, {}, {}
    for key, call in calls.items():  # compile
        t = time.perf_counter()
        out_[key] = block(call())
        first[key] = time.perf_counter() - t
        best[key] = math.inf
    for _ in range(repeats + 1):  # interleaved: a shared machine's load drifts
        for key, call in calls.items():
            t = time.perf_counter()
            out_[key] = block(call())
            best[key] = min(best[key], time.perf_counter() - t)
    value, f_first, f_warm = out_["forward"], first["forward"], best["forward"]
    grad_full, gf_first, gf_warm = out_["full"][1], first["full"], best["full"]
    if default_adjoint:
        grad, g_first, g_warm = out_["default"][1], first["default"], best["default"]
    else:  # --quick: one gradient compile only
        grad, g_first, g_warm = grad_full, None, None
    # central differences of the fixed-step solve (a smooth discrete map between the
    # kinks of the max over steps): 1e-7 m already straddles kinks, 1e-9 m does not
    fds = {h: (float(fwd(r0 + h)) - float(fwd(r0 - h))) / (2 * h) for h in (1e-8, 1e-9)}
    fd = fds[1e-9]
    out = {
        "members": n,
        "steps": steps,
        "objective": "mean over members of the peak roller/tooth force [N]",
        "wrt": "driver seating radius [m]",
        "value_N": float(value),
        "grad_N_per_m": float(grad),
        "grad_every_step_checkpointed_N_per_m": float(grad_full),
        "fd_N_per_m": fd,
        "fd_by_step_m": {f"{h:g}": v for h, v in fds.items()},
        "grad_vs_fd_rel": abs(float(grad_full) / fd - 1) if fd else None,
        "forward_s": f_warm,
        "value_and_grad_s": g_warm,
        "value_and_grad_every_step_checkpointed_s": gf_warm,
        "grad_over_forward": g_warm / f_warm if default_adjoint else None,
        "grad_over_forward_every_step_checkpointed": gf_warm / f_warm,
        "compile_forward_s": f_first - f_warm,
        "compile_grad_s": g_first - g_warm if default_adjoint else None,
        "compile_grad_every_step_checkpointed_s": gf_first - gf_warm,
        "target_grad_over_forward": TARGETS["grad_over_forward"],
    }
    out["target_met"] = (
        out["grad_over_forward"] <= TARGETS["grad_over_forward"] if default_adjoint else None
    )
    out["target_met_every_step_checkpointed"] = (
        out["grad_over_forward_every_step_checkpointed"] <= TARGETS["grad_over_forward"]
    )
    print(
        f"  forward {f_warm:.2f} s; value+grad (every step checkpointed) {gf_warm:.2f} s: "
        f"×{out['grad_over_forward_every_step_checkpointed']:.2f}"
        + (
            f"; value+grad (default checkpoints) {g_warm:.2f} s: ×{out['grad_over_forward']:.2f}"
            if default_adjoint
            else ""
        )
        + f"; target ≤ {TARGETS['grad_over_forward']:.0f}. grad {float(grad_full):.6g} vs "
        f"central FD {fd:.6g} N/m (h = 1e-9 m)",
        flush=True,
    )
    return out


# ------------------------------------------------------------------------- (e) compile
def _compile_row(fid, links, t1, kw):
    sc = probe_drive(links, fid)
    traces = {"forward": 0, "gradient": 0, "tangent": 0}

    def peak(scene):
        return jc.simulate(scene, t1, **kw).peak_contact_force

    def forward(scene):
        traces["forward"] += 1
        return peak(scene)

    def objective(r, scene):
        traces["gradient"] += 1
        scene = eqx.tree_at(lambda s: s.sprockets[0].profile.seating_radius, scene, r)
        return peak(scene)

    def tangent(r, scene):  # d peak / d r by forward mode: the solve carries the tangent
        traces["tangent"] += 1

        def at(r):
            moved = eqx.tree_at(lambda s: s.sprockets[0].profile.seating_radius, scene, r)
            return jc.simulate(moved, t1, adjoint=diffrax.ForwardMode(), **kw).peak_contact_force

        return jax.jvp(at, (r,), (jnp.ones_like(r),))

    fwd = eqx.filter_jit(forward)
    grad = eqx.filter_jit(jax.grad(objective))
    jvp = eqx.filter_jit(tangent)
    r0 = sc.sprockets[0].profile.seating_radius
    # new values, same structure: a heavier load, a new seating radius
    heavier = sc.sprockets[1].load_torque * 2
    sc2 = eqx.tree_at(lambda s: s.sprockets[1].torque_load.value, sc, heavier)
    row = {"fidelity": fid, "links": links, "bodies": sc.n_bodies}
    outs = {}
    for name, call, again in (
        ("forward", lambda: fwd(sc), lambda: fwd(sc2)),
        ("gradient", lambda: grad(r0, sc), lambda: grad(r0 * 1.001, sc2)),
        ("tangent", lambda: jvp(r0, sc), lambda: jvp(r0 * 1.001, sc2)),
    ):
        t = time.perf_counter()
        out = outs[name] = block(call())
        first = time.perf_counter() - t
        n = traces[name]
        t = time.perf_counter()
        out2 = block(again())
        warm = time.perf_counter() - t
        row[f"compile_{name}_s"] = first - warm
        row[f"{name}_warm_s"] = warm
        row[f"{name}_retraced"] = traces[name] != n
        row[f"{name}_finite"] = bool(np.all(np.isfinite(out)) and np.all(np.isfinite(out2)))
    row["retraced"] = row["forward_retraced"] or row["gradient_retraced"] or row["tangent_retraced"]
    # the same derivative both ways (d peak / d r: reverse mode's gradient, forward's tangent)
    g, (_, t) = outs["gradient"], outs["tangent"]
    row["gradient_value"], row["tangent_value"] = float(g), float(t)
    row["tangent_vs_gradient"] = float(abs(t - g) / max(abs(g), 1e-300))
    row["target_forward_met"] = row["compile_forward_s"] <= TARGETS["compile_forward_s"]
    row["target_gradient_met"] = row["compile_gradient_s"] <= TARGETS["compile_gradient_s"]
    print(
        f"  {fid:10s} {links} links ({sc.n_bodies} bodies): compile forward "
        f"{row['compile_forward_s']:.1f} s (target ≤ {TARGETS['compile_forward_s']:.0f}), "
        f"gradient {row['compile_gradient_s']:.1f} s (target ≤ "
        f"{TARGETS['compile_gradient_s']:.0f}), forward-mode derivative "
        f"{row['compile_tangent_s']:.1f} s (d peak / d r {row['tangent_value']:.6g} N/m, "
        f"reverse mode's {row['gradient_value']:.6g}); retraced on a second call: "
        f"{row['retraced']}",
        flush=True,
    )
    return row


def compile_study(fidelities, links):
    rows = []
    t1, dt = 20e-6, 1e-6
    kw = dict(
        solver=diffrax.Tsit5(),
        stepsize_controller=diffrax.ConstantStepSize(),
        dt0=dt,
        max_steps=32,
        n_save=3,
        throw=False,
    )
    for fid in fidelities:
        rows.append(_compile_row(fid, links, t1, kw))
    return {"t1_s": t1, "dt_s": dt, "rows": rows}


# ------------------------------------------------------------------------- main
def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--sharding-worker", type=Path, help=argparse.SUPPRESS)
    ap.add_argument(
        "--compile-only",
        action="store_true",
        help="(e) alone, written to ensembles_compile.json",
    )
    args = parse(ap, argv)
    if args.sharding_worker:
        return sharding_worker(args.sharding_worker)
    if args.compile_only:
        return compile_only(args)
    quick = args.quick
    t_start = time.perf_counter()
    results = {
        "machine": machine(),
        "versions": {"jax": jax.__version__, "jaxchain": jc.__version__},
        "quick": quick,
    }
    # one set of solver options for (a)-(c): every batch size is compiled once
    kw = dict(n_save=21, max_steps=20_000)
    t1 = (0.5 if quick else 2.0) * PERIOD
    repeats = 1 if quick else 2
    sizes = (1, 4) if quick else (1, 2, 4, 8, 16, 32)
    print(f"(a) throughput against batch size (t1 = {t1 * 1e3:.2f} ms):", flush=True)
    results["throughput"] = throughput(sizes, t1, kw, repeats)
    n_waste = 4 if quick else 16
    spreads = (0.7,) if quick else (0.1, 0.4, 0.7, 0.9)
    print(f"(b) waste against spread ({n_waste} members):", flush=True)
    results["waste"] = waste_study(n_waste, spreads, t1, kw, 1)
    n_shard = 4 if quick else 8
    print(f"(c) sharded over 4 host devices vs one device ({n_shard} members):", flush=True)
    results["sharding"] = sharding(n_shard, t1, kw, repeats, 0.5)
    print("(d) gradient over forward cost of an ensemble objective:", flush=True)
    results["gradient"] = gradient_study(
        4 if quick else 8, (0.5 if quick else 1.0) * PERIOD, 2e-6, repeats, not quick
    )
    links = 50 if quick else 200
    print(f"(e) compile time of simulate and its gradient, {links}-link drive:", flush=True)
    results["compile"] = compile_study(("lumped",) if quick else ("lumped", "clearance"), links)
    results["machine"]["loadavg_end"] = loadavg()
    results["wall_s"] = time.perf_counter() - t_start
    g, rows = results["gradient"], results["compile"]["rows"]
    results["targets"] = {
        "grad_over_forward": g["grad_over_forward"],
        "grad_over_forward_met": g["target_met"],
        "grad_over_forward_every_step_checkpointed": g["grad_over_forward_every_step_checkpointed"],
        "grad_over_forward_every_step_checkpointed_met": g["target_met_every_step_checkpointed"],
        **{
            f"compile_{r['fidelity']}_{k}_met": r[f"target_{k}_met"]
            for r in rows
            for k in ("forward", "gradient")
        },
        "no_retrace": not any(r["retraced"] for r in rows),
    }
    print("targets:", json.dumps(results["targets"], indent=1))
    (args.out / "ensembles.json").write_text(json.dumps(results, indent=1))
    _chart(results, args.out / "ensembles.png")
    print(f"wrote {args.out / 'ensembles.json'} and ensembles.png ({results['wall_s']:.0f} s)")
    return results


def compile_only(args) -> dict:
    """(e) alone (``--compile-only``): ``ensembles_compile.json``, no chart."""
    t_start = time.perf_counter()
    links = 50 if args.quick else 200
    results = {
        "command": "python -m benchmarks.ensembles --compile-only"
        + (" --quick" if args.quick else ""),
        "machine": machine(),
        "versions": {"jax": jax.__version__, "jaxchain": jc.__version__},
    }
    print(f"(e) compile time of simulate and its derivatives, {links}-link drive:", flush=True)
    fidelities = ("lumped",) if args.quick else ("lumped", "clearance")
    results["compile"] = compile_study(fidelities, links)
    results["machine"]["loadavg_end"] = loadavg()
    results["wall_s"] = time.perf_counter() - t_start
    (args.out / "ensembles_compile.json").write_text(json.dumps(results, indent=1))
    print(f"wrote {args.out / 'ensembles_compile.json'} ({results['wall_s']:.0f} s)")
    return results


def _chart(res, path):
    fig, ax = figure(2, 3, figsize=(16, 8.5))
    a = ax[0, 0]
    rows = res["throughput"]["rows"]
    a.plot(
        [r["batch"] for r in rows], [r["member_steps_per_s"] for r in rows], "o-", label="ensemble"
    )
    a.axhline(
        res["throughput"]["simulate_one_at_a_time"]["member_steps_per_s"],
        color="k",
        ls="--",
        label="simulate, one at a time",
    )
    a.set_xscale("log", base=2)
    a.set_xlabel("batch size (members)")
    a.set_ylabel("member-steps / s (warm)")
    a.set_ylim(0, 1.1 * a.get_ylim()[1])
    a.set_title("(a) throughput of one vmapped batch")
    a.legend(fontsize=8, loc="lower right")

    rows = res["waste"]["rows"]
    sp = [100 * r["spread"] for r in rows]
    styles = ("o-", "s--", "^:", "D-")  # lines that coincide stay visible
    sizes = (9, 7, 5, 5)
    a = ax[0, 1]
    for (key, label, _, _), st, ms in zip(WASTE_VARIANTS, styles, sizes, strict=True):
        a.plot(sp, [r[f"waste_{key}"] for r in rows], st, ms=ms, label=label)
    a.axhline(1.5, color="grey", ls=":", lw=0.8)
    a.axhline(1.2, color="grey", ls=":", lw=0.8)
    a.set_xlabel("spread of speeds [± %]")
    a.set_ylabel("steps executed / steps needed")
    a.set_title(f"(b) waste ratio, {rows[0]['members']} members")
    a.legend(fontsize=8)
    a = ax[0, 2]
    for (key, label, _, _), st, ms in zip(WASTE_VARIANTS, styles, sizes, strict=True):
        a.plot(sp, [r[f"wall_{key}_s"] for r in rows], st, ms=ms, label=label)
    a.set_xlabel("spread of speeds [± %]")
    a.set_ylabel("wall time [s] (pilot included)")
    a.set_ylim(bottom=0)
    a.set_title("(b) wall time")
    a.legend(fontsize=8)

    a = ax[1, 0]
    runs = res["sharding"]["runs"]
    keys = ["one_device", "one_device_grouped", "sharded", "sharded_grouped"]
    a.bar(range(4), [runs[k]["members_per_s"] for k in keys])
    a.set_xticks(range(4), ["1 device", "1 dev. grouped", "4 devices", "4 dev. grouped"])
    for i, k in enumerate(keys):
        a.text(
            i, runs[k]["members_per_s"], f"waste {runs[k]['waste']:.2f}", ha="center", va="bottom"
        )
    a.set_ylabel("members / s")
    a.set_ylim(0, 1.12 * max(runs[k]["members_per_s"] for k in keys))
    a.set_title(f"(c) sharding, {res['sharding']['members']} members, 4 forced host devices")

    a = ax[1, 1]
    g = res["gradient"]
    a.bar(
        [
            "forward",
            "value + grad\n(default\ncheckpoints)",
            "value + grad\n(every step\ncheckpointed)",
        ],
        [
            g["forward_s"],
            g["value_and_grad_s"] or 0.0,
            g["value_and_grad_every_step_checkpointed_s"],
        ],
    )
    a.axhline(g["target_grad_over_forward"] * g["forward_s"], color="grey", ls=":", label="target")
    a.set_ylabel("wall time [s]")
    a.set_title(
        f"(d) ensemble gradient / forward:\n×{g['grad_over_forward'] or math.nan:.2f} "
        f"(default), ×{g['grad_over_forward_every_step_checkpointed']:.2f} (every step)"
    )
    a.legend(fontsize=8)

    a = ax[1, 2]
    rows = res["compile"]["rows"]
    labels, vals = [], []
    for r in rows:
        labels += [f"{r['fidelity']}\nforward", f"{r['fidelity']}\ngradient"]
        vals += [r["compile_forward_s"], r["compile_gradient_s"]]
    a.bar(range(len(vals)), vals, color=["C0", "C1"] * len(rows))
    a.set_xticks(range(len(vals)), labels)
    a.axhline(TARGETS["compile_forward_s"], color="C0", ls=":", label="target forward")
    a.axhline(TARGETS["compile_gradient_s"], color="C1", ls=":", label="target gradient")
    a.set_ylabel("compile time [s]")
    a.set_ylim(0, 1.1 * max([*vals, TARGETS["compile_forward_s"], TARGETS["compile_gradient_s"]]))
    a.set_title(f"(e) compile, {rows[0]['links']}-link drive")
    a.legend(fontsize=8)
    load = res["machine"]["loadavg"][0]
    write_chart(
        fig, path, f"jaxchain ensembles ({res['machine']['cpu_count']} CPU cores, load {load:.1f})"
    )


if __name__ == "__main__":
    main()
