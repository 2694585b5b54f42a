"""What sets a meshing peak in the clearance-joint chain: the per-engagement peak against
the state of the roller and its joints at impact, and the peak distribution with one piece
of physics switched off at a time.

    python -m benchmarks.clearance_peak            # full study (~21 min on 2 busy cores)
    python -m benchmarks.clearance_peak --quick    # smoke run (3 engagements per variant)
    python -m benchmarks.clearance_peak --resume   # statistics and chart from saved solves
    python -m benchmarks.clearance_peak --chart-only  # the figures again from the JSON

Writes ``benchmarks/results/clearance_peak.json`` and its figures: ``clearance_peak.png``
(the peak against the bush point's approach speed, by link side),
``clearance_peak_rattle.png``, ``clearance_peak_correlations.png`` and
``clearance_peak_variants.png``.

Notes: benchmarks/clearance_peak.md
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import NamedTuple

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.clearance_tools import clean, solve, timed  # noqa: E402
from benchmarks.common import finish, header, parse, parser, save_chart  # noqa: E402
from benchmarks.engagement_stats import CHAIN, DISCARD, TEETH, TENSION, period, strand  # noqa: E402

THRESHOLD, WINDOW = 1.0, 0.5  # EngagementPeaks' defaults [N], [tooth periods]

#: variant -> engagement() keywords (the default joint friction unless None is given)
VARIANTS = {
    "default (Dahl joint friction)": {"fidelity": "clearance"},
    "frictionless joints": {"fidelity": "clearance", "joint_friction": None},
    "roller fixed to bush": {"fidelity": "clearance", "rollers_on_bush": "lumped"},
    "roller fixed to bush, frictionless": {
        "fidelity": "clearance",
        "rollers_on_bush": "lumped",
        "joint_friction": None,
    },
    "lumped chain": {"fidelity": "lumped"},
}
#: controlled pairs (a, b): one piece of physics switched off from a to b
PAIRS = (
    ("default (Dahl joint friction)", "frictionless joints"),  # joint friction off
    ("default (Dahl joint friction)", "roller fixed to bush"),  # rattle off
    ("frictionless joints", "roller fixed to bush, frictionless"),  # rattle off, no friction
    ("roller fixed to bush", "roller fixed to bush, frictionless"),  # friction off, no rattle
    ("default (Dahl joint friction)", "lumped chain"),
)
DEFAULT = "default (Dahl joint friction)"

#: what the observer records per roller at an instant (columns of its records)
FIELDS = (
    "t",  # [s]
    "force",  # roller/tooth normal force [N]
    "approach",  # (d) roller centre's speed toward the tooth surface [m/s]
    "bush_approach",  # the bush point's speed toward the tooth surface [m/s]
    "rattle_n",  # (a) roller − bush velocity along −n (toward the tooth) [m/s]
    "rattle",  # (a) |roller − bush velocity| [m/s]
    "ecc_n",  # (b) (roller − bush)·(−n) / bush/roller clearance
    "ecc",  # (b) |roller − bush| / bush/roller clearance
    "pin_ecc_n",  # (b) (bush − pin)·(−n) / pin clearance
    "pin_ecc",  # (b) |bush − pin| / pin clearance
    "spin",  # (c) roller's angular velocity [rad/s]
    "spin_rel",  # (c) ... relative to its roller link [rad/s]
    "bush_force",  # bush/roller joint force [N]
    "pin_force",  # pin/bush joint force in the same bush [N]
)
COL = {name: i for i, name in enumerate(FIELDS)}

#: the candidate explanatory variables, as correlated with the peak: (record, field, label)
CANDIDATES = (
    ("onset", "rattle_n", "(a) rattle toward tooth at onset [m/s]"),
    ("onset", "rattle", "(a) |roller − bush velocity| at onset [m/s]"),
    ("onset", "ecc_n", "(b) roller eccentricity toward tooth at onset [c]"),
    ("onset", "ecc", "(b) |roller eccentricity| at onset [c]"),
    ("onset", "pin_ecc_n", "(b) pin/bush eccentricity toward tooth at onset [c]"),
    ("onset", "pin_ecc", "(b) |pin/bush eccentricity| at onset [c]"),
    ("onset", "spin", "(c) roller spin at onset [rad/s]"),
    ("onset", "spin_rel", "(c) roller spin relative to its link at onset [rad/s]"),
    ("onset", "approach", "(d) roller approach speed at onset [m/s]"),
    ("onset", "bush_approach", "bush approach speed at onset [m/s]"),
    ("peak_contact", "approach", "approach speed at the start of the peak's contact [m/s]"),
    ("peak_contact", "rattle_n", "rattle toward tooth at the start of the peak's contact [m/s]"),
    ("peak_contact", "bush_approach", "bush approach at the start of the peak's contact [m/s]"),
    ("peak_contact", "ecc_n", "roller eccentricity toward tooth, peak's contact start [c]"),
    (
        "engagement",
        "same_link",
        "meshes on the roller link of the roller seated before (1) or not (0)",
    ),
    ("engagement", "contact_index", "contact (bounce) in which the peak falls"),
    ("engagement", "lag", "peak time − onset [ms]"),
    ("engagement", "onset_periods", "onset [tooth periods] (a trend along the run)"),
    ("at_max", "bush_force", "bush/roller joint force at the peak [N]"),
    ("at_max", "pin_force", "pin/bush joint force at the peak [N]"),
)


# ------------------------------------------------------------------- per-roller geometry
GEO_ARRAYS = (
    "roller_body",
    "roller_offset",
    "bush_body",
    "bush_offset",
    "pin_body",
    "pin_offset",
    "has_pin",
)


def roller_geometry(scene) -> dict:
    """For each roller (static numpy): the body and offset of its bush point (its roller
    link's bush: the bush/roller joint's point a; with the roller fixed to its bush, the
    roller's own point; in the lumped chain the roller), of the pin in that bush (the
    pin/bush joint whose hole is that bush; none at a strand end or in the lumped chain),
    and the clearances. Read from the public ``Scene`` fields (``pairs[0]``: pin/bush
    joints, ``pairs[1]``: bush/roller joints)."""
    body = np.asarray(scene.roller_body)
    off = np.asarray(scene.roller_offset, dtype=float)
    n = len(body)
    geo = {
        "roller_body": body,
        "roller_offset": off,
        "bush_body": body.copy(),
        "bush_offset": off.copy(),
        "pin_body": np.zeros(n, int),
        "pin_offset": np.zeros((n, 2)),
        "has_pin": np.zeros(n, bool),
        "on_joint": False,
        "bush_clearance": math.nan,
        "pin_clearance": math.nan,
    }
    joints = [g for g in scene.pairs if isinstance(g.element, jc.ClearanceJoints)]
    if not joints:
        return geo
    pin = joints[0]  # a: pin link (pin at ra), b: roller link (bush at rb)
    geo["pin_clearance"] = float(pin.element.clearance)
    if len(joints) > 1:  # rollers on their bush/roller joints: a = roller link, b = roller
        bush = joints[1]
        where = {int(b): k for k, b in enumerate(np.asarray(bush.b))}
        k = np.asarray([where[int(b)] for b in body])
        geo["bush_body"] = np.asarray(bush.a)[k]
        geo["bush_offset"] = np.asarray(bush.ra, dtype=float)[k]
        geo["bush_clearance"] = float(bush.element.clearance)
        geo["on_joint"] = True
    pa, pb = np.asarray(pin.a), np.asarray(pin.b)
    pra, prb = np.asarray(pin.ra, dtype=float), np.asarray(pin.rb, dtype=float)
    for r in range(n):
        hit = np.flatnonzero(
            (pb == geo["bush_body"][r]) & np.all(np.isclose(prb, geo["bush_offset"][r]), -1)
        )
        if len(hit):
            geo["pin_body"][r], geo["pin_offset"][r] = pa[hit[0]], pra[hit[0]]
            geo["has_pin"][r] = True
    return geo


def _point(q, v, body, offset):
    """World position and velocity of body-fixed points."""
    c, s = jnp.cos(q[body, 2]), jnp.sin(q[body, 2])
    arm = jnp.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1]], -1)
    x = q[body, :2] + arm
    xd = v[body, :2] + v[body, 2:3] * jnp.stack([-arm[:, 1], arm[:, 0]], -1)
    return x, xd


def features(y: jc.DriveState, scene, geo: dict, rows) -> jax.Array:
    """(len(rows), len(FIELDS) − 1) what :data:`FIELDS` names (all but t) for the rollers
    ``rows`` in state ``y``; NaN where the scene has no such joint. The roller/tooth
    contact is the vector field's (each roller against its nearest gap of the one
    sprocket, ``scene.roller_law``), rebuilt from public pieces."""
    (sp,) = scene.sprockets
    g = {k: jnp.asarray(geo[k])[rows] for k in GEO_ARRAYS}
    xr, vr = _point(y.q, y.v, g["roller_body"], g["roller_offset"])
    xb, vb = _point(y.q, y.v, g["bush_body"], g["bush_offset"])
    xp, vp = _point(y.q, y.v, g["pin_body"], g["pin_offset"])
    theta, omega = y.theta[0], y.omega[0]
    c, s = jnp.cos(theta), jnp.sin(theta)
    rel = xr - sp.centre
    local = jnp.stack([c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1]], -1)
    depth, nl = jax.vmap(jc.gap_contact, in_axes=(None, 0))(sp.profile, local)
    n = jnp.stack([c * nl[:, 0] - s * nl[:, 1], s * nl[:, 0] + c * nl[:, 1]], -1)
    arm_s = rel - scene.roller_radius * n  # contact point from the axis
    vsurf = omega * jnp.stack([-arm_s[:, 1], arm_s[:, 0]], -1)
    toward = lambda u: -jnp.sum(n * u, -1)  # noqa: E731  (component along −n)
    approach = toward(vr - vsurf)
    force = scene.roller_law.normal_force(depth, approach, scene.impact_speed)
    absent = jnp.zeros_like(force)  # (a solve's observed values must be finite: masked later)
    spin = y.v[g["roller_body"], 2]
    out = {
        "force": force,
        "approach": approach,
        "bush_approach": toward(vb - vsurf),
        "spin": spin,
        "spin_rel": spin - y.v[g["bush_body"], 2],
    }
    if geo["on_joint"]:
        el = scene.pairs[1].element
        d, dv = xr - xb, vr - vb
        ell = jnp.sqrt(jnp.sum(d * d, -1))
        rate = jnp.sum(d * dv, -1) / jnp.maximum(ell, 1e-15)
        out.update(
            rattle_n=toward(dv),
            rattle=jnp.sqrt(jnp.sum(dv * dv, -1)),
            ecc_n=toward(d) / geo["bush_clearance"],
            ecc=ell / geo["bush_clearance"],
            bush_force=el.tension(ell, rate, scene.impact_speed),
        )
    if np.isfinite(geo["pin_clearance"]):
        el = scene.pairs[0].element
        d, dv = xb - xp, vb - vp
        ell = jnp.sqrt(jnp.sum(d * d, -1))
        rate = jnp.sum(d * dv, -1) / jnp.maximum(ell, 1e-15)
        has = g["has_pin"]
        out.update(
            pin_ecc_n=jnp.where(has, toward(d) / geo["pin_clearance"], absent),
            pin_ecc=jnp.where(has, ell / geo["pin_clearance"], absent),
            pin_force=jnp.where(has, el.tension(ell, rate, scene.impact_speed), absent),
        )
    return jnp.stack([out.get(k, absent) for k in FIELDS[1:]], -1)


# ------------------------------------------------------------------------------ observer
class Impacts(NamedTuple):
    """:class:`ImpactStates`' state and value, per roller (R,): ``phase`` 0 waiting for
    its engagement, 1 in its window, 2 done (or touching at t0: never armed); records
    (R, len(FIELDS)) at the onset, at the start of the latest contact, at the start of the
    contact holding the largest force, and at the step end of the largest force."""

    force: jax.Array  # at the last step end [N]
    phase: jax.Array
    end: jax.Array  # window end [s]
    contacts: jax.Array  # contacts (threshold crossings) so far in the window
    contact_index: jax.Array  # ... the one holding the largest force (1 = the first)
    top: jax.Array  # largest step-end force in the window [N]
    onset: jax.Array
    contact: jax.Array
    peak_contact: jax.Array
    at_max: jax.Array


class ImpactStates(jc.observers.AbstractStepObserver):
    """Per roller of an open strand (one engagement each): the state of the roller and its
    joints (:func:`features`) at the onset of its engagement and at the start of each
    contact in the window of ``window`` tooth periods after it (the start of the contact
    holding the largest force kept), read at accepted step ends; a crossing of
    ``threshold`` is interpolated linearly between two step ends and the state there taken
    from the solver's dense interpolant (one vmapped evaluation over the rollers, only in
    steps where some roller crosses). Onset and arming as
    :class:`jc.observers.EngagementPeaks`: a roller touching at t0 is never armed."""

    geo: dict
    threshold: float
    window: float

    def _features(self, y, scene, rows):
        return features(y, scene, self.geo, rows)

    def init(self, t0, y0, scene):
        rows = np.arange(scene.n_rollers)
        f0 = self._features(y0, scene, rows)[:, 0]
        blank = jnp.zeros((len(rows), len(FIELDS)))
        zero = jnp.zeros_like(f0)
        count = jnp.zeros(f0.shape, jnp.int32)
        phase = jnp.where(f0 <= self.threshold, 0, 2).astype(jnp.int32)
        return Impacts(f0, phase, zero, count, count, zero, blank, blank, blank, blank)

    def step(self, t0, t1, y0, y1, dense, scene, state):
        st, thr = state, self.threshold
        rows = np.arange(scene.n_rollers)
        feat1 = self._features(y1, scene, rows)
        f1 = feat1[:, 0]
        up = (st.force <= thr) & (f1 > thr)
        rise = jnp.where(up, f1 - st.force, 1.0)
        t_c = t0 + jnp.clip((thr - st.force) / rise, 0.0, 1.0) * (t1 - t0)
        in_win = (st.phase == 1) & (t1 <= st.end)
        start = up & (st.phase == 0)
        new = start | (up & in_win)

        def at_crossings():
            ys = dense(t_c)  # one state per roller, at its own crossing time
            one = lambda y, r: self._features(y, scene, r[None])[0]  # noqa: E731
            return jax.vmap(one)(ys, jnp.asarray(rows))

        snap = jax.lax.cond(jnp.any(new), at_crossings, lambda: jnp.zeros_like(feat1))
        rec = jnp.concatenate([t_c[:, None], snap], -1)
        now = jnp.concatenate([jnp.full_like(f1, t1)[:, None], feat1], -1)
        teeth = scene.sprockets[0].profile.teeth
        per = 2 * jnp.pi / (teeth * jnp.maximum(jnp.abs(y1.omega[0]), 1e-12))
        onset = jnp.where(start[:, None], rec, st.onset)
        contact = jnp.where(new[:, None], rec, st.contact)
        contacts = jnp.where(start, 1, st.contacts + (up & in_win))
        end = jnp.where(start, t_c + self.window * per, st.end)
        higher = start | (in_win & (f1 > st.top))
        closing = (st.phase == 1) & (t1 > st.end)
        return Impacts(
            force=f1,
            phase=jnp.where(start, 1, jnp.where(closing, 2, st.phase)).astype(jnp.int32),
            end=end,
            contacts=contacts,
            contact_index=jnp.where(higher, contacts, st.contact_index),
            top=jnp.where(higher, f1, st.top),
            onset=onset,
            contact=contact,
            peak_contact=jnp.where(higher[:, None], contact, st.peak_contact),
            at_max=jnp.where(higher[:, None], now, st.at_max),
        )

    def value(self, state, t0, t1):
        return state


# --------------------------------------------------------------------------------- runs
def run(rpm: float, n_entry: int, variant: dict) -> dict:
    """One solve of the strand to its horizon with both observers; the engagements after
    the start transient with their peaks and impact records."""
    sc, statics_s = timed(strand, rpm, n_entry, **variant)
    per = period(rpm)
    t1 = float(sc.horizon)
    obs = (
        jc.observers.EngagementPeaks(window=WINDOW, threshold=THRESHOLD),
        ImpactStates(roller_geometry(sc), THRESHOLD, WINDOW),
    )
    sol, wall = solve(sc, t1, obs, n_save=2)
    row = {
        "ok": bool(sol.ok),
        "result": sol.result_name,
        "steps": int(sol.stats["num_steps"]),
        "wall_s_with_compile": wall,
        "statics_s": statics_s,
        "t1_s": t1,
        "tooth_period_s": per,
    }
    if not sol.ok:
        print(f"    FAILED: {sol.message}", flush=True)
        return row
    eng = jc.engagement_peaks(sol, t_start=DISCARD * per)
    every = jc.engagement_peaks(sol)  # with the start transient: who meshed before whom
    imp = jax.tree_util.tree_map(np.asarray, sol.observed[1])
    r = eng.roller
    geo = obs[1].geo
    for name in ("onset", "contact", "peak_contact", "at_max"):  # absent joints: NaN
        a = getattr(imp, name).copy()
        if not geo["on_joint"]:
            a[:, [COL[f] for f in ("rattle_n", "rattle", "ecc_n", "ecc", "bush_force")]] = np.nan
        for f in ("pin_ecc_n", "pin_ecc", "pin_force"):
            a[~geo["has_pin"], COL[f]] = np.nan
        imp = imp._replace(**{name: a})
    rec = {
        name: {f: listed(getattr(imp, name)[r, COL[f]]) for f in FIELDS}
        for name in ("onset", "peak_contact", "at_max")
    }
    before = [
        every.roller[every.onset < t][-1] if np.any(every.onset < t) else -1 for t in eng.onset
    ]
    bush = geo["bush_body"]
    same = [float(bush[a] == bush[b]) if b >= 0 else np.nan for a, b in zip(r, before, strict=True)]
    row.update(
        n=len(eng),
        roller=r.tolist(),
        onset_s=eng.onset.tolist(),
        t_peak_s=eng.t_peak.tolist(),
        peak_N=eng.peak.tolist(),
        engagement={
            "contacts": imp.contacts[r].tolist(),
            "contact_index": imp.contact_index[r].tolist(),
            "same_link": listed(same),
            "lag": ((eng.t_peak - eng.onset) * 1e3).tolist(),
            "step_end_top_N": imp.top[r].tolist(),
        },
        records=rec,
        # the two observers' agreement (the same threshold, different sampling)
        onset_difference_us=float(np.max(np.abs(imp.onset[r, 0] - eng.onset)) * 1e6),
        top_over_peak=[float(np.min(imp.top[r] / eng.peak)), float(np.max(imp.top[r] / eng.peak))],
    )
    return row


def listed(a) -> list:
    """A JSON list, NaN as null."""
    return clean(np.asarray(a, dtype=float).tolist())


def impedance(by: dict) -> dict:
    """Per variant: the peak over the approach speed at onset [N·s/m] (an impact of a mass
    m on a contact of stiffness k peaks at v·√(k·m) for a linear law), and how much of
    the peaks' scatter is the approach speed's and how much the ratio's (coefficients of
    variation); then the peak against the approach speed over all variants' engagements."""
    out, xs, ys = {}, [], []
    for name, row in by.items():
        if not row.get("ok") or row["n"] < 2:
            continue
        y, v = np.asarray(row["peak_N"]), values(row, "onset", "approach")
        ratio = y / v
        cv = lambda a: float(np.std(a, ddof=1) / np.mean(a))  # noqa: E731
        out[name] = {
            "approach_mean_m_s": float(v.mean()),
            "approach_cv": cv(v),
            "peak_cv": cv(y),
            "peak_over_approach_mean_Ns_m": float(ratio.mean()),
            "peak_over_approach_cv": cv(ratio),
        }
        xs.append(v)
        ys.append(y)
    if xs:
        out["all variants: peak against approach at onset"] = correlate(
            np.concatenate(xs), np.concatenate(ys)
        )
    return out


