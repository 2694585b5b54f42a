"""Can a gradient through the clearance-joint chain's solve design a tooth? Pathwise
derivatives of meshing-peak objectives against finite differences on fixed steps, their
growth with the horizon, windows restarted from a running chain, and the slope of the
long-run mean peak they should estimate.

    python -m benchmarks.clearance_gradient            # full study (~30 min on 2 busy cores)
    python -m benchmarks.clearance_gradient --quick    # smoke run (~12 min)
    python -m benchmarks.clearance_gradient --replot   # the chart from the saved JSON

Writes ``benchmarks/results/clearance_gradient.json`` and ``clearance_gradient.png``.

Notes: benchmarks/clearance_gradient.md
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path
from typing import ClassVar

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.clearance_tools import clean, solve, timed  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402
from benchmarks.engagement_stats import CHAIN, TEETH, TENSION, period  # noqa: E402
from jaxchain.design import DesignSpace  # noqa: E402

RPM = 1250.0
PERIOD = period(RPM)
PARAMS = ("seating_radius", "flank_radius")
DT = 0.5e-6  # the fixed step of parts 1 and 3 [s]
HS = (1e-3, 1e-4, 1e-5)  # central-difference steps in u (settled start)
TEMPERATURE, REFERENCE = 20.0, 1500.0  # soft peaks [N]
DISCARD = 1.5  # engagements with onset before this many periods are the start transient
GRID = 0.01  # state saves of the long runs [periods]
TRUTH_U = 2.0  # the ground truth's central difference: u = ±TRUTH_U

#: the models: fidelity, the roller/tooth and the joints' contact-onset widths [m] (the
#: clearance chain's nominal laws have 10 nm; set as arrays, so that both clearance models
#: share every compiled solve), and the fixed step of part 1 [s]
NOMINAL_WIDTH = 1e-8
MODELS = {
    "clearance": ("clearance", NOMINAL_WIDTH, NOMINAL_WIDTH, DT),
    "clearance, wide onsets": ("clearance", 3e-6, 1e-6, DT),
    "lumped": ("lumped", None, None, 1e-6),
}


# ---------------------------------------------------------------------- scenes and design
def space() -> DesignSpace:
    """Seating radius and flank radius of the ISO 606 mid form, each over its ISO range."""
    chain = jc.ChainSpec.iso606(CHAIN)
    lim = jc.iso606_limits(chain, TEETH)
    iso = jc.ToothProfile.iso606(chain, TEETH, "mid")
    return DesignSpace.select(iso, {p: lim[p] for p in PARAMS})


SPACE = space()
U0 = jnp.zeros(len(PARAMS))


def steps_per_period(dt: float) -> int:
    """Fixed steps per tooth period for a step of about ``dt`` (a multiple of 20, so that
    every horizon k + 0.6 periods and every 0.05 P lies on the step grid)."""
    return 20 * round(PERIOD / dt / 20)


def strand(model: str, n_entry: int, u=U0) -> jc.Scene:
    """The settled engagement strand of ``model`` with the profile at ``u``."""
    fidelity, roller_width, joint_width, _ = MODELS[model]
    law = None
    if roller_width is not None:
        law = jc.scenes.roller_law(jc.ChainSpec.iso606(CHAIN), 0.7, width=roller_width)
    scene = jc.scenes.engagement(
        CHAIN,
        TEETH,
        speed_rpm=RPM,
        tension=TENSION,
        n_entry=n_entry,
        fidelity=fidelity,
        profile=SPACE.profile(jnp.asarray(u, dtype=float)),
        model=jc.scenes.ChainModel(roller_contact=law, settle=joint_width is None),
    )
    if joint_width is None:
        return scene
    pairs = tuple(
        eqx.tree_at(lambda g: g.element.law.width, g, jnp.asarray(joint_width))
        if isinstance(g.element, jc.ClearanceJoints)
        else g
        for g in scene.pairs
    )
    return jc.scenes.equilibrate(dataclasses.replace(scene, pairs=pairs))


def with_profile(scene: jc.Scene, u) -> jc.Scene:
    """``scene`` with the profile at ``u`` swapped in (its start held)."""
    return eqx.tree_at(lambda s: s.sprockets[0].profile, scene, SPACE.profile(u))


class StateProbe(jc.elements.AbstractElement):
    """A force element that exerts nothing and reports the whole drive state among a
    solution's saved outputs (``element_outputs``: probe_q, probe_v, probe_bristle)."""

    def effect(self, t, y, scene, state):
        return jc.elements.Effect(body=jnp.zeros_like(y.q))

    def outputs(self, t, y, scene, effect):
        out = {"probe_q": y.q, "probe_v": y.v}
        if y.bristle is not None:
            out["probe_bristle"] = y.bristle
        return out


class RestartedDahl(jc.contact.AbstractFrictionLaw):
    """``law`` (Dahl) whose bristles start at ``start`` (P,) instead of zero: its own state
    is the deflection's change since the restart."""

    law: jc.contact.DahlFriction
    start: jax.Array
    states_per_contact: ClassVar[int] = 1

    def traction(self, normal_force, slip_velocity, state):
        return self.law.traction(normal_force, slip_velocity, state + self.start)

    def state_rate(self, state, slip_velocity):
        return self.law.state_rate(state + self.start, slip_velocity)


