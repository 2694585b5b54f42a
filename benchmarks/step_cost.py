"""Where a step's time goes: the vector field by force element, the exact peak record,
and the saves.

1. The vector field: µs per call of each of the scene's force elements (``Scene.
   force_elements``, jitted loops of 2000 calls at the start state) beside the whole
   field's.
2. ``Solution.peak_contact_force`` is read along the solve by :class:`jaxchain.observers.
   PeakRecord`: each roller's tooth force at every accepted step's ends and, where the
   force can reach the record inside the step, at three interior times from the solver's
   dense output (a parabola through each sample triple). One solve per way of reading
   it, on the same scene and steps:

   * ``none``: no peak record (the step's cost without it);
   * ``ends``: the end forces only (one contact evaluation per step);
   * ``every step``: the interior sampled in every step (``PeakRecord(gate=False)``);
   * ``gated``: the interior sampled only where the record can be reached (the default).

   For each: µs of wall time per step (the minimum of warm runs; CPU time beside it), the
   peak record's share of a step (its µs over the step's), the share of steps whose
   interior was sampled, and the peak, which ``gated`` must give as ``every step`` does.
3. The saves: the default solve with 2 and with 2001 save times, µs per save.

Scenes: the 08B z = 18 engagement strand (1000 N, 1000 rpm, 6 tooth periods) and the 08B
18/36 drive (1000 rpm, 20 N·m, 3 tooth periods), both at ``simulate``'s defaults.

    python -m benchmarks.step_cost            # ~4 min on 2 cores
"""

from __future__ import annotations

import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    finish,
    header,
    parse,
    parser,
    save_chart,
    tooth_period,
)


class NoPeak(jc.observers.PeakRecord):
    """Reads nothing after the start (the step's cost without a peak record)."""

    def step(self, t0, t1, y0, y1, dense, scene, state):
        return state


class EndsOnly(jc.observers.PeakRecord):
    """The end forces only: one contact evaluation per step."""

    def step(self, t0, t1, y0, y1, dense, scene, state):
        f1 = jnp.sum(jc.roller_normal_forces(y1, scene), axis=0)
        return jnp.maximum(state[0], jnp.max(f1, initial=0.0)), f1, state[1], t1 - t0


class Counted(jc.observers.PeakRecord):
    """The gated record, counting the steps whose interior it samples."""

    def init(self, t0, y0, scene):
        return (*super().init(t0, y0, scene), jnp.zeros((), jnp.int32))

    def step(self, t0, t1, y0, y1, dense, scene, state):
        f1 = jnp.sum(jc.roller_normal_forces(y1, scene), axis=0)
        sampled = self.interior_needed(t1 - t0, f1, state[:4])
        out = super().step(t0, t1, y0, y1, dense, scene, state[:4])
        return (*out, state[4] + sampled.astype(jnp.int32))

    def value(self, state, t0, t1):
        return state[4]


WAYS = {
    "none": NoPeak(),
    "ends": EndsOnly(),
    "every step": jc.observers.PeakRecord(gate=False),
    "gated": jc.observers.PeakRecord(),
}


def scenes(quick: bool) -> dict:
    period = tooth_period(18)
    out = {"08B z18 strand": (jc.scenes.engagement("08B", 18), (3 if quick else 6) * period)}
    if not quick:
        out["08B 18/36 drive"] = (jc.scenes.drive("08B", (18, 36)), 3 * period)
    return out


def measure(sc, t1, repeats: int) -> dict:
    """Each way's steps, peak and µs per step: wall time (its CPU time beside it: XLA runs
    parts of a step on a second thread, so CPU time counts them twice), the minimum over
    ``repeats`` warm runs, the ways interleaved so a burst of load falls on all of them
    alike."""
    run = lambda way: jc.simulate(sc, t1, n_save=2, observers=(way,))
    rows = {}
    for name, way in WAYS.items():
        t = time.perf_counter()
        sol = run(way)
        jax.block_until_ready(sol.peak_contact_force)
        rows[name] = {
            "steps": int(sol.stats["num_steps"]),
            "peak_N": float(sol.peak_contact_force),
            "first_call_s": time.perf_counter() - t,
            "cpu_s": [],
            "wall_s": [],
        }
    for _ in range(repeats):
        for name, way in WAYS.items():
            t, c = time.perf_counter(), time.process_time()
            jax.block_until_ready(run(way).peak_contact_force)
            rows[name]["cpu_s"].append(time.process_time() - c)
            rows[name]["wall_s"].append(time.perf_counter() - t)
    for r in rows.values():
        r["us_per_step"] = min(r["wall_s"]) / r["steps"] * 1e6
        r["cpu_us_per_step"] = min(r["cpu_s"]) / r["steps"] * 1e6
    sol = run(Counted())
    rows["gated"]["sampled_steps"] = int(sol.observed[0])
    base = rows["none"]["us_per_step"]
    for r in rows.values():
        r["record_share"] = (r["us_per_step"] - base) / r["us_per_step"]
    return rows