#: which roller of its roller link meshes (``engagement.same_link``): the first, its
#: bush joined through a pin link to the roller seated before; or the second, on a roller
#: link already seated at its other bush
SIDES = {0.0: "first roller of its link", 1.0: "second roller of its link"}


def link_sides(row: dict) -> dict:
    """The engagements split by :data:`SIDES`: peak statistics, approach speed at onset,
    peak over approach speed, and the second side against the first (``compare_peaks``)."""
    side = values(row, "engagement", "same_link")
    y, v = np.asarray(row["peak_N"]), values(row, "onset", "approach")
    out = {}
    for key, name in SIDES.items():
        m = side == key
        if m.sum() < 2:
            return {}
        ratio = y[m] / v[m]
        out[name] = {
            "statistics": stats_of(y[m]),
            "approach_mean_m_s": float(v[m].mean()),
            "peak_over_approach_mean_Ns_m": float(ratio.mean()),
            "peak_over_approach_cv": float(np.std(ratio, ddof=1) / ratio.mean()),
        }
    out["second against first"] = comparison(y[side == 0.0], y[side == 1.0])
    return out


def summarize(by: dict) -> dict:
    """Per variant: its peak statistics, and for each controlled pair the difference."""
    out = {}
    for name, row in by.items():
        entry = {"ok": row["ok"], "steps": row["steps"]}
        if row["ok"] and row["n"] >= 2:
            entry["statistics"] = stats_of(row["peak_N"])
            entry["by_link_side"] = link_sides(row)
            idx = np.asarray(row["engagement"]["contact_index"])
            entry["peak_in_contact"] = {str(k): int(np.sum(idx == k)) for k in np.unique(idx)}
            entry["contacts_per_window_median"] = float(np.median(row["engagement"]["contacts"]))
        out[name] = entry
    out["impedance"] = impedance(by)
    out["pairs"] = []
    for a, b in PAIRS:
        ra, rb = by.get(a), by.get(b)
        if ra and rb and ra["ok"] and rb["ok"] and min(ra["n"], rb["n"]) >= 2:
            out["pairs"].append({"a": a, "b": b, **comparison(ra["peak_N"], rb["peak_N"])})
    return out


