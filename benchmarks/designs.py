"""The design toolkit the design studies share: the design operating point (08B, z = 18,
1000 rpm engagement), its design spaces and objectives (ISO box, per-gap patterns, every
gap meshed by six turned members), the cost of a value and gradient, the independent
tight re-measurement with the nominal and the second contact law, and the robust design
model's options.

Studies: ``gradient_cost``, ``methods``, ``pattern_remeasure``, ``pattern_design``,
``design_fidelity``, ``step_convergence``, ``job_threads`` (the main job's committed run and
its settings).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxchain as jc  # noqa: E402
from jaxchain.design import DesignSpace, ProfileObjective, SoftMax  # noqa: E402
from optimize.problem import Settings  # noqa: E402

LEARNING_RATE = 1.0  # Adam's step in u (the sigmoid coordinate of each box)

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = 60.0 / (Z * RPM)
T1 = 2 * PERIOD  # the design objective's solve: two tooth periods
LAW = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)
JOINTS = jc.contact.CoulombFriction(coefficient=0.1, slip_velocity=2e-2)
DT = 4e-6  # the fixed step [s]
# the main job's committed run (python -m optimize on its defaults)
RUN = Path(__file__).parent / "results" / "optimize_default" / "results.json"


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
        CHAIN,
        Z,
        speed_rpm=RPM,
        profile=profile,
        n_entry=n_entry,
        model=jc.scenes.ChainModel(
            roller_contact=roller_contact, joint_friction=joint_friction, settle=settle
        ),
    )


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
        combine=SoftMax(member_temperature or temperature) if combine == "max" else combine,
        dt=dt, samples=samples, **kwargs,
    )  # fmt: skip


def cost_of(
    space: DesignSpace,
    repeats: int,
    seed: int = 0,
    dt: float = DT,
    obj: ProfileObjective | None = None,
    others: dict[str, ProfileObjective] | None = None,
) -> dict:
    """Value and value + gradient of ``obj`` (default: :func:`objective` over ``space``
    with steps of ``dt``); for each of ``others`` (the same objective differentiated
    another way, e.g. ``{"checkpointed": checkpointed(space)}``) also its value +
    gradient, timed interleaved with the rest, and how far its gradient lies from
    ``obj``'s (row keys suffixed with the name)."""
    obj = objective(space, dt=dt) if obj is None else obj
    others = others or {}
    u = jnp.asarray(np.random.default_rng(seed).normal(0.0, 0.3, space.size))
    scenes = obj.scenes(u)
    calls = {
        "value": lambda: obj.value_on(u, scenes)[0],
        "value_and_grad": lambda: obj.value_and_grad_on(u, scenes)[:2],
    }
    for name, other in others.items():
        calls[f"value_and_grad_{name}"] = lambda o=other: o.value_and_grad_on(u, scenes)[1]
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
        "gradient": obj.gradient,
        "value_s": best["value"],
        "value_and_grad_s": best["value_and_grad"],
        "ratio": best["value_and_grad"] / best["value"],
        "first_value_s": first["value"],
        "first_value_and_grad_s": first["value_and_grad"],
        "objective_N": float(value),
        "grad_norm": float(jnp.linalg.norm(grad)),
        "grad_finite": bool(np.all(np.isfinite(np.asarray(grad)))),
    }
    for name in others:
        key = f"value_and_grad_{name}"
        row |= {
            f"{key}_s": best[key],
            f"ratio_{name}": best[key] / best["value"],
            f"first_{key}_s": first[key],
            f"grad_difference_{name}": float(jnp.linalg.norm(out[key] - grad))
            / float(jnp.linalg.norm(grad)),
        }
    return row


def checkpointed(space: DesignSpace, dt: float = DT) -> ProfileObjective:
    """:func:`objective` differentiated with every step checkpointed (diffrax's
    ``RecursiveCheckpointAdjoint``, one checkpoint per step) instead of
    :class:`~jaxchain.StepResidualsAdjoint`."""
    n = jc.SolveOptions(dt=dt).steps(0.0, T1)
    return objective(space, dt=dt, adjoint=diffrax.RecursiveCheckpointAdjoint(checkpoints=n))


def space_of(name: str, spaces: dict):
    """The design space of a methods row ("36g": the 36-coordinate space)."""
    return spaces[name.removesuffix("g")]


def laws() -> dict:
    """The re-measurement's roller laws: the nominal (Johnson, None) and the second law."""

    return {"johnson": None, "hertz": jc.design.second_law(CHAIN)}


