"""jaxchain beside EXUDYN on one lumped drive at matched physics, one after the other.

    python -m benchmarks.peers            # ~13 min on 2 shared cores (load 6-8)
    python -m benchmarks.peers --quick    # one mesh period (t1 = 0.012 s)
    python -m benchmarks.peers --rpm 600  # the second speed: results/peers_600rpm.json

Writes ``benchmarks/results/peers.json`` and ``peers.png``. Notes: benchmarks/peers.md
"""

import math
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import finish, header, loadavg, parse, parser, save_chart  # noqa: E402

DRIVE = dict(chain="08B", teeth=(18, 36), n_links=60, load_torque=20.0, pretension=200.0)
RPM, SAVE_DT, DRIVER_INERTIA = 300.0, 1e-4, 1e4
sys.exudynFast = True  # EXUDYN without range checks (~30 % faster), set before its import
MODEL = jc.scenes.ChainModel(joint_friction=None, friction=None, restitution=1.0)
R = [float(jc.ToothProfile.iso606(DRIVE["chain"], z).pitch_radius) for z in DRIVE["teeth"]]


def clock(call):  # result, wall and CPU time (all the process's threads)
    t, c = time.perf_counter(), time.process_time()
    return call(), time.perf_counter() - t, time.process_time() - c


def matched_law(sc) -> tuple[float, object, dict]:
    """EXUDYN's k_c [N/m²] and the jaxchain law equal to EXUDYN's in a seat: a roller of
    radius r in a seat of radius r + ΔR overlaps it by A = (4/3)·r·√(2/ΔR)·δ^1.5."""
    from scipy.optimize import brentq

    r, ri = float(sc.roller_radius), float(sc.sprockets[0].profile.seating_radius)
    f_ref = DRIVE["pretension"] + DRIVE["load_torque"] / R[1]
    depth = brentq(lambda d: float(sc.roller_law.normal_force(d, 0.0, 1.0)) - f_ref, 1e-10, 1e-4)
    geo = 4 / 3 * r * math.sqrt(2 / (ri - r))
    k_c = f_ref / (geo * depth**1.5)
    law = jc.contact.HuntCrossley(stiffness=k_c * geo, exponent=1.5, restitution=1.0, width=1e-8)
    return k_c, law, {"reference_force_N": f_ref, "johnson_depth_m": depth, "exudyn_k_c_N_m2": k_c,
                      "seat_clearance_m": ri - r, "hunt_crossley_K": k_c * geo}  # fmt: skip


def segments(profile, seg: float) -> np.ndarray:
    """The closed outline as (N, 4) segments of length ≈ ``seg``, chord midpoints on it."""
    o = np.asarray(profile.sprocket_outline(1000))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(o, axis=0), axis=1))])
    at = lambda t: np.stack([np.interp(t, s, o[:, 0]), np.interp(t, s, o[:, 1])], -1)
    pts = at(t := np.linspace(0.0, s[-1], int(round(s[-1] / seg)) + 1))
    dev = at(0.5 * (t[:-1] + t[1:])) - 0.5 * (pts[:-1] + pts[1:])
    pts = pts[:-1] + 0.5 * (dev + np.roll(dev, 1, axis=0))
    return np.concatenate([pts, np.roll(pts, -1, axis=0)], 1)


