"""Design objectives computed inside the ODE solve: a smooth peak force, any observer, over
an ensemble of operating points, with its gradient (see :mod:`jaxchain.design`)."""

from __future__ import annotations

import abc
import math
import warnings
from collections.abc import Callable, Sequence
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .. import _checks as checks
from .._numerics import is_concrete
from .._observers.base import (
    EXP_CAP as EXP_CAP,
    AbstractIntegralObserver,
    AbstractObserver,
    AbstractStepObserver,
    SampledSoftPeak,
    SoftPeak,
    check_rollers,
    window_weight as window_weight,
)
from .._profiles.iso import ToothProfile
from .._programs import stored
from .._scene import Scene
from .._scenes.statics import resettle_by_inverse, statics_jacobian
from .._solve import distributed as dist
from .._solve.options import SolveOptions, with_options
from .._solve.result import Result, SolveError, raise_if_failed, result_names
from .._solve.solve import check_horizon, solve, strong_scene
from .._solve.stack import stack
from .space import DesignSpace, coordinate
from .sprocket import SprocketDesign, place

__all__ = [
    "AbstractReduction",
    "Mean",
    "SoftMax",
    "Worst",
    "PeakForce",
    "Observed",
    "Penalized",
    "observe",
    "soft_peak_force",
    "window_weight",
    "ProfileObjective",
]


class Observed(NamedTuple):
    """Result of :func:`observe` (and each member's, from :class:`ProfileObjective`)."""

    value: Array  # the observer's value
    result: Result
    num_steps: Array

    @property
    def soft(self) -> Array:
        """The value (for the default objective, the soft peak force [N])."""
        return self.value


def _objective_observer(observer, caller: str):
    if not isinstance(observer, (AbstractIntegralObserver, AbstractStepObserver)):
        raise TypeError(
            f"{caller}: the objective must be a jc.observers observer with a scalar value "
            f"(SoftPeak, BandLevel, SpeedVariation, design.Penalized, ...), got "
            f"{type(observer).__name__}"
        )
    return observer


def observe(
    scene: Scene,
    t1: ArrayLike,
    observer: AbstractObserver,
    *,
    options: SolveOptions | None = None,
    **solve_options,
) -> Observed:
    """One observer's value over [0, t1], carried by the one solve (``simulate``'s), the
    outcome reported as a result code (classified as ``simulate`` classifies it), not
    raised. Solve options as in :func:`~jaxchain.simulate`; ``dt`` gives fixed steps,
    differentiated exactly (for gradients checked against finite differences)."""
    opts = with_options(options, solve_options, "observe")
    _objective_observer(observer, "observe")
    if is_concrete(t1):
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
    return _observe(scene, t1, observer, opts, "observe")


def _observe(scene, t1, observer, opts: SolveOptions, caller: str) -> Observed:
    resolved = opts.resolve(0.0, t1)  # before t1 becomes an array: dt's step count
    t1 = jnp.asarray(t1, dtype=float)
    scene = strong_scene(scene, caller)
    check_horizon(scene, t1, caller)
    check_rollers(scene, (observer,), caller)
    traj = solve(scene, jnp.asarray(0.0, dtype=float), t1, None, resolved, (observer,))
    return Observed(traj.observed[0], traj.result, traj.stats["num_steps"])


