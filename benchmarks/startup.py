"""Time to first result: a first process against a second one that finds the first's
persistent compilation cache, and which programs the cache refused.

    python -m benchmarks.startup            # two processes, equinox in its default mode,
                                            # with jaxchain's program store and without
    python -m benchmarks.startup --quick    # the same, the design objective left out

Writes ``benchmarks/results/startup.json`` and ``startup.png``.

Each process (a fresh interpreter, the cache in a new temporary folder shared by both)
times, in order: importing jaxchain; building the 08B z = 18 engagement strand from its
static equilibrium; its first ``simulate`` of one tooth period (trace, compile or cache
load, run) and a second one (run only); the ISO-box design objective's value and gradient
(fixed 4 µs steps). JAX logs every program it compiles and whether the persistent cache
took it; the study counts the programs refused ("uses host callbacks"). equinox runs in
its default mode (``EQX_ON_ERROR`` unset), as in a user's notebook. The pair runs twice,
each in a cache of its own: with jaxchain's store of traced programs beside the cache
(the default) and without it (``JAXCHAIN_PROGRAM_STORE=0``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time

from benchmarks.common import finish, header, parse, parser, save_chart

STORE = "JAXCHAIN_PROGRAM_STORE"  # jaxchain's traced programs beside the cache: 0 = off
PHASES = ("import", "build + statics", "first simulate", "second simulate", "objective")

CHILD = r"""
import json, logging, sys, time
t0 = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", sys.argv[1])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
refused = []
class Refused(logging.Handler):
    def emit(self, record):
        msg = record.getMessage()
        if msg.startswith("Not writing persistent cache entry"):
            refused.append(msg.split("'")[1])
logging.getLogger("jax._src.compiler").addHandler(Refused())
logging.getLogger("jax._src.compiler").setLevel(logging.DEBUG)
import jaxchain as jc
times = {"import": time.perf_counter() - t0}
def phase(name, fn):
    t = time.perf_counter(); out = fn(); times[name] = time.perf_counter() - t; return out
period = 60.0 / (18 * 1000.0)
scene = phase("build + statics", lambda: jc.scenes.engagement("08B", 18, n_entry=3))
peak = lambda: float(jc.simulate(scene, period).peak_contact_force)
phase("first simulate", peak)
phase("second simulate", peak)
if sys.argv[2] == "1":
    space = jc.design.DesignSpace.iso606("08B", 18)
    build = lambda p: jc.scenes.engagement("08B", 18, profile=p, n_entry=3)
    obj = jc.design.ProfileObjective(space, build, t1=2 * period, dt=4e-6)
    phase("objective", lambda: float(obj.value_and_grad(jax.numpy.zeros(4))[0]))
print(json.dumps({"times_s": times, "refused": refused}))
"""


def run(cache: str, objective: bool, store: bool = True) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("EQX_ON_ERROR", STORE)}
    if not store:
        env[STORE] = "0"
    t = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", CHILD, cache, "1" if objective else "0"],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    row = json.loads(out.stdout.strip().splitlines()[-1])
    row["wall_s"] = time.perf_counter() - t
    row["total_s"] = sum(row["times_s"].values())
    return row


def chart(results: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.2))
    for i, row in enumerate(results["processes"].values()):
        left = 0.0
        for k, name in enumerate(p for p in PHASES if p in row["times_s"]):
            w = row["times_s"][name]
            ax.barh(i, w, left=left, color=f"C{k}", label=name if i == 0 else None)
            left += w
        ax.text(left, i, f" {left:.1f} s", va="center")
    ax.set_yticks(range(len(results["processes"])), list(results["processes"]))
    most = max(r["total_s"] for r in results["processes"].values())
    ax.set_xlim(0, 1.15 * most)
    ax.set_ylim(-0.6, len(results["processes"]) + 0.6)  # room for the legend above
    ax.set_xlabel("time to each result [s]")
    ax.set_title("first process against a second with the first's caches")
    ax.legend(fontsize=7, loc="upper center", ncols=len(PHASES), frameon=False)
    save_chart(fig, results, path)


def main(argv=None) -> dict:
    ap = parser(__doc__, quick_help="the design objective left out")
    args = parse(ap, argv)
    start = time.perf_counter()
    res = header("startup", argv)
    processes = {}
    for store, label in ((True, ""), (False, ", no program store")):
        with tempfile.TemporaryDirectory() as cache:
            processes[f"first process{label}"] = run(cache, not args.quick, store)
            processes[f"second process{label}"] = run(cache, not args.quick, store)
    res["processes"] = processes
    total = {k: v["total_s"] for k, v in processes.items()}
    res["second_over_first"] = total["second process"] / total["first process"]
    res["second_over_first_no_store"] = (
        total["second process, no program store"] / total["first process, no program store"]
    )
    refused = sorted({r for v in processes.values() for r in v["refused"]})
    print(
        f"first {total['first process']:.1f} s, second {total['second process']:.1f} s "
        f"({100 * res['second_over_first']:.0f} %); without the program store "
        f"{total['first process, no program store']:.1f} s and "
        f"{total['second process, no program store']:.1f} s "
        f"({100 * res['second_over_first_no_store']:.0f} %); refused by the cache: {refused}"
    )
    return finish(res, args.out, "startup", chart, start)


if __name__ == "__main__":
    main()
