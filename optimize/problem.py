"""The design problems of the main job: scene, design space, objective, re-measurement.

Three problems (``--problem``), all robust over a band of speeds and chain wear:

* ``gentle`` (the default): a free-form asymmetric tooth (each side of the gap its own
  seat angle and a flank of two arcs, plus the seating radius; 7 coordinates) against
  the worst peak roller/tooth force of the engagement;
* ``iso``: the four ISO 606 tooth-gap parameters inside the standard's box;
* ``ring``: the free-form tooth and a cushion ring beside it (its radius, stiffness and
  damping; 10 coordinates), against the members' mean peak (:data:`MAX_COMBINED` says
  why): :func:`ring_space`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxchain as jc
from jaxchain.design import DesignSpace, ProfileObjective, SprocketDesign


def _is_optimizer(name: str) -> bool:
    """Whether ``optax.<name>(learning_rate)`` builds a gradient transformation."""
    import optax

    make = getattr(optax, name, None) if name.isidentifier() else None
    if not callable(make) or isinstance(make, type):
        return False
    try:
        opt = make(0.1)
    except Exception:  # noqa: BLE001 - anything that is not an optimizer factory
        return False
    return callable(getattr(opt, "init", None)) and callable(getattr(opt, "update", None))


PROBLEMS = ("gentle", "iso", "ring")
# problems whose members combine by a soft maximum (the others: by their mean). The ring
# problem averages: a ring reaches only an unworn chain (a 2 %-worn 08B chain seats 0.7 mm
# further out, beyond any ring the box allows), so the worn members, the worst, do not
# see it, and under a soft maximum its gain on the unworn ones would count for nothing
MAX_COMBINED = ("gentle",)
HORIZONS = ("slowest", "own")


def option(default, help: str, **cli):
    """A :class:`Settings` field with its command-line option: ``help`` (the default is
    appended), ``flag`` (default ``--`` + the name with dashes), ``choices``, and
    ``fast``: the option's default is None on the command line, so that ``--fast`` can tell
    a value given from the default (:data:`optimize.__main__.FAST`)."""
    meta = {"help": help, **cli}
    if isinstance(default, tuple):
        return field(default_factory=lambda: default, metadata=meta)
    return field(default=default, metadata=meta)


@dataclass
class Settings:
    """Everything that defines a run (saved with its results; a resume must match). Each
    field's option of ``python -m optimize`` is generated from it (``optimize.__main__``)."""

    problem: str = option(
        "gentle",
        "gentle: free-form asymmetric tooth, worst peak over speeds and wear; iso: the four "
        "ISO 606 parameters inside the standard's box; ring: the free-form tooth with a "
        "cushion ring beside it (its radius, stiffness and damping; the members' mean "
        "peak); timing: a timing drive's non-circular crank sprocket and tensioner against "
        "the camshafts' torque over 1000-6000 rpm (optimize/timing.py; --iterations, --out, "
        "--resume, --fast apply); quiet: the tooth alone and the tooth with a cushion ring "
        "(problem ring: the ring's radius, stiffness and damping beside the tooth), "
        "re-measured in the clearance-joint chain dry and in oil (optimize/quiet.py; "
        "--speeds, --clearance-engagements, --viscosity, --iterations, --out, --resume, "
        "--fast apply)",
        choices=("gentle", "iso", "ring", "timing", "quiet"),
    )
    scene: str = option(
        "engagement",
        "engagement: one driver meshing a tensioned strand; drive: closed chain over driver "
        "and driven sprockets",
        choices=("engagement", "drive"),
    )
    chain: str = option("08B", "ISO 606 chain")
    teeth: int = option(18, "teeth of the designed sprocket (the driver)")
    driven_teeth: int = option(36, "drive scene: teeth of the driven sprocket")
    speed_rpm: float = option(1000.0, "driver speed [rpm]", flag="--speed")
    load: float = option(
        1000.0,
        "engagement: entry tension [N] (default 1000); drive: load torque [N·m] (default 20)",
        by_scene={"engagement": 1000.0, "drive": 20.0},
    )
    pretension: float = option(200.0, "drive scene: chain tension at rest [N]")
    fidelity: str = option(
        "lumped", "the designed model's fidelity", choices=("lumped", "clearance")
    )
    periods: int = option(2, "tooth periods simulated", fast=2)
    warmup: int = option(1, "periods before the objective's window (start-up)", fast=1)
    temperature: float = option(0.007, "soft-max temperature as a fraction of the baseline peak")
    samples: int = option(
        8,
        "soft peak: trapezoid parts per fixed step (0: integrated by the solver's stages)",
    )
    horizon: str = option(
        "own",
        "each member's solve: --periods of its own tooth periods (one compiled solve per "
        "speed) or the slowest member's periods (one solve, 3× the periods at the fastest of "
        "a 0.5-1.5 band); the window fits the slowest member either way",
        choices=HORIZONS,
    )
    dt: float = option(4e-6, "fixed step of the optimized solve [s]")
    contact_width: float = option(3e-6, "contact-onset regularization of the optimized model [m]")
    joint_slip: float = option(
        2e-2, "joint friction's creep speed in the optimized model [m/s] (nominal 2e-3)"
    )
    ensemble: tuple[float, ...] = option(
        (0.5, 1.0, 1.5), "speed factors of the operating points, e.g. 0.9,1,1.1", fast=(1.0,)
    )
    wear: tuple[float, ...] = option(
        (0.0, 0.02), "chain elongations of the operating points, e.g. 0,0.02", fast=(0.0,)
    )
    iterations: int = option(10, "optimizer iterations", fast=3)
    optimizer: str = option("adam", "optax optimizer (adam, sgd, ...)")
    learning_rate: float = option(
        0.25, "in the design coordinate u (ISO range: u in about [-4, 4])"
    )
    clip: float = option(100.0, "clip the gradient to this norm [N] before the optimizer (0: off)")
    baseline_budget: int = option(
        120, "simulations for the Nelder–Mead comparison (0 skips it)", fast=4
    )
    remeasure_rtol: float = option(1e-9, "the re-measurement's tolerance (--fast: 1e-6)", flag=None)
    clearance_engagements: int = option(
        30,
        "re-measure both designs in the clearance-joint chain (the source paper's model, "
        "default joint friction) over this many meshing events per operating point (0 "
        "skips it)",
        fast=0,
    )
    clearance_points: str = option(
        "worst",
        "where to re-measure in the clearance chain: the baseline's worst operating point "
        "in the lumped chain (about a minute) or all of them",
        choices=("worst", "all"),
    )

    def validate(self) -> None:
        if self.problem not in PROBLEMS:
            raise ValueError(f"problem must be one of {PROBLEMS}, got {self.problem!r}")
        if self.scene not in ("engagement", "drive"):
            raise ValueError(f"scene must be 'engagement' or 'drive', got {self.scene!r}")
        if self.fidelity not in ("lumped", "clearance"):
            raise ValueError(f"fidelity must be 'lumped' or 'clearance', got {self.fidelity!r}")
        jc.ChainSpec.iso606(self.chain)  # raises with the list of designations
        for name in ("teeth", "driven_teeth"):
            if not 7 <= getattr(self, name) <= 250:
                raise ValueError(f"{name} must be in [7, 250], got {getattr(self, name)}")
        reals = ["speed_rpm", "load", "temperature", "dt", "learning_rate", "remeasure_rtol"]
        for name in reals + ["contact_width", "joint_slip"]:
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite number, got {getattr(self, name)}")
        for name in reals[:1] + reals[2:]:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.load < 0:
            raise ValueError(f"load must be >= 0, got {self.load}")
        if not (math.isfinite(self.pretension) and self.pretension > 0):
            raise ValueError(f"pretension must be a finite number > 0 [N], got {self.pretension}")
        if not (math.isfinite(self.clip) and self.clip >= 0):
            raise ValueError(f"clip must be a finite number >= 0 (0: no clipping), got {self.clip}")
        if self.baseline_budget < 0:
            raise ValueError(
                f"baseline_budget must be >= 0 (0 skips it), got {self.baseline_budget}"
            )
        if not 1 <= self.warmup + 1 <= self.periods:
            raise ValueError(
                f"need 0 <= warmup < periods (window of at least one period), got warmup="
                f"{self.warmup}, periods={self.periods}"
            )
        if self.horizon not in HORIZONS:
            raise ValueError(f"horizon must be one of {HORIZONS}, got {self.horizon!r}")
        if not 0 <= self.samples <= 64:
            raise ValueError(
                f"samples must be in [0, 64] (0: the soft peak integrated by the solver's "
                f"stages; 8 resolves the 4 µs step), got {self.samples}"
            )
        if self.iterations < 1:
            raise ValueError(f"iterations must be >= 1, got {self.iterations}")
        if not self.ensemble or not all(0.2 <= f <= 5 for f in self.ensemble):  # NaN fails
            raise ValueError(f"ensemble speed factors must be in [0.2, 5], got {self.ensemble}")
        if not self.wear or not all(0 <= e <= 0.03 for e in self.wear):
            raise ValueError(
                f"wear (chain elongations) must be in [0, 0.03] (0.02 = 2 %), got {self.wear}"
            )
        if self.scene == "drive" and any(e != 0 for e in self.wear):
            raise ValueError("the drive scene models an unworn chain: use --wear 0")
        if not _is_optimizer(self.optimizer):
            raise ValueError(
                f"optimizer must name an optax optimizer taking a learning rate (adam, sgd, "
                f"adamw, lion, ...), got {self.optimizer!r}"
            )
        if not 0 <= self.contact_width <= 2e-5:
            raise ValueError(
                "contact_width must be in [0, 2e-5] m (nominal law: 1e-8), got "
                f"{self.contact_width}"
            )
        if not 1e-4 <= self.joint_slip <= 0.1:
            raise ValueError(
                "joint_slip must be in [1e-4, 0.1] m/s (nominal joint friction: "
                f"{float(jc.scenes.JOINT_FRICTION.slip_velocity)}), got {self.joint_slip}"
            )
        if not 0 <= self.clearance_engagements <= 1000:
            raise ValueError(
                "clearance_engagements must be in [0, 1000] (0 skips the clearance-chain "
                f"re-measurement; 30 or more for a confidence interval), got "
                f"{self.clearance_engagements}"
            )
        if self.clearance_points not in ("worst", "all"):
            raise ValueError(
                f"clearance_points must be 'worst' or 'all', got {self.clearance_points!r}"
            )
        if self.dt > 2e-5:
            raise ValueError(f"dt must be <= 2e-5 s to resolve the meshing impacts, got {self.dt}")

    def as_dict(self) -> dict:
        d = asdict(self)
        d["ensemble"] = list(self.ensemble)
        d["wear"] = list(self.wear)
        return d


