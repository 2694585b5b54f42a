"""The optimization run: optax loop with checkpoint/resume, gradient-free baseline,
independent re-measurement, results folder (JSON + figures)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import optax

import jaxchain as jc

from .clearance import (
    lines as clearance_lines,
    points_for as clearance_points,
    remeasure as clearance_remeasure,
)
from .problem import Problem, Settings, iso_forms, make_problem, profile_values, remeasure_many

CHECKPOINT = "checkpoint.json"
FORMS = ("min", "max", "mid")  # the ISO 606 tooth-gap forms every run is compared with
RESULTS = "results.json"
PROFILE = "profile.json"  # the delivered design, read back by jc.load_profile
CUSHION = "cushion.json"  # its cushion ring (problem "ring"), jc.elements.CushionRing.load


# ---------------------------------------------------------------------- files
def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so a reader (or a resume after a kill) sees either the
    old file or the new one, never half of one."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)  # mkstemp makes it private
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_figure(fig, path: Path) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=120, bbox_inches="tight")
    os.chmod(tmp, 0o644)
    os.replace(tmp, path)


def jsonable(x):
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items() if not isinstance(v, np.ndarray)}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def write_design(out: Path, design) -> dict:
    """The delivered design's files in ``out``: ``profile.json`` (the tooth profile, for
    ``jc.load_profile``), ``sprocket.dxf`` (its outline as DXF arcs in millimetres) and,
    for a :class:`~jaxchain.design.SprocketDesign` with a ring, ``cushion.json``
    (``jc.elements.CushionRing.load``). Returns the files' names by part."""
    profile = jc.design.profile_of(design)
    profile.save(out / PROFILE)
    profile.to_dxf(out / "sprocket.dxf")
    files = {"profile": PROFILE}
    cushion = getattr(design, "cushion", None)
    if cushion is not None:
        cushion.save(out / CUSHION)
        files["cushion"] = CUSHION
    return files


def delivered_profile(results: dict):
    """The tooth profile delivered by a run, from its ``results.json`` (read as a dict):
    :func:`delivered_design`'s tooth."""
    return jc.design.profile_of(delivered_design(results))


def delivered_design(results: dict):
    """The design delivered by a run, from its ``results.json`` (read as a dict): the
    design space of its settings at its coordinates ``optimized.u`` (a tooth profile, or
    a :class:`~jaxchain.design.SprocketDesign` for the ``ring`` problem). Raises
    ``ValueError`` if its parameters are not those the results record (the design space
    has changed since the run)."""
    known = {f.name for f in dataclasses.fields(Settings)}
    given = {k: v for k, v in results["settings"].items() if k in known}
    given["ensemble"], given["wear"] = tuple(given["ensemble"]), tuple(given["wear"])
    problem = make_problem(Settings(**given))
    design = problem.space.design(jnp.asarray(results["optimized"]["u"], dtype=float))
    if profile_values(design, problem.space) != results["optimized"]["params"]:
        raise ValueError(
            "the results' coordinates give other parameters in this version's design space "
            "than the run recorded; the design cannot be rebuilt from them"
        )
    return design


def write_profile_from_results(folder: str | Path) -> Path:
    """Write ``folder``/profile.json from ``folder``/results.json (a run made before the
    job wrote it); returns its path. Needs float64 (``jax_enable_x64``)."""
    folder = Path(folder)
    results = json.loads((folder / RESULTS).read_text())
    return delivered_profile(results).save(folder / PROFILE)


def versions() -> dict:
    import diffrax
    import equinox

    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "jax": jax.__version__,
        "jax_backend": jax.default_backend(),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),  # compiler settings change rounding
        "diffrax": diffrax.__version__,
        "equinox": equinox.__version__,
        "optax": optax.__version__,
        "jaxchain": getattr(jc, "__version__", "0.1.0"),
    }


class RunFailed(RuntimeError):
    """The run cannot go on (a failed simulation, a non-finite objective); the message says
    what to change."""


# ---------------------------------------------------------------------- checkpoint
def _state_to_json(state) -> list:
    return [np.asarray(leaf).tolist() for leaf in jax.tree_util.tree_leaves(state)]


