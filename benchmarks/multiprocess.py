"""Ensembles across processes: one process against two on JAX's multi-process runtime
(gloo CPU collectives, local processes started by ``python -m jaxchain.launch``).

    python -m benchmarks.multiprocess            # ~10 min on 2 shared cores
    python -m benchmarks.multiprocess --quick    # smoke run (a few minutes)

Writes ``benchmarks/results/multiprocess.json`` and ``multiprocess.png``. Every number is
measured in this run; the machine is shared, so ``uptime``'s load averages are recorded
before and after each configuration (compare ratios measured together, not seconds).

(a) throughput: a 16-member engagement ensemble (08B, z = 18, lumped, settled, speeds
    1000 rpm ± 10 %, Tsit5 at rtol 1e-6, one tooth period) with ``sharding="auto"``, each
    process building only its own members, as 1 process × 1 CPU device, 2 processes × 1
    device, and 1 process × 2 forced host devices; member-steps per second of the warm
    solve (minimum over repeats), results gathered complete on every process;
(b) collective overhead per design iteration: the all-gather of one value-and-gradient
    iteration's per-member values, gradients and result codes (a 4-member objective over
    the 4 ISO 606 coordinates), timed alone after the processes are lined up (median),
    beside the whole iteration's wall time on 1 and 2 processes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.common import FRICTIONLESS, finish, modelled, parse, parser

ROOT = Path(__file__).resolve().parents[1]
NAME = "multiprocess"
Z, RPM = 18, 1000.0
PERIOD = 60.0 / RPM / Z


def uptime() -> str:
    """``uptime``'s line (the load averages of the shared machine)."""
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())


# ------------------------------------------------------------------------- worker
def worker(path: Path, members: int, repeats: int, iterations: int) -> None:
    """One configuration (run as each of its processes): writes ``path``.<process>.json."""
    import jax

    import jaxchain as jc

    jc.distributed.initialize()
    jax.config.update("jax_enable_x64", True)
    import numpy as np

    me = jax.process_index()
    out = {"processes": jax.process_count(), "devices": jax.device_count()}
    speeds = RPM * (1 + 0.1 * np.linspace(-1, 1, members))

    def make(i):
        return jc.scenes.engagement(
            "08B", Z, **modelled(speed_rpm=float(speeds[i]), n_entry=4, **FRICTIONLESS)
        )

    # (a) throughput
    t = time.perf_counter()
    local = jc.distributed.local_members(members, make)
    out["build_s"] = time.perf_counter() - t
    kw = dict(n_save=21, max_steps=20_000, sharding="auto", group_waste=None)
    walls = []
    for _ in range(repeats + 1):  # the first call compiles
        jc.distributed.gather(np.zeros(1))  # line the processes up
        t = time.perf_counter()
        ens = jc.simulate_ensemble(local, PERIOD, **kw)
        jax.block_until_ready(ens.peak_contact_force)
        walls.append(time.perf_counter() - t)
    steps = int(np.sum(np.asarray(ens.steps)))
    out["throughput"] = {
        "members": members,
        "member_steps": steps,
        "steps_executed": int(ens.steps_executed),
        "first_call_s": walls[0],
        "wall_s": min(walls[1:]),
        "member_steps_per_s": steps / min(walls[1:]),
        "all_successful": ens.ok,
        "peak_N": np.asarray(ens.peak_contact_force).tolist(),
    }

    # (b) one design iteration, and its all-gather alone
    chain = jc.ChainSpec.iso606("08B")
    space = jc.design.DesignSpace.iso606(chain, Z)
    law = jc.scenes.roller_law(chain, 0.7, width=3e-6)
    joints = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)
    factors = (0.9, 1.0, 1.1, 1.2)

    def build(profile):
        return jc.distributed.local_members(
            len(factors),
            lambda i: jc.scenes.engagement(
                chain, Z, speed_rpm=RPM * factors[i], profile=profile, n_entry=3,
                model=jc.scenes.ChainModel(roller_contact=law, joint_friction=joints),
            ),
        )  # fmt: skip

    obj = jc.design.ProfileObjective(
        space, build, t1=1.5 * PERIOD, t_start=0.5 * PERIOD, temperature=50.0,
        reference=2000.0, dt=4e-6, combine="max", sharding="auto",
    )  # fmt: skip
    u = np.array([0.3, -0.5, 0.2, 0.1])
    scenes = obj.scenes(u)
    times = []
    for _ in range(iterations + 1):
        jc.distributed.gather(np.zeros(1))
        t = time.perf_counter()
        value, grad, _ = obj.value_and_grad_on(u, scenes)
        jax.block_until_ready(grad)
        times.append(time.perf_counter() - t)
    # what an iteration gathers: each of this process's rows' value, gradient, result
    # code and step count
    sp = jc.distributed.split(len(factors))
    payload = {
        "value": np.zeros(sp.rows),
        "grad": np.zeros((sp.rows, space.size)),
        "result": np.zeros(sp.rows, dtype=np.int32),
        "num_steps": np.zeros(sp.rows, dtype=np.int64),
    }
    gathers = []
    for _ in range(20):
        jc.distributed.gather(np.zeros(1))
        t = time.perf_counter()
        jax.block_until_ready(jc.distributed.gather(payload, rows=sp.members))
        gathers.append(time.perf_counter() - t)
    out["design"] = {
        "members": len(factors),
        "coordinates": space.size,
        "value": float(value),
        "grad": np.asarray(grad).tolist(),
        "iteration_s": min(times[1:]),
        "first_iteration_s": times[0],
        "gather_ms_median": 1e3 * float(np.median(gathers)),
        "gather_ms_min": 1e3 * float(np.min(gathers)),
        "payload_bytes": int(sum(np.asarray(x).nbytes for x in jax.tree_util.tree_leaves(payload))),
    }
    Path(f"{path}.{me}.json").write_text(json.dumps(out))


