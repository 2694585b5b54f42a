"""Cost of a design gradient against the dimension of the design space.

    python -m benchmarks.gradient_cost            # full study (~5 min on 2 cores)
    python -m benchmarks.gradient_cost --quick    # smoke run (CI-sized)

Writes ``benchmarks/results/gradient_cost.json`` and ``gradient_cost.png``. Reverse mode
costs a small multiple of one forward solve whatever the number of parameters; a
gradient-free method or finite differences pay per parameter. Measured here, in one run
(machines are shared and noisy: compare ratios, not seconds):

* the design objective of ``python -m optimize``'s scene (08B engagement, z = 18, 1000 rpm,
  1000 N, design contact law, fixed steps of 4 µs over two tooth periods, soft peak over
  the second) built for a free-form tooth and differentiated in design spaces of
  4 (the ISO 606 box), 36 (per-gap seating radius and clockwise seat angle) and 72
  coordinates (per-gap seating radius, both seat angles and seat offset);
* for each: the wall time of the value alone and of value + gradient (the least of
  ``repeats`` warm calls, interleaved; compile excluded), their ratio, and the compile
  times; the gradient by the default fixed-step adjoint (every step's residuals kept,
  :class:`jaxchain.StepResidualsAdjoint`) and by diffrax's checkpointing of every step
  (each step run forward again on the way back), with the difference of the two.

A value+gradient then counts as ``ratio`` simulations when methods are compared on one
simulation budget (issue "design that pays": the ratio should stay ≤ 4 and flat in the
dimension).
"""

from __future__ import annotations

import datetime
import math
import time

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from benchmarks._cli import (  # noqa: E402
    finish,
    machine_info,  # noqa: E402
    parse,
    parser,
)
from jaxchain.design import DesignSpace, ProfileObjective  # noqa: E402

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = 60.0 / (Z * RPM)
T1 = 2 * PERIOD  # the design objective's solve: two tooth periods
LAW = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)
JOINTS = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)
DT = 4e-6  # the fixed step [s]


def per_gap_space(form: str = "mid", wide: bool = False) -> DesignSpace:
    """A per-gap space around the uniform ISO 606 ``form`` (u = 0: that form, one arc per
    flank): each gap's seating radius ±20 µm and clockwise seat angle ±0.04 rad (36
    coordinates); ``wide`` adds each gap's counter-clockwise seat angle ±0.04 rad and seat
    offset ±20 µm (72)."""
    iso = jc.ToothProfile.iso606(CHAIN, Z, form)
    tooth = jc.FreeformProfile.from_iso(iso, 1)
    ri, a = float(iso.seating_radius), float(iso.seating_angle) / 2
    ones = np.ones(Z)
    angle = ((a - 0.04) * ones, (a + 0.04) * ones)
    leaves = {"seating_radius": (ri - 20e-6 * ones, ri + 20e-6 * ones), "cw.seat_angle": angle}
    if wide:
        leaves |= {"ccw.seat_angle": angle, "seat_offset": (-20e-6 * ones, 20e-6 * ones)}
    return DesignSpace.select(tooth, leaves)


def spaces() -> dict[str, DesignSpace]:
    """The three design spaces (module docstring), named by their dimension."""
    return {
        "4": DesignSpace.iso606(CHAIN, Z),
        "36": per_gap_space(),
        "72": per_gap_space(wide=True),
    }


def build(
    profile, n_entry: int = 3, settle: bool = True, roller_contact=LAW, joint_friction=JOINTS
):
    """The study's engagement for ``profile`` (the design model's contact law and joint
    friction unless given)."""
    return jc.scenes.engagement(
        CHAIN, Z, speed_rpm=RPM, profile=profile, n_entry=n_entry,
        roller_contact=roller_contact, joint_friction=joint_friction, settle=settle,
    )  # fmt: skip