def _state_from_json(template, leaves):
    flat, treedef = jax.tree_util.tree_flatten(template)
    shapes = [np.shape(t) for t in flat]
    if len(flat) != len(leaves) or [np.shape(v) for v in leaves] != shapes:
        raise ValueError(
            f"--resume: the checkpoint's optimizer state does not match this optimizer's "
            f"({len(leaves)} arrays vs {len(flat)}); delete {CHECKPOINT} to start afresh"
        )
    return jax.tree_util.tree_unflatten(
        treedef,
        [jnp.asarray(v, dtype=jnp.asarray(t).dtype) for v, t in zip(leaves, flat, strict=True)],
    )


_CHECKPOINT_KEYS = ("settings", "u", "opt_state", "history", "baselines", "evaluations", "timing")


def load_checkpoint(out: Path, settings: Settings, size: int) -> dict | None:
    """The checkpoint in ``out`` (None if there is none); ``ValueError`` naming the file
    when it is damaged (``u`` must have the design space's ``size``), foreign, or from
    other settings."""
    path = out / CHECKPOINT
    if not path.exists():
        return None
    fix = f"delete {path} (or use another --out) to start afresh"
    try:
        ck = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"--resume: {path} is not a readable checkpoint ({e}); {fix}") from None
    missing = [k for k in _CHECKPOINT_KEYS if not isinstance(ck, dict) or k not in ck]
    if missing or not isinstance(ck["settings"], dict):
        raise ValueError(
            f"--resume: {path} is not a checkpoint of python -m optimize (missing "
            f"{missing or ['settings']}); {fix}"
        )
    try:
        u = np.asarray(ck["u"], dtype=float)
        leaves = [np.asarray(v, dtype=float) for v in ck["opt_state"]]
    except (TypeError, ValueError):
        raise ValueError(
            f"--resume: {path} holds non-numeric values in u or opt_state; {fix}"
        ) from None
    finite = np.all(np.isfinite(u)) and all(np.all(np.isfinite(v)) for v in leaves)
    if u.shape != (size,) or not finite or not isinstance(ck["history"], list):
        raise ValueError(
            f"--resume: {path} is damaged (u of shape {u.shape}, finite: {bool(finite)}); {fix}"
        )
    mine, theirs = settings.as_dict(), dict(ck["settings"])
    mine.pop("iterations"), theirs.pop("iterations")  # a resume may extend the run
    diff = {k: (theirs.get(k), v) for k, v in mine.items() if theirs.get(k) != v}
    if diff:
        raise ValueError(
            f"--resume: the checkpoint in {out} was made with other settings "
            f"{ {k: f'{a} (checkpoint) vs {b}' for k, (a, b) in diff.items()} }; "
            "use the same options or another --out"
        )
    return ck


