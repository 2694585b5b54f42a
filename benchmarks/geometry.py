"""Cost of free-form tooth geometry: arc-spline flanks and per-gap patterns against the
uniform ISO profile.

    python -m benchmarks.geometry            # full study (~4 min on 2 cores)
    python -m benchmarks.geometry --quick    # smoke run (CI-sized)

Writes ``benchmarks/results/geometry.json`` and ``geometry.png``. Every ratio is
measured in this one run (machines are shared and noisy: compare ratios, not seconds).

Profiles, on every sprocket of the scene:

* ``iso`` — ``ToothProfile.iso606(chain, z, "mid")`` (symmetric, folded evaluation);
* ``freeform_uniform`` — K = 3 arcs per flank, the two sides different (seat angles,
  curvatures, break points), every leaf a scalar;
* ``freeform_per_gap`` — the same with every leaf one value per gap (seating radius,
  seat offset, phase, both sides' seat angle, curvatures and break points).

Scenes: the 08B engagement (z = 18, 600 rpm) and the 08B 18/36 drive of 100 links
(lumped, frictionless joints as the other cost studies). Measured per scene and profile:
µs per vector-field call in a jitted loop (the least of 5 runs), µs per contact
evaluation of the rollers (engagement), and the compile time of ``simulate`` (first
call minus a warm call, the least of 3 from emptied caches).
"""

from __future__ import annotations

import datetime
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks.common import (  # noqa: E402
    FRICTIONLESS,
    finish,
    machine_info,  # noqa: E402
    modelled,
    parse,
    parser,
    vf_time,
)

CHAIN = "08B"
K = 3


def freeform(iso: jc.ToothProfile, per_gap: bool, seed: int = 0) -> jc.FreeformProfile:
    """The study's free-form profile on ``iso``'s sprocket (module docstring)."""
    z = iso.teeth
    rng = np.random.default_rng(seed)
    a, k = float(iso.seating_angle) / 2, 1 / float(iso.flank_radius)

    def leaf(value, spread, tail=()):
        value = np.broadcast_to(np.asarray(value, dtype=float), tail)
        if not per_gap:
            return value
        return value + spread * rng.uniform(-1, 1, (z,) + tail)

    def flank(sign):
        return jc.Flank(
            leaf(a + sign * 0.03, 0.02),
            leaf(k * np.array([1.15, 1.0, 0.9]) ** sign, 0.05 * k, (K,)),
            leaf([0.3, 0.65], 0.05, (K - 1,)),
        )

    return jc.FreeformProfile.from_iso(
        iso,
        K,
        cw=flank(1),
        ccw=flank(-1),
        seating_radius=leaf(float(iso.seating_radius) + 20e-6, 15e-6),
        seat_offset=leaf(0.0, 10e-6),
        phase=leaf(0.0, 5e-4),
    )


def profiles(z: int) -> dict:
    iso = jc.ToothProfile.iso606(CHAIN, z, "mid")
    return {
        "iso": iso,
        "freeform_uniform": freeform(iso, False),
        "freeform_per_gap": freeform(iso, True, seed=z),
    }


def contact_time(profile, points, n: int) -> float:
    """µs per contact evaluation of all ``points`` (jitted loop)."""

    @jax.jit
    def run(p, x):
        def body(i, acc):
            d, nrm = jax.vmap(jc.gap_contact, (None, 0))(p, x + acc * 1e-15)
            return acc + jnp.sum(d) + jnp.sum(nrm)

        return jax.lax.fori_loop(0, n, body, 0.0)

    jax.block_until_ready(run(profile, points))
    best = np.inf
    for _ in range(5):
        t = time.perf_counter()
        jax.block_until_ready(run(profile, points))
        best = min(best, time.perf_counter() - t)
    return best / n * 1e6


def compile_time(scene, t1: float, repeats: int) -> float:
    """First call minus a warm call of ``simulate``, the least of ``repeats`` (each from
    emptied in-memory caches)."""
    best = np.inf
    for _ in range(repeats):
        jax.clear_caches()
        times = []
        for _ in range(2):
            t = time.perf_counter()
            sol = jc.simulate(scene, t1, n_save=3, throw=False)
            jax.block_until_ready(sol.peak_contact_force)
            times.append(time.perf_counter() - t)
        best = min(best, times[0] - times[1])
    return best