def _best(f, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(f())
        times.append(time.perf_counter() - t)
    return min(times)


def objective(
    space: DesignSpace, *, dt: float = DT, samples: int = 0, **kwargs
) -> ProfileObjective:
    """The design objective of the study (module docstring) over ``space``, fixed steps
    of ``dt``, the soft peak's window integrated by the solver (``samples`` 0) or sampled
    ``samples`` times per step; ``kwargs`` go to :class:`ProfileObjective` (e.g.
    ``throw=False``)."""
    return ProfileObjective(
        space, build, t1=T1, t_start=PERIOD, temperature=20.0, reference=1500.0,
        dt=dt, samples=samples, **kwargs,
    )  # fmt: skip


# the every-gap objective: MEMBERS solves, each with the sprocket turned by z/MEMBERS
# pitches and EVERY_GAP_PERIODS tooth periods long, so that every gap meshes in one window
MEMBERS = 6
EVERY_GAP_PERIODS = 4


def build_turned(profile, **model) -> list:
    """``MEMBERS`` engagements of ``profile``, each settled with the sprocket turned by
    z/MEMBERS more pitches (gap k centred at angle0 + 2πk/z), ``EVERY_GAP_PERIODS`` + 1
    entry rollers: over periods 2 to EVERY_GAP_PERIODS member j meshes z/MEMBERS gaps
    of its own, and the members together mesh every gap once. For a uniform tooth the
    members are the same solve turned by whole pitches (equal values). ``model``:
    :func:`build`'s ``roller_contact`` and ``joint_friction`` (default: the design
    model's)."""
    base = build(profile, n_entry=EVERY_GAP_PERIODS + 1, settle=False, **model)
    a0 = base.sprockets[0].angle0
    turn = 2 * math.pi / Z * (Z // MEMBERS)
    return [
        jc.scenes.equilibrate(eqx.tree_at(lambda s: s.sprockets[0].angle0, base, a0 - j * turn))
        for j in range(MEMBERS)
    ]


def every_gap_objective(
    space: DesignSpace,
    *,
    dt: float = DT,
    samples: int = 0,
    model: dict | None = None,
    temperature: float = 20.0,
    combine: str = "mean",
    member_temperature: float | None = None,
    **kwargs,
) -> ProfileObjective:
    """The study's objective over every gap: each of :func:`build_turned`'s members'
    soft peak over periods 2 to ``EVERY_GAP_PERIODS`` (one window), averaged over the
    members (``combine="max"``: their soft maximum, temperature ``member_temperature``,
    default ``temperature``). A per-gap coordinate then moves the objective whichever gap
    it shapes; in :func:`objective`'s single two-period solve only the gaps holding the
    wrapped rollers and the one that meshes do. ``model``: :func:`build_turned`'s
    (default the design model); ``temperature`` [N]: the soft peak's (default 20 N)."""
    if Z % MEMBERS:
        raise ValueError(f"MEMBERS ({MEMBERS}) must divide the teeth ({Z})")
    model = model or {}
    return ProfileObjective(
        space, lambda p: build_turned(p, **model), t1=EVERY_GAP_PERIODS * PERIOD,
        t_start=PERIOD, temperature=temperature, reference=1500.0,
        member_temperature=member_temperature or temperature, combine=combine, dt=dt,
        samples=samples, **kwargs,
    )  # fmt: skip


def measure(
    space: DesignSpace,
    repeats: int,
    seed: int = 0,
    dt: float = DT,
    obj: ProfileObjective | None = None,
    checkpointed: ProfileObjective | None = None,
) -> dict:
    """Value and value + gradient of ``obj`` (default: :func:`objective` over ``space``
    with steps of ``dt``); with ``checkpointed`` (the same objective differentiated with
    every step checkpointed) also its value + gradient, timed interleaved with the
    others, and how far its gradient lies from ``obj``'s."""
    obj = objective(space, dt=dt) if obj is None else obj
    u = jnp.asarray(np.random.default_rng(seed).normal(0.0, 0.3, space.size))
    scenes = obj.scenes(u)
    calls = {
        "value": lambda: obj.value_on(u, scenes)[0],
        "value_and_grad": lambda: obj.value_and_grad_on(u, scenes)[:2],
    }
    if checkpointed is not None:
        calls["value_and_grad_checkpointed"] = lambda: checkpointed.value_and_grad_on(u, scenes)[1]
    first, best, out = {}, {}, {}
    for key, call in calls.items():  # compile (the results kept for the row)
        t = time.perf_counter()
        out[key] = jax.block_until_ready(call())
        first[key], best[key] = time.perf_counter() - t, np.inf
    for _ in range(repeats):  # interleaved, so all see the same load; the least of each
        for key, call in calls.items():
            best[key] = min(best[key], _best(call, 1))
    value, grad = out["value_and_grad"]
    row = {
        "dimension": space.size,
        "value_s": best["value"],
        "value_and_grad_s": best["value_and_grad"],
        "ratio": best["value_and_grad"] / best["value"],
        "first_value_s": first["value"],
        "first_value_and_grad_s": first["value_and_grad"],
        "objective_N": float(value),
        "grad_norm": float(jnp.linalg.norm(grad)),
        "grad_finite": bool(np.all(np.isfinite(np.asarray(grad)))),
    }
    if checkpointed is not None:
        other = out["value_and_grad_checkpointed"]
        row |= {
            "value_and_grad_checkpointed_s": best["value_and_grad_checkpointed"],
            "ratio_checkpointed": best["value_and_grad_checkpointed"] / best["value"],
            "first_value_and_grad_checkpointed_s": first["value_and_grad_checkpointed"],
            "grad_difference_checkpointed": float(jnp.linalg.norm(other - grad))
            / float(jnp.linalg.norm(grad)),
        }
    return row


def checkpointed(space: DesignSpace, dt: float = DT) -> ProfileObjective:
    """:func:`objective` differentiated with every step checkpointed (diffrax's
    ``RecursiveCheckpointAdjoint``, one checkpoint per step) instead of
    :class:`~jaxchain.StepResidualsAdjoint`."""
    n = jc.SolveOptions(dt=dt).steps(0.0, T1)
    return objective(space, dt=dt, adjoint=diffrax.RecursiveCheckpointAdjoint(checkpoints=n))


def chart(results: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = results["rows"]
    dims = [r["dimension"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(
        dims,
        [r["ratio"] for r in rows],
        "o-",
        color="tab:red",
        label="reverse mode, every step's residuals kept",
    )
    if "ratio_checkpointed" in rows[0]:
        ax.plot(dims, [r["ratio_checkpointed"] for r in rows], "s--", color="tab:orange",
                label="reverse mode, every step checkpointed")  # fmt: skip
    ax.plot(dims, [d + 1 for d in dims], "--", color="0.5", label="forward differences (n + 1)")
    ax.axhline(4, color="k", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(dims, [str(d) for d in dims], minor=False)
    ax.set_xticks([], minor=True)
    ax.set_yticks([2, 4, 8, 16, 32, 64], ["2", "4", "8", "16", "32", "64"])
    ax.set_yticks([], minor=True)
    ax.set_xlabel("design coordinates")
    ax.set_ylabel("cost of value + gradient / value")
    ax.set_title("Gradient cost against dimension (08B engagement, fixed 4 µs steps)")
    ax.legend()
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def main(argv=None) -> dict:
    args = parse(parser(__doc__), argv)
    start = time.perf_counter()
    repeats = 3 if args.quick else 9
    picks = ("4", "72") if args.quick else ("4", "36", "72")
    rows = []
    for name, space in spaces().items():
        if name not in picks:
            continue
        row = measure(space, repeats, checkpointed=checkpointed(space))
        rows.append(row)
        print(
            f"dimension {row['dimension']:3d}: value {row['value_s']:.3f} s, value+grad "
            f"{row['value_and_grad_s']:.3f} s, ratio {row['ratio']:.2f} (every step "
            f"checkpointed: {row['ratio_checkpointed']:.2f}, gradients differ by "
            f"{row['grad_difference_checkpointed']:.1e})",
            flush=True,
        )
    results = {
        "study": "gradient_cost",
        "command": "python -m benchmarks.gradient_cost" + (" --quick" if args.quick else ""),
        "date": datetime.date.today().isoformat(),
        "machine": machine_info(),
        "repeats": repeats,
        "rows": rows,
    }
    return finish(results, args.out, "gradient_cost", chart, start)


if __name__ == "__main__":
    main()