@dataclass
class Problem:
    settings: Settings
    chain: jc.ChainSpec
    space: DesignSpace
    tooth_period: float
    t1: float
    t_start: float
    start: object = None  # the design the optimizer starts from (a tooth profile)
    reference: float = 1.0
    objective: ProfileObjective | None = None
    baselines: dict = field(default_factory=dict)

    def spec(
        self,
        design,
        speed_factor: float = 1.0,
        roller_contact=None,
        joint_friction=jc.scenes.JOINT_FRICTION,
        wear: float = 0.0,
    ) -> jc.scenes.StrandSpec | jc.scenes.DriveSpec:
        """The scene of ``design`` (a tooth profile, or a
        :class:`~jaxchain.design.SprocketDesign`: its tooth and its cushion ring) at one
        operating point, as data: the meshing strand's :class:`~jaxchain.scenes.StrandSpec`
        or the drive's :class:`~jaxchain.scenes.DriveSpec` (``spec.replace(...)`` for
        another point; :meth:`build` builds it)."""
        s = self.settings
        profile, cushion = jc.design.profile_of(design), getattr(design, "cushion", None)
        model = dict(
            chain=self.chain,
            speed_rpm=s.speed_rpm * speed_factor,
            fidelity=s.fidelity,
            roller_contact=roller_contact,
            joint_friction=joint_friction,
        )
        driver = jc.scenes.SprocketSpec(s.teeth, profile=profile, load=None, cushion=cushion)
        if s.scene == "engagement":
            # the window is set by the slowest member; a faster one meshes more rollers
            n_entry = math.ceil(s.periods * max(s.ensemble) / min(s.ensemble)) + 1
            return jc.scenes.StrandSpec(
                sprocket=driver, tension=s.load, n_entry=n_entry, elongation=wear, **model
            )
        driven = jc.ToothProfile.iso606(self.chain, s.driven_teeth, "mid")
        return jc.scenes.DriveSpec(
            sprockets=(driver, jc.scenes.SprocketSpec(s.driven_teeth, profile=driven, load=s.load)),
            pretension=s.pretension,
            **model,
        )

    def build(self, design, *args, **kwargs):
        """The settled scene of ``design`` at one operating point (:meth:`spec`'s
        arguments), built from its spec."""
        return self.spec(design, *args, **kwargs).build()

    @property
    def take_up(self) -> float:
        return 2 * self.settings.pretension if self.settings.scene == "drive" else 0.0

    def design_law(self):
        """The optimized model's roller/tooth law: the nominal one with its contact-onset
        regularization widened to ``contact_width``, so the fixed step resolves contact
        onset and the gradient converges as the step shrinks (the nominal 10 nm onset is
        crossed inside one step, and where steps fall then puts sub-micrometre ripples
        into the objective). Every result is re-measured with the nominal law."""
        return jc.scenes.roller_law(self.chain, 0.7, width=self.settings.contact_width)

    def design_joint_friction(self):
        """The optimized model's joint friction: the nominal μ with its creep band widened
        to ``joint_slip`` (the nominal 2 mm/s band makes the joints' sticking a decay of
        about a microsecond, which an explicit fixed step of a few µs does not follow:
        the gradient then blows up). Every result is re-measured with the nominal."""
        mu = jc.scenes.JOINT_FRICTION.coefficient
        return jc.contact.CoulombFriction(coefficient=mu, slip_velocity=self.settings.joint_slip)

    @property
    def operating_points(self) -> list[tuple[float, float]]:
        """(speed factor, wear) of every ensemble member, speeds outer."""
        return [(f, e) for f in self.settings.ensemble for e in self.settings.wear]

    @property
    def shared(self) -> bool:
        """Whether the operating points are shared among processes (JAX's multi-process
        runtime, ``python -m jaxchain.launch -n N -m optimize``)."""
        import jax

        return jax.process_count() > 1

    def members(self, profile, points=None):
        law, joints = self.design_law(), self.design_joint_friction()
        points = self.operating_points if points is None else points

        def member(i):
            f, e = points[i]
            return self.build(profile, f, roller_contact=law, joint_friction=joints, wear=e)

        if self.shared:  # each process builds its own operating points only
            return jc.distributed.local_members(len(points), member)
        return [member(i) for i in range(len(points))]

    def make_objective(self, reference: float) -> ProfileObjective | SpeedGroups:
        """The design objective; with ``horizon`` "own" one objective per speed, each
        solving its members over ``periods`` of their own tooth periods, combined."""
        s = self.settings
        self.reference = reference

        def objective(points, t1, t_start):
            return ProfileObjective(
                self.space,
                lambda profile: self.members(profile, points),
                t1=t1,
                t_start=t_start,
                temperature=s.temperature * reference,
                reference=reference,
                samples=s.samples,
                dt=s.dt,
                take_up=self.take_up,
                combine="max" if s.problem in MAX_COMBINED else "mean",
                throw=False,  # a failed member is reported by the run (NaN value, its message)
                sharding="auto" if self.shared else None,
            )

        if s.horizon == "slowest":
            self.objective = objective(self.operating_points, self.t1, self.t_start)
            return self.objective
        groups = []
        for f in s.ensemble:
            scale = min(s.ensemble) / f  # this speed's tooth period over the slowest's
            points = [(f, e) for e in s.wear]
            groups.append(objective(points, self.t1 * scale, self.t_start * scale))
        tau = s.temperature * reference if s.problem in MAX_COMBINED else None  # None: mean
        self.objective = SpeedGroups(groups, tau)
        return self.objective


