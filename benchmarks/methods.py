"""Gradients against gradient-free methods at 4, 36 and 72 design coordinates: Adam and
L-BFGS on reverse-mode gradients, CMA-ES and Nelder-Mead, each from the middle of the box
with one budget of simulation-equivalents (a value + gradient charged its measured cost).

    python -m benchmarks.methods            # full study (45 min on 2 cores)
    python -m benchmarks.methods --quick    # smoke run (4 and 36 coordinates, small budget)
    python -m benchmarks.methods --dimensions 36g --seeds 1 --name methods_every_gap
    python -m benchmarks.methods --name NAME --probes-only | --extend-cma BUDGET |
        --perturbed-adam SIGMA              # amend OUT/NAME.json
    (also --dt, --samples: the objective's fixed step and soft-peak samples)

Writes ``benchmarks/results/methods.json`` and ``methods.png`` (best objective so far
against simulation-equivalents, per method, per dimension).

Notes: benchmarks/methods.md
"""

from __future__ import annotations

import datetime
import json
import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks import designs  # noqa: E402
from benchmarks.common import (  # noqa: E402
    figure,
    finish,
    machine_info,  # noqa: E402
    parse,
    parser,
)

LEARNING_RATE = designs.LEARNING_RATE
SIGMA0 = 1.0  # CMA-ES's initial step size in u
TARGET_FRACTION = 0.9  # the common target: this fraction of the largest decrease found
FAILED = 1e6  # the value a gradient-free method sees for a failed solve [N]
PROBE_STEPS = (1e-3, 1e-2, 0.1, 1.0)  # steps along the descent direction (largest |Δu|)
SAMPLES = 8  # the soft peak's samples per step (0: integrated by the solver's stages)
PERTURBED = "Adam, perturbed start"  # Adam from u0 + σ·N(0, 1) (--perturbed-adam)
GRADIENT_METHODS = ("Adam", "L-BFGS", PERTURBED)


def plan(quick: bool) -> dict:
    """Dimensions, budgets (simulation-equivalents per method run) and CMA-ES seeds."""
    if quick:
        return {"dimensions": ("4", "36"), "budget": {"4": 24, "36": 24}, "seeds": (1,),
                "repeats": 2}  # fmt: skip
    return {"dimensions": ("4", "36", "72"),
            "budget": {"4": 150, "36": 300, "72": 300, "36g": 150},
            "seeds": (1, 2, 3), "repeats": 5}  # fmt: skip


def objective_of(name: str, space, dt: float, samples: int, **kwargs):
    """The objective of a row: ``designs.objective``, or for "…g" rows
    ``designs.every_gap_objective``."""
    make = designs.every_gap_objective if name.endswith("g") else designs.objective
    return make(space, dt=dt, samples=samples, **kwargs)


def saved_steps(settings: dict) -> tuple[float, int]:
    """The step and soft-peak samples a result file's rows were run with (files written
    before ``samples`` was recorded integrated the soft peak: 0)."""
    return settings.get("dt", designs.DT), settings.get("samples", 0)


class _Budget(Exception):
    """The run's budget of simulation-equivalents is spent."""