#: linear models of the peak (record, field): the link (which roller of its link, the
#: bush point's approach speed) and the roller's rattle (velocity relative to the bush,
#: eccentricity, spin) apart and together
LINK = (("engagement", "same_link"), ("onset", "bush_approach"))
RATTLE = (("onset", "rattle_n"), ("onset", "rattle"), ("onset", "ecc_n"), ("onset", "spin"))
MODELS = {"link": LINK, "rattle": RATTLE, "link + rattle": LINK + RATTLE}


def _fit(y, x):
    """Least squares of standardized y on standardized columns x: (RSS, coefficients)."""
    xs = (x - x.mean(0)) / x.std(0)
    ys = (y - y.mean()) / y.std()
    a = np.column_stack([np.ones(len(y)), xs])
    coef, *_ = np.linalg.lstsq(a, ys, rcond=None)
    return float(np.sum((ys - a @ coef) ** 2)), coef[1:]


def regression(runs: dict, variant: str) -> dict:
    """Least squares of the peak on each of :data:`MODELS` at the main operating point
    (the first speed; columns constant over the engagements dropped): R², adjusted R²,
    standardized coefficients; and the F test of the rattle added to the link."""
    rpm = next(iter(runs))
    r = runs[rpm].get(variant)
    if not r or not r.get("ok"):
        return {}
    y = np.asarray(r["peak_N"])
    cols = {m: values(r, *m) for m in LINK + RATTLE}
    ok = np.all(np.isfinite(np.column_stack(list(cols.values()))), axis=1)
    n = int(ok.sum())
    out, rss = {"rpm": rpm, "n": n}, {}
    for name, model in MODELS.items():
        used = [m for m in model if np.ptp(cols[m][ok]) > 0]
        k = len(used)
        if n <= k + 2:
            continue
        rss[name], coef = _fit(y[ok], np.column_stack([cols[m][ok] for m in used]))
        r2 = 1 - rss[name] / n  # standardized y: total sum of squares n
        out[name] = {
            "k": k,
            "r2": r2,
            "adjusted_r2": 1 - (1 - r2) * (n - 1) / (n - k - 1),
            "standardized_coefficients": {
                f"{rec}.{f}": float(c) for (rec, f), c in zip(used, coef, strict=True)
            },
        }
    if "link" in out and "link + rattle" in out:
        k0, k1 = out["link"]["k"], out["link + rattle"]["k"]
        f = ((rss["link"] - rss["link + rattle"]) / (k1 - k0)) / (
            rss["link + rattle"] / (n - k1 - 1)
        )
        out["rattle added to link: F"] = float(f)
        out["rattle added to link: p"] = float(stats.f.sf(f, k1 - k0, n - k1 - 1))
    return out