class SpeedGroups:
    """Several :class:`ProfileObjective` (one per speed, of equally many members each) as
    one: their values combined as the members of one would be — a soft maximum (``tau``)
    of log-mean-exp values of equal-sized groups is the log-mean-exp of all members, a
    mean of equal-sized means the mean — with the gradient by the same weights. The
    members' results are concatenated in the groups' order. Each group builds, settles
    and solves its members in a thread of its own, ``threads`` at a time (default: one
    per core, :func:`solve_threads`), with the results of one after the other, bit for
    bit."""

    def __init__(
        self, groups: list[ProfileObjective], tau: float | None, threads: int | None = None
    ):
        self.groups, self.tau, self.threads, self._offset = groups, tau, threads, 0

    @property
    def evaluations(self) -> int:
        return self._offset + sum(g.evaluations for g in self.groups)

    @evaluations.setter
    def evaluations(self, n: int) -> None:
        self._offset = n - sum(g.evaluations for g in self.groups)

    def _weights(self, values):
        v = jnp.stack(values)
        if self.tau is None:
            return jnp.mean(v), jnp.full(v.shape, 1.0 / v.shape[0])
        lse = jax.nn.logsumexp(v / self.tau)
        return self.tau * (lse - math.log(v.shape[0])), jnp.exp(v / self.tau - lse)

    @staticmethod
    def _members(outs):
        return jax.tree_util.tree_map(lambda *x: jnp.concatenate(x), *outs)

    def value(self, u):
        outs = solve_all(lambda g: g.value(u), self.groups, self.threads)
        return self._weights([v for v, _ in outs])[0], self._members([o for _, o in outs])

    def value_and_grad(self, u):
        outs = solve_all(lambda g: g.value_and_grad(u), self.groups, self.threads)
        value, w = self._weights([v for v, _, _ in outs])
        grad = sum(wi * g for wi, (_, g, _) in zip(w, outs, strict=True))
        return value, grad, self._members([o for _, _, o in outs])