def scenes(name: str):
    if name == "engagement":
        for key, p in profiles(18).items():
            yield (
                key,
                jc.scenes.engagement(
                    CHAIN, 18, **modelled(speed_rpm=600, profile=p, **FRICTIONLESS)
                ),
            )
    else:
        p18, p36 = profiles(18), profiles(36)
        for key in p18:
            yield (
                key,
                jc.scenes.drive(
                    CHAIN,
                    **modelled(
                        teeth=(18, 36),
                        n_links=100,
                        profiles=(p18[key], p36[key]),
                        **FRICTIONLESS,
                        model=jc.scenes.ChainModel(settle=False),
                    ),
                ),
            )


def main(argv=None) -> dict:
    args = parse(parser(__doc__), argv)
    start = time.perf_counter()
    machine = machine_info()
    n_vf = 300 if args.quick else 3000
    rows = []
    for scene_name in ("engagement", "drive100"):
        base = None
        for key, scene in scenes(scene_name):
            vf = min(vf_time(scene, n_vf) for _ in range(2 if args.quick else 5))
            row = {"scene": scene_name, "profile": key, "us_per_vf_call": vf}
            if scene_name == "engagement":
                r = float(scene.sprockets[0].profile.pitch_radius)
                ang = np.linspace(-0.6, 0.6, scene.n_rollers)
                pts = jnp.asarray(np.stack([r * np.cos(ang), r * np.sin(ang)], -1))
                row["us_per_contact"] = contact_time(scene.sprockets[0].profile, pts, n_vf)
            row["compile_s"] = compile_time(scene, 20e-6, 1 if args.quick else 3)
            base = base or row
            row["vf_ratio"] = vf / base["us_per_vf_call"]
            row["compile_ratio"] = row["compile_s"] / base["compile_s"]
            if "us_per_contact" in row:
                row["contact_ratio"] = row["us_per_contact"] / base["us_per_contact"]
            rows.append(row)
            print(
                f"  {scene_name:10s} {key:17s} vf {vf:6.1f} µs (×{row['vf_ratio']:.2f})  "
                f"compile {row['compile_s']:5.1f} s (×{row['compile_ratio']:.2f})"
                + (
                    f"  contact {row['us_per_contact']:5.2f} µs (×{row['contact_ratio']:.2f})"
                    if "us_per_contact" in row
                    else ""
                ),
                flush=True,
            )
    results = {
        "command": "python -m benchmarks.geometry" + (" --quick" if args.quick else ""),
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "machine": machine,
        "arcs_per_flank": K,
        "rows": rows,
        "goal": "vector field and compile time at most 1.5x the uniform ISO profile",
    }
    return finish(results, args.out, "geometry", chart, start)


def chart(res: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    keys = ["iso", "freeform_uniform", "freeform_per_gap"]
    for i, (metric, title) in enumerate(
        (("vf_ratio", "vector-field cost"), ("compile_ratio", "compile time of simulate"))
    ):
        for j, scene in enumerate(("engagement", "drive100")):
            vals = [
                next(r[metric] for r in res["rows"] if r["scene"] == scene and r["profile"] == k)
                for k in keys
            ]
            ax[i].bar(np.arange(3) + 0.38 * j, vals, 0.36, label=scene)
        ax[i].axhline(1.5, color="r", ls="--", lw=0.8, label="goal 1.5×")
        ax[i].set_xticks(np.arange(3) + 0.19, ["ISO", f"K={K} uniform", f"K={K} per gap"])
        ax[i].set(ylabel="÷ uniform ISO profile (same run)", title=title)
        ax[i].set_ylim(0, 1.35 * ax[i].get_ylim()[1])  # the legend above the bars
        ax[i].legend(fontsize=8, loc="upper left", ncol=3)
    fig.suptitle(f"{res['command']} · {res['date'][:10]} · {res['machine']['cpu_count']} CPUs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