def stats_of(peaks) -> dict:
    return jc.peak_statistics(np.asarray(peaks))._asdict()


def comparison(a, b) -> dict:
    c = jc.compare_peaks(np.asarray(a), np.asarray(b))._asdict()
    c.pop("a"), c.pop("b")
    return c


def values(row: dict, record: str, field: str) -> np.ndarray:
    if field == "onset_periods":
        return np.asarray(row["onset_s"]) / row["tooth_period_s"]
    if record == "engagement":
        return np.asarray(row["engagement"][field], dtype=float)
    return np.asarray(row["records"][record][field], dtype=float)


def correlate(x, y) -> dict:
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    n = int(ok.sum())
    if n < 4 or np.ptp(x[ok]) == 0:
        return {"n": n, "pearson": None, "pearson_p": None, "spearman": None, "spearman_p": None}
    pr, sr = stats.pearsonr(x[ok], y[ok]), stats.spearmanr(x[ok], y[ok])
    return {
        "n": n,
        "pearson": float(pr.statistic),
        "pearson_p": float(pr.pvalue),
        "spearman": float(sr.statistic),
        "spearman_p": float(sr.pvalue),
    }


def correlations(runs: dict, variant: str) -> dict:
    """Peak against each candidate, per operating point and pooled over them (the peak
    and candidate each standardized per operating point before pooling, so the speed's
    own effect on both does not make a correlation); at the main operating point also
    within each of :data:`SIDES`."""
    out = {}
    for rec, field, label in CANDIDATES:
        row, pooled_x, pooled_y = {}, [], []
        for rpm, by in runs.items():
            r = by.get(variant)
            if not r or not r.get("ok"):
                continue
            x, y = values(r, rec, field), np.asarray(r["peak_N"])
            row[rpm] = correlate(x, y)
            if rpm == next(iter(runs)):
                side = values(r, "engagement", "same_link")
                for key, name in SIDES.items():
                    row[f"{rpm}, {name}"] = correlate(x[side == key], y[side == key])
            ok = np.isfinite(x)
            if ok.sum() > 2 and np.std(x[ok]) > 0:
                pooled_x.append((x - np.nanmean(x)) / np.nanstd(x))
                pooled_y.append((y - y.mean()) / y.std())
        if len(runs) > 1:
            row["pooled (standardized per speed)"] = correlate(
                np.concatenate(pooled_x), np.concatenate(pooled_y)
            )
        out[f"{rec}.{field}"] = {"label": label, **row}
    return out