def run_exudyn(sc, k_c: float, seg: float, h: float, t1: float) -> dict:
    import exudyn as exu
    from exudyn import itemInterface as ii

    y0, el, pairs = jc.initial_state(sc), sc.pairs[0].element, sc.pairs[0]
    mbs = (container := exu.SystemContainer()).AddSystem()
    add, node, mark, mnc = mbs.AddObject, mbs.AddNode, mbs.AddMarker, ii.MarkerNodeCoordinate
    gnd = mark(mnc(nodeNumber=node(ii.NodePointGround()), coordinate=0))

    def body(q, v, mass, inertia):
        n = node(ii.NodeRigidBody2D(referenceCoordinates=list(q), initialVelocities=list(v)))
        add(ii.RigidBody2D(mass=mass, inertia=inertia, nodeNumber=n))
        return n, mark(ii.MarkerNodeRigid(nodeNumber=n))

    q0, v0 = np.asarray(y0.q), np.asarray(y0.v)
    rollers = [body(q0[i], v0[i], float(sc.mass[i]), float(sc.inertia[i])) for i in range(len(q0))]
    for a, b in zip(np.asarray(pairs.a), np.asarray(pairs.b), strict=True):
        add(ii.SpringDamper(
            markerNumbers=[rollers[a][1], rollers[b][1]], stiffness=float(el.stiffness),
            damping=float(el.damping), referenceLength=float(el.rest_length)))  # fmt: skip
    hubs = []
    for k, s in enumerate(sc.sprockets):
        n, mk = body([*map(float, s.centre), float(y0.theta[k])], [0.0, 0.0, float(y0.omega[k])],
                     1.0, float(s.inertia) if s.driven else DRIVER_INERTIA)  # fmt: skip
        for c in (0, 1):  # the axis held
            add(ii.CoordinateConstraint(markerNumbers=[gnd, mark(mnc(nodeNumber=n, coordinate=c))]))
        if s.driven:
            mbs.AddLoad(ii.Torque(markerNumber=mk, loadVector=[0, 0, -float(s.torque_load.value)]))
        segs, mat = segments(s.profile, seg), exu.MatrixContainer()
        mat.SetWithDenseMatrix(segs, useDenseMatrix=True)
        data = node(ii.NodeGenericData(initialCoordinates=[0.0] * 3 * len(segs),
                                       numberOfDataCoordinates=3 * len(segs)))  # fmt: skip
        add(ii.ObjectContactCurveCircles(
            markerNumbers=[mk, *(m for _, m in rollers)], nodeNumber=data, segmentsData=mat,
            circlesRadii=[float(sc.roller_radius)] * len(rollers), contactStiffness=k_c,
            contactDamping=0.0, contactModel=0))  # fmt: skip
        hubs.append(n)
    out, ns, sn = exu.OutputVariableType, [n for n, _ in rollers], ii.SensorNode
    sensors = lambda nodes, var: [mbs.AddSensor(sn(nodeNumber=n, outputVariableType=var,
                                                   storeInternal=True)) for n in nodes]  # fmt: skip
    s_w, s_x = sensors(hubs, out.AngularVelocity), sensors(ns, out.Position)
    s_v = sensors(ns, out.Velocity)
    mbs.Assemble()
    ti, so = (st := exu.SimulationSettings()).timeIntegration, st.solution
    ti.numberOfSteps, ti.endTime, ti.verboseMode = int(round(t1 / h)), t1, 0
    ti.explicit.eliminateConstraints, st.parallel.numberOfThreads = True, 1  # 2: slower
    so.file.write, so.sensors.writePeriod = False, SAVE_DT
    _, wall, cpu = clock(lambda: exu.SolveDynamic(mbs, st, solverType=exu.DynamicSolverType.RK44))
    got = lambda ss: np.stack([np.asarray(mbs.GetSensorStoredData(s)) for s in ss], 1)
    w, x, v = got(s_w), got(s_x), got(s_v)
    del container
    return {"ts": w[:, 0, 0], "omega": w[..., 3], "pos": x[..., 1:3], "vel": v[..., 1:3],
            "wall_s": wall, "cpu_s": cpu, "steps": int(ti.numberOfSteps),
            "loadavg": loadavg()}  # fmt: skip


def run_jaxchain(sc, t1: float, repeats: int = 1, **opts) -> dict:
    ts = np.minimum(np.arange(0.0, t1 + 0.5 * SAVE_DT, SAVE_DT), t1)
    go = lambda: jax.block_until_ready(jc.simulate(sc, t1, ts=ts, **opts))
    (_, first, _), *warm = (clock(go) for _ in range(1 + repeats))  # compile, then warm
    sol, wall, cpu = min(warm, key=lambda w: w[1])
    return {"ts": ts, "omega": np.asarray(sol.sprocket_speed), "wall_s": wall, "cpu_s": cpu,
            "walls_s": [w[1] for w in warm],
            "pos": np.asarray(sol.roller_position), "vel": np.asarray(sol.roller_velocity),
            "torque": np.asarray(sol.sprocket_torque), "first_call_s": first,
            "steps": int(sol.stats["num_accepted_steps"]), "loadavg": loadavg()}  # fmt: skip


def span_tensions(sc, run) -> np.ndarray:
    """(T, 2) mean tension of the links in the middle 60 % of the tight and slack spans."""
    el, a, b = jax.tree.map(float, sc.pairs[0].element), *np.asarray([sc.pairs[0].a, sc.pairs[0].b])
    d, dv = run["pos"][:, b] - run["pos"][:, a], run["vel"][:, b] - run["vel"][:, a]
    length = np.linalg.norm(d, axis=-1)
    f = el.stiffness * (length - el.rest_length) + el.damping * np.sum(d * dv, -1) / length
    mid, c = 0.5 * (run["pos"][:, b] + run["pos"][:, a]), float(sc.sprockets[1].centre[0])
    inner = (mid[..., 0] > 0.2 * c) & (mid[..., 0] < 0.8 * c)
    up, lo = inner & (mid[..., 1] > 0), inner & (mid[..., 1] < 0)
    return np.stack([np.sum(f * up, 1) / np.sum(up, 1), np.sum(f * lo, 1) / np.sum(lo, 1)], -1)