class Tracker:
    """Evaluations of one method run: simulation-equivalents spent, values, the best, and
    the run's wall time from its start."""

    def __init__(self, budget: float):
        self.budget = budget
        self.sims = 0.0
        self.trace: list[tuple[float, float]] = []  # (simulation-equivalents, value)
        self.best, self.best_u, self.failed = math.inf, None, 0
        self.start = time.perf_counter()

    def room(self, cost: float) -> bool:
        return self.sims + cost <= self.budget + 1e-9

    def record(self, cost: float, value: float, u) -> float:
        self.sims += cost
        if not math.isfinite(value):
            self.failed += 1
            value = FAILED
        self.trace.append((self.sims, value))
        if value < self.best:
            self.best, self.best_u = value, np.asarray(u, dtype=float).copy()
        return value

    def value_fn(self, obj):
        """f(u) for a gradient-free method: one simulation each; ``_Budget`` when spent."""

        def f(u):
            if not self.room(1.0):
                raise _Budget
            value = float(obj.value(jnp.asarray(u, dtype=float))[0])
            return self.record(1.0, value, u)

        return f

    @staticmethod
    def spend(run) -> str | None:
        """``run()``'s stop message, or None where it raised ``_Budget``."""
        try:
            return run()
        except _Budget:
            return None

    def result(self, method: str, seed: int | None, **extra) -> dict:
        wall = time.perf_counter() - self.start
        sims = np.array([s for s, _ in self.trace])
        values = np.array([v for _, v in self.trace])
        best_so_far = np.minimum.accumulate(values)
        improved = np.r_[True, best_so_far[1:] < best_so_far[:-1]]
        at = int(np.argmin(values))
        return {
            "method": method,
            "seed": seed,
            "evaluations": len(values),
            "simulation_equivalents": float(self.sims),
            "best_N": float(values[at]),
            "best_at_sims": float(sims[at]),
            "failed_solves": self.failed,
            "wall_s": wall,
            "seconds_per_evaluation": wall / max(len(values), 1),
            # the best-so-far curve at its improvements (and at the end)
            "curve": [
                [float(s), float(b)]
                for s, b in zip(sims[improved], best_so_far[improved], strict=True)
            ]
            + [[float(sims[-1]), float(best_so_far[-1])]],
            "best_u": self.best_u.tolist(),
            **extra,
        }


def said(run: dict, where: str = "") -> dict:
    """``run``, its best printed."""
    seed = "" if run["seed"] is None else f" seed {run['seed']}"
    stop = f" ({run['stop']})" if "stop" in run else ""
    print(
        f"  {where}{run['method']}{seed}: best {run['best_N']:.2f} N at "
        f"{run['best_at_sims']:.0f} sims{stop}",
        flush=True,
    )
    return run


def adam(obj, u0, ratio: float, budget: float, method: str = "Adam") -> tuple[dict, np.ndarray]:
    """Adam's run and the gradient at its start."""
    import optax

    tr = Tracker(budget)
    opt = optax.adam(LEARNING_RATE)
    u = jnp.asarray(u0)
    state = opt.init(u)
    grad0 = None
    while tr.room(ratio):
        value, grad, _ = obj.value_and_grad(u)
        tr.record(ratio, float(value), u)
        if not bool(jnp.all(jnp.isfinite(grad))):
            break
        grad0 = np.asarray(grad) if grad0 is None else grad0
        updates, state = opt.update(grad, state)
        u = optax.apply_updates(u, updates)
    return tr.result(method, None, learning_rate=LEARNING_RATE), grad0


def lbfgs(obj, u0, ratio: float, budget: float) -> dict:
    from scipy.optimize import minimize

    tr = Tracker(budget)

    def f(u):
        if not tr.room(ratio):
            raise _Budget
        value, grad, _ = obj.value_and_grad(jnp.asarray(u))
        grad = np.asarray(grad, dtype=float)
        if not np.all(np.isfinite(grad)):
            tr.record(ratio, math.nan, u)
            raise _Budget  # a failed solve ends the run, as for Adam
        return tr.record(ratio, float(value), u), grad

    def run():
        options = {"maxfun": 10**9, "maxiter": 10**9, "ftol": 1e-12, "gtol": 1e-8}
        res = minimize(f, np.asarray(u0), jac=True, method="L-BFGS-B", options=options)
        return str(res.message)

    stop = tr.spend(run) or ("failed solve" if tr.failed else "budget")
    return tr.result("L-BFGS", None, stop=stop)


def cma_es(obj, u0, budget: float, seed: int) -> dict:
    import cma

    tr = Tracker(budget)
    f = tr.value_fn(obj)
    es = cma.CMAEvolutionStrategy(np.asarray(u0), SIGMA0, {"seed": seed, "verbose": -9})

    def run():
        while not es.stop():
            xs = es.ask()
            es.tell(xs, [f(x) for x in xs])
        return ", ".join(f"{k}" for k in es.stop())

    stop = tr.spend(run) or "budget"
    return tr.result("CMA-ES", seed, sigma0=SIGMA0, popsize=es.popsize, stop=stop)