# ---------------------------------------------------------------------------------- chart
#: the 2×2 of :func:`_chart_link`: (joint friction on/off) × (roller on its bush joint/fixed)
GRID = (
    (DEFAULT, "roller fixed to bush"),
    ("frictionless joints", "roller fixed to bush, frictionless"),
)
#: the rattle quantities of :func:`_chart_rattle`
RATTLE_SHOWN = (
    ("onset", "rattle"),
    ("onset", "rattle_n"),
    ("onset", "ecc_n"),
    ("onset", "pin_ecc_n"),
)
#: the candidates' names on the correlation chart (``record.field`` -> short label)
SHORT_LABEL = {
    "onset.rattle_n": "(a) rattle toward tooth",
    "onset.rattle": "(a) |roller − bush velocity|",
    "onset.ecc_n": "(b) roller eccentricity toward tooth",
    "onset.ecc": "(b) |roller eccentricity|",
    "onset.pin_ecc_n": "(b) pin/bush eccentricity toward tooth",
    "onset.pin_ecc": "(b) |pin/bush eccentricity|",
    "onset.spin": "(c) roller spin",
    "onset.spin_rel": "(c) roller spin relative to its link",
    "onset.approach": "(d) roller approach speed",
    "onset.bush_approach": "bush point's approach speed",
    "peak_contact.approach": "peak's contact: roller approach speed",
    "peak_contact.rattle_n": "peak's contact: rattle toward tooth",
    "peak_contact.bush_approach": "peak's contact: bush approach speed",
    "peak_contact.ecc_n": "peak's contact: roller eccentricity",
    "engagement.same_link": "second roller of its link (0/1)",
    "engagement.contact_index": "contact (bounce) holding the peak",
    "engagement.lag": "peak time − onset",
    "engagement.onset_periods": "onset time (a drift along the run)",
    "at_max.bush_force": "bush/roller joint force at the peak",
    "at_max.pin_force": "pin/bush joint force at the peak",
}
#: the two quantities the claim names (bold on the correlation chart)
LINK_KEYS = ("onset.bush_approach", "engagement.same_link")
SHORT = {DEFAULT: "default (Dahl friction)", "frictionless joints": "frictionless joints"}
TAG = {
    DEFAULT: "default",
    "frictionless joints": "frictionless",
    "roller fixed to bush": "fixed",
    "roller fixed to bush, frictionless": "fixed,\nfrictionless",
    "lumped chain": "lumped",
}
#: which roller of its link meshes: marker colour and fill (open: first, filled: second)
SIDE_STYLE = {0.0: ("C0", "none"), 1.0: ("C1", "C1")}
#: the variants' colours (none of :data:`SIDE_STYLE`'s, nor the p95 bars' red)
COLOUR = dict(zip(VARIANTS, ("C2", "C4", "C5", "C9", "C7"), strict=True))
#: text sizes [pt]: every text on the charts is at least 8 pt
STYLE = {
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "legend.fontsize": 8,
}


def figure_path(path, suffix: str) -> Path:
    """``clearance_peak_<suffix>.png`` beside ``path``."""
    path = Path(path)
    return path.with_name(f"{path.stem}_{suffix}{path.suffix}")


def _rho(c: dict | None) -> str:
    """'ρ = +0.51 (p 0.002, n 33)' or '—'."""
    if not c or c.get("spearman") is None:
        return "—"
    return f"ρ = {c['spearman']:+.2f} (p {c['spearman_p']:.1g}, n {c['n']})"