def _bristle_groups(scene) -> tuple[list[tuple[int, int, int]], int]:
    """(pair group, start, count) of each joint group's Dahl states in ``DriveState.bristle``
    (the pair groups come first among the force elements), and the total."""
    out, at = [], 0
    for i, g in enumerate(scene.pairs):
        el = g.element
        if isinstance(el, jc.ClearanceJoints) and el.friction is not None:
            n = int(np.shape(g.a)[0]) * el.friction.states_per_contact
            if n:
                out.append((i, at, n))
                at += n
    return out, at


def restarted(scene: jc.Scene, t: float, q, v, angle, bristle) -> jc.Scene:
    """``scene`` (settled, not restarted) started at time ``t`` of a run in the state (q,
    v, driver angle, Dahl bristles), time shifted to 0: the guides moved on by their speed
    × t, the horizon shortened by t, the bristles restored."""
    groups, total = _bristle_groups(scene)
    if total != (0 if bristle is None else np.shape(bristle)[-1]):
        raise ValueError(f"bristle layout: {total} joint states, the run saved {np.shape(bristle)}")
    pairs = list(scene.pairs)
    for i, at, n in groups:
        law = RestartedDahl(pairs[i].element.friction, jnp.asarray(bristle[at : at + n]))
        pairs[i] = eqx.tree_at(lambda g: g.element.friction, pairs[i], law)
    an = scene.anchors
    return eqx.tree_at(
        lambda s: (s.q0, s.v0, s.sprockets[0].angle0, s.anchors.origin, s.horizon),
        dataclasses.replace(scene, pairs=tuple(pairs)),
        (
            jnp.asarray(q), jnp.asarray(v), jnp.asarray(angle),
            an.origin + (an.speed * t)[:, None] * an.direction, scene.horizon - t,
        ),
    )  # fmt: skip


def _np(tree):
    return jax.tree_util.tree_map(np.asarray, tree)


def _forward(raw):
    """``raw(u, adjoint) -> (outputs, aux)`` as ``(u, dirs) -> (outputs, tangents (D, ...),
    aux)``: one forward-mode tangent per row of ``dirs``, vmapped."""

    def jvps(u, dirs):
        def one(d):
            return jax.jvp(lambda u: raw(u, diffrax.ForwardMode()), (u,), (d,), has_aux=True)

        return jax.vmap(one, out_axes=(None, 0, None))(dirs)

    return jvps


# ---------------------------------------------------------------------- part 0: statics
def statics_rows(model: str = "clearance", hs=(1e-6, 1e-5, 1e-4, 1e-3, 1e-2)) -> dict:
    """The first-order resettle's start displacement at u₀ ± h (linear: ∝ h)."""
    scene = strand(model, 3)
    jac = jc.scenes.statics_jacobian(scene)
    rows = []
    for h in hs:
        for sign in (1, -1):
            u = U0.at[0].set(sign * h)
            s = jc.scenes.resettle(with_profile(scene, u), jacobian=jac)
            dq = float(jnp.max(jnp.abs(s.q0 - scene.q0)))
            rows.append({"h": sign * h, "max_dq_m": dq, "dq_over_h": dq / h})
            print(f"statics {model}: u0 {sign * h:+.0e}: start moved {dq:.3g} m", flush=True)
    return {"model": model, "rows": rows}


# ---------------------------------------------------------------------- part 1 and 2
def _settled_raw(u, scene, jacobian, t1: float, n: int, stride: int, adjoint=None):
    """One fixed-step solve from ``scene``'s settled start resettled for the profile at
    ``u``: the saved forces, every roller's first engagement peak, the rollers' positions
    every ``stride`` steps; (onsets, counts, result)."""
    kw = {} if adjoint is None else {"adjoint": adjoint}
    ts = jnp.linspace(0.0, t1, n + 1)  # every step's end
    start = jc.scenes.resettle(with_profile(scene, u), jacobian=jacobian)
    obs = jc.observers.EngagementPeaks(capacity=1)
    sol = jc.simulate(start, t1, ts=ts, observers=(obs,), n_steps=n, throw=False, **kw)
    rec = sol.observed[0]
    out = {
        "force": sol.roller_sprocket_force,
        "peak": rec.peak[0, :, 0],
        "x": sol.roller_position[::stride],
    }
    return out, (rec.onset[0, :, 0], rec.count[0], sol.result)


# module level: one compiled program per scene structure and step count, shared by the
# models of one structure (the two clearance models)
_settled_value = eqx.filter_jit(_settled_raw)


@eqx.filter_jit
def _settled_jvps(u, dirs, scene, jacobian, t1: float, n: int, stride: int):
    raw = lambda u, adjoint: _settled_raw(u, scene, jacobian, t1, n, stride, adjoint)  # noqa: E731
    return _forward(raw)(u, dirs)