class Penalized(AbstractIntegralObserver):
    """ "Minimize ``objective`` subject to ``constraint`` ≤ ``limit``" as one smooth value,
    an exterior penalty:

        J = objective + weight · width · softplus((constraint − limit) / width)

    Below the limit by a few ``width`` the penalty vanishes (softplus ≈ 0); above it, it
    grows with slope ``weight`` [objective units per constraint unit]. Both parts are
    integrated by the same solve. Example: the largest mesh-order line [dB] with the
    soft peak force held at the baseline's [N]:
    ``Penalized(BandLevel.mesh_band(18, 0.2, 2.2), SoftPeak(...), limit=1500.0,
    weight=0.1, width=10.0)`` costs 0.1 dB per newton over 1500 N.

    Attributes:
        objective, constraint: integral observers with scalar values.
        limit: the constraint's bound [its units].
        weight: penalty slope [objective units per constraint unit], > 0.
        width: softplus width [constraint units], > 0.
    """

    objective: AbstractIntegralObserver
    constraint: AbstractIntegralObserver
    limit: Float[Array, ""]
    weight: Float[Array, ""]
    width: Float[Array, ""]

    def __init__(self, objective, constraint, *, limit, weight=1.0, width=1.0):
        for name, o in (("objective", objective), ("constraint", constraint)):
            checks.instance(
                f"Penalized.{name}", o, AbstractIntegralObserver,
                "an integral observer (SoftPeak, BandLevel, SpeedVariation, ...)",
            )  # fmt: skip
        if is_concrete((limit, weight, width)):
            checks.real("Penalized.limit", limit)
            checks.real("Penalized.weight", weight, lo=0.0, lo_open=True)
            checks.real("Penalized.width", width, lo=0.0, lo_open=True)
        self.objective = objective
        self.constraint = constraint
        self.limit = jnp.asarray(limit, dtype=float)
        self.weight = jnp.asarray(weight, dtype=float)
        self.width = jnp.asarray(width, dtype=float)

    def integrand(self, t, y, scene, forces):
        return (
            self.objective.integrand(t, y, scene, forces),
            self.constraint.integrand(t, y, scene, forces),
        )

    def parts(self, state, t0, t1) -> tuple[Array, Array]:
        """(objective, constraint) values."""
        return self.objective.value(state[0], t0, t1), self.constraint.value(state[1], t0, t1)

    def value(self, state, t0, t1):
        obj, con = self.parts(state, t0, t1)
        excess = jax.nn.softplus((con - self.limit) / self.width)
        return obj + self.weight * self.width * excess


class PeakForce(NamedTuple):
    """Result of :func:`soft_peak_force`."""

    soft: Float[Array, ""]  # smooth peak of the roller/tooth normal force [N]
    result: Result
    num_steps: Array


def soft_peak_force(
    scene: Scene,
    t1: ArrayLike,
    *,
    t_start: ArrayLike = 0.0,
    rise: ArrayLike | None = None,
    temperature: ArrayLike = 50.0,
    reference: ArrayLike = 0.0,
    samples: int = 0,
    options: SolveOptions | None = None,
    **solve_options,
) -> PeakForce:
    """Smooth peak of the roller/tooth normal force over [t_start, t1] (from t0 = 0): the
    :class:`~jaxchain.observers.SoftPeak` observer integrated by the one solve
    (``rise`` defaults to 5 % of the window); with ``samples`` ≥ 1 the
    :class:`~jaxchain.observers.SampledSoftPeak`, its integral by the trapezoid rule on
    ``samples`` parts of every step (for fixed steps longer than the soft maximum's
    spike, see there).

    Solve options as in :func:`~jaxchain.simulate` (``options=`` and/or keywords).
    ``dt`` gives fixed steps, ⌈t1/dt⌉ of them, differentiated exactly (a smooth
    function of every parameter, as needed for gradients checked against finite
    differences); without it, adaptive steps (PID, ``rtol``/``atol`` in the max norm).

    The outcome is reported, not raised: ``PeakForce.result`` is classified exactly as
    ``simulate`` classifies the same solve (:class:`ProfileObjective` raises).
    """
    opts = with_options(options, solve_options, "soft_peak_force")
    if is_concrete((t1, t_start, temperature, reference, rise)):
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
        checks.real("temperature", temperature, lo=0.0, lo_open=True, unit="N")
        checks.real("reference", reference, unit="N")
        checks.real("t_start", t_start, lo=0.0, hi=t1, hi_open=True, unit=f"s (t1 = {t1:.6g} s)")
        if rise is not None:
            checks.real("rise", rise, lo=0.0, unit="s (0: a step)")
    t_start = jnp.asarray(t_start, dtype=float)
    rise = 0.05 * (jnp.asarray(t1, dtype=float) - t_start) if rise is None else rise
    observer = _soft_peak(t_start, rise, temperature, reference, samples)
    out = _observe(scene, t1, observer, opts, "soft_peak_force")
    return PeakForce(out.value, out.result, out.num_steps)


def _soft_peak(t_start, rise, temperature, reference, samples):
    """The soft peak observer: integrated by the solver (``samples`` 0) or sampled."""
    samples = checks.integer("samples", samples, lo=0)
    if samples:
        return SampledSoftPeak(t_start, rise, temperature, reference, samples)
    return SoftPeak(t_start, rise, temperature, reference)