# ------------------------------------------------------------------------- driver
def run_config(name, processes, devices, out_dir, members, repeats, iterations):
    """Run one configuration; its process 0's results with the load around it."""
    env = dict(os.environ, JAX_PLATFORMS="cpu", EQX_ON_ERROR="nan")
    env.pop("XLA_FLAGS", None)
    cmd = [sys.executable, "-m", "jaxchain.launch", "-n", str(processes)]
    if devices > 1:
        cmd += ["--devices", str(devices)]
    path = out_dir / f".{NAME}-{name}"
    cmd += ["-m", "benchmarks.multiprocess", "--worker", str(path)]
    cmd += ["--members", str(members), "--repeats", str(repeats)]
    cmd += ["--iterations", str(iterations)]
    before = uptime()
    t = time.perf_counter()
    p = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        raise RuntimeError(f"{name} failed ({p.returncode}):\n{p.stderr[-4000:]}")
    res = [json.loads(Path(f"{path}.{r}.json").read_text()) for r in range(processes)]
    for r in range(processes):
        Path(f"{path}.{r}.json").unlink()
    row = res[0] | {"name": name, "processes_started": processes, "devices_per_process": devices}
    row["uptime_before"], row["uptime_after"], row["run_s"] = before, uptime(), wall
    # every process got the same complete results
    row["same_on_every_process"] = all(
        r["throughput"]["peak_N"] == res[0]["throughput"]["peak_N"]
        and r["design"]["grad"] == res[0]["design"]["grad"]
        for r in res
    )
    print(
        f"  {name}: {row['throughput']['member_steps_per_s']:.0f} member-steps/s, "
        f"iteration {row['design']['iteration_s']:.2f} s, gather "
        f"{row['design']['gather_ms_median']:.2f} ms  [{row['uptime_after']}]",
        flush=True,
    )
    return row


def chart(res: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = res["configs"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    names = [r["name"] for r in rows]
    a.bar(names, [r["throughput"]["member_steps_per_s"] for r in rows], color="tab:blue")
    a.set_ylabel("member-steps per second (warm)")
    a.set_ylim(0, 1.12 * max(r["throughput"]["member_steps_per_s"] for r in rows))
    a.set_title(f"(a) {res['members']}-member engagement ensemble")
    for i, r in enumerate(rows):
        a.annotate(
            f"×{r['speedup']:.2f}",
            (i, r["throughput"]["member_steps_per_s"]),
            ha="center",
            va="bottom",
        )
    b.bar(names, [r["design"]["iteration_s"] for r in rows], color="tab:red")
    b.set_ylabel("value + gradient iteration [s]")
    two = next((r for r in rows if r["name"] == "2 processes"), None)
    if two:
        b.set_title(f"(b) design iteration; all-gather {two['design']['gather_ms_median']:.2f} ms")
    fig.suptitle(f"load before → after: {res['load_note']}", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    ap = parser(__doc__)
    ap.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--members", type=int, default=16, help="ensemble members (default 16)")
    ap.add_argument("--repeats", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("--iterations", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        return worker(args.worker, args.members, args.repeats, args.iterations)
    args = parse(ap, argv)
    t_start = time.perf_counter()
    repeats = args.repeats or (1 if args.quick else 3)
    iterations = args.iterations or (1 if args.quick else 3)
    configs = [("1 process", 1, 1), ("2 processes", 2, 1)]
    if not args.quick:
        configs.append(("1 process, 2 devices", 1, 2))
    import jax

    results = {
        "machine": {
            "platform": sys.platform,
            "cpu_count": os.cpu_count(),
            "uptime_start": uptime(),
            "shared": "other jobs ran on the machine during this study",
        },
        "versions": {"jax": jax.__version__},
        "quick": args.quick,
        "members": args.members,
        "t1_s": PERIOD,
        "configs": [],
    }
    print(f"{args.members} members, one tooth period; design: 4 members, 4 coordinates")
    for name, n, d in configs:
        results["configs"].append(
            run_config(name, n, d, args.out, args.members, repeats, iterations)
        )
    one = results["configs"][0]
    for r in results["configs"]:
        r["speedup"] = (
            r["throughput"]["member_steps_per_s"] / one["throughput"]["member_steps_per_s"]
        )
        r["design"]["iteration_speedup"] = one["design"]["iteration_s"] / r["design"]["iteration_s"]
    two = results["configs"][1]
    results["collective_ms_per_iteration"] = two["design"]["gather_ms_median"]
    results["collective_fraction_of_iteration"] = (
        1e-3 * two["design"]["gather_ms_median"] / two["design"]["iteration_s"]
    )
    results["load_note"] = "; ".join(
        f"{r['name']}: {r['uptime_before'].split('load average:')[-1].strip()} → "
        f"{r['uptime_after'].split('load average:')[-1].strip()}"
        for r in results["configs"]
    )
    results["machine"]["uptime_end"] = uptime()
    from benchmarks.common import loadavg

    results["machine"]["loadavg"] = loadavg()
    return finish(results, args.out, NAME, chart, t_start)


if __name__ == "__main__":
    main()