def nelder_mead(obj, u0, budget: float) -> dict:
    from scipy.optimize import minimize

    tr = Tracker(budget)
    f = tr.value_fn(obj)
    u0 = np.asarray(u0)
    n = u0.shape[0]
    simplex = u0 + np.vstack([np.zeros(n), np.eye(n)])
    options = {"initial_simplex": simplex, "adaptive": True, "maxfev": 10**9,
               "xatol": 1e-9, "fatol": 1e-9}  # fmt: skip
    stop = tr.spend(lambda: str(minimize(f, u0, method="Nelder-Mead", options=options).message))
    return tr.result("Nelder-Mead", None, stop=stop or "budget")


def probe(obj, u, fine) -> dict:
    """How far the gradient at ``u`` predicts the objective: the value along the steepest
    descent direction d = −g/max|g| (steps of at most ``h`` in every coordinate) against
    the first-order prediction, ``PROBE_STEPS``; and the same points on ``fine`` (the
    objective at half the step), which tells the roughness of the discrete map from the
    model's."""
    value, grad, _ = obj.value_and_grad(jnp.asarray(u))
    g, value = np.asarray(grad), float(value)
    d = -g / np.abs(g).max()
    slope = float(g @ d)
    steps = []
    for h in PROBE_STEPS:
        fh = float(obj.value(jnp.asarray(u + h * d))[0])
        steps.append({"h": h, "value_N": fh, "secant_slope": (fh - value) / h})
    half = [float(fine.value(jnp.asarray(u + h * d))[0]) for h in (0.0, *PROBE_STEPS)]
    return {"value_N": value, "grad_norm": float(np.linalg.norm(g)), "slope": slope,
            "steps": steps, "half_step_values_N": half}  # fmt: skip


def add_probes(row: dict, space, dt: float, samples: int) -> None:
    """The gradient's reach at the start and at Adam's best (into ``row``)."""
    obj = objective_of(row["space"], space, dt, samples, throw=False)
    fine = objective_of(row["space"], space, dt / 2, samples, throw=False)
    adam_u = np.asarray(next(r for r in row["runs"] if r["method"] == "Adam")["best_u"])
    row["probe"] = {
        "start": probe(obj, np.zeros(row["dimension"]), fine),
        "adam_best": probe(obj, adam_u, fine),
    }


def sims_to_reach(curve: list, target: float) -> float | None:
    """Simulation-equivalents at which a best-so-far curve first reaches ``target``."""
    return next((s for s, b in curve if b <= target), None)


def analyse(row: dict) -> None:
    """Targets, simulations to reach them and the speed-up over CMA-ES (into ``row``)."""
    runs, f0 = row["runs"], row["start_N"]
    best = min(r["best_N"] for r in runs)
    target = f0 - TARGET_FRACTION * (f0 - best)
    row["target_N"] = target
    for r in runs:
        r["sims_to_target"] = sims_to_reach(r["curve"], target)
    cma_runs = [r for r in runs if r["method"] == "CMA-ES"]
    row["speedup_over_cma"] = {}
    for grad_run in (r for r in runs if r["method"] in GRADIENT_METHODS):
        m = grad_run["method"]
        speedups = []
        for r in cma_runs:
            need = sims_to_reach(grad_run["curve"], r["best_N"])
            r.setdefault("sims_to_this_best", {})[m] = need
            speedups.append(None if need is None else r["best_at_sims"] / need)
        reached = [s for s in speedups if s is not None]
        every = len(reached) == len(speedups)
        row["speedup_over_cma"][m] = {
            "per_seed": speedups,
            "median": float(np.median(reached)) if every else None,
            "min": min(reached) if every else None,
            "seeds_reached": len(reached),
        }