def metrics(sc, run) -> dict:
    """Over the last whole mesh periods; driven torque load + I2·Δω2/Δt (both codes)."""
    (z1, z2), (r1, r2) = DRIVE["teeth"], R
    rpm = float(sc.sprockets[0].speed) * 30 / math.pi
    load, f_mesh, t1, w = DRIVE["load_torque"], rpm / 60 * z1, run["ts"][-1], run["omega"]
    ta = t1 - (n := int(t1 * f_mesh + 1e-6)) / f_mesh
    grid = np.linspace(ta, t1, 64 * n, endpoint=False)
    mean = lambda y: float(np.mean(np.interp(grid, run["ts"], y)))
    wave = np.exp(-2j * np.pi * f_mesh * grid)
    line = lambda y: float(2 * abs(np.mean(np.interp(grid, run["ts"], y) * wave)))
    rate = lambda k: float(np.diff(np.interp([ta, t1], run["ts"], w[:, k]))[0] / (t1 - ta))
    t_2 = load + float(sc.sprockets[1].inertia) * rate(1)
    t_1 = mean(run["torque"][:, 0]) if "torque" in run else DRIVER_INERTIA * rate(0)
    diff = mean((sp := span_tensions(sc, run))[:, 0] - sp[:, 1])
    return {"window_s": [float(ta), float(t1)], "mesh_periods": n, "mesh_hz": f_mesh,
            "mean_speed_rad_s": [mean(w[:, 0]), mean(w[:, 1])], "driven_torque_Nm": t_2,
            "driver_torque_Nm": t_1, "tight_minus_slack_N": diff,
            "tension_error": diff * r2 / load - 1,
            "speed_ratio_error": mean(w[:, 1]) / mean(w[:, 0]) / (z1 / z2) - 1,
            "driven_torque_error": t_2 / load - 1, "driver_torque_error": -t_1 * r2 / r1 / load - 1,
            "mesh_speed_line_rad_s": line(w[:, 1]), "mesh_tension_line_N": line(sp[:, 0]),
            "span_means_N": [mean(sp[:, 0]), mean(sp[:, 1])]}  # fmt: skip


def refine(sc, scm, k_c, t_ref: float, seg: float, tol: float, quick: bool) -> dict:
    """EXUDYN's steps (and half the segment) against its finest; jaxchain's rtol against 1e-8."""

    def against(run, ref):  # mesh line and tight − slack against ref's; largest speed gap
        a, b = metrics(sc, run), metrics(sc, ref)
        t = np.linspace(0, ref["ts"][-1], 2001)
        wa, wb = (np.interp(t, r["ts"], r["omega"][:, 1]) for r in (run, ref))
        return {"line": a["mesh_speed_line_rad_s"] / b["mesh_speed_line_rad_s"] - 1,
                "tension": a["tight_minus_slack_N"] / b["tight_minus_slack_N"] - 1,
                "speed": float(np.max(np.abs(wa - wb)) / np.mean(wb))}  # fmt: skip

    fine_h = 5e-6 if quick else 2.5e-6
    cases = [(1e-5, seg), (5e-6, seg)] + ([] if quick else [(2.5e-6, seg), (5e-6, seg / 2)])
    runs = {c: run_exudyn(sc, k_c, c[1], c[0], t_ref) for c in cases}
    rows = [{"dt_s": h, "segment_m": s} | {k: r[k] for k in ("wall_s", "steps", "loadavg")}
            | against(r, runs[(fine_h if s == seg else 5e-6, seg)])
            for (h, s), r in runs.items()]  # fmt: skip
    ok = [r["dt_s"] for r in rows if r["segment_m"] == seg and r["dt_s"] > fine_h
          and abs(r["line"]) <= tol and abs(r["tension"]) <= tol / 10]  # fmt: skip
    fine = run_jaxchain(scm, t_ref, rtol=1e-8, atol=1e-11, max_steps=10**6)
    default = run_jaxchain(scm, t_ref)
    steps = {"steps": [default["steps"], fine["steps"]]}
    return {"horizon_s": t_ref, "tolerance": {"line": tol, "tension": tol / 10}, "exudyn": rows,
            "chosen_dt_s": max(ok, default=fine_h),
            "jaxchain_default_vs_rtol_1e-8": against(default, fine) | steps,
            "exudyn_finest_vs_jaxchain_rtol_1e-8": against(runs[(fine_h, seg)], fine)}  # fmt: skip