def field_parts(sc, n: int = 2000) -> dict:
    """µs per call of each force element's effect and of the whole vector field."""
    y = jc.initial_state(sc)
    elements = sc.force_elements

    def loop(f):
        @jax.jit
        def run(y, sc):
            def body(i, c):
                acc, y = c
                leaves = jax.tree_util.tree_leaves(f(i * 1e-9, y, sc))
                s = sum(jnp.sum(leaf) for leaf in leaves)
                return acc + s, jax.tree_util.tree_map(lambda a: a + 1e-18 * s, y)

            return jax.lax.fori_loop(0, n, body, (0.0, y))

        jax.block_until_ready(run(y, sc))
        c = time.perf_counter()
        jax.block_until_ready(run(y, sc))
        return (time.perf_counter() - c) / n * 1e6

    out = {"vector field": loop(jc.vector_field)}
    for k, el in enumerate(elements):
        name = f"{k}: {type(el).__name__}"
        # element k's effect (and the tensions it reads): XLA drops the others' work
        out[name] = loop(lambda t, y, s, k=k: jc.element_effects(t, y, s)[k])
    return out


def saves(sc, t1, repeats: int) -> dict:
    """µs per save (wall time): the default solve with 2 and with 2001 save times."""
    cpu = {}
    for n in (2, 2001):
        jax.block_until_ready(jc.simulate(sc, t1, n_save=n).peak_contact_force)
        best = []
        for _ in range(repeats):
            c = time.perf_counter()
            jax.block_until_ready(jc.simulate(sc, t1, n_save=n).peak_contact_force)
            best.append(time.perf_counter() - c)
        cpu[n] = min(best)
    return {
        "wall_s": {str(k): v for k, v in cpu.items()},
        "us_per_save": (cpu[2001] - cpu[2]) / 1999 * 1e6,
    }


def chart(res: dict, path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    names = list(WAYS)
    kinds = []  # every force element's kind, in the order met
    for r in res["scenes"].values():
        for n in r["field_us"]:
            if n != "vector field" and n.split(": ")[1] not in kinds:
                kinds.append(n.split(": ")[1])
    for k, (scene, r) in enumerate(res["scenes"].items()):
        rows = r["peak"]
        x = [i + 0.38 * k for i in range(len(names))]
        ax[1].bar(x, [rows[n]["us_per_step"] for n in names], 0.36, label=scene)
        ax[2].bar(x[1:], [100 * rows[n]["record_share"] for n in names[1:]], 0.36, label=scene)
        parts = {n.split(": ")[1]: v for n, v in r["field_us"].items() if n != "vector field"}
        y = [kinds.index(n) + 0.38 * k for n in parts]
        whole = r["field_us"]["vector field"]
        ax[0].barh(y, list(parts.values()), 0.36, label=f"{scene} (whole field {whole:.1f} µs)")
    ax[0].set_yticks([j + 0.19 for j in range(len(kinds))], kinds)
    ax[0].set(xlabel="µs per call", title="the vector field by force element")
    ax[1].set_xticks([i + 0.19 for i in range(len(names))], names)
    ax[2].set_xticks([i + 0.19 for i in range(1, len(names))], names[1:])
    ax[1].set(ylabel="µs (wall) per accepted step", title="a step, by how the peak is read")
    ax[2].set(ylabel="peak record's share of a step [%]", title="what reading the peak costs")
    ax[2].axhline(10, color="k", lw=0.8, ls="--")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    save_chart(fig, res, path)


def main(argv=None) -> dict:
    ap = parser(__doc__)
    ap.add_argument("--repeats", type=int, default=3, help="warm runs per way (min taken)")
    args = parse(ap, argv)
    start = time.perf_counter()
    res = header("step_cost", argv)
    res["scenes"] = {}
    for name, (sc, t1) in scenes(args.quick).items():
        r = {"field_us": field_parts(sc), "peak": measure(sc, t1, args.repeats)}
        r["saves"] = saves(sc, t1, args.repeats)
        res["scenes"][name] = r
        rows, g, e = r["peak"], r["peak"]["gated"], r["peak"]["every step"]
        parts = ", ".join(f"{k} {v:.2f}" for k, v in r["field_us"].items())
        print(f"{name}: vector field µs per call: {parts}")
        print(
            f"{name}: {g['steps']} steps; µs/step none {rows['none']['us_per_step']:.1f}, "
            f"ends {rows['ends']['us_per_step']:.1f}, every step {e['us_per_step']:.1f}, "
            f"gated {g['us_per_step']:.1f}; record share every step "
            f"{100 * e['record_share']:.1f} % → gated {100 * g['record_share']:.1f} % "
            f"({g['sampled_steps']} of {g['steps']} steps sampled); peak every step "
            f"{e['peak_N']:.3f} N, gated {g['peak_N']:.3f} N; "
            f"{r['saves']['us_per_save']:.1f} µs per save"
        )
    return finish(res, args.out, "step_cost", chart, start)


if __name__ == "__main__":
    main()