def _r_rho(c: dict | None) -> str:
    """'r = +0.57, ρ = +0.51 (p 0.002)' or '—'."""
    if not c or c.get("spearman") is None:
        return "—"
    return f"r = {c['pearson']:+.2f}, ρ = {c['spearman']:+.2f} (p {c['spearman_p']:.1g})"


def _by_side(ax, row: dict, rec: str, field: str, ms: float = 6.0) -> None:
    """The engagements' peaks against ``rec.field``, open for the first roller of its
    link, filled for the second (labelled for a legend)."""
    x, y = values(row, rec, field), np.asarray(row["peak_N"])
    side = values(row, "engagement", "same_link")
    for key, name in SIDES.items():
        colour, fill = SIDE_STYLE[key]
        m = side == key
        if m.any():
            ax.plot(x[m], y[m], "o", ms=ms, mec=colour, mfc=fill, mew=1.2, alpha=0.85, label=name)


def _side_legend(fig, title: str | None = None) -> None:
    """The figure's legend of :data:`SIDE_STYLE`, at the bottom."""
    from matplotlib.lines import Line2D

    handles = [
        Line2D([], [], ls="", marker="o", ms=6, mec=colour, mfc=fill, mew=1.2)
        for colour, fill in (SIDE_STYLE[k] for k in SIDES)
    ]
    labels = [f"{'filled' if k else 'open'}: {name}" for k, name in SIDES.items()]
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=9, title=title)


def _note(ax, lines: list[str], loc: str = "upper left") -> None:
    """A boxed note in a corner of ``ax``."""
    x, ha = (0.03, "left") if "left" in loc else (0.97, "right")
    y, va = (0.97, "top") if "upper" in loc else (0.03, "bottom")
    ax.text(
        x,
        y,
        "\n".join(lines),
        transform=ax.transAxes,
        ha=ha,
        va=va,
        fontsize=8,
        bbox={"boxstyle": "round", "fc": "white", "ec": "0.7", "alpha": 0.9},
    )


def _chart_link(results: dict, path) -> None:
    """What sets the peak: the peak against the bush point's approach speed at onset, by
    which roller of its link meshes; joint friction on (top) and off (bottom), the roller
    on its bush joint (left) and fixed to its bush (right)."""
    import matplotlib.pyplot as plt

    runs = results["runs"]
    rpm = next(iter(runs))
    by, vs = runs[rpm], results["variants"][rpm]
    corr, reg = results.get("correlations", {}), results.get("regression", {})
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.4), sharex="row", squeeze=False)
    for i, pair in enumerate(GRID):
        for j, name in enumerate(pair):
            ax = axes[i, j]
            row = by.get(name, {})
            ax.set_title(f"{name}: {rpm} rpm", fontsize=10)
            if not row.get("ok"):
                ax.text(0.5, 0.5, "not run", transform=ax.transAxes, ha="center")
                continue
            _by_side(ax, row, "onset", "bush_approach")
            c = corr.get(name, {}).get("onset.bush_approach", {})
            lines = [f"all: {_r_rho(c.get(rpm))}"]
            lines += [
                f"{n.split(' of')[0]}: {_r_rho(c.get(f'{rpm}, {n}'))}" for n in SIDES.values()
            ]
            d = vs.get(name, {}).get("by_link_side", {}).get("second against first")
            if d:
                lines.append(
                    f"second − first: {d['difference']:+.0f} N ({d['relative']:+.0%}), "
                    f"95 % CI [{d['ci_low']:+.0f}, {d['ci_high']:+.0f}]"
                )
            if reg.get(name, {}).get("link"):
                lines.append(
                    f"R² of the peak on link side + bush approach: {reg[name]['link']['r2']:.3f}"
                )
            # a complete split of the peaks by side: every peak above a level is a second roller
            side, pk = values(row, "engagement", "same_link"), np.asarray(row["peak_N"])
            if (side == 0.0).any() and (side == 1.0).any():
                top_first, low_second = pk[side == 0.0].max(), pk[side == 1.0].min()
                if top_first < low_second:
                    ax.axhline(top_first, color="0.4", ls=":", lw=1)
                    lines.append(f"dotted: every peak above {top_first:.0f} N is a second roller")
            _note(ax, lines)
            ax.set_xlabel("bush point's approach speed toward the tooth at onset [m/s]")
            ax.set_ylabel("engagement peak [N]")
            # room for the note above the data
            lo, hi = ax.get_ylim()
            ax.set_ylim(lo, hi + (0.1 + 0.07 * len(lines)) * (hi - lo))
    _side_legend(fig)
    save_chart(fig, results, path, rect=(0, 0.04, 1, 0.98))


def _chart_rattle(results: dict, path) -> None:
    """The rattle at onset against the peak in the default variant, by link side: the
    correlation over all engagements, and within each side."""
    import matplotlib.pyplot as plt

    runs = results["runs"]
    rpm = next(iter(runs))
    row = runs[rpm].get(DEFAULT, {})
    corr = results.get("correlations", {}).get(DEFAULT, {})
    labels = {f"{r}.{f}": lab for r, f, lab in CANDIDATES}
    fig, axes = plt.subplots(2, 2, figsize=(11, 8.4), sharey=True, squeeze=False)
    for ax, (rec, field) in zip(axes.flat, RATTLE_SHOWN, strict=True):
        key = f"{rec}.{field}"
        if row.get("ok") and np.isfinite(values(row, rec, field)).any():
            _by_side(ax, row, rec, field)
        c = corr.get(key, {})
        lines = [f"all: {_rho(c.get(rpm))}"]
        lines += [f"{n.split(' of')[0]}: {_rho(c.get(f'{rpm}, {n}'))}" for n in SIDES.values()]
        _note(ax, lines)
        ax.set_xlabel(labels[key])
        ax.margins(y=0.08)
    for ax in axes[:, 0]:
        ax.set_ylabel("engagement peak [N]")
    lo, hi = axes[0, 0].get_ylim()
    axes[0, 0].set_ylim(lo, hi + 0.3 * (hi - lo))
    _side_legend(
        fig, f"{DEFAULT}, {rpm} rpm: the roller's rattle at onset ([c]: the joint's clearance)"
    )
    save_chart(fig, results, path, rect=(0, 0.07, 1, 0.98))


