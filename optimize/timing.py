"""``python -m optimize --problem timing``: a timing drive's crank sprocket made
non-circular, with its tensioner's spring and damper, to lower the worst tight-span
tension swing over an engine-speed band; gradients through the span-level chain over
many revolutions, the design re-measured on the lumped polygonal chain.

The drive is notebook 05's (06B; a 21-tooth crank sprocket; two 42-tooth camshaft
sprockets; the tensioner's shoe on the slack span) without its guide, each camshaft
loaded by :func:`jc.loads.camshaft_torque` at the engine speed (the exhaust lobes
:data:`EXHAUST_PHASE_DEG` of camshaft angle after the intake's). The tensioner's spring
and damper are a hydraulic tensioner's (:data:`TENSIONER`).

Design coordinates u (6,), u = 0 the circular crank with that tensioner:

* the crank's pitch-curve harmonics of orders 2 and 4 (cosine and sine parts,
  ``A·tanh(u)``, A = :data:`AMPLITUDE`), so the amplitude and phase are free and the
  circle is an interior point;
* the tensioner's spring rate and damping, × 10^tanh(u) of the baseline's.

Objective, worst over the band (a soft maximum over the speeds): the tight span's
tension peak-to-peak over the last :data:`WINDOW` of :data:`REVOLUTIONS` crank
revolutions (soft max − soft min), relative to the baseline's worst; penalties hold

* the cam timing error (each camshaft's angle minus half the crank's, in crank degrees,
  peak-to-peak) at or below :data:`TIMING_LIMIT_DEG`;
* the tight span's 4th and 6th engine orders at or below the baseline's (+ 5 N);
* the tensioner arm inside ±:data:`STROKE_RAD` of its laid-out angle.

Every speed's solve takes the same number of fixed steps over its own horizon
(``n_steps``): one compiled program for the band, vmapped over the speeds.

Adam (optax, reverse-mode gradients through the solves) runs against CMA-ES (the ``cma``
package) at the same budget of simulation-equivalents (a value and gradient counts as the
measured time ratio of a value and gradient to a value); the design with the lower objective
is delivered and re-measured on the lumped chain (settled starts, :data:`REMEASURE_SPEEDS`,
:data:`REMEASURE_SETTLE` + :data:`REMEASURE_REVOLUTIONS` revolutions, adaptive steps),
against the circular crank with the baseline tensioner.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import time
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxchain as jc

CHAIN = "06B"
TEETH = (21, 42, 42)
CENTRES = ((0.0, 0.0), (0.05, 0.18), (-0.09, 0.18))  # notebook 05's drive [m]
PRETENSION = 400.0  # N (the cams swing the spans by ±150 N each)
EXHAUST_PHASE_DEG = 110.0  # camshaft degrees between the intake's and the exhaust's lobes
#: a hydraulic tensioner on notebook 05's shoe: spring [N·m/rad], damper [N·m·s/rad]
TENSIONER = dict(span=0, shoe_radius=0.12, deflection=0.015, stiffness=60.0, damping=4.0)
SPEEDS = (1000.0, 2000.0, 3000.0, 4000.0, 5000.0, 6000.0)  # engine (crank) rpm
REVOLUTIONS = 6  # crank revolutions per solve
WINDOW = 3  # the last revolutions analysed
SAVES = 120  # per revolution in the window
STEPS = 6000  # fixed steps per solve (every speed)
AMPLITUDE = (0.2e-3, 0.02e-3)  # m, orders 2 and 4: A·tanh(u)
TIMING_LIMIT_DEG = 1.5
STROKE_RAD = 0.05
ORDER_SLACK_N = 5.0
REMEASURE_SPEEDS = (1000.0, 2250.0, 3500.0, 4750.0, 6000.0)
REMEASURE_SETTLE, REMEASURE_REVOLUTIONS = 2, 3
SOFT_N = 1.0  # soft max/min temperature of a peak-to-peak [N]
SIGMA0 = 0.2  # CMA-ES initial step in u


@dataclasses.dataclass
class TimingSettings:
    speeds: tuple[float, ...] = SPEEDS
    revolutions: int = REVOLUTIONS
    window: int = WINDOW
    steps: int = STEPS
    iterations: int = 30
    learning_rate: float = 0.05
    cma_seed: int = 1
    remeasure_speeds: tuple[float, ...] = REMEASURE_SPEEDS
    remeasure_revolutions: int = REMEASURE_REVOLUTIONS

    def validate(self) -> None:
        if len(self.speeds) < 1 or min(self.speeds) <= 0:
            raise ValueError(f"speeds must be positive engine speeds [rpm], got {self.speeds}")
        if not 1 <= self.window < self.revolutions:
            raise ValueError(
                f"window must be in [1, revolutions - 1] (revolutions before it settle), got "
                f"window={self.window}, revolutions={self.revolutions}"
            )
        for name in ("steps", "iterations"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")


FAST = dict(speeds=(2000.0, 6000.0), revolutions=3, window=1, steps=1500, iterations=3,
            remeasure_speeds=(6000.0,), remeasure_revolutions=1)  # fmt: skip


@functools.cache
def iso_profiles():
    """The ISO 606 crank and camshaft sprockets (built once, concretely)."""
    chain = jc.ChainSpec.iso606(CHAIN)
    return jc.ToothProfile.iso606(chain, TEETH[0]), jc.ToothProfile.iso606(chain, TEETH[1])


def crank_profile(u):
    """The crank sprocket at coordinates ``u`` (its first four used; may be traced)."""
    base = iso_profiles()[0]
    a2, a4 = AMPLITUDE
    t = jnp.tanh(jnp.asarray(u[:4]))
    rows = ((2, a2 * t[0], math.pi / 2), (2, a2 * t[1], 0.0))
    rows += ((4, a4 * t[2], math.pi / 2), (4, a4 * t[3], 0.0))
    return jc.FreeformProfile.noncircular(base, rows)


def tensioner_rates(u):
    """(stiffness, damping) of the tensioner at coordinates ``u``."""
    t = jnp.tanh(jnp.asarray(u[4:6]))
    return TENSIONER["stiffness"] * 10.0 ** t[0], TENSIONER["damping"] * 10.0 ** t[1]


def cam_loads(rpm: float):
    return (
        jc.loads.camshaft_torque(engine_rpm=rpm),
        jc.loads.camshaft_torque(engine_rpm=rpm, phase_deg=EXHAUST_PHASE_DEG),
    )


def build(rpm: float, fidelity: str = "spans", u=None, **kw):
    """The timing drive at engine speed ``rpm`` (concrete ``u``: the design's crank and
    tensioner; None: the baseline)."""
    chain = jc.ChainSpec.iso606(CHAIN)
    u = np.zeros(6) if u is None else np.asarray(u, dtype=float)
    k, c = (float(x) for x in tensioner_rates(u))
    tensioner = jc.scenes.Tensioner(**(TENSIONER | dict(stiffness=k, damping=c)))
    iso42 = iso_profiles()[1]
    return jc.scenes.drive(
        chain, teeth=TEETH, centres=CENTRES, speed_rpm=rpm, load_torque=cam_loads(rpm),
        pretension=PRETENSION, tensioner=tensioner, fidelity=fidelity,
        profiles=(crank_profile(u), iso42, iso42), **kw,
    )  # fmt: skip


def _soft_range(x, width):
    return width * (jax.nn.logsumexp(x / width) + jax.nn.logsumexp(-x / width))


def _order(signal, angle, order):
    return 2 / signal.shape[0] * jnp.abs(jnp.sum(signal * jnp.exp(-1j * order * angle)))


def measures(sol, layout_angle):
    """Per solve: soft and exact tight-span peak-to-peak [N], its 2nd/4th/6th engine orders
    [N], each cam's timing error peak-to-peak [crank deg], the arm's largest excursion
    from its laid-out angle [rad] (the window's saves)."""
    tight = sol.span_tension[:, -1]  # the last span runs into the crank: the tight side
    angle = sol.sprocket_angle
    crank = angle[:, 0]
    error = jnp.degrees(2 * jnp.abs(angle[:, 1:]) - crank[:, None])  # crank degrees
    arm = sol.tensioner_angle[:, 0] - layout_angle
    return {
        "p2p_soft": _soft_range(tight, SOFT_N),
        "p2p": jnp.max(tight) - jnp.min(tight),
        "peak": jnp.max(tight),
        "mean": jnp.mean(tight),
        "orders": jnp.stack([_order(tight, crank, k) for k in (2, 4, 6)]),
        "timing": jnp.stack([jnp.max(e) - jnp.min(e) for e in error.T]),
        "timing_soft": jnp.stack([_soft_range(e, 0.01) for e in error.T]),
        "stroke": jnp.max(jnp.abs(arm)),
        "stroke_soft": 0.002 * jax.nn.logsumexp(jnp.concatenate([arm, -arm]) / 0.002),
    }


class TimingObjective:
    """The objective over the speed band on the span-level chain (module docstring):
    ``value(u)``, ``value_and_grad(u)`` (jitted once: the speeds are a vmapped axis, every
    solve ``steps`` fixed steps) and ``measure(u)`` (every speed's measures)."""

    def __init__(self, s: TimingSettings):
        self.s = s
        scenes = [build(rpm) for rpm in s.speeds]
        self.base = jc.scenes.stack(scenes)
        el = scenes[0].added[0]
        self.centres = jnp.stack([sp.centre for sp in scenes[0].sprockets])
        zero = jnp.zeros(len(TEETH))
        arm0 = scenes[0].tensioners.angle0
        tension0 = el.tensions(zero, zero, self.centres, arm0, jnp.zeros(1))[0]
        geo = el.geometry(zero, self.centres, arm0)
        self.ea = float((el.stiffness * geo.length)[0])
        self.ca = float((el.damping * geo.length)[0])
        self.tension0 = tension0
        self.sense = el.sense
        shoe_offset, pivot = el.shoe_offset[0], el.shoe_pivot[0]
        self.shoe = jc.scenes.SpanShoe(
            int(TENSIONER["span"]), float(el.shoe_radius[0]), pivot + shoe_offset, pivot,
            float(el.shoe_angle[0]),
        )  # fmt: skip
        self.layout_angle = float(scenes[0].tensioners.layout_angle[0])
        self.iso42 = scenes[0].sprockets[1].profile
        rev = 60.0 / np.asarray(s.speeds)
        self.t1 = jnp.asarray(rev * s.revolutions)
        k = np.arange(s.window * SAVES)
        self.ts = jnp.asarray((s.revolutions - s.window + k[None, :] / SAVES) * rev[:, None])
        self.traces = 0
        self._value = jax.jit(self._objective)
        self._vg = jax.jit(jax.value_and_grad(self._objective, has_aux=True))
        # the baseline's measures through the same compiled program (scale and bounds are
        # arguments of it; their values here do not matter)
        n = len(s.speeds)
        self.scale, self.allowed = 1.0, np.full((n, 2), np.inf)
        self.baseline = self.value(np.zeros(6))[1]
        self.scale = float(np.max(self.baseline["p2p"]))
        self.allowed = np.maximum(self.baseline["orders"][:, 1:], 0.0) + ORDER_SLACK_N

    def _scene(self, u, scene):
        crank = crank_profile(u)
        spans = jc.scenes.span_element(
            (crank, self.iso42, self.iso42), self.centres, self.sense, self.tension0,
            self.ea, self.ca, shoe=self.shoe,
        )  # fmt: skip
        k, c = tensioner_rates(u)
        tn = scene.tensioners
        tn = eqx.tree_at(lambda t: (t.stiffness, t.damping), tn, (k[None], c[None]))
        return eqx.tree_at(lambda x: (x.added[0], x.tensioners), scene, (spans, tn))

    def _one(self, u, scene, t1, ts):
        sol = jc.simulate(self._scene(u, scene), t1, ts=ts, n_steps=self.s.steps, throw=False)
        out = measures(sol, self.layout_angle)
        out["ok"] = sol.result == jc.Result.successful
        return out

    def _measure(self, u):
        one = eqx.filter_vmap(self._one, in_axes=(None, eqx.if_array(0), 0, 0))
        return one(u, self.base, self.t1, self.ts)

    def _objective(self, u, scale, allowed):
        self.traces += 1  # Python: runs only when jit traces (tests count retraces)
        m = self._measure(u)
        worst = 10.0 * jax.nn.logsumexp(m["p2p_soft"] / 10.0)  # soft max over the speeds [N]
        j = worst / scale
        over = jax.nn.relu(m["timing_soft"] - TIMING_LIMIT_DEG) / 0.1
        orders = jax.nn.relu(m["orders"][:, 1:] - allowed) / ORDER_SLACK_N
        stroke = jax.nn.relu(m["stroke_soft"] - STROKE_RAD) / (0.1 * STROKE_RAD)
        penalty = jnp.sum(over**2) + jnp.sum(orders**2) + jnp.sum(stroke**2)
        return j + 0.1 * penalty, m

    def value(self, u):
        j, m = self._value(jnp.asarray(u, dtype=float), self.scale, jnp.asarray(self.allowed))
        return float(j), jax.tree.map(np.asarray, m)

    def value_and_grad(self, u):
        (j, m), g = self._vg(jnp.asarray(u, dtype=float), self.scale, jnp.asarray(self.allowed))
        return float(j), np.asarray(g), jax.tree.map(np.asarray, m)


def feasible(m: dict, allowed) -> bool:
    return bool(
        np.all(m["timing"] <= TIMING_LIMIT_DEG)
        and np.all(m["orders"][:, 1:] <= allowed + 1e-9)
        and np.all(m["stroke"] <= STROKE_RAD)
    )


# ---------------------------------------------------------------------- the run
def _log(msg: str, quiet: bool) -> None:
    if not quiet:
        print(msg, flush=True)


class _Checkpoint:
    """Every finished evaluation of the run, in ``out``/timing_checkpoint.pkl: a resumed run
    replays them (no solve) and continues where the interrupted one stopped."""

    def __init__(self, out: Path, resume: bool, settings: TimingSettings):
        self.path = out / "timing_checkpoint.pkl"
        self.settings = dataclasses.asdict(settings)
        self.done: dict = {"settings": self.settings, "evaluations": []}
        if resume and self.path.exists():
            import pickle

            done = pickle.loads(self.path.read_bytes())
            if done["settings"] != self.settings:
                raise ValueError(
                    f"--resume: {self.path} was written with other settings "
                    f"({done['settings']}); run without --resume or with those settings"
                )
            self.done = done
        self.cursor = 0

    def evaluate(self, kind: str, u, fn):
        """``fn(u)`` (``kind`` "value" or "grad"), or its recorded result when resuming."""
        ev = self.done["evaluations"]
        if self.cursor < len(ev):
            k, uu, result = ev[self.cursor]
            if k != kind or not np.allclose(uu, u, rtol=0, atol=1e-12):
                raise ValueError("--resume: the checkpoint does not replay; run without --resume")
        else:
            result = fn(u)
            ev.append((kind, np.asarray(u, dtype=float), result))
            self.save()
        self.cursor += 1
        return result

    def save(self) -> None:
        import pickle

        tmp = self.path.with_suffix(".tmp")
        tmp.write_bytes(pickle.dumps(self.done))
        tmp.replace(self.path)


def _adam(obj, s: TimingSettings, ck: _Checkpoint, ratio: float, quiet: bool) -> dict:
    import optax

    opt = optax.adam(s.learning_rate)
    u = jnp.zeros(6)
    state = opt.init(u)
    trace, best = [], (math.inf, np.zeros(6))
    for it in range(s.iterations):
        value, grad, m = ck.evaluate("grad", np.asarray(u), obj.value_and_grad)
        if not (math.isfinite(value) and np.all(np.isfinite(grad))):
            _log(f"Adam {it}: the objective or its gradient is not finite; stopping", quiet)
            break
        trace.append([(it + 1) * ratio, value])
        if value < best[0] and bool(np.all(m["ok"])):
            best = (value, np.asarray(u))
        _log(
            f"Adam {it + 1}/{s.iterations}: J {value:.4f}, worst tight p2p "
            f"{np.max(m['p2p']):.1f} N, timing {np.max(m['timing']):.2f} deg",
            quiet,
        )
        updates, state = opt.update(jnp.asarray(grad), state)
        u = optax.apply_updates(u, updates)
    return {"method": "Adam", "best_J": best[0], "u": best[1].tolist(), "curve": trace}


def _cma(obj, s: TimingSettings, ck: _Checkpoint, budget: float, quiet: bool) -> dict:
    import cma

    es = cma.CMAEvolutionStrategy(np.zeros(6), SIGMA0, {"seed": s.cma_seed, "verbose": -9})
    spent, trace, best = 0, [], (math.inf, np.zeros(6))
    while spent + es.popsize <= budget:
        xs = es.ask()
        values = []
        for x in xs:
            value, m = ck.evaluate("value", np.asarray(x), obj.value)
            spent += 1
            ok = math.isfinite(value) and bool(np.all(m["ok"]))
            values.append(value if ok else 1e3)
            if ok and value < best[0]:
                best = (value, np.asarray(x))
            trace.append([spent, min(best[0], 1e3)])
        es.tell(xs, values)
        _log(f"CMA-ES: {spent} of {budget:.0f} simulations, best J {best[0]:.4f}", quiet)
    return {"method": "CMA-ES", "seed": s.cma_seed, "best_J": best[0], "u": best[1].tolist(),
            "curve": trace}  # fmt: skip


def _lumped(u, rpm: float, s: TimingSettings) -> dict:
    """The lumped polygonal chain at ``rpm`` from its settled start: the measures over
    ``remeasure_revolutions`` after ``REMEASURE_SETTLE`` (adaptive steps)."""
    scene = build(rpm, "lumped", u)
    rev = 60.0 / rpm
    total = REMEASURE_SETTLE + s.remeasure_revolutions
    k = np.arange(s.remeasure_revolutions * SAVES)
    ts = (REMEASURE_SETTLE + k / SAVES) * rev
    wall = time.perf_counter()
    sol = jc.simulate(scene, total * rev, ts=ts, rtol=1e-4, max_steps=5_000_000, throw=False)
    wall = time.perf_counter() - wall
    layout = float(scene.tensioners.layout_angle[0])
    m = jax.tree.map(lambda x: np.asarray(x).tolist(), measures(sol, layout))
    m.pop("p2p_soft"), m.pop("timing_soft"), m.pop("stroke_soft")
    return m | {"rpm": rpm, "ok": bool(sol.ok), "message": sol.message, "wall_s": wall}


def run(s: TimingSettings, out: Path, *, resume: bool = False, quiet: bool = False) -> dict:
    from .run import versions, write_design

    s.validate()
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    ck = _Checkpoint(out, resume, s)
    _log(f"timing drive: {len(s.speeds)} speeds, {s.steps} fixed steps each, compiling", quiet)
    obj = TimingObjective(s)
    allowed = obj.allowed
    # the cost of a value and gradient against a value (warm, this machine)
    u_probe = np.full(6, 0.05)
    obj.value(u_probe), obj.value_and_grad(u_probe)
    t = time.perf_counter()
    obj.value(u_probe)
    t_value = time.perf_counter() - t
    t = time.perf_counter()
    obj.value_and_grad(u_probe)
    ratio = (time.perf_counter() - t) / t_value
    _log(f"value {t_value:.2f} s, value and gradient {ratio:.1f}× that", quiet)
    adam = _adam(obj, s, ck, ratio, quiet)
    cmaes = _cma(obj, s, ck, s.iterations * ratio, quiet)
    runs = [adam, cmaes]
    better = min(runs, key=lambda r: r["best_J"])
    u = np.asarray(better["u"])
    span_base = jax.tree.map(lambda x: np.asarray(x).tolist(), obj.baseline)
    span_design = jax.tree.map(lambda x: np.asarray(x).tolist(), obj.value(u)[1])
    # the round crank with the designed tensioner: what the tensioner alone gives
    u_round = np.concatenate([np.zeros(4), u[4:]])
    span_round = jax.tree.map(lambda x: np.asarray(x).tolist(), obj.value(u_round)[1])
    _log("re-measuring on the lumped chain", quiet)
    lumped = {"baseline": [], "optimized": []}
    for rpm in s.remeasure_speeds:
        for name, uu in (("baseline", np.zeros(6)), ("optimized", u)):
            row = _lumped(uu, rpm, s)
            lumped[name].append(row)
            _log(
                f"  {name:9s} {rpm:5.0f} rpm: tight p2p {row['p2p']:.1f} N, 2nd order "
                f"{row['orders'][0]:.1f} N, timing {max(row['timing']):.2f} deg, "
                f"{row['wall_s']:.0f} s",
                quiet,
            )
    worst = {k: max(r["p2p"] for r in v) for k, v in lumped.items()}
    worst2 = {k: max(r["orders"][0] for r in v) for k, v in lumped.items()}
    k, c = (float(x) for x in tensioner_rates(u))
    profile = crank_profile(jnp.asarray(u))
    summary = {
        "objective": "worst tight-span tension peak-to-peak over the engine-speed band",
        "unit": "N",
        "baseline": "circular ISO 606 crank sprocket, baseline tensioner",
        "baseline_value": worst["baseline"],
        "optimized_value": worst["optimized"],
        "improvement": 1.0 - worst["optimized"] / worst["baseline"],
        "remeasured": True,
        "remeasured_on": "lumped polygonal chain, settled starts, adaptive steps (rtol 1e-4)",
        "method": better["method"],
        "order2": {
            "baseline_value": worst2["baseline"],
            "optimized_value": worst2["optimized"],
            "improvement": 1.0 - worst2["optimized"] / worst2["baseline"],
        },
        "timing_error_deg": max(max(r["timing"]) for r in lumped["optimized"]),
        "timing_limit_deg": TIMING_LIMIT_DEG,
        "feasible_in_design_model": feasible(jax.tree.map(np.asarray, obj.value(u)[1]), allowed),
        "span_model": {
            "baseline_value": float(np.max(span_base["p2p"])),
            "optimized_value": float(np.max(span_design["p2p"])),
            "round_crank_designed_tensioner_value": float(np.max(span_round["p2p"])),
        },
        "design": {
            "order2_cos_sin_m": [float(x) for x in AMPLITUDE[0] * np.tanh(u[:2])],
            "order4_cos_sin_m": [float(x) for x in AMPLITUDE[1] * np.tanh(u[2:4])],
            "tensioner_stiffness_Nm_per_rad": k,
            "tensioner_damping_Nms_per_rad": c,
        },
    }
    results = {
        "summary": summary,
        "settings": dataclasses.asdict(s),
        "drive": {
            "chain": CHAIN,
            "teeth": TEETH,
            "centres": CENTRES,
            "pretension": PRETENSION,
            "tensioner": TENSIONER,
            "exhaust_phase_deg": EXHAUST_PHASE_DEG,
        },  # fmt: skip
        "cost": {"value_s": t_value, "gradient_ratio": ratio, "traces": obj.traces},
        "runs": runs,
        "span_model": {
            "baseline": span_base,
            "optimized": span_design,
            "round_crank_designed_tensioner": span_round,
        },  # fmt: skip
        "lumped": lumped,
        "versions": versions(),
        "wall_s": time.perf_counter() - start,
    }
    (out / "results.json").write_text(json.dumps(results, indent=1))
    write_design(out, profile)
    _plots(results, profile, out)
    _log(
        f"worst tight-span p2p on the lumped chain: {worst['baseline']:.1f} → "
        f"{worst['optimized']:.1f} N ({100 * summary['improvement']:.1f} % lower); 2nd order "
        f"{worst2['baseline']:.1f} → {worst2['optimized']:.1f} N; wrote {out}",
        quiet,
    )
    return results


def _plots(results: dict, profile, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    for name, style in (("baseline", "o-"), ("optimized", "s-")):
        rows = results["lumped"][name]
        rpm = [r["rpm"] for r in rows]
        ax[0].plot(rpm, [r["p2p"] for r in rows], style, label=f"lumped, {name}")
        ax[1].plot(rpm, [r["orders"][0] for r in rows], style, label=f"lumped, {name}")
        sp = results["span_model"][name]
        speeds = results["settings"]["speeds"]
        ax[0].plot(speeds, sp["p2p"], style[0] + "--", alpha=0.6, label=f"spans, {name}")
        ax[1].plot(speeds, [o[0] for o in sp["orders"]], style[0] + "--", alpha=0.6,
                   label=f"spans, {name}")  # fmt: skip
    ax[0].set(xlabel="engine speed [rpm]", ylabel="tight-span tension p2p [N]")
    ax[1].set(xlabel="engine speed [rpm]", ylabel="tight-span 2nd order [N]")
    ax[0].legend(fontsize=7)
    for r in results["runs"]:
        c = np.asarray(r["curve"])
        ax[2].plot(c[:, 0], np.minimum.accumulate(c[:, 1]), label=r["method"])
    ax[2].set(xlabel="simulation-equivalents", ylabel="best objective", yscale="log")
    ax[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "timing.png", dpi=120)
    plt.close(fig)
    radius, angle = (np.asarray(x) for x in profile.pitch_polar())
    base = float(iso_profiles()[0].pitch_radius)
    fig, ax = plt.subplots(figsize=(5, 4))
    order = np.argsort(angle)
    ax.plot(np.degrees(angle[order]), 1e3 * (radius[order] - base), "o-")
    ax.set(xlabel="seat angle [deg]", ylabel="seat radius − ISO pitch radius [mm]",
           title="designed crank sprocket: pitch curve")  # fmt: skip
    fig.tight_layout()
    fig.savefig(out / "pitch_curve.png", dpi=120)
    plt.close(fig)


def lines(rpm: float, u=None, *, saves: int = 360, top: int = 6) -> dict:
    """What makes up the tight span's swing on the lumped chain at ``rpm`` (design ``u``;
    None: the baseline), revolutions 3–5 sampled ``saves`` times per revolution: its
    peak-to-peak, that of its 1st–6th engine orders alone and of the rest, and its
    ``top`` largest order lines [N] (up to the 60th)::

        python -c "from optimize import timing; print(timing.lines(3500.0))"

    Needs float64 (``jax_enable_x64``)."""
    scene = build(rpm, "lumped", u)
    rev = 60.0 / rpm
    ts = (REMEASURE_SETTLE + np.arange(REMEASURE_REVOLUTIONS * saves) / saves) * rev
    sol = jc.simulate(scene, (REMEASURE_SETTLE + REMEASURE_REVOLUTIONS) * rev, ts=ts,
                      rtol=1e-4, max_steps=5_000_000)  # fmt: skip
    tight = np.asarray(sol.span_tension)[:, -1]
    crank = np.asarray(sol.sprocket_angle)[:, 0]
    k = np.arange(61)
    c = 2 / len(tight) * (np.exp(-1j * np.outer(k, crank)) @ tight)
    low = np.real(c[1:7] @ np.exp(1j * np.outer(k[1:7], crank)))
    rest = tight - tight.mean() - low
    order = np.argsort(np.abs(c[1:]))[::-1][:top] + 1
    return {
        "p2p": float(np.ptp(tight)),
        "p2p_orders_1_6": float(np.ptp(low)),
        "p2p_rest": float(np.ptp(rest)),
        "lines": [(int(j), float(abs(c[j]))) for j in order],
    }