def gentle_space(chain: jc.ChainSpec, teeth: int) -> tuple[DesignSpace, jc.FreeformProfile]:
    """The free-form asymmetric tooth's design space and its start: the ISO 606 minimum
    form's seat and flanks (each flank split into two arcs) with the tip circle at the
    standard's smallest diameter; coordinates: the seating radius (ISO range), each
    side's seat angle (clockwise side 62–78°, counter-clockwise 57–68°; ISO: 57.5–67.5°
    at z = 18) and its two arcs' curvatures (clockwise 8–50 1/m, counter-clockwise
    20–50 1/m; ISO: 29–49 1/m). Every corner of the box is a valid tooth."""
    start, bounds = _gentle(chain, teeth)
    return DesignSpace.select(start, bounds), start


def _gentle(chain: jc.ChainSpec, teeth: int) -> tuple[jc.FreeformProfile, dict]:
    """:func:`gentle_space`'s start and bounds."""
    lim = jc.iso606_limits(chain, teeth)
    iso = jc.ToothProfile.iso606(chain, teeth, "min")
    start = jc.FreeformProfile.from_iso(iso, 2, tip_diameter=lim["tip_diameter"][0])
    deg = math.radians
    return start, {
        "seating_radius": lim["seating_radius"],
        "cw.seat_angle": (deg(62.0), deg(78.0)),
        "ccw.seat_angle": (deg(57.0), deg(68.0)),
        "cw.curvature": (8.0, 50.0),
        "ccw.curvature": (20.0, 50.0),
    }