def settled_run(
    model: str,
    dt: float | None,
    horizon: float,
    tangents=(0, 1),
    hs=HS,
    fd_params=(0, 1),
    timing: bool = False,
) -> dict:
    """AD and central differences of (a), (b), (c) at every horizon k + 0.6 ≤ ``horizon``
    periods, from one fixed-step solve (``dt``; None: the model's) from the settled start,
    resettled to first order for the profile at u (``ProfileObjective``'s model); the
    sensitivity of the rollers' positions along it."""
    dt = MODELS[model][3] if dt is None else dt
    n_pp = steps_per_period(dt)
    n = round(horizon * n_pp)
    t1 = horizon * PERIOD
    ts = jnp.linspace(0.0, t1, n + 1)
    stride = n_pp // 20  # rollers' positions every 0.05 P
    scene = strand(model, math.ceil(horizon) + 1)
    jacobian = jc.scenes.statics_jacobian(scene)
    args = (scene, jacobian, t1, n, stride)

    def value(u):
        return _settled_value(u, *args)

    def jvps(u, dirs):
        return _settled_jvps(u, dirs, *args)

    (out0, (onset, count, result)), first_value = timed(value, U0)
    if jc.result_names(result)[0] != "successful":
        raise RuntimeError(
            f"{model}, dt {dt}: the solve at u = 0 failed: {jc.result_names(result)}"
        )
    onset, count = np.asarray(onset) / PERIOD, np.asarray(count)
    horizons = [k + 0.6 for k in range(int(horizon - 0.6 + 1e-9) + 1)]
    rollers = []
    for k, _ in enumerate(horizons):  # engagement k: onset within half a period of k
        meshing = (count > 0) & (np.asarray(out0["peak"]) > 100.0)  # not a loose seated roller
        near = np.nonzero(meshing & (np.abs(onset - k - 0.05) < 0.5))[0]
        if len(near) != 1:
            raise RuntimeError(f"{model}: engagement {k}: rollers {near} (onsets {onset[near]})")
        rollers.append(int(near[0]))
    tsn = np.asarray(ts)

    def objectives(o):
        sharp = o["peak"][jnp.asarray(rollers)]
        soft = []
        g = o["force"] - REFERENCE
        g = jnp.sum(
            jnp.exp(g / TEMPERATURE - jax.nn.softplus(g / TEMPERATURE - jc.observers.EXP_CAP)), -1
        )
        for h in horizons:
            start = max(0.0, h - 1.0) * PERIOD
            rise = 0.0 if start == 0.0 else 0.05 * PERIOD
            w = jc.observers.window_weight(ts, start, rise) * (tsn <= h * PERIOD + 1e-12)
            integral = jnp.trapezoid(w * g, ts)
            soft.append(REFERENCE + TEMPERATURE * jnp.log(integral / (h * PERIOD - start)))
        # (c): engagements 2 … k (onset ≥ DISCARD periods, as the long runs'); NaN before
        mean = [jnp.mean(sharp[2 : k + 1]) if k >= 2 else jnp.nan for k in range(len(horizons))]
        return {"sharp": sharp, "soft": jnp.stack(soft), "mean": jnp.stack(mean)}

    values = _np(objectives(out0))
    dirs = jnp.eye(len(PARAMS))[jnp.asarray(tangents)]
    (_, tan, _), first_jvp = timed(jvps, U0, dirs)
    ad = {}
    for i, p in enumerate(tangents):
        t_in = jax.tree_util.tree_map(lambda a, i=i: a[i], tan)
        _, t_obj = jax.jvp(objectives, (out0,), (t_in,))
        # a slope only where the objective is defined ((c) needs engagement 2)
        ad[PARAMS[p]] = {k: np.where(np.isnan(values[k]), np.nan, v) for k, v in _np(t_obj).items()}
    warm_jvp = None
    if timing:
        _, warm_jvp = timed(jvps, U0, dirs)
    fd, walls = {}, []
    for p in fd_params:
        e = jnp.eye(len(PARAMS))[p]
        for h in hs:
            (hi, aux_hi), w1 = timed(value, U0 + h * e)
            (lo, aux_lo), w2 = timed(value, U0 - h * e)
            walls += [w1, w2]
            ok = all(jc.result_names(a[2])[0] == "successful" for a in (aux_hi, aux_lo))
            vh, vl = _np(objectives(hi)), _np(objectives(lo))
            fd[f"{PARAMS[p]} {h:g}"] = {
                k: ((vh[k] - vl[k]) / (2 * h)).tolist() if ok else None for k in vh
            }
    # the rollers' sensitivity along the solve
    xt = np.asarray(tan["x"])  # (D, T', R, 2)
    sens = np.sqrt(np.sum(xt**2, axis=(2, 3)))
    t_sens = np.asarray(ts[::stride]) / PERIOD
    row = {
        "model": model,
        "dt_s": PERIOD / n_pp,
        "steps_per_period": n_pp,
        "horizon_periods": horizon,
        "horizons": horizons,
        "engagement_rollers": rollers,
        "onsets_periods": [float(onset[r]) for r in rollers],
        "values": {k: v.tolist() for k, v in values.items()},
        "ad": {p: {k: v.tolist() for k, v in d.items()} for p, d in ad.items()},
        "fd": fd,
        "sensitivity_t_periods": t_sens.tolist(),
        "sensitivity": {PARAMS[p]: sens[i].tolist() for i, p in enumerate(tangents)},
        "growth_per_period": {PARAMS[p]: growth(t_sens, sens[i]) for i, p in enumerate(tangents)},
        "value_first_s": first_value,
        "jvp_first_s": first_jvp,
        "value_warm_s": min(walls) if walls else None,
        "jvp_warm_s": warm_jvp,
        "tangents": len(tangents),
    }
    show = "; ".join(
        f"H {h:.2f}: sharp {values['sharp'][k]:.0f} N, AD {ad[PARAMS[tangents[0]]]['sharp'][k]:.3g}"
        + "".join(
            f", FD({hh:g}) {fd[f'{PARAMS[tangents[0]]} {hh:g}']['sharp'][k]:.3g}"
            for hh in hs
            if tangents[0] in fd_params and fd.get(f"{PARAMS[tangents[0]]} {hh:g}")
        )
        for k, h in enumerate(horizons)
    )
    print(f"{model}, dt {row['dt_s'] * 1e6:.3f} µs: {show}", flush=True)
    return row