def study(name: str, spaces: dict, p: dict, dt: float, samples: int) -> dict:
    """Row ``name`` of the plan ``p``: every method's runs on its objective, analysed."""
    space, budget = designs.space_of(name, spaces), p["budget"][name]
    cost = designs.cost_of(space, p["repeats"], obj=objective_of(name, space, dt, samples))
    ratio = cost["ratio"]
    print(f"{name}: value+gradient / value = {ratio:.2f}", flush=True)
    obj = objective_of(name, space, dt, samples, throw=False)
    u0 = jnp.zeros(space.size)
    start, members = obj.value(u0)
    start = float(start)
    run, grad0 = adam(obj, u0, ratio, budget)
    runs = [said(run), said(lbfgs(obj, u0, ratio, budget))]
    runs += [said(cma_es(obj, u0, budget, seed)) for seed in p["seeds"]]
    runs.append(said(nelder_mead(obj, u0, budget)))
    g = np.abs(grad0)
    free = [r["seconds_per_evaluation"] for r in runs if r["method"] not in GRADIENT_METHODS]
    row = {
        "space": name,
        "dimension": space.size,
        "names": list(space.names),
        "budget": budget,
        "ratio": ratio,
        "cost": cost,
        # seconds per Adam step over seconds per gradient-free evaluation, statics included
        "wall_ratio": runs[0]["seconds_per_evaluation"] / float(np.median(free)),
        "start_N": start,
        # the members at the start (every-gap rows: one uniform tooth turned, all equal)
        "start_members_N": np.asarray(members.value, dtype=float).tolist(),
        "live_coordinates": int(np.sum(g > 1e-6 * g.max())),
        "runs": runs,
    }
    analyse(row)
    add_probes(row, space, dt, samples)
    return row