def seated_plate_edge(chain: jc.ChainSpec, teeth: int) -> float:
    """How far from the axis the seated links' plate edges sit [m]: r_p·cos(π/z) − h/2
    (08B on 18 teeth: 30.108 mm)."""
    rp = float(chain.pitch) / (2 * math.sin(math.pi / teeth))
    return rp * math.cos(math.pi / teeth) - float(chain.plate_height) / 2


# the ring's box (ring_space): its reach into the seated plates, its stiffness, damping
RING_REACH = (-0.05e-3, 0.2e-3)  # [m] about the seated plate edges
RING_STIFFNESS = (2e7, 5e7)  # [N/m^1.5] per plate edge and face
RING_DAMPING = (0.1, 1.0)  # [s/m] Hunt–Crossley α: restitution 0.93–0.47 at 1 m/s


def ring_space(chain: jc.ChainSpec, teeth: int) -> tuple[DesignSpace, SprocketDesign]:
    """The free-form tooth of :func:`gentle_space` with a cushion ring on both faces
    (:class:`jc.elements.CushionRing`): its radius from 0.05 mm short of the seated
    plate edges to 0.2 mm into them (:data:`RING_REACH`; 0.2 mm is 20 % of the default
    ring's 1 mm elastomer layer, the usual limit of an elastomer's static compression),
    its stiffness from 2·10⁷ to the default HNBR ring's 5·10⁷ N/m^1.5 (softer
    elastomers) and its damping 0.1–1 s/m. The box bounds the ring's load on the seated
    links at rest: at most the default ring's 0.2 mm into them. Starts from the gentle
    start's tooth and the box's middle ring."""
    tooth, tooth_bounds = _gentle(chain, teeth)
    reach = [seated_plate_edge(chain, teeth) + r for r in RING_REACH]
    mid = lambda lo_hi: 0.5 * (lo_hi[0] + lo_hi[1])  # noqa: E731
    ring = jc.elements.CushionRing(
        mid(reach), stiffness=mid(RING_STIFFNESS), damping=mid(RING_DAMPING)
    )
    bounds = {f"profile.{name}": pair for name, pair in tooth_bounds.items()} | {
        "cushion.radius": tuple(reach),
        "cushion.stiffness": RING_STIFFNESS,
        "cushion.damping": RING_DAMPING,
    }
    start = SprocketDesign(tooth, ring)
    return DesignSpace.select(start, bounds), start