def _chart_correlations(results: dict, path) -> None:
    """Spearman ρ of every candidate with the peak: over all engagements with and without
    joint friction (left), and within each side of the link with friction (right), each
    with its p = 0.05 band."""
    import matplotlib.pyplot as plt

    rpm = next(iter(results["runs"]))
    corr = results.get("correlations", {})
    keys = [f"{r}.{f}" for r, f, _ in CANDIDATES]
    ypos = np.arange(len(keys))
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 8), sharey=True, squeeze=False)
    panels = (
        (
            f"{rpm} rpm, all engagements",
            [(name, short, rpm, COLOUR[name]) for name, short in SHORT.items()],
        ),
        (
            f"{rpm} rpm, {SHORT[DEFAULT]}: within each side",
            [(DEFAULT, n, f"{rpm}, {n}", SIDE_STYLE[k][0]) for k, n in SIDES.items()],
        ),
    )
    for ax, (title, bars) in zip(axes[0], panels, strict=True):
        height = 0.8 / len(bars)
        ns, missing = [], []
        for j, (name, label, at, colour) in enumerate(bars):
            cs = [corr.get(name, {}).get(k, {}).get(at) or {} for k in keys]
            rho = [np.nan if c.get("spearman") is None else c["spearman"] for c in cs]
            ns += [c["n"] for c in cs if c.get("n")]
            off = (j - (len(bars) - 1) / 2) * height
            ax.barh(ypos + off, rho, height=height, color=colour, label=label)
            missing.append(
                [(y, label) for y, r in zip(ypos + off, rho, strict=True) if np.isnan(r)]
            )
        # a candidate constant over the engagements (or too few of them) has no ρ
        for i in ypos:
            gone = [(y, lab) for m in missing for y, lab in m if round(y) == i]
            if len(gone) == len(bars):
                ax.text(0.02, i, "no ρ: constant", va="center", fontsize=8, color="0.4")
            elif gone:
                for y, lab in gone:
                    ax.text(
                        0.02, y, f"no ρ ({lab}): constant", va="center", fontsize=8, color="0.4"
                    )
        if ns and min(ns) > 3:
            n_lo, n_hi = min(ns), max(ns)
            band = 1.96 / math.sqrt(n_hi - 1)
            n_text = (
                f"n = {n_hi}"
                if n_lo == n_hi
                else f"n = {n_hi}; {1.96 / math.sqrt(n_lo - 1):.2f} at n = {n_lo}"
            )
            ax.axvspan(
                -band, band, color="0.9", zorder=0, label=f"|ρ| < {band:.2f}: p > 0.05 ({n_text})"
            )
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlim(-1, 1)
        ax.set_xlabel("Spearman ρ with the engagement peak")
        ax.set_title(title)
        ax.legend(loc="lower left", bbox_to_anchor=(0, 1.04), ncol=1, frameon=False)
        ax.grid(axis="x", color="0.85", lw=0.5)
    ax = axes[0, 0]
    ax.set_yticks(ypos, [SHORT_LABEL.get(k, k) for k in keys])
    for k, tick in zip(keys, ax.get_yticklabels(), strict=True):
        if k in LINK_KEYS:
            tick.set_fontweight("bold")
    ax.invert_yaxis()
    ax.set_ylabel("(a)–(d), bush point: at the onset of contact")
    save_chart(fig, results, path, rect=(0, 0, 1, 0.98))


def _chart_variants(results: dict, path) -> None:
    """The variants: per-engagement peaks with mean ± 95 % CI and p95; the coefficients
    of variation of the peak, the approach speed and their ratio; the peaks in meshing
    order."""
    import matplotlib.pyplot as plt

    runs = results["runs"]
    rpm = next(iter(runs))
    by, vs = runs[rpm], results["variants"][rpm]
    names = [n for n in VARIANTS if by.get(n, {}).get("ok")]
    colour = COLOUR
    fig = plt.figure(figsize=(12, 9))
    gs = fig.add_gridspec(2, 2, height_ratios=(1.15, 1), width_ratios=(1, 1.3))

    ax = fig.add_subplot(gs[0, :])
    for i, name in enumerate(names):
        pk = np.asarray(by[name]["peak_N"])
        side = values(by[name], "engagement", "same_link")
        jitter = 0.2 * (np.random.default_rng(i).random(len(pk)) - 0.5)
        for key in SIDES:
            m = side == key if key else side != 1.0
            ax.plot(
                i + jitter[m],
                pk[m],
                "o",
                ms=4.5,
                mec=colour[name],
                mfc=colour[name] if key else "none",
                alpha=0.7,
            )
        st = vs.get(name, {}).get("statistics")
        if not st:
            continue
        ax.errorbar(
            i + 0.25,
            st["mean"],
            yerr=[[st["mean"] - st["ci_low"]], [st["ci_high"] - st["mean"]]],
            fmt="o",
            color="k",
            capsize=4,
        )
        ax.plot(i + 0.25, st["p95"], "_", color="C3", ms=16, mew=2)
        ax.annotate(
            f"mean {st['mean']:.0f} N\np95 {st['p95']:.0f} N\nCV {st['std'] / st['mean']:.0%}",
            (i + 0.34, st["mean"]),
            fontsize=8,
            va="center",
        )
    ax.set_xticks(range(len(names)), [n.replace(", ", ",\n").replace(" (", "\n(") for n in names])
    ax.set_xlim(-0.4, len(names) - 0.15)
    ax.set_ylabel("engagement peak [N]")
    n = min((vs.get(k, {}).get("statistics", {}).get("n", 0) for k in names), default=0)
    ax.set_title(
        f"{rpm} rpm, {n} engagements each: peaks (open: first roller of its link, filled: "
        "second), mean ± 95 % CI (black), p95 (red bar)"
    )

    # where the scatter is: the approach speed's or the peak per approach speed's
    ax = fig.add_subplot(gs[1, 0])
    imp = vs.get("impedance", {})
    shown = [n for n in names if n in imp]
    width = 0.27
    for j, (k, lab) in enumerate(
        (
            ("peak_cv", "peak"),
            ("approach_cv", "approach speed at onset"),
            ("peak_over_approach_cv", "peak / approach speed"),
        )
    ):
        ax.bar(
            np.arange(len(shown)) + (j - 1) * width,
            [imp[n][k] for n in shown],
            width,
            color=("0.2", "0.55", "0.85")[j],
            edgecolor="k",
            lw=0.5,
            label=lab,
        )
    ax.set_xticks(range(len(shown)), [TAG[n] for n in shown])
    ax.yaxis.set_major_formatter(plt.matplotlib.ticker.PercentFormatter(1.0, decimals=0))
    ax.set_ylabel("coefficient of variation over engagements")
    ax.set_title("scatter of the peak, the approach speed, their ratio")
    ax.legend()

    # the peaks in meshing order
    ax = fig.add_subplot(gs[1, 1])
    for name in names:
        r = by[name]
        ax.plot(
            np.asarray(r["onset_s"]) / r["tooth_period_s"],
            r["peak_N"],
            "o-",
            ms=3,
            lw=0.8,
            color=colour[name],
            label=TAG[name].replace("\n", " "),
        )
    ax.set_xlabel("onset [tooth periods]")
    ax.set_ylabel("engagement peak [N]")
    ax.set_title("peaks in meshing order")
    ax.legend(ncol=3, loc="upper left")
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.2 * (hi - lo))
    save_chart(fig, results, path, rect=(0, 0, 1, 0.98))