class AbstractReduction(eqx.Module):
    """How a :class:`ProfileObjective` combines its members' values (one per operating
    point) into the objective: a function of the (M,) values, differentiable where the
    design needs it. Subclass it for a reduction of your own (a weighted mean, a
    quantile); its array fields are traced, so a new weight does not recompile."""

    @abc.abstractmethod
    def __call__(self, values: Float[Array, " M"]) -> Float[Array, ""]:
        """The objective from the members' values."""


class Mean(AbstractReduction):
    """The members' mean: every operating point counts alike."""

    def __call__(self, values):
        return jnp.mean(values)


class SoftMax(AbstractReduction):
    """A soft maximum of the members, their log-mean-exp at ``temperature`` [objective
    units]: the worst member dominates, and the gradient still sees the others within a
    few temperatures of it. ``temperature`` None: the default soft peak's (the
    objective's ``temperature``)."""

    temperature: Array | None = None

    def __init__(self, temperature: float | None = None):
        if temperature is not None and is_concrete(temperature):
            checks.real("SoftMax.temperature", temperature, lo=0.0, lo_open=True)
        self.temperature = None if temperature is None else jnp.asarray(temperature, float)

    def __call__(self, values):
        tau = self.temperature
        return tau * (jax.nn.logsumexp(values / tau) - math.log(values.shape[0]))


class Worst(AbstractReduction):
    """The worst (largest) member's value: its gradient is that member's alone, and jumps
    where another member overtakes it (:class:`SoftMax` is the smooth form)."""

    def __call__(self, values):
        return jnp.max(values)


#: ``combine``'s names for the reductions
REDUCTIONS = {"mean": Mean, "max": SoftMax, "worst": Worst}


def _reduction(combine, temperature: float, member_temperature) -> AbstractReduction:
    """``combine`` (a name of :data:`REDUCTIONS` or a reduction) as a reduction, a
    :class:`SoftMax` without its own temperature at ``member_temperature`` (the older
    keyword), else at the default soft peak's ``temperature``."""
    if isinstance(combine, str):
        checks.choice("combine", combine, tuple(REDUCTIONS))
        combine = REDUCTIONS[combine]()
    checks.instance(
        "combine", combine, AbstractReduction,
        f"one of {', '.join(map(repr, REDUCTIONS))} or a jc.design reduction (Mean(), "
        "SoftMax(temperature), Worst(), any jc.design.AbstractReduction)",
    )  # fmt: skip
    if isinstance(combine, SoftMax) and combine.temperature is None:
        tau = temperature if member_temperature is None else member_temperature
        tau = checks.real(
            "member_temperature" if member_temperature is not None else "temperature",
            tau, lo=0.0, lo_open=True, unit="(objective units)",
        )  # fmt: skip
        combine = SoftMax(tau)
    return combine


class _Config(eqx.Module):
    """Objective settings: arrays are traced, the rest (static) fixes the compiled shape."""

    objective: AbstractObserver
    reduction: AbstractReduction
    options: SolveOptions
    t1: float = eqx.field(static=True)
    sprocket: int = eqx.field(static=True)
    take_up: float = eqx.field(static=True)


def _member(u, space, scene, inverse, cfg):
    scene = place(scene, space.design(u), cfg.sprocket)
    scene = resettle_by_inverse(scene, cfg.take_up, inverse)
    return observe(scene, cfg.t1, cfg.objective, options=cfg.options)


def _combine(values, cfg):
    """The members' values (M,) combined into the objective."""
    return cfg.reduction(values)


# members: the scenes' array leaves (stack keeps the agreed non-array leaves as they are)
# and their statics Jacobians' inverses
_MEMBER_AXES = (None, None, eqx.if_array(0), 0, None)


def _loss(u, space, scenes, inverses, cfg):
    out = eqx.filter_vmap(_member, in_axes=_MEMBER_AXES)(u, space, scenes, inverses, cfg)
    return _combine(out.value, cfg), out


def _member_valued(u, space, scene, inverse, cfg):
    """One member's value and its :class:`Observed` (the value differentiated)."""
    out = _member(u, space, scene, inverse, cfg)
    return out.value, out


def _member_grad(u, space, scene, inverse, cfg):
    """One member's value's gradient in ``u``, and its :class:`Observed`."""
    return jax.grad(_member_valued, has_aux=True)(u, space, scene, inverse, cfg)