def make_problem(settings: Settings) -> Problem:
    settings.validate()
    chain = jc.ChainSpec.iso606(settings.chain)
    if settings.problem == "iso":
        space = DesignSpace.iso606(chain, settings.teeth)
        start = space.template  # the mid form, u = 0
    elif settings.problem == "ring":
        space, start = ring_space(chain, settings.teeth)
    else:
        space, start = gentle_space(chain, settings.teeth)
    period = 60.0 / (settings.teeth * settings.speed_rpm)
    slowest = period / min(settings.ensemble)  # the window fits the slowest member
    return Problem(
        settings=settings,
        chain=chain,
        space=space,
        tooth_period=period,
        t1=settings.periods * slowest,
        t_start=settings.warmup * slowest,
        start=start,
    )


#: the independent check's roller/tooth law (``jc.design.second_law``)
second_law = jc.design.second_law
solve_threads = jc.design.solve_threads


#: every job's solve, in order, on the cores this process may use
solve_all = jc.design.solve_each


def remeasure(problem: Problem, profile, *, law: str = "johnson", rtol: float | None = None):
    """Independent check of one design: fresh settled scene(s), Dopri8 (the optimization
    used fixed-step Tsit5), tight tolerances, the *sharp* maximum of the roller/tooth force
    in the objective's window from dense output (spacing ≤ 0.5 µs). Returns a dict per
    ensemble member and the worst over them."""
    return remeasure_many(problem, [(profile, law)], rtol=rtol)[0]


def remeasure_many(
    problem: Problem, designs: list, *, rtol: float | None = None, threads: int | None = None
) -> list[dict]:
    """:func:`remeasure` of each ``(profile, law)`` in ``designs``, in order:
    ``jc.design.remeasure`` of its operating points, each built, settled and solved
    independently of the others, ``threads`` at a time (default :func:`solve_threads`),
    each on a core of its own. The results are those of one solve after the other, bit for
    bit."""
    s = problem.settings
    rtol = s.remeasure_rtol if rtol is None else rtol
    out = []
    for profile, law in designs:
        contact = None if law == "johnson" else second_law(problem.chain)
        builds = [
            lambda p=profile, c=contact, f=f, e=e: problem.build(p, f, roller_contact=c, wear=e)
            for f, e in problem.operating_points
        ]
        r = jc.design.remeasure(
            builds, problem.t1, t_start=problem.t_start, rtol=rtol, threads=threads
        )
        for (f, e), m in zip(problem.operating_points, r["members"], strict=True):
            m.update(speed_factor=f, wear=e)
        out.append(r)
    return out


def profile_values(profile, space: DesignSpace | None = None) -> dict:
    """The design's parameters: the ISO 606 four of a ``ToothProfile``, else the space's
    chosen leaves (floats or lists)."""
    out = {}
    for name in jc.design.PARAMETERS if space is None else space.names:
        leaf = profile
        for part in name.split("."):
            leaf = getattr(leaf, part)
        v = np.asarray(leaf, dtype=float)
        out[name] = float(v) if v.ndim == 0 else v.tolist()
    return out


def iso_forms(problem: Problem) -> dict:
    return {
        form: jc.ToothProfile.iso606(problem.chain, problem.settings.teeth, form)
        for form in ("min", "max", "mid")
    }


def replace_profile(scene, profile, k: int = 0):
    return eqx.tree_at(lambda sc: sc.sprockets[k].profile, scene, profile)


def coordinates_of(problem: Problem, profile) -> jnp.ndarray:
    return problem.space.coordinates(profile, margin=0.02)