def growth(t, s, t_from: float = 0.2) -> float | None:
    """The state sensitivity's growth factor per tooth period: log-linear least squares
    over t ≥ ``t_from`` periods."""
    keep = (t >= t_from) & np.isfinite(s) & (s > 0)
    if keep.sum() < 3:
        return None
    return float(math.exp(np.polyfit(t[keep], np.log(s[keep]), 1)[0]))


# ---------------------------------------------------------------------- part 3: long runs
def long_run(model: str, u, n_entry: int) -> dict:
    """An adaptive solve (``simulate``'s default tolerances) of the settled strand at
    ``u``: every engagement's peak, and the whole state every GRID periods."""
    scene = strand(model, n_entry, u).add_elements(StateProbe())
    t1 = (n_entry - 0.1) * PERIOD
    grid = np.arange(0.0, t1, GRID * PERIOD)
    obs = jc.observers.EngagementPeaks.for_solve(scene, t1)
    sol, wall = solve(scene, t1, (obs,), ts=grid)
    if not sol.ok:
        raise RuntimeError(f"long run {model} at u = {u}: {sol.message}")
    e = jc.engagement_peaks(sol, t_start=DISCARD * PERIOD)
    eo = sol.element_outputs
    run = {
        "model": model,
        "u": [float(x) for x in np.asarray(u)],
        "n_entry": n_entry,
        "peaks_N": e.peak.tolist(),
        "rollers": e.roller.tolist(),
        "onsets_periods": (e.onset / PERIOD).tolist(),
        "peak_after_onset_periods": ((e.t_peak - e.onset) / PERIOD).tolist(),
        "steps": int(sol.stats["num_accepted_steps"]),
        "rejected": int(sol.stats["num_rejected_steps"]),
        "wall_s": wall,
    }
    states = {
        "grid": grid,
        "q": np.asarray(eo["probe_q"]),
        "v": np.asarray(eo["probe_v"]),
        "bristle": np.asarray(eo["probe_bristle"]) if "probe_bristle" in eo else None,
        "angle": np.asarray(sol.sprocket_angle[:, 0]),
    }
    st = jc.peak_statistics(e.peak)
    print(
        f"long run {model}, u {run['u']}: {st.n} engagements, mean {st.mean:.0f} N "
        f"[{st.ci_low:.0f}, {st.ci_high:.0f}], {run['steps']} steps, {wall:.0f} s",
        flush=True,
    )
    return run | {"states": states}


def _window_raw(u, scene, roller, span: float, n: int, adjoint=None):
    """One restarted window with the profile at ``u``: (a) ``roller``'s engagement peak, (b)
    the sampled soft peak over the window; (its event count, result)."""
    kw = {} if adjoint is None else {"adjoint": adjoint}
    obs = (
        jc.observers.EngagementPeaks(window=0.1, capacity=1),
        jc.observers.SampledSoftPeak(0.0, 0.0, TEMPERATURE, REFERENCE, samples=4),
    )
    sol = jc.simulate(
        with_profile(scene, u), span, n_save=2, observers=obs, n_steps=n, throw=False, **kw
    )
    rec = sol.observed[0]
    out = {"sharp": rec.peak[0, roller, 0], "soft": sol.observed[1]}
    return out, (rec.count[0, roller], sol.result)


def _window_jvps(u, dirs, scene, roller, span: float, n: int):
    raw = lambda u, adjoint: _window_raw(u, scene, roller, span, n, adjoint)  # noqa: E731
    return _forward(raw)(u, dirs)


# every window vmapped; module level (shared by the models of one structure)
_window_value = eqx.filter_jit(
    eqx.filter_vmap(_window_raw, in_axes=(None, eqx.if_array(0), 0, None, None))
)
_window_jvp = eqx.filter_jit(
    eqx.filter_vmap(_window_jvps, in_axes=(None, None, eqx.if_array(0), 0, None, None))
)