def _forward(f):
    """``f(u, *args) -> (value, aux)`` as ``((value, aux), ∇value)`` by forward mode: one
    tangent per coordinate of ``u``, all carried by one vmapped solve (the primal is
    computed once)."""

    def value_and_grad(u, *args):
        at = lambda d: jax.jvp(lambda u: f(u, *args), (u,), (d,))  # noqa: E731
        basis = jnp.eye(u.shape[0], dtype=u.dtype)
        (value, aux), (slopes, _) = jax.vmap(at, out_axes=((None, None), 0))(basis)
        return (value, aux), slopes

    return value_and_grad


def _member_grad_forward(u, space, scene, inverse, cfg):
    """:func:`_member_grad` by forward mode."""
    (_, out), grad = _forward(_member_valued)(u, space, scene, inverse, cfg)
    return grad, out


def _combined(values, grads, cfg):
    """The objective and its gradient from every member's value and gradient (the
    chain rule through :func:`_combine`)."""
    value, pullback = jax.vjp(lambda v: _combine(v, cfg), values)
    return value, pullback(jnp.ones_like(value))[0] @ grads


# module level: every ProfileObjective with the same static settings and scene structure
# shares one compiled function
# (and across processes: jaxchain._programs)
_value = stored("jaxchain.design.value")(eqx.filter_jit(_loss))
_value_and_grad = {
    "reverse": stored("jaxchain.design.value_and_grad")(
        eqx.filter_jit(eqx.filter_value_and_grad(_loss, has_aux=True))
    ),
    "forward": stored("jaxchain.design.value_and_grad.forward")(eqx.filter_jit(_forward(_loss))),
}
# across processes: each process's share of the members, per member; combined after
_members = eqx.filter_jit(eqx.filter_vmap(_member, in_axes=_MEMBER_AXES))
_members_grad = {
    "reverse": eqx.filter_jit(eqx.filter_vmap(_member_grad, in_axes=_MEMBER_AXES)),
    "forward": eqx.filter_jit(eqx.filter_vmap(_member_grad_forward, in_axes=_MEMBER_AXES)),
}
_combine_jit = eqx.filter_jit(_combine)
_combined_jit = eqx.filter_jit(_combined)
# the members' statics Jacobians at their settled starts, outside the differentiated
# function: compiled once per scene structure (stored: once across processes and
# threads), shared by the value and the gradient;
# inverted on the host (:meth:`ProfileObjective._prepared`), so that the differentiated
# programs hold no LAPACK call and run side by side in threads
_jacobians = stored("jaxchain.design.jacobians")(
    eqx.filter_jit(
        eqx.filter_vmap(
            lambda scene, take_up: statics_jacobian(scene, take_up=take_up),
            in_axes=(eqx.if_array(0), None),
        )
    )
)


#: design coordinates up to which ``gradient="auto"`` differentiates by forward mode (fixed
#: steps). Forward mode costs about half a value solve per coordinate, reverse mode about
#: four whatever the count (``benchmarks/gradient_cost.py``, the 08B engagement objective:
#: value + gradient 2.9× the value forward against 3.9× in reverse at 4 coordinates, 24×
#: against 4.4× at 36). On ``python -m optimize``'s default objective (7 coordinates, 6
#: members) forward mode ran 27–28 s per iteration against 18–23 s in reverse.
FORWARD_UP_TO = 4


#: a gradient beyond this many times the objective's own size (per unit of the design
#: coordinate u, which spans a box in a few units) is the trace of a fixed step that does
#: not follow a fast mode of the model, not a sensitivity: the largest measured on a
#: design objective is ~6e3 N per unit against a ~1e3 N value (the clearance-joint chain
#: over one engagement), the blow-ups ~1e35 and beyond
BLOWN_UP = 1e6


def _blown_up(value, grad) -> bool:
    g = np.asarray(grad)
    return bool(np.all(np.isfinite(g))) and float(np.max(np.abs(g), initial=0.0)) > BLOWN_UP * max(
        abs(float(value)), 1.0
    )


def _gradient_mode(gradient: str, space: DesignSpace, options: SolveOptions) -> str:
    """ "forward" or "reverse" for ``gradient`` ("auto", "forward", "reverse")."""
    checks.choice("gradient", gradient, ("auto", "forward", "reverse"))
    adjoint = options.adjoint
    forward_adjoint = isinstance(adjoint, diffrax.ForwardMode)
    if gradient == "forward" and not (adjoint is None or forward_adjoint):
        raise ValueError(
            f"gradient='forward' carries tangents through the solve with "
            f"diffrax.ForwardMode; the options' adjoint {type(adjoint).__name__} is a "
            "reverse-mode one: drop it, or use gradient='reverse'"
        )
    if gradient == "reverse" and forward_adjoint:
        raise ValueError(
            "gradient='reverse' cannot run through diffrax.ForwardMode: drop the adjoint, "
            "or use gradient='forward'"
        )
    if gradient != "auto":
        return gradient
    if forward_adjoint or (adjoint is None and options.fixed and space.size <= FORWARD_UP_TO):
        return "forward"
    return "reverse"