TIMES = ("wall_s", "cpu_s", "walls_s", "steps", "loadavg", "first_call_s")
ERRORS = {"speed_ratio_error": "speed ratio", "driven_torque_error": "driven torque",
          "driver_torque_error": "driver torque", "tension_error": "tight − slack"}  # fmt: skip


def chart(res: dict, path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(13, 8.5), dpi=120)
    for i, (name, run) in enumerate(res["runs"].items()):
        tr = res["traces"][name]
        kw = {"color": f"C{i}", "lw": 1, "ls": "-" if name == "exudyn" else "--"}
        t, label = np.asarray(tr["t"]) * 1e3, name.replace("_", ", ")
        ax[0, 0].plot(t, tr["driven_speed"], label=label, **kw)
        ax[0, 1].plot(t, tr["tight"], label=label, **kw)
        ax[0, 1].plot(t, tr["slack"], **kw)
        ax[1, 0].bar(np.arange(4) + (i - 1) * 0.27, [100 * run["metrics"][k] for k in ERRORS],
                     0.27, color=f"C{i}", label=label)  # fmt: skip
        ax[1, 1].bar(i, run["wall_s"], color=f"C{i}")
        text = f"{run['steps']} steps\n{run['wall_s']:.1f} s (CPU {run['cpu_s']:.1f} s)\nload "
        text += f"{run['loadavg'][0]:.1f}"
        ax[1, 1].text(i, run["wall_s"], text, ha="center", va="bottom", fontsize=8)
    ax[0, 0].axhline(res["closed_form"]["driven_speed_rad_s"], color="k", lw=0.6)
    ax[0, 0].set(xlabel="t [ms]", ylabel="driven speed [rad/s]", title="driven speed (—: ω1·z1/z2)")
    ax[0, 1].set(xlabel="t [ms]", ylabel="span tension [N]", title="tight (upper) and slack spans")
    ax[1, 0].set_xticks(np.arange(4), list(ERRORS.values()), fontsize=8)
    ax[1, 0].set(ylabel="error [%]", title="against the closed forms (last whole mesh periods)")
    ax[1, 1].set_xticks(range(3), [n.replace("_", "\n") for n in res["runs"]], fontsize=8)
    w, c = (res["ratio"][f"{k}_exudyn_over_jaxchain_matched"] for k in ("wall", "cpu"))
    title = f"{res['horizon_s']:g} s: EXUDYN / jaxchain (matched law) {w:.1f}× wall, {c:.1f}× CPU"
    ax[1, 1].set(ylabel="wall time [s]", ylim=(0, 1.3 * run["wall_s"]), title=title)  # EXUDYN's
    for a in ax.flat:
        a.grid(alpha=0.3)
        a.title.set_fontsize(10)
        _ = a is ax[1, 1] or a.legend(fontsize=8)
    save_chart(fig, res, path)


NOT_MATCHED = [  # fmt: skip
    "contact law: EXUDYN's overlap area (Winkler) vs jaxchain's Johnson depth law; the matched "
    "Hunt–Crossley δ^1.5 law equals EXUDYN's in a seat, not on a flank (EXUDYN's is softer)",
    "outline: straight segments (EXUDYN) vs exact arcs (jaxchain)",
    "driver: prescribed speed (jaxchain) vs a 1e4 kg·m² body started at that speed (EXUDYN)",
    "driver torque: jaxchain's the mean of its samples (every 0.1 ms), EXUDYN's I1·Δω1/Δt",
]