def chart(results: dict, path) -> None:
    """``path`` (``clearance_peak.png``): the peak against the bush point's approach speed
    by link side, friction on/off × roller on its joint/fixed; and beside it
    ``clearance_peak_rattle.png`` (the rattle at onset against the peak, by link side),
    ``_correlations.png`` (Spearman ρ of every candidate with the peak) and
    ``_variants.png`` (the variants' peak distributions and where their scatter comes
    from)."""
    import matplotlib.pyplot as plt

    with plt.rc_context(STYLE):
        _chart_link(results, path)
        _chart_rattle(results, figure_path(path, "rattle"))
        _chart_correlations(results, figure_path(path, "correlations"))
        _chart_variants(results, figure_path(path, "variants"))


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--n-entry", type=int, default=35, help="rollers meshing per solve")
    ap.add_argument(
        "--speeds",
        type=float,
        nargs="+",
        default=[1250.0],
        help="driver speeds [rpm], the first the main operating point",
    )
    ap.add_argument(
        "--resume",
        action="store_true",
        help="reuse the solves of an interrupted run (its clearance_peak.partial.json in "
        "--out) or of the last finished one (clearance_peak.json), same options; the result "
        "keeps that run's command, date and machine",
    )
    ap.add_argument(
        "--chart-only",
        action="store_true",
        help="redraw the figures from the saved clearance_peak.json in --out (no solves)",
    )
    args = parse(ap, argv)
    if args.chart_only:
        results = json.loads((args.out / "clearance_peak.json").read_text())
        chart(results, args.out / "clearance_peak.png")
        return results
    start = time.perf_counter()
    results = header("clearance_peak", argv)
    speeds, n_entry = (1250.0,), 5
    if not args.quick:
        speeds, n_entry = tuple(args.speeds), args.n_entry
    partial = args.out / "clearance_peak.partial.json"
    done = {}
    final = args.out / "clearance_peak.json"
    source = partial if partial.exists() else final
    if args.resume and source.exists():
        old = json.loads(source.read_text())
        if old["n_entry"] == n_entry:
            done = old["runs"]
            resumed = {k: results[k] for k in ("command", "date")}
            results = {k: old[k] for k in ("command", "date", "machine")}
            results["resumed_by"] = resumed
            results["solve_wall_s_of_first_run"] = sum(
                r["wall_s_with_compile"] + r["statics_s"]
                for by in done.values()
                for r in by.values()
            )
    results.update(
        chain=CHAIN,
        teeth=TEETH,
        tension_N=TENSION,
        n_entry=n_entry,
        discarded_periods=DISCARD,
        window_periods=WINDOW,
        threshold_N=THRESHOLD,
        variants={},
        runs={},
    )
    runs = results["runs"]
    for rpm in speeds:
        key = f"{rpm:g}"
        runs[key] = {}
        for name, kw in VARIANTS.items():
            print(f"{key} rpm, {name}", flush=True)
            row = done.get(key, {}).get(name) or run(rpm, n_entry, kw)
            runs[key][name] = row
            if row["ok"]:
                s = stats_of(row["peak_N"])
                print(
                    f"    {row['steps']} steps, {row['wall_s_with_compile']:.0f} s: n={s['n']} "
                    f"mean {s['mean']:.0f} N, p95 {s['p95']:.0f}, max {s['max']:.0f}; onsets "
                    f"agree within {row['onset_difference_us']:.2f} µs",
                    flush=True,
                )
        results["variants"][key] = summarize(runs[key])
        for c in results["variants"][key]["pairs"]:
            print(
                f"  {c['b']} − {c['a']}: {c['difference']:+.0f} N ({c['relative']:+.1%}), "
                f"95 % CI [{c['ci_low']:+.0f}, {c['ci_high']:+.0f}] N",
                flush=True,
            )
        print(json.dumps(results["variants"][key]["impedance"], indent=1), flush=True)
        # write as we go: a long run keeps what it measured
        partial.write_text(json.dumps(results))
    results["correlations"] = {name: correlations(runs, name) for name in VARIANTS}
    results["regression"] = {
        name: regression(runs, name) for name in (DEFAULT, "frictionless joints")
    }
    print(json.dumps(results["regression"], indent=1))
    for name, rows in results["correlations"].items():
        print(name)
        for row in rows.values():
            for rpm, c in row.items():
                if rpm != "label" and c["pearson"] is not None:
                    print(
                        f"  {row['label'][:60]:60s} {rpm:>8s}: r={c['pearson']:+.2f} "
                        f"ρ={c['spearman']:+.2f} (n={c['n']}, p={c['spearman_p']:.2g})"
                    )
    out = finish(results, args.out, "clearance_peak", chart, start)
    partial.unlink(missing_ok=True)
    return out


if __name__ == "__main__":
    main()