class ProfileObjective:
    """The design objective: a smooth measure of the scenes built for a tooth profile — by
    default their soft peak roller/tooth force — as a function of the design coordinate
    ``u``.

    For each evaluation the scenes are built and settled for the concrete profile at
    ``u`` (``build(profile) -> Scene`` or a list of scenes: an ensemble of operating
    points, which must share one structure); inside the differentiated function the
    profile is swapped in and :func:`~jaxchain.scenes.resettle` carries the static
    equilibrium's dependence on the profile into the gradient (implicit function
    theorem; each settled scene's statics Jacobian is computed once, outside the
    differentiated function, by :func:`~jaxchain.scenes.statics_jacobian`). Ensemble
    members are vmapped and combined by ``combine``, a reduction: "mean" (:class:`Mean`),
    "max" (:class:`SoftMax`, the members' log-mean-exp at the default soft peak's
    ``temperature``, or ``SoftMax(temperature)`` at its own), "worst" (:class:`Worst`,
    the largest member) or any :class:`AbstractReduction`.

    The measure is ``objective``, any observer with a scalar value integrated by the one
    solve (:class:`~jaxchain.observers.BandLevel` for the largest mesh-order line [dB],
    :class:`~jaxchain.observers.SpeedVariation`, :class:`Penalized` for a constrained
    form, ...); without it, :class:`~jaxchain.observers.SoftPeak` over [``t_start``,
    ``t1``] at ``temperature`` and ``reference`` — with ``samples`` ≥ 1 the
    :class:`~jaxchain.observers.SampledSoftPeak`, the form whose gradient converges as a
    fixed step shrinks (8 parts per step on the main job's engagement at 4 µs).

    With ``sharding="auto"`` each member's value and gradient are computed (vmapped) and
    then combined by the chain rule; under JAX's multi-process runtime
    (:mod:`jaxchain.distributed`) the members are shared among the processes: each solves
    its share, one all-gather brings every member's value, gradient and result code to
    every process, and each combines them, so every process gets the same value and
    gradient, equal to one process's with ``sharding="auto"``. ``build`` may then return
    every member's scenes, or this process's share
    (:func:`jaxchain.distributed.local_members`) so that each process builds only its own.
    The default (a reverse pass through the combination) agrees with it to round-off of
    the backward pass.

    A member whose solve failed makes the evaluation fail: ``RuntimeError`` naming the
    members and what to change (``throw=True``, the default), or with ``throw=False`` a
    NaN value and gradient, the members' codes in the returned :class:`Observed` — never
    a plausible number from a failed solve.

    Args:
        space: the :class:`DesignSpace` (any number of coordinates).
        build: profile -> settled scene(s) (concrete, outside the gradient); for a space
            over a :class:`~jaxchain.design.SprocketDesign`, the design (its tooth and
            its ring, which ``build`` puts on the designed sprocket) -> scene(s).
        t1: end of each solve [s].
        objective: the observer measured (default: the soft peak force below).
        t_start, temperature, reference: the default objective's, as in
            :func:`soft_peak_force`.
        samples: the default objective's parts per step (0: integrated by the solver's
            stages, for adaptive solves; ≥ 1: sampled, for fixed steps).
        sprocket: index of the designed sprocket in the scenes.
        take_up: the take-up the scenes were settled with (closed drives).
        combine: the members' reduction: "mean", "max", "worst" or a reduction
            (:class:`SoftMax` ``(temperature)`` for the soft maximum at a temperature
            of its own [objective units]; the older keyword ``member_temperature=τ``
            still gives it, with a ``DeprecationWarning``).
        throw: raise when a member fails (see above).
        sharding: None, or "auto": members shared among the processes (see above).
        gradient: "forward" (one tangent per coordinate, carried through the solve by
            ``diffrax.ForwardMode``), "reverse" (through the solve's adjoint), or "auto":
            forward for fixed steps and at most :data:`FORWARD_UP_TO` coordinates
            (faster to compile and to run there), reverse otherwise.
        options, **solve_options: as in :func:`~jaxchain.simulate` (``dt=`` for fixed
            steps).
    """

    def __init__(
        self,
        space: DesignSpace,
        build: Callable[[ToothProfile | SprocketDesign], Scene | Sequence[Scene]],
        *,
        t1: float,
        objective: AbstractObserver | None = None,
        t_start: float = 0.0,
        temperature: float = 50.0,
        reference: float = 0.0,
        samples: int = 0,
        sprocket: int = 0,
        take_up: float = 0.0,
        combine: str | AbstractReduction = "mean",
        throw: bool = True,
        sharding: str | None = None,
        gradient: str = "auto",
        options: SolveOptions | None = None,
        **solve_options,
    ):
        checks.instance("space", space, DesignSpace, "a jc.design.DesignSpace")
        if not callable(build):
            raise TypeError(
                f"build must be a function profile -> scene(s), got {type(build).__name__}"
            )
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
        temperature = checks.real("temperature", temperature, lo=0.0, lo_open=True, unit="N")
        reference = checks.real("reference", reference, unit="N")
        t_start = checks.real(
            "t_start", t_start, lo=0.0, hi=t1, hi_open=True, unit=f"s (t1 = {t1:.6g} s)"
        )
        member_temperature = solve_options.pop("member_temperature", None)
        if member_temperature is not None:
            warnings.warn(
                "ProfileObjective(member_temperature=τ) is now spelled "
                "combine=jc.design.SoftMax(τ)",
                DeprecationWarning,
                stacklevel=2,
            )
        reduction = _reduction(combine, temperature, member_temperature)
        if objective is None:
            rise = 0.05 * (t1 - t_start)
            objective = _soft_peak(t_start, rise, temperature, reference, samples)
        elif samples:
            raise ValueError(
                "samples sets the default soft peak's sampling; an objective given "
                f"({type(objective).__name__}) carries its own: pass samples=0"
            )
        _objective_observer(objective, "ProfileObjective")
        sprocket = checks.integer("sprocket", sprocket, lo=0)
        take_up = checks.real("take_up", take_up, lo=0.0, unit="N")
        checks.flag("throw", throw)
        if sharding is not None:
            checks.choice("sharding", sharding, ("auto",))
        self.sharding = sharding
        self.space = space
        self.build = build
        self.throw = bool(throw)
        self.config = _Config(
            objective=objective,
            reduction=reduction,
            options=with_options(options, solve_options, "ProfileObjective"),
            t1=float(t1),
            sprocket=int(sprocket),
            take_up=float(take_up),
        )
        self.gradient = _gradient_mode(gradient, space, self.config.options)
        # the forward gradient's solve carries the tangents through diffrax's own loop
        self._grad_config = self.config
        if self.gradient == "forward":
            self._grad_config = eqx.tree_at(
                lambda c: c.options.adjoint,
                self.config,
                diffrax.ForwardMode(),
                is_leaf=lambda x: x is None,
            )
        self.evaluations = 0  # forward simulations run (ensemble members count each)

    def scenes(self, u) -> Scene | dist.LocalMembers:
        """The settled scenes at ``u``, stacked along a leading ensemble axis (or this
        process's share, where ``build`` returns one)."""
        built = self.build(self.space.design(self._u(u)))
        if isinstance(built, dist.LocalMembers):
            return built
        return stack([built] if isinstance(built, Scene) else list(built))

    def _share(self, scenes) -> tuple[Scene, dist.Split | None]:
        """The scenes this process solves, and the split when shared among processes."""
        shared = self.sharding == "auto"
        if isinstance(scenes, dist.LocalMembers):
            if not shared and scenes.split.processes > 1:
                raise ValueError("LocalMembers of several processes need sharding='auto'")
            return scenes.scenes, scenes.split if shared else None
        if not shared:
            return scenes, None
        sp = dist.split(int(np.shape(scenes.q0)[0]))
        return jax.tree_util.tree_map(
            lambda x: x[np.asarray(sp.slots)] if eqx.is_array(x) else x, scenes
        ), sp

    def _prepared(self, scenes) -> tuple[Scene, dist.Split | None, Array]:
        """This process's scenes (counted as simulations), the split when shared, and the
        inverses of the scenes' statics Jacobians."""
        local, sp = self._share(scenes)
        self._count(local, sp.members if sp else int(np.shape(local.q0)[0]))
        jacobians = np.asarray(_jacobians(local, self.config.take_up))
        return local, sp, jnp.asarray(np.linalg.inv(jacobians))

    def _across(self, u, local, inverses, sp, grad: bool):
        """Value (and gradient) from this process's share: per member, gathered."""
        if grad:
            grads, out = _members_grad[self.gradient](
                u, self.space, local, inverses, self._grad_config
            )
        else:
            grads, out = None, _members(u, self.space, local, inverses, self.config)
        grads, out = dist.gather((grads, out), rows=sp.members)
        if grad:
            value, grads = _combined_jit(out.value, grads, self.config)
        else:
            value = _combine_jit(out.value, self.config)
        return value, grads, out

    def _u(self, u) -> Array:
        u = coordinate(u, "u", self.space.size, self.space.names)
        if is_concrete(u) and not np.all(np.isfinite(np.asarray(u))):
            raise ValueError(f"ProfileObjective: u must be finite, got {np.asarray(u)}")
        return u

    def _count(self, scenes, n_members: int):
        check_horizon(scenes, self.config.t1, "ProfileObjective", members=True)
        n_sprockets = len(scenes.sprockets)
        if self.config.sprocket >= n_sprockets:
            raise ValueError(
                f"ProfileObjective: sprocket={self.config.sprocket} but the scenes have "
                f"{n_sprockets} sprocket(s); index the designed one in [0, {n_sprockets - 1}]"
            )
        if isinstance(self.space.template, SprocketDesign):  # its ring is on the scenes
            place(scenes, self.space.template, self.config.sprocket)
        self.evaluations += n_members

    def _checked(self, value, grad, out: Observed):
        """(value, grad) when every member succeeded and the gradient is one a solve
        can have; else raise or NaN them."""
        if self.throw:
            raise_if_failed(out.result, None, "ProfileObjective")
        elif not bool(jnp.all(out.result == Result.successful)):
            value = jnp.full_like(value, jnp.nan)
            grad = None if grad is None else jnp.full_like(grad, jnp.nan)
        if grad is not None and _blown_up(value, grad):
            if self.throw:
                raise SolveError(
                    f"ProfileObjective: the gradient blew up (|grad| = "
                    f"{float(jnp.max(jnp.abs(grad))):.3g} at value {float(value):.6g}) while "
                    "the solve itself succeeded: a fixed step (dt) too long for a fast "
                    "dissipative mode, most often the joint friction's creep band (the "
                    "nominal 2 mm/s sticks within about a microsecond). Widen it for design "
                    "solves, e.g. joint_friction=jc.contact.CoulombFriction(0.1, "
                    "slip_velocity=2e-2), or shorten dt; re-measure the design with the "
                    "nominal model",
                    result_names(out.result),
                )
            value, grad = jnp.full_like(value, jnp.nan), jnp.full_like(grad, jnp.nan)
        return value, grad

    def value(self, u) -> tuple[Array, Observed]:
        """Objective at ``u`` and the members' :class:`Observed`."""
        return self.value_on(u, self.scenes(u))

    def value_and_grad(self, u) -> tuple[Array, Array, Observed]:
        """Objective, its gradient in ``u``, and the members' results."""
        return self.value_and_grad_on(u, self.scenes(u))

    def value_on(self, u, scenes: Scene) -> tuple[Array, Observed]:
        """:meth:`value` on ``scenes`` already built (``self.scenes(u0)``) and held: the
        profile at ``u`` is swapped in and resettled to first order — the same model the
        gradient at ``u0`` sees, for finite-difference checks."""
        local, sp, inverses = self._prepared(scenes)
        if sp is not None:
            value, _, out = self._across(self._u(u), local, inverses, sp, grad=False)
        else:
            value, out = _value(self._u(u), self.space, local, inverses, self.config)
        return self._checked(value, None, out)[0], out

    def value_and_grad_on(self, u, scenes: Scene) -> tuple[Array, Array, Observed]:
        """:meth:`value_and_grad` on ``scenes`` already built (see :meth:`value_on`)."""
        local, sp, inverses = self._prepared(scenes)
        u = self._u(u)
        if sp is not None:
            value, grad, out = self._across(u, local, inverses, sp, grad=True)
        else:
            (value, out), grad = _value_and_grad[self.gradient](
                u, self.space, local, inverses, self._grad_config
            )
        value, grad = self._checked(value, grad, out)
        return value, grad, out