def windows(model: str, run: dict, lead: float, hs_seat, hs_flank, timing: bool) -> dict:
    """AD and central differences of every engagement's window restarted ``lead`` periods
    before its onset from ``run``'s saved state, the profile at u (the state at u = 0)."""
    base = strand(model, run["n_entry"])
    st = run["states"]
    members, rollers = [], []
    for onset, r in zip(run["onsets_periods"], run["rollers"], strict=True):
        i = int(math.floor((onset - lead) / GRID + 1e-9))
        b = None if st["bristle"] is None else st["bristle"][i]
        members.append(restarted(base, st["grid"][i], st["q"][i], st["v"][i], st["angle"][i], b))
        rollers.append(r)
    scenes = jc.scenes.stack(members)
    rollers = jnp.asarray(rollers)
    span = (lead + GRID + 0.13) * PERIOD
    n = round(span / DT)

    def value(u, scenes, rollers):
        return _window_value(u, scenes, rollers, span, n)

    def jvp_all(u, dirs, scenes, rollers):
        return _window_jvp(u, dirs, scenes, rollers, span, n)

    (v0, (count, result)), first_value = timed(value, U0, scenes, rollers)
    ok0 = np.asarray(jc.result_names(result)) == "successful"
    dirs = jnp.eye(len(PARAMS))
    (_, tan, _), first_jvp = timed(jvp_all, U0, dirs, scenes, rollers)
    warm_jvp = timed(jvp_all, U0, dirs, scenes, rollers)[1] if timing else None
    fd, walls = {}, []
    for p, hs in ((0, hs_seat), (1, hs_flank)):
        e = dirs[p]
        for h in hs:
            (hi, (_, r_hi)), w1 = timed(value, U0 + h * e, scenes, rollers)
            (lo, (_, r_lo)), w2 = timed(value, U0 - h * e, scenes, rollers)
            walls += [w1, w2]
            good = (np.asarray(jc.result_names(r_hi)) == "successful") & (
                np.asarray(jc.result_names(r_lo)) == "successful"
            )
            fd[f"{PARAMS[p]} {h:g}"] = {
                k: np.where(
                    good, (np.asarray(hi[k]) - np.asarray(lo[k])) / (2 * h), np.nan
                ).tolist()
                for k in hi
            }
    peaks_long = np.asarray(run["peaks_N"])
    row = {
        "model": model,
        "lead_periods": lead,
        "span_periods": span / PERIOD,
        "dt_s": span / n,
        "members": len(members),
        "ok": ok0.tolist(),
        "events": np.asarray(count).tolist(),
        "values": {k: np.asarray(v).tolist() for k, v in v0.items()},
        "long_run_peaks_N": peaks_long.tolist(),
        "restart_max_abs_diff_N": float(np.max(np.abs(np.asarray(v0["sharp"]) - peaks_long))),
        "ad": {
            PARAMS[p]: {k: np.asarray(tan[k])[:, p].tolist() for k in tan}
            for p in range(len(PARAMS))
        },
        "fd": fd,
        "value_first_s": first_value,
        "jvp_first_s": first_jvp,
        "value_warm_s": min(walls) if walls else None,
        "jvp_warm_s": warm_jvp,
    }
    row["summary"] = window_summary(row)
    s = row["summary"]["seating_radius"]["sharp"]
    print(
        f"windows {model}, lead {lead} P, {len(members)} members: restart vs long run "
        f"{row['restart_max_abs_diff_N']:.2g} N; seat, sharp: mean AD {s['ad_mean']:.4g} ± "
        f"{s['ad_se']:.3g}, "
        + ", ".join(f"FD({h}) {d['mean']:.4g} ± {d['se']:.3g}" for h, d in s["fd"].items()),
        flush=True,
    )
    return row