# ---------------------------------------------------------------------- progress
class Progress:
    """tqdm bar on a terminal; plain lines otherwise (logs, notebooks' captured output)."""

    def __init__(self, total: int, start: int, quiet: bool):
        self.quiet = quiet
        self.bar = None
        if not quiet:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, initial=start, desc="optimize", unit="it")

    def update(self, k: int, value: float, gnorm: float, sims: int) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(f"peak~{value:.1f} N |grad| {gnorm:.3g} N sims {sims}")
            self.bar.update(1)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def log(msg: str, quiet: bool = False) -> None:
    if not quiet:
        print(msg, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------- the run
def run(settings: Settings, out: Path, *, resume: bool = False, quiet: bool = False) -> dict:
    """Optimize, re-measure, write ``out``/results.json and figures; returns the results.

    Under JAX's multi-process runtime every process runs this with the same settings (the
    objective's members shared among them, every process getting the same values): all
    read the checkpoint on ``resume``, process 0 alone writes checkpoints and results."""
    t_wall = time.perf_counter()
    lead = jax.process_index() == 0  # the one process that writes
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    problem = make_problem(settings)
    # before any simulation: a bad checkpoint is refused at once
    ck = load_checkpoint(out, settings, problem.space.size) if resume else None
    if resume and ck is None:
        log(f"--resume: no checkpoint in {out}; starting afresh", quiet)
    jc.distributed.gather(np.zeros(1))  # several processes: all have read before any writes
    forms = iso_forms(problem)
    timing = dict(ck["timing"]) if ck else {}

    # 1. baselines: the ISO forms, re-measured sharply (also fixes the objective's scale);
    # their Johnson-law solves are kept for step 5 (not across a resume: the checkpoint
    # holds their peaks, not their force traces)
    measured = {}
    if ck:
        base = ck["baselines"]
    else:
        log("re-measuring the ISO 606 baselines (min, max, mid forms) ...", quiet)
        t = time.perf_counter()
        base = {}
        ms = remeasure_many(problem, [(forms[form], "johnson") for form in FORMS])
        for form, m in zip(FORMS, ms, strict=True):
            base[form] = {"params": profile_values(forms[form]), "peak_N": m["peak_N"]}
            measured[form] = m
            log(f"  ISO {form} form: worst peak {m['peak_N']:.0f} N", quiet)
        timing["baselines_s"] = time.perf_counter() - t
    # the best ISO 606 form measured (the mid form complies with the standard too)
    better = min(FORMS, key=lambda f: base[f]["peak_N"])
    reference = max(base[f]["peak_N"] for f in ("min", "max", "mid"))
    objective = problem.make_objective(reference)

    # 2. the optax loop, from the problem's start (the ISO box: its middle, u = 0)
    opt = getattr(optax, settings.optimizer)(settings.learning_rate)
    if settings.clip > 0:  # a rebound appearing or vanishing spikes the gradient
        opt = optax.chain(optax.clip_by_global_norm(settings.clip), opt)
    u = start_coordinates(problem)
    state = opt.init(u)
    history: list[dict] = []
    start = 0
    if ck:
        u = jnp.asarray(ck["u"])
        state = _state_from_json(state, ck["opt_state"])
        history = ck["history"]
        start = len(history)
        objective.evaluations = ck["evaluations"]
        log(f"resuming after iteration {start} of {settings.iterations}", quiet)

    def checkpoint():
        if not lead:
            return
        write_atomic(
            out / CHECKPOINT,
            json.dumps(
                {
                    "settings": settings.as_dict(),
                    "u": np.asarray(u).tolist(),
                    "opt_state": _state_to_json(state),
                    "history": history,
                    "baselines": base,
                    "evaluations": objective.evaluations,
                    "timing": timing,
                }
            ),
        )

    if not ck:
        checkpoint()
    bar = Progress(settings.iterations, start, quiet)
    try:
        for k in range(start, settings.iterations):
            t = time.perf_counter()
            value, grad, members = objective.value_and_grad(u)
            dt = time.perf_counter() - t
            bad = failures(members)
            if not np.isfinite(float(value)) or not np.all(np.isfinite(np.asarray(grad))):
                raise RunFailed(
                    f"iteration {k}: non-finite objective or gradient at u={np.asarray(u)} "
                    f"(solver: {[m for m in bad if m] or 'successful'}); lower --dt or "
                    "--learning-rate"
                )
            if any(bad):
                raise RunFailed(f"iteration {k}: the simulation failed: {bad[0]}")
            gnorm = float(jnp.linalg.norm(grad))
            history.append(
                {
                    "iteration": k,
                    "objective_N": float(value),
                    "grad_norm_N": gnorm,
                    "u": np.asarray(u).tolist(),
                    "params": profile_values(problem.space.design(u), problem.space),
                    "fraction": np.asarray(problem.space.fraction(u)).tolist(),
                    "seconds": dt,
                    "simulations": objective.evaluations,
                }
            )
            updates, state = opt.update(grad, state, u)
            u = optax.apply_updates(u, updates)
            checkpoint()
            bar.update(k, float(value), gnorm, objective.evaluations)
    except KeyboardInterrupt:
        bar.close()
        log(
            f"interrupted: {len(history)} iterations are in {out / CHECKPOINT}; "
            "continue with the same command and --resume",
            quiet,
        )
        raise
    bar.close()
    adam_seconds = [h["seconds"] for h in history[start:]]  # this process's iterations
    timing["optimization_s"] = timing.get("optimization_s", 0.0) + sum(adam_seconds)
    best = min(history, key=lambda h: h["objective_N"])
    u_best = jnp.asarray(best["u"])

    # 3. gradient-free baseline: Nelder–Mead on the same objective (forward solves only);
    # the gradient's cost against a forward solve from both optimizers' calls
    nm = gradient_free(problem, best["objective_N"], settings.baseline_budget, quiet)
    timing.update(call_costs(adam_seconds, nm.get("call_seconds", [])))

    # 4. independent re-measurement: Dopri8, tight tolerance, sharp peak, two laws; both
    # optimizers' designs, and the better ISO form
    rt = settings.remeasure_rtol
    log(f"re-measuring: Dopri8 at rtol {rt:.0e}, sharp peak, Johnson and Hertz laws ...", quiet)
    t = time.perf_counter()
    candidates = {"gradient": (u_best, best["objective_N"])}  # coordinates, objective
    if not nm.get("skipped"):
        candidates["nelder_mead"] = (jnp.asarray(nm["best_u"]), nm["best_N"])
    checks = {}
    traces = {}
    designs = [(name, problem.space.design(u)) for name, (u, _) in candidates.items()]
    designs.append((f"iso_{better}", forms[better]))
    # every solve at once (independent: they share the cores), the better ISO form's
    # Johnson solves kept from step 1 where this run made them
    kept = {(f"iso_{better}", "johnson"): measured[better]} if better in measured else {}
    todo = [
        (name, prof, law)
        for name, prof in designs
        for law in ("johnson", "hertz")
        if (name, law) not in kept
    ]
    todo += [(f"iso_{other}", forms[other], "hertz") for other in FORMS if other != better]
    done = remeasure_many(problem, [(prof, law) for _, prof, law in todo])
    results_by = kept | {(name, law): m for (name, _, law), m in zip(todo, done, strict=True)}
    for name, _ in designs:
        for law in ("johnson", "hertz"):
            m = results_by[(name, law)]
            checks.setdefault(name, {})[law] = {
                "peak_N": m["peak_N"],
                "members": [jsonable(r) for r in m["members"]],
            }
            if law == "johnson":
                traces[name] = m["members"]
    for other in (f for f in FORMS if f != better):
        checks[f"iso_{other}"] = {
            "hertz": {"peak_N": results_by[(f"iso_{other}", "hertz")]["peak_N"]},
            "johnson": {"peak_N": base[other]["peak_N"]},
        }
    timing["remeasure_s"] = time.perf_counter() - t
    # the delivered design: the optimizers' better one, as re-measured (nominal law)
    method = min(candidates, key=lambda c: checks[c]["johnson"]["peak_N"])
    u_opt, objective_value = candidates[method]
    optimized = problem.space.design(u_opt)
    checks["optimized"] = checks[method]
    traces["optimized"] = traces[method]
    if not nm.get("skipped"):
        nm["remeasured"] = {
            law: checks["nelder_mead"][law]["peak_N"] for law in ("johnson", "hertz")
        }
    # force traces at the baseline's worst operating point, both designs
    worst = int(np.argmax([r["peak_N"] for r in traces[f"iso_{better}"]]))
    traces = {name: traces[name][worst] for name in ("optimized", f"iso_{better}")}
    spectra = {name: torque_spectrum(tr["ts"], tr["torque"]) for name, tr in traces.items()}

    # against the best ISO form under each law (which form is best may differ per law)
    def gains(name):
        return {
            law: 1
            - checks[name][law]["peak_N"] / min(checks[f"iso_{f}"][law]["peak_N"] for f in FORMS)
            for law in ("johnson", "hertz")
        }

    gain = gains("optimized")
    clearance = None
    if settings.clearance_engagements > 0:
        # 6. the source paper's model: per-engagement peak statistics, design vs baseline
        t = time.perf_counter()
        lumped = [r["peak_N"] for r in checks[f"iso_{better}"]["johnson"]["members"]]
        points = clearance_points(problem, settings.clearance_points, lumped)
        log(
            f"re-measuring in the clearance-joint chain: {settings.clearance_engagements} "
            f"engagements at {len(points)} operating point(s), the design and the ISO "
            f"{better} form ...",
            quiet,
        )
        designs = {"optimized": optimized, f"iso_{better}": forms[better]}
        clearance = clearance_remeasure(
            problem, designs, f"iso_{better}", points, settings.clearance_engagements
        )
        timing["clearance_s"] = time.perf_counter() - t
    soft_bias = objective_value / checks["optimized"]["johnson"]["peak_N"] - 1
    timing["total_s"] = timing.get("total_s", 0.0) + time.perf_counter() - t_wall
    results = {
        "summary": run_summary(checks, better, method, clearance),
        "settings": settings.as_dict(),
        "versions": versions(),
        "problem": settings.problem,
        "design_space": {
            "parameters": list(problem.space.names),
            "shapes": [list(sh) for sh in problem.space.shapes],
            "lower": np.asarray(problem.space.lower).tolist(),
            "upper": np.asarray(problem.space.upper).tolist(),
        },
        "window_s": [problem.t_start, problem.t1],
        "reference_N": reference,
        "temperature_N": settings.temperature * reference,
        "baselines": base,
        "better_baseline": f"iso_{better}",
        "optimized": {
            "method": method,
            "params": profile_values(optimized, problem.space),
            "fraction_of_box": np.asarray(problem.space.fraction(u_opt)).tolist(),
            "u": np.asarray(u_opt).tolist(),
            "iteration": best["iteration"] if method == "gradient" else None,
            "objective_N": objective_value,
        },
        "remeasured": checks,
        "reduction_vs_better_baseline": gain,
        "reduction_by_method": {name: gains(name) for name in candidates},
        "soft_peak_bias": soft_bias,
        "history": history,
        "spectra": {
            "signal": "the chain's torque on the driver [N·m], Hann-windowed over the window",
            "speed_factor": traces["optimized"]["speed_factor"],
            "wear": traces["optimized"]["wear"],
            "mesh_frequency_Hz": mesh_frequency(problem, traces["optimized"]["speed_factor"]),
        }
        | spectra,  # (their arrays are left out of the JSON: the figure shows them)
        "gradient_free": nm,
        "clearance": clearance,
        "timing": timing,
    }
    if lead:
        results["files"] = write_design(out, optimized)
        write_atomic(out / RESULTS, json.dumps(jsonable(results), indent=1))
        figures(problem, out, forms, optimized, better, history, nm, traces, spectra)
    log(summary(results), quiet)
    return results


METHODS = {
    "gradient": "gradient (optax, gradients by automatic differentiation through the solve)",
    "nelder_mead": "Nelder-Mead (scipy, forward solves only)",
}


def run_summary(
    checks: dict, best_iso: str, method: str = "gradient", clearance: dict | None = None
) -> dict:
    """The run's headline, one schema for every problem: the objective, its unit, the
    baseline (the best ISO 606 form under the nominal law), both values re-measured, the
    improvement (a fraction for N), the method whose design is delivered (the better
    re-measured of the gradient and gradient-free runs), and the worst-member table (each
    operating point under both laws, the optimized design beside the baseline); with a
    clearance-chain re-measurement, its per-member statistics (fidelity, engagements, the
    means with their confidence intervals, the difference's interval)."""
    opt, base = checks["optimized"], checks[f"iso_{best_iso}"]
    members = []
    for i, row in enumerate(opt["johnson"]["members"]):
        members.append(
            {
                "speed_factor": row["speed_factor"],
                "wear": row["wear"],
                "optimized_N": row["peak_N"],
                "baseline_N": base["johnson"]["members"][i]["peak_N"],
                "optimized_second_law_N": opt["hertz"]["members"][i]["peak_N"],
            }
        )
    return {
        "objective": "peak roller/tooth force (worst operating point)",
        "unit": "N",
        "baseline": f"ISO 606 {best_iso} form",
        "baseline_value": base["johnson"]["peak_N"],
        "optimized_value": opt["johnson"]["peak_N"],
        "improvement": 1 - opt["johnson"]["peak_N"] / base["johnson"]["peak_N"],
        "remeasured": True,
        "method": METHODS[method],
        "second_law": {
            "law": "Hertz (Lankarani-Nikravesh), one stiffness for every design",
            "baseline_value": min(checks[f"iso_{f}"]["hertz"]["peak_N"] for f in FORMS),
            "optimized_value": opt["hertz"]["peak_N"],
        },
        "members": members,
        "clearance": None if clearance is None else clearance_summary(clearance, best_iso),
    }


def clearance_summary(c: dict, best_iso: str) -> dict:
    """The clearance re-measurement's rows for the summary."""
    rows = []
    for m in c["members"]:
        opt, base = m["optimized"], m[f"iso_{best_iso}"]
        row = {"speed_factor": m["speed_factor"], "wear": m["wear"]}
        for key, r in (("optimized", opt), ("baseline", base)):
            row[f"{key}_engagements"] = r["n"]
            row[f"{key}_mean_N"] = r.get("mean_N")
            row[f"{key}_ci95_N"] = r.get("ci95_N")
        d = opt.get("difference")
        row["improvement"] = None if d is None else -d["relative"]
        row["difference_ci95_N"] = None if d is None else d["ci95_N"]
        row["resolved"] = None if d is None else d["excludes_zero"]
        rows.append(row)
    return {
        "fidelity": c["fidelity"],
        "statistic": "mean per-engagement peak roller/tooth force",
        "baseline": f"ISO 606 {best_iso} form",
        "members": rows,
    }


def start_coordinates(problem: Problem) -> jnp.ndarray:
    """Where the optimizer starts: the ISO box's middle (u = 0), or the coordinates of
    the problem's start design."""
    if problem.settings.problem == "iso":
        return jnp.zeros(problem.space.size)
    return problem.space.coordinates(problem.start, margin=0.02)


def _fmt(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else "[" + ", ".join(f"{x:.4g}" for x in v) + "]"


def failures(members) -> list[str]:
    """Messages of the ensemble members whose solve did not succeed ("" for those that did)."""
    return jc.result_messages(members.result)


def gradient_free(problem: Problem, target: float, budget: int, quiet: bool) -> dict:
    """Nelder–Mead (SciPy) on the same objective from the same start: simulations it needs
    to reach ``target`` (the gradient run's best), within ``budget`` simulations."""
    if budget <= 0:
        return {"method": "Nelder-Mead", "skipped": True}
    from scipy.optimize import minimize

    obj = problem.objective
    n0 = obj.evaluations
    best, trace, seconds = math.inf, [], []

    def f(u):
        nonlocal best
        t = time.perf_counter()
        value, members = obj.value(jnp.asarray(u))
        value = float(value)
        seconds.append(time.perf_counter() - t)
        if not np.isfinite(value) or any(failures(members)):
            value = 10 * problem.reference  # a failed solve is a bad point, not a crash
        best = min(best, value)
        trace.append(best)
        return value

    log(f"gradient-free baseline: Nelder–Mead, up to {budget} simulations ...", quiet)
    t = time.perf_counter()
    u0 = np.asarray(start_coordinates(problem))
    n = u0.shape[0]
    simplex = u0 + np.vstack([np.zeros(n), np.eye(n)])
    members = len(problem.operating_points)  # simulations per objective evaluation
    options = {"maxfev": max(1, budget // members), "initial_simplex": simplex}
    res = minimize(f, u0, method="Nelder-Mead", options=options)
    reached = next(((i + 1) * members for i, v in enumerate(trace) if v <= target), None)
    return {
        "method": "Nelder-Mead (scipy), simplex of unit steps in u",
        "budget": budget,
        "simulations": obj.evaluations - n0,
        "best_N": best,
        "best_u": np.asarray(res.x).tolist(),
        "target_N": target,
        "simulations_to_target": reached,
        "best_so_far_N": trace,
        "simulations_per_evaluation": members,
        "seconds": time.perf_counter() - t,
        "call_seconds": seconds,
    }


def call_costs(gradient_calls: list[float], forward_calls: list[float]) -> dict:
    """The cost of a gradient against a forward solve, from the run's own calls of the
    objective (``seconds`` of the optimizer's value-and-gradient calls, of the gradient-free
    baseline's value calls; each list of this process): the medians of the calls after
    each list's first (which compiles). None where a list has fewer than two calls."""

    def typical(seconds):
        return float(np.median(seconds[1:])) if len(seconds) > 1 else None

    grad, fwd = typical(gradient_calls), typical(forward_calls)
    ratio = grad / fwd if grad is not None and fwd is not None else None
    return {"forward_s": fwd, "value_and_grad_s": grad, "grad_over_forward": ratio}


def summary(r: dict) -> str:
    lines = [
        "",
        "ISO 606 baselines (sharp peak, re-measured): "
        + ", ".join(f"{f} form {r['baselines'][f]['peak_N']:.0f} N" for f in ("min", "max", "mid")),
        f"delivered design: {r['summary']['method']}"
        + (f", iteration {it}" if (it := r["optimized"]["iteration"]) is not None else "")
        + ": "
        + ", ".join(f"{k} {_fmt(v)}" for k, v in r["optimized"]["params"].items()),
    ]
    isos = [k for k in r["remeasured"] if k.startswith("iso_")]
    for law in ("johnson", "hertz"):
        # the best ISO form under this law (it may differ between the laws)
        best = min(isos, key=lambda k: r["remeasured"][k][law]["peak_N"])
        lines.append(
            f"  {law:8s} law: optimized {r['remeasured']['optimized'][law]['peak_N']:.0f} N vs "
            f"{best} {r['remeasured'][best][law]['peak_N']:.0f} N -> "
            f"{-100 * r['reduction_vs_better_baseline'][law]:+.1f} % against the best ISO form"
        )
    g = r["remeasured"]["gradient"]
    lines.append(
        f"gradient run: best re-measured {g['johnson']['peak_N']:.0f} N (Johnson), "
        f"{g['hertz']['peak_N']:.0f} N (Hertz)"
    )
    nm = r["gradient_free"]
    if not nm.get("skipped"):
        at = nm["simulations_to_target"]
        reach = f"reached after {at}" if at is not None else "not reached"
        lines.append(
            f"Nelder–Mead: best {nm['best_N']:.1f} N in {nm['simulations']} simulations; the"
            f" gradient run's {nm['target_N']:.1f} N {reach};"
            f" its best re-measured {nm['remeasured']['johnson']:.0f} N (Johnson),"
            f" {nm['remeasured']['hertz']:.0f} N (Hertz)"
        )
    if r.get("clearance"):
        names = {"optimized": "optimized", r["clearance"]["baseline"]: r["clearance"]["baseline"]}
        lines.extend(clearance_lines(r["clearance"], names))
    t = r["timing"]
    ratio = t.get("grad_over_forward")
    cost = "n/a" if ratio is None else f"{ratio:.2f}x"
    lines.append(f"gradient / forward cost {cost}; total wall {t['total_s']:.0f} s")
    return "\n".join(lines)


BANDS_HZ = ((0.0, 1e3), (1e3, 5e3), (5e3, 20e3))  # reported RMS bands of the spectra


def mesh_frequency(problem: Problem, speed_factor: float) -> float:
    """Teeth meshing per second on the designed sprocket at ``speed_factor`` [Hz]."""
    s = problem.settings
    return s.teeth * s.speed_rpm * speed_factor / 60


def torque_spectrum(ts, x, pad: int = 8, f_max: float = 20e3) -> dict:
    """Single-sided amplitude spectrum of ``x(ts)`` (uniform ``ts``) with the mean removed
    and a Hann window (amplitude-corrected, so a sine of amplitude A reads A): the
    frequencies up to ``f_max`` of the ``pad``-times zero-padded transform (a smooth
    curve; its resolution stays 1/window), the largest line, and the RMS in
    :data:`BANDS_HZ` (Parseval on the unpadded transform, Hann-corrected)."""
    ts, x = np.asarray(ts, float), np.asarray(x, float)
    n, dt = len(x), float(ts[1] - ts[0])
    w = np.hanning(n)
    y = (x - x.mean()) * w
    f = np.fft.rfftfreq(pad * n, dt)
    amp = 2 * np.abs(np.fft.rfft(y, pad * n)) / w.sum()
    keep = f <= f_max
    f1 = np.fft.rfftfreq(n, dt)
    power = np.abs(np.fft.rfft(y)) ** 2 * 2 / (n * (w**2).sum())  # per bin, mean square
    power[0] = 0.0
    rms = {
        f"{lo / 1e3:g}-{hi / 1e3:g} kHz": float(np.sqrt(power[(f1 >= lo) & (f1 < hi)].sum()))
        for lo, hi in BANDS_HZ
    }
    k = int(np.argmax(amp[keep]))
    return {
        "frequency_Hz": f[keep],
        "amplitude": amp[keep],
        "largest_line": {"frequency_Hz": float(f[k]), "amplitude": float(amp[k])},
        "band_rms": rms,
        "resolution_Hz": 1 / (n * dt),
    }


def figures(problem, out, forms, optimized, better, history, nm, traces, spectra) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    # profile before/after against the ISO 606 band
    fig, ax = plt.subplots(figsize=(6, 6))
    jc.plot_profiles(
        problem.chain,
        problem.settings.teeth,
        extra=({"ISO 606 mid form": forms["mid"]} if better == "mid" else {})
        | {"optimized": jc.design.profile_of(optimized)},
        ax=ax,
    )
    ax.set_title("Tooth gap: optimized against the ISO 606 band")
    save_figure(fig, out / "profile.png")
    plt.close(fig)

    # contact force histories
    fig, ax = plt.subplots(figsize=(8, 4))
    for name, color in [(f"iso_{better}", "tab:blue"), ("optimized", "tab:red")]:
        tr = traces[name]
        ax.plot(
            tr["ts"] * 1e3,
            tr["force"],
            color=color,
            lw=1,
            label=f"{name}: peak {tr['peak_N']:.0f} N",
        )
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("largest roller/tooth force [N]")
    tr = traces["optimized"]
    ax.set_title(
        f"Re-measured (Dopri8, tight tolerance) at the baseline's worst operating point\n"
        f"(speed ×{tr['speed_factor']:g}, wear {100 * tr['wear']:g} %)"
    )
    ax.legend()
    save_figure(fig, out / "forces.png")
    plt.close(fig)

    # spectra of the driver torque, both designs, mesh harmonics marked
    fig, ax = plt.subplots(figsize=(8, 4))
    for name, color in [(f"iso_{better}", "tab:blue"), ("optimized", "tab:red")]:
        sp = spectra[name]
        a = np.maximum(sp["amplitude"], 1e-9)
        ax.plot(sp["frequency_Hz"] / 1e3, 20 * np.log10(a), color=color, lw=1, label=name)
    fm = mesh_frequency(problem, tr["speed_factor"])
    for k in range(1, int(20e3 / fm) + 1):
        ax.axvline(fm * k / 1e3, color="0.85", lw=0.6, zorder=0)
    ax.set_xscale("log")
    ax.set_xlim(max(0.1, 0.5 * fm / 1e3), 20)
    ax.set_xlabel("frequency [kHz] (grey: mesh-frequency harmonics)")
    ax.set_ylabel("driver torque amplitude [dB re 1 N·m]")
    ax.set_title(
        f"Spectra of the driver torque in the window (Hann, resolution "
        f"{spectra['optimized']['resolution_Hz']:.0f} Hz)"
    )
    ax.legend()
    save_figure(fig, out / "spectra.png")
    plt.close(fig)

    # objective history
    fig, ax = plt.subplots(figsize=(7, 4))
    sims = [h["simulations"] for h in history]
    ax.plot(
        sims,
        [h["objective_N"] for h in history],
        "o-",
        color="tab:red",
        ms=3,
        label="gradient (optax), per value+gradient",
    )
    if not nm.get("skipped"):
        ax.plot(
            nm["simulations_per_evaluation"] * np.arange(1, len(nm["best_so_far_N"]) + 1),
            nm["best_so_far_N"],
            color="0.4",
            label="Nelder–Mead, best so far",
        )
    ax.set_xlabel("simulations")
    ax.set_ylabel("objective: smooth peak force [N]")
    ax.set_title("Objective history")
    ax.legend()
    save_figure(fig, out / "objective.png")
    plt.close(fig)