def remeasure(profile, law, rtol: float) -> dict:
    """The six turned members of ``profile`` with the nominal model (``law``: None for
    the nominal Johnson law) solved tightly; each member's sharp peak over periods 2–4."""
    import diffrax

    import jaxchain as jc

    scenes = build_turned(profile, roller_contact=law, joint_friction=jc.scenes.JOINT_FRICTION)
    t0, t1 = PERIOD, EVERY_GAP_PERIODS * PERIOD
    ts = np.linspace(t0, t1, math.ceil((t1 - t0) / 0.5e-6) + 1)
    peaks, steps, ok = [], [], []
    for scene in scenes:
        sol = jc.simulate(
            scene, t1, solver=diffrax.Dopri8(), rtol=rtol, atol=rtol * 1e-3, ts=ts,
            max_steps=1_000_000, throw=False,
        )  # fmt: skip
        ok.append(bool(sol.ok))
        peaks.append(float(np.max(np.asarray(sol.roller_sprocket_force))) if sol.ok else math.nan)
        steps.append(int(sol.stats["num_accepted_steps"]))
    # a failed member makes the worst NaN (never the largest of the others)
    return {"peak_N": float(np.max(peaks)), "members_N": peaks, "steps": steps, "ok": all(ok)}


def hertz_design_law(width: float | None = None):
    """The second law (Hertz, ``jc.design.second_law``) as a design law: its contact
    onset regularized over ``width`` [m] (default the Johnson design law's 3 µm)."""
    import equinox as eqx

    width = LAW.width if width is None else width
    return eqx.tree_at(lambda law: law.width, jc.design.second_law(CHAIN), width)


def design_objectives(
    space,
    width: float = 3e-6,
    dt: float = 4e-6,
    hertz_temperature: float = 20.0,
    member_max: float | None = None,
) -> dict:
    """The every-gap objective over ``space`` under each design law ("johnson", "hertz"),
    the contact onset regularized over ``width`` [m], fixed steps of ``dt`` [s]; the soft
    peak's temperature 20 N (Johnson) and ``hertz_temperature`` [N]; the members
    averaged, or with ``member_max`` [N] their soft maximum at that temperature."""
    import jaxchain as jc

    laws = {
        "johnson": jc.scenes.roller_law(CHAIN, 0.7, width=width),
        "hertz": hertz_design_law(width),
    }
    temperature = {"johnson": 20.0, "hertz": hertz_temperature}
    return {
        law: every_gap_objective(
            space,
            dt=dt,
            samples=8,
            model={"roller_contact": c},
            temperature=temperature[law],
            combine="mean" if member_max is None else "max",
            member_temperature=member_max,
        )
        for law, c in laws.items()
    }


def add_model_options(ap) -> None:
    """The design model's options (onset, step, Hertz soft-peak temperature) on ``ap``."""
    ap.add_argument("--width", type=float, default=3.0, help="onset [µm] (default %(default)s)")
    ap.add_argument("--dt", type=float, default=4.0, help="fixed step [µs] (default %(default)s)")
    ap.add_argument(
        "--hertz-temperature", type=float, default=20.0,
        help="the Hertz design objective's soft-peak temperature [N] (default %(default)s)",
    )  # fmt: skip


def model_options(args) -> dict:
    """:func:`design_objectives`'s keywords from :func:`add_model_options`' options."""
    return {
        "width": 1e-6 * args.width, "dt": 1e-6 * args.dt,
        "hertz_temperature": args.hertz_temperature,
    }  # fmt: skip


def suffix(args) -> str:
    """A result file's name suffix naming each design-model or Adam option that differs
    from its default."""
    out = f"_w{args.width:g}_dt{args.dt:g}" if (args.width, args.dt) != (3.0, 4.0) else ""
    out += f"_tH{args.hertz_temperature:g}" if args.hertz_temperature != 20.0 else ""
    member, lr = getattr(args, "member_max", None), getattr(args, "lr", None)
    out += f"_max{member:g}" if member is not None else ""
    return out + (f"_lr{lr:g}" if lr is not None else "")


def add_run_option(ap) -> None:
    """``--run``: the main-job run whose objective a study measures (default :data:`RUN`)."""
    ap.add_argument("--run", type=Path, default=RUN, help="the main-job run's results.json")


def read_run(path: Path) -> dict:
    """The main-job run's results (``--run``), or an exit saying how to make them."""
    if not path.exists():
        raise SystemExit(f"{path} not found: make it with python -m optimize --out <folder>")
    return json.loads(path.read_text())


def settings_of(run: dict, dt: float, samples: int, horizon: str = "slowest") -> Settings:
    """The run's settings (lists back to tuples) with the fixed step ``dt``, the soft
    peak's ``samples`` and the members' ``horizon``."""
    s = Settings()
    for name, value in run["settings"].items():
        setattr(s, name, tuple(value) if isinstance(value, list) else value)
    s.dt, s.samples, s.horizon = dt, samples, horizon
    s.validate()
    return s