def _mean_se(x) -> dict:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    n = x.size
    se = float(x.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
    return {"mean": float(x.mean()) if n else math.nan, "se": se, "n": int(n)}


def window_summary(row: dict) -> dict:
    """Per coordinate and objective: the windows' mean AD and mean central difference at
    each h with standard errors (the average over windows: the held states' mean-peak
    objective), the windows' spread, and AD against FD per window (median relative
    difference at the smallest h)."""
    out = {}
    for p in PARAMS:
        out[p] = {}
        for k in ("sharp", "soft"):
            ad = np.asarray(row["ad"][p][k])
            m = _mean_se(ad)
            fds = {}
            for key, d in row["fd"].items():
                name, h = key.rsplit(" ", 1)
                if name == p:
                    fds[h] = _mean_se(d[k])
            hs = sorted(fds, key=float)
            per = None
            if hs:
                f = np.asarray(row["fd"][f"{p} {hs[0]}"][k])
                rel = np.abs(ad - f) / np.maximum(np.abs(f), 1e-12)
                per = {
                    "h": float(hs[0]),
                    "median_rel": float(np.nanmedian(rel)),
                    "within_10pct": int(np.sum(rel < 0.1)),
                    "n": int(np.sum(np.isfinite(rel))),
                }
            out[p][k] = {
                "ad_mean": m["mean"], "ad_se": m["se"], "ad_std": float(np.nanstd(ad, ddof=1)),
                "ad_abs_max": float(np.nanmax(np.abs(ad))), "fd": fds, "per_window": per,
            }  # fmt: skip
    return out


# ---------------------------------------------------------------------- part 4: truth
def stratified_difference(a: dict, b: dict, confidence: float = 0.95) -> dict:
    """mean(b) − mean(a) of per-engagement peaks, each mean the average of the two
    link-side strata (roller index parity), with its t interval (Welch–Satterthwaite)."""
    terms, var_terms = [], []
    for side in (0, 1):
        xs = []
        for run in (a, b):
            pk = np.asarray(run["peaks_N"])[np.asarray(run["rollers"]) % 2 == side]
            xs.append(pk)
        if min(len(x) for x in xs) < 2:
            return {"difference_N": math.nan, "ci": [math.nan, math.nan]}
        terms.append(xs[1].mean() - xs[0].mean())
        var_terms += [(x.var(ddof=1) / len(x) / 4, len(x) - 1) for x in xs]
    d = 0.5 * sum(terms)
    var = sum(v for v, _ in var_terms)
    dof = var**2 / sum(v**2 / k for v, k in var_terms if k > 0)
    half = float(stats.t.ppf(0.5 + confidence / 2, dof)) * math.sqrt(var)
    return {
        "difference_N": float(d),
        "se_N": math.sqrt(var),
        "dof": dof,
        "ci": [d - half, d + half],
    }


def paired_difference(a: dict, b: dict, confidence: float = 0.95) -> dict | None:
    """mean(b − a) over engagements matched by order (the same roller of the same strand),
    with its t interval; None when the runs' engagements do not match."""
    if a["rollers"] != b["rollers"] or len(a["rollers"]) < 3:
        return None
    d = np.asarray(b["peaks_N"]) - np.asarray(a["peaks_N"])
    se = float(d.std(ddof=1) / math.sqrt(d.size))
    half = float(stats.t.ppf(0.5 + confidence / 2, d.size - 1)) * se
    m = float(d.mean())
    return {"difference_N": m, "se_N": se, "ci": [m - half, m + half]}


def truth(model: str, runs: dict, p: int) -> dict:
    """The central difference of the long-run mean peak in coordinate ``p`` over ±TRUTH_U
    per unit u: engagements paired by order (the primary interval: the lumped chain repeats
    its sequence; in the clearance chain the pairs are independent and the pairing matches
    link sides), stratified by link side, and Welch's unpaired interval."""
    a, b = runs[f"{PARAMS[p]} -"], runs[f"{PARAMS[p]} +"]
    scale = 1.0 / (2 * TRUTH_U)
    paired = paired_difference(a, b)
    strat = stratified_difference(a, b)
    c = jc.compare_peaks(a["peaks_N"], b["peaks_N"])
    main = paired or strat
    return {
        "model": model,
        "parameter": PARAMS[p],
        "u": TRUTH_U,
        "engagements": [len(a["peaks_N"]), len(b["peaks_N"])],
        "means_N": [float(np.mean(a["peaks_N"])), float(np.mean(b["peaks_N"]))],
        "interval": "paired" if paired else "stratified",
        "slope_per_u": main["difference_N"] * scale,
        "slope_ci_per_u": [x * scale for x in main["ci"]],
        "slope_stratified_ci_per_u": [x * scale for x in strat["ci"]],
        "slope_welch_ci_per_u": [c.ci_low * scale, c.ci_high * scale],
    }


# ---------------------------------------------------------------------- chart
def _f(x) -> np.ndarray:
    """A result list as floats (None: NaN)."""
    return np.asarray(x, dtype=float)


def chart(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(13, 9))
    ax = axes[0, 0]
    for i, row in enumerate(results["settled"] + results["steps"]):
        s = row["sensitivity"].get("seating_radius")
        if s is None:
            continue
        ls = "-" if row["model"] == "clearance" else ("--" if "wide" in row["model"] else ":")
        ax.semilogy(row["sensitivity_t_periods"], np.fmax(_f(s), 1e-12), ls, color=f"C{i}",
                    label=f"{row['model']}, {row['dt_s'] * 1e6:.3g} µs")  # fmt: skip
    ax.set_xlabel("time from the settled start [tooth periods]")
    ax.set_ylabel("|∂x/∂u₀| of every roller's position [m per unit u]")
    ax.set_title("State sensitivity to the seating radius (forward mode, fixed steps)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[0, 1]
    for i, row in enumerate(results["settled"]):
        h = row["horizons"]
        ad = np.abs(_f(row["ad"]["seating_radius"]["sharp"]))
        ax.semilogy(h, ad, "o-", color=f"C{i}", label=f"{row['model']}: AD")
        for j, hh in enumerate(HS):
            fd = row["fd"].get(f"seating_radius {hh:g}")
            if fd:
                ax.semilogy(h, np.abs(_f(fd["sharp"])), "x" if j else "+", color=f"C{i}", alpha=0.5,
                            ms=4 + 2 * j)  # fmt: skip
    ax.set_xlabel("horizon H [tooth periods]: engagement k = H − 0.6")
    ax.set_ylabel("|d(peak of engagement k)/du₀| [N per unit u]")
    ax.set_title("Sharp peak: AD (lines) and central differences h = 1e-3, 1e-4, 1e-5 (marks)",
                 fontsize=9)  # fmt: skip
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)

    ax = axes[1, 0]
    for i, row in enumerate(results["windows"]):
        s = row["summary"]["seating_radius"]["sharp"]
        hs = sorted(s["fd"], key=float)
        x = [float(h) for h in hs]
        label = f"{row['model']}, lead {row['lead_periods']} P: FD of the mean"
        ax.errorbar(x, [s["fd"][h]["mean"] for h in hs], yerr=[1.96 * s["fd"][h]["se"] for h in hs],
                    fmt="o-", color=f"C{i}", capsize=3, label=label)  # fmt: skip
        ax.errorbar(x[0] * 0.5, s["ad_mean"], yerr=1.96 * s["ad_se"], fmt="s", color=f"C{i}",
                    capsize=3, label="… mean AD (at left)")  # fmt: skip
    for t in results.get("truth", []):
        if t["model"] == "clearance" and t["parameter"] == "seating_radius":
            ax.axhspan(*t["slope_ci_per_u"], color="k", alpha=0.15, label="long-run truth, 95 % CI")
    ax.set_xscale("log")
    ax.set_yscale("symlog", linthresh=100)
    ax.set_xlabel("central-difference step h [u]")
    ax.set_ylabel("d(mean per-engagement peak)/du₀ [N per unit u]")
    ax.set_title("Windows restarted from a running chain, averaged (95 % CI)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.set_ylim(top=1e4 * ax.get_ylim()[1])  # room for the legend above the data
    ax.legend(fontsize=7, loc="upper right")

    ax = axes[1, 1]
    labels, mids, los, his = [], [], [], []
    for t in results.get("truth", []):
        labels.append(f"{t['model']}\n{t['parameter']}: long-run FD")
        mids.append(t["slope_per_u"])
        los.append(t["slope_ci_per_u"][0])
        his.append(t["slope_ci_per_u"][1])
    for w in results["windows"]:
        s = w["summary"]["seating_radius"]["sharp"]
        labels.append(f"{w['model']}, lead {w['lead_periods']}\nwindows: mean AD")
        mids.append(s["ad_mean"])
        los.append(s["ad_mean"] - 1.96 * s["ad_se"])
        his.append(s["ad_mean"] + 1.96 * s["ad_se"])
    for row in results["settled"]:
        if row["model"] == "lumped":
            k = len(row["horizons"]) - 1
            for p in row["ad"]:
                labels.append(f"lumped, {p}\nsettled start: AD of (c)")
                mids.append(row["ad"][p]["mean"][k])
                los.append(mids[-1])
                his.append(mids[-1])
    y = np.arange(len(labels))
    ax.errorbar(mids, y, xerr=[np.subtract(mids, los), np.subtract(his, mids)], fmt="o",
                capsize=3, color="k")  # fmt: skip
    ax.axvline(0, color="0.6", lw=0.8)
    ax.set_yticks(y, labels, fontsize=8)
    ax.set_xscale("symlog", linthresh=10)
    ax.set_xlabel("d(mean peak)/du [N per unit u] (95 % CI)")
    ax.set_title("What the designer wants against what the gradients give", fontsize=9)
    ax.grid(True, axis="x", alpha=0.3)
    save_chart(fig, results, path)


# ---------------------------------------------------------------------- main
def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--long-entry", type=int, default=12,
                    help="entry rollers of each long run (default %(default)s)")  # fmt: skip
    ap.add_argument("--leads", type=float, nargs="+", default=[0.05, 0.25],
                    help="window leads before onset [periods] (default %(default)s)")  # fmt: skip
    ap.add_argument("--replot", action="store_true",
                    help="redraw the chart from --out's clearance_gradient.json")  # fmt: skip
    args = parse(ap, argv)
    if args.replot:
        path = args.out / "clearance_gradient.json"
        results = json.loads(path.read_text())
        for row in results["settled"] + results["steps"]:  # (c) undefined before engagement 2
            for d in row["ad"].values():
                d["mean"] = [a if v is not None else None for a, v in
                             zip(d["mean"], row["values"]["mean"], strict=True)]  # fmt: skip
        path.write_text(json.dumps(results, indent=1))
        chart(results, args.out / "clearance_gradient.png")
        return results
    start = time.perf_counter()
    quick = args.quick
    results = header("clearance_gradient", argv) | {
        "scene": f"{CHAIN}, z = {TEETH}, {RPM:g} rpm, {TENSION:g} N, engagement strand, settled",
        "period_s": PERIOD,
        "parameters": list(PARAMS),
        "u_scale_m_per_u": (np.asarray(SPACE.upper - SPACE.lower) / 4).tolist(),
        "dt_s": DT,
        "soft_peak": {"temperature_N": TEMPERATURE, "reference_N": REFERENCE},
    }
    results["statics"] = statics_rows()

    # 1. horizon
    h_clear, h_lumped = (1.6, 2.6) if quick else (2.6, 8.6)
    hs = (1e-4,) if quick else HS
    settled = [settled_run("clearance", None, h_clear, hs=hs, timing=True)]
    if not quick:
        settled.append(settled_run("clearance, wide onsets", None, h_clear, hs=hs))
    settled.append(settled_run("lumped", None, h_lumped, hs=hs if quick else HS[:2]))
    results["settled"] = settled
    checkpoint(results, args.out)

    # 2. step
    one = {"tangents": (0,), "hs": (1e-4,), "fd_params": (0,)}
    dts = [0.25e-6] if quick else [0.25e-6, 0.125e-6]
    models = ["clearance"] if quick else ["clearance", "clearance, wide onsets"]
    results["steps"] = [settled_run(m, dt, 1.6, **one) for dt in dts for m in models]
    checkpoint(results, args.out)

    # 3. windows from running chains
    n_long = 6 if quick else args.long_entry
    runs = {"clearance": long_run("clearance", U0, n_long)}
    if not quick:
        runs["clearance, wide onsets"] = long_run("clearance, wide onsets", U0, n_long)
    seat_hs = (1e-2, 1e-4) if quick else (1e-1, 1e-2, 1e-3, 1e-4)
    flank_hs = (1e-4,) if quick else (1e-2, 1e-4)
    leads = [args.leads[0]] if quick else args.leads
    fewer = ((1e-2, 1e-4), (1e-4,))  # the central differences of the other window rows
    results["windows"] = [
        windows("clearance", runs["clearance"], leads[0], seat_hs, flank_hs, True)
    ]
    # then the wide onsets at the first lead, the nominal model at the other leads
    others = [(m, leads[0]) for m in runs if m != "clearance"]
    others += [("clearance", lead) for lead in leads[1:]]
    results["windows"] += [windows(m, runs[m], lead, *fewer, timing=False) for m, lead in others]
    checkpoint(results, args.out)

    # 4. ground truth
    truth_runs = {"clearance": {}, "lumped": {}}
    for model, params in (("clearance", (0,)), ("lumped", (0, 1))):
        for p in params:
            for sign, name in ((-1, "-"), (1, "+")):
                u = U0.at[p].set(sign * TRUTH_U)
                n_entry = n_long if model == "clearance" else min(n_long, 10)
                truth_runs[model][f"{PARAMS[p]} {name}"] = long_run(model, u, n_entry)
    results["truth"] = [truth("clearance", truth_runs["clearance"], 0)] + [
        truth("lumped", truth_runs["lumped"], p) for p in (0, 1)
    ]
    for t in results["truth"]:
        print(
            f"truth {t['model']}, {t['parameter']}: {t['slope_per_u']:+.3g} N per unit u "
            f"[{t['slope_ci_per_u'][0]:+.3g}, {t['slope_ci_per_u'][1]:+.3g}] "
            f"(means {t['means_N'][0]:.0f} / {t['means_N'][1]:.0f} N, n {t['engagements']})",
            flush=True,
        )
    if "clearance, wide onsets" in runs:
        c = jc.compare_peaks(
            runs["clearance"]["peaks_N"], runs["clearance, wide onsets"]["peaks_N"]
        )
        results["wide_against_nominal"] = {
            "difference_N": c.difference, "relative": c.relative, "ci": [c.ci_low, c.ci_high],
        }  # fmt: skip
        print(f"wide onsets against nominal, long-run mean peak: {c.difference:+.0f} N "
              f"[{c.ci_low:+.0f}, {c.ci_high:+.0f}]")  # fmt: skip
    strip = lambda r: {k: v for k, v in r.items() if k != "states"}  # noqa: E731
    results["long_runs"] = {
        "windows": {m: strip(r) for m, r in runs.items()},
        "truth": {m: {k: strip(r) for k, r in d.items()} for m, d in truth_runs.items()},
    }
    results["cost"] = cost(results)
    out = finish(clean(results), args.out, "clearance_gradient", chart, start)
    (args.out / "clearance_gradient.partial.json").unlink(missing_ok=True)
    return out


def checkpoint(results: dict, out: Path) -> None:
    """The parts measured so far, kept while the study runs (removed at its end)."""
    (out / "clearance_gradient.partial.json").write_text(json.dumps(clean(results), indent=1))


def cost(results: dict) -> dict:
    """Warm value and value + gradient (forward mode, the row's tangents) times, and the
    first calls (compile + one run)."""
    out = {}
    for row in results["settled"] + results["windows"]:
        if row.get("jvp_warm_s") and row.get("value_warm_s"):
            name = row["model"] + (
                f", windows lead {row['lead_periods']} P ({row['members']} vmapped)"
                if "lead_periods" in row
                else f", settled start, {row['horizon_periods']} P"
            )
            out[name] = {
                "value_s": row["value_warm_s"],
                "value_and_grad_s": row["jvp_warm_s"],
                "ratio": row["jvp_warm_s"] / row["value_warm_s"],
                "tangents": row.get("tangents", len(PARAMS)),
                "value_first_s": row["value_first_s"],
                "value_and_grad_first_s": row["jvp_first_s"],
                "compile_value_s": row["value_first_s"] - row["value_warm_s"],
                "compile_value_and_grad_s": row["jvp_first_s"] - row["jvp_warm_s"],
            }
    lr = results["long_runs"]["windows"]["clearance"]
    out["clearance, long adaptive run"] = {
        "wall_s": lr["wall_s"],
        "engagements": len(lr["peaks_N"]),
        "periods": lr["n_entry"] - 0.1,
        "steps": lr["steps"],
    }
    for k, v in out.items():
        if "ratio" in v:
            print(f"cost {k}: value {v['value_s']:.2f} s, value+gradient "
                  f"{v['value_and_grad_s']:.2f} s (×{v['ratio']:.2f})")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