def main(argv=None) -> dict:
    ap = parser(__doc__, "t1 = 0.012 s (one mesh period), refinement over the same")
    ap.add_argument("--t1", type=float, default=0.1, help="horizon [s] (default %(default)s)")
    ap.add_argument("--segment", type=float, default=2.5e-4, help="EXUDYN outline segment [m]")
    ap.add_argument("--tol", type=float, default=0.02, help="EXUDYN's step: mesh line within "
                    "this of its finest, tight − slack a tenth")  # fmt: skip
    ap.add_argument("--repeats", type=int, default=2, help="timed runs of each code (fastest kept)")
    ap.add_argument("--rpm", type=float, default=RPM, help="driver speed (default %(default)s)")
    args = parse(ap, argv)
    rpm, stem = args.rpm, "peers" if args.rpm == RPM else f"peers_{args.rpm:g}rpm"
    t1, t_ref = (0.012, 0.012) if args.quick else (args.t1, 120 / rpm / DRIVE["teeth"][0] + 1e-9)
    start, res = time.perf_counter(), header("peers", argv)
    res["machine"]["versions"]["exudyn"] = __import__("exudyn").__version__
    (z1, z2), (r1, r2), load = DRIVE["teeth"], R, DRIVE["load_torque"]
    sc = jc.scenes.drive(**DRIVE, speed_rpm=rpm, model=MODEL)
    k_c, law, cal = matched_law(sc)
    scm = jc.scenes.drive(**DRIVE, speed_rpm=rpm, model=MODEL.replace(roller_contact=law))
    el, jl, spr = sc.pairs[0].element, sc.roller_law, sc.sprockets
    res["horizon_s"], res["parameters"] = t1, {  # every parameter both codes get, from the scene
        "drive": DRIVE | {"speed_rpm": rpm, "restitution": 1.0, "link_damping_ratio": 0.05},
        "source": "jc.scenes.drive and jc.initial_state (settled start): sc.mass, sc.inertia, "
        "sc.pairs[0].element, the Sprocket fields, profile.sprocket_outline",
        "roller_mass_kg": float(sc.mass[0]), "roller_spin_inertia_kgm2": float(sc.inertia[0]),
        "roller_radius_m": float(sc.roller_radius), "matched_contact": cal,
        **{f"link_{k}": float(getattr(el, k)) for k in ("stiffness", "damping", "rest_length")},
        **{f"johnson_{k}": float(getattr(jl, k)) for k in ("clearance", "length", "modulus")},
        "sprocket_centres_m": [np.asarray(s.centre).tolist() for s in spr],
        "sprocket_inertias_kgm2": [float(s.inertia) for s in spr], "pitch_radii_m": [r1, r2],
        "exudyn_segment_m": args.segment, "exudyn_driver_inertia_kgm2": DRIVER_INERTIA,
        "not_matched": NOT_MATCHED}  # fmt: skip
    res["closed_form"] = {"speed_ratio": z1 / z2, "driven_torque_Nm": load,
                          "driven_speed_rad_s": rpm * math.pi / 30 * z1 / z2,
                          "driver_torque_Nm": -load * r1 / r2,
                          "tight_minus_slack_N": load / r2}  # fmt: skip
    res["refinement"] = refine(sc, scm, k_c, t_ref, args.segment, args.tol, args.quick)
    h = res["refinement"]["chosen_dt_s"]
    n = 1 if args.quick else args.repeats  # the fastest of n warm runs each
    ex = [run_exudyn(sc, k_c, args.segment, h, t1) for _ in range(n)]
    ex = min(ex, key=lambda r: r["wall_s"]) | {"walls_s": [r["wall_s"] for r in ex]}
    runs = {f"jaxchain_{k}": run_jaxchain(s, t1, n) for k, s in (("johnson", sc), ("matched", scm))}
    runs["exudyn"] = ex
    res["runs"], res["traces"] = {}, {}
    for name, run in runs.items():
        sp = span_tensions(sc, run)
        solver = f"RK4, dt {h:g} s" if name == "exudyn" else "Tsit5, rtol 1e-6, atol 1e-9"
        res["runs"][name] = {k: run.get(k) for k in TIMES}
        res["runs"][name] |= {"solver": solver, "metrics": metrics(sc, run)}
        res["traces"][name] = {"t": run["ts"].tolist(), "driven_speed": run["omega"][:, 1].tolist(),
                               "tight": sp[:, 0].tolist(), "slack": sp[:, 1].tolist()}  # fmt: skip
    e, j, m = (res["runs"][n]["metrics"] for n in ("exudyn", *list(runs)[:2]))
    keys = ["mesh_speed_line_rad_s", "mesh_tension_line_N", "tight_minus_slack_N"]
    res["exudyn_vs_jaxchain_matched"] = {k: e[k] / m[k] - 1 for k in keys}
    res["johnson_vs_matched_law"] = {k: j[k] / m[k] - 1 for k in keys}
    res["ratio"] = {f"{k[:-2]}_exudyn_over_{n}": runs["exudyn"][k] / runs[n][k]
                    for k in ("wall_s", "cpu_s") for n in list(runs)[:2]}  # fmt: skip
    return finish(res, args.out, stem, chart, start)


if __name__ == "__main__":
    main()