def chart(results: dict, path) -> None:
    import matplotlib.pyplot as plt

    rows = results["rows"]
    fig, axes = figure(1, len(rows), figsize=(5 * len(rows), 4), squeeze=False)
    colors = {"Adam": "tab:red", "L-BFGS": "tab:purple", "CMA-ES": "tab:blue",
              "Nelder-Mead": "tab:green", PERTURBED: "tab:orange"}  # fmt: skip
    for ax, row in zip(axes[0], rows, strict=True):
        labelled = set()
        for r in row["runs"]:
            s, b = np.array(r["curve"]).T
            m = r["method"]
            label = None
            if m not in labelled:
                label = m
                if m in GRADIENT_METHODS:
                    label = f"{m} (value+grad = {row['ratio']:.1f} sims)"
                labelled.add(m)
            ax.step(np.r_[0.5, s], np.r_[row["start_N"], b], where="post", color=colors[m],
                    lw=2.0 if m in GRADIENT_METHODS else 1.2,
                    alpha=1.0 if m != "CMA-ES" else 0.7, label=label)  # fmt: skip
        ax.axhline(row["target_N"], color="0.4", ls=":", lw=0.8, label="target (90 %)")
        ax.set_xscale("log")
        ax.set_xlim(0.8, max(row["budget"], row.get("cma_budget", 0)) * 1.1)
        lo = min(r["best_N"] for r in row["runs"])
        ax.set_ylim(lo - 0.05 * (row["start_N"] - lo), row["start_N"] + 0.1 * (row["start_N"] - lo))
        ax.set_xlabel("simulation-equivalents")
        ax.set_ylabel("best soft peak force so far [N]")
        every = ", every gap" if row["space"].endswith("g") else ""
        ax.set_title(f"{row['dimension']} coordinates ({row['live_coordinates']} live{every})")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    dt, samples = saved_steps(results["settings"])
    how = f"window sampled {samples}× per step" if samples else "window integrated by the stages"
    fig.suptitle(
        f"Gradients against gradient-free methods (08B engagement, z = 18, fixed "
        f"{dt * 1e6:g} µs steps, {how})"
    )
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def amend(args, start: float) -> dict:
    """``--probes-only``, ``--extend-cma`` or ``--perturbed-adam`` (the first given) on the
    rows of OUT/NAME.json: re-measure the probes; re-run each row's CMA-ES seeds with the
    budget given, replacing their runs; or add an Adam run from the start moved by
    σ·N(0, 1) (seed 0: on the every-gap objective the turned members make the gradient at
    the uniform start equal for gaps k, k + 3, …, and Adam from there keeps that symmetry;
    from a perturbed start it searches every direction). Re-analyses; rewrites the file
    and its chart with the amending command."""
    path = args.out / f"{args.name}.json"
    results = json.loads(path.read_text())
    spaces, steps = designs.spaces(), saved_steps(results["settings"])
    for row in results["rows"]:
        space = designs.space_of(row["space"], spaces)
        if args.probes_only:
            add_probes(row, space, *steps)
            continue
        obj = objective_of(row["space"], space, *steps, throw=False)
        where = f"{row['space']}: "
        if args.extend_cma is not None:
            for i, r in enumerate(row["runs"]):
                if r["method"] == "CMA-ES":
                    run = cma_es(obj, jnp.zeros(space.size), args.extend_cma, r["seed"])
                    row["runs"][i] = said(run, where)
            row["cma_budget"] = args.extend_cma
        else:
            sigma, seed = args.perturbed_adam, 0
            u0 = sigma * np.random.default_rng(seed).normal(size=space.size)
            run, _ = adam(obj, jnp.asarray(u0), row["ratio"], row["budget"], method=PERTURBED)
            run.update(start_noise=sigma, noise_seed=seed, start_value_N=run["curve"][0][1])
            row["runs"] = [r for r in row["runs"] if r["method"] != PERTURBED] + [said(run, where)]
        analyse(row)
    if args.probes_only:
        results["probes_command"] = "python -m benchmarks.methods --probes-only"
        results["probes_date"] = datetime.date.today().isoformat()
        results["probes_s"] = time.perf_counter() - start
    else:
        key = "extend_cma" if args.extend_cma is not None else "perturbed_adam"
        flag = f"--{key.replace('_', '-')} {getattr(args, key):g}"
        results[key] = {
            "command": f"python -m benchmarks.methods --name {args.name} {flag}",
            "date": datetime.date.today().isoformat(),
            "seconds": time.perf_counter() - start,
        }
    path.write_text(json.dumps(results, indent=1))
    chart(results, args.out / f"{args.name}.png")
    return results


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument(
        "--probes-only", action="store_true",
        help="only (re)measure the gradient probes of the rows in OUT/NAME.json",
    )  # fmt: skip
    for flag, metavar, what in (
        ("--extend-cma", "BUDGET", "re-run the CMA-ES seeds of OUT/NAME.json with this budget"),
        ("--perturbed-adam", "SIGMA", "add to OUT/NAME.json an Adam run from u = SIGMA·N(0, 1)"),
    ):
        ap.add_argument(flag, type=float, default=None, metavar=metavar, help=what)
    ap.add_argument(
        "--dt",
        type=float,
        default=designs.DT,
        help="fixed step of the objective's solves [s] (default %(default)s)",
    )
    ap.add_argument(
        "--samples",
        type=int,
        default=SAMPLES,
        help="the soft peak's samples per step, 0: integrated by the solver's stages "
        "(default %(default)s)",
    )
    ap.add_argument(
        "--dimensions",
        default=None,
        help="comma-separated rows of 4,36,72,36g (default: 4,36,72; 36g: the 36-coordinate "
        "space on the every-gap objective)",
    )
    ap.add_argument(
        "--seeds", type=int, default=None, help="CMA-ES seeds 1..SEEDS (default: the plan's)"
    )
    ap.add_argument("--name", default="methods", help="results' file name (default %(default)s)")
    args = parse(ap, argv)
    start = time.perf_counter()
    if args.probes_only or args.extend_cma is not None or args.perturbed_adam is not None:
        return amend(args, start)
    p = plan(args.quick)
    if args.dimensions:
        p["dimensions"] = tuple(d for d in args.dimensions.split(",") if d in p["budget"])
        if not p["dimensions"]:
            raise SystemExit(f"--dimensions: choose from {','.join(p['budget'])}")
    if args.seeds is not None:
        p["seeds"] = tuple(range(1, args.seeds + 1))
    spaces = designs.spaces()
    rows = [study(name, spaces, p, args.dt, args.samples) for name in p["dimensions"]]
    results = {
        "study": "methods",
        "command": "python -m benchmarks.methods"
        + "".join(
            f" {flag}"
            for flag, on in (
                ("--quick", args.quick),
                (f"--dt {args.dt:g}", args.dt != designs.DT),
                (f"--samples {args.samples}", args.samples != SAMPLES),
                (f"--dimensions {args.dimensions}", args.dimensions),
                (f"--seeds {args.seeds}", args.seeds is not None),
                (f"--name {args.name}", args.name != "methods"),
            )
            if on
        ),
        "date": datetime.date.today().isoformat(),
        "machine": machine_info(),
        "settings": {
            "dt": args.dt,
            "samples": args.samples,
            "learning_rate": LEARNING_RATE,
            "sigma0": SIGMA0,
            "target_fraction": TARGET_FRACTION,
            **p,
        },  # fmt: skip
        "rows": rows,
    }
    return finish(results, args.out, args.name, chart, start)


if __name__ == "__main__":
    main()
