"""Tooth-profile design: a smooth box-bounded parametrization and a smooth peak-force
objective computed inside the ODE solve (see :mod:`jaxchain.design`)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from . import _checks as checks, _distributed as dist
from ._chain import ChainSpec
from ._numerics import is_concrete
from ._observers import (
    EXP_CAP as EXP_CAP,
    AbstractIntegralObserver,
    AbstractObserver,
    AbstractStepObserver,
    SampledSoftPeak,
    SoftPeak,
    window_weight as window_weight,
)
from ._options import SolveOptions, with_options
from ._profiles.base import AbstractProfile
from ._profiles.freeform import FreeformProfile
from ._profiles.iso import ToothProfile, flank_meeting_diameter, iso606_limits
from ._result import Result, raise_if_failed
from ._scene import Scene
from ._scenes.statics import resettle, statics_jacobian
from ._solve import check_horizon, solve, strong_scene
from ._stack import stack

__all__ = [
    "PARAMETERS",
    "DesignSpace",
    "PeakForce",
    "Observed",
    "Penalized",
    "observe",
    "soft_peak_force",
    "window_weight",
    "ProfileObjective",
]

PARAMETERS = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")


class DesignSpace(eqx.Module):
    """Tooth-profile parameters inside a box, reached through a smooth unconstrained
    coordinate ``u``: ``x = lower + (upper − lower)·sigmoid(u)``.

    Every ``u`` gives a profile inside the box, so an unconstrained optimizer (optax)
    can never leave it; the map is smooth with finite derivatives everywhere. ``u = 0``
    is the middle of the box.

    By default the box holds the four ISO 606 parameters of a :class:`ToothProfile`
    (``PARAMETERS``). :meth:`select` chooses any leaves of a tooth profile instead
    (``"seating_radius"``, ``"ccw.curvature"``, ``"cw.seat_angle"``, ``"phase"``, …), each
    a scalar, a (K,) flank leaf or one value per gap, with its own bounds: ``u`` is then
    the concatenation of every chosen leaf's entries, in the order given.

    Attributes:
        template: the profile whose other fields are kept.
        lower, upper: (n,) box of the chosen entries (SI units).
        names: the chosen leaves (dotted paths into the profile; static).
        shapes: their shapes (static).
    """

    template: ToothProfile | FreeformProfile
    lower: Float[Array, " n"]
    upper: Float[Array, " n"]
    names: tuple[str, ...] = eqx.field(static=True)
    shapes: tuple[tuple[int, ...], ...] = eqx.field(static=True)

    def __init__(
        self,
        template: ToothProfile | FreeformProfile,
        lower: ArrayLike,
        upper: ArrayLike,
        names: Sequence[str] = PARAMETERS,
        shapes: Sequence[tuple[int, ...]] | None = None,
    ):
        names = tuple(names)
        checks.instance(
            "template", template, AbstractProfile,
            "a jc.ToothProfile, jc.FreeformProfile or another jc.AbstractProfile",
        )  # fmt: skip
        iso_box = names == PARAMETERS
        if iso_box:  # the ISO 606 four: leaves of the template's own
            missing = [n for n in names if not _is_leaf(template, n)]
            if missing:
                raise TypeError(
                    f"the default design box needs the ISO 606 parameters {PARAMETERS}; this "
                    f"{type(template).__name__} has no {missing}: choose its leaves with "
                    "DesignSpace.select(template, {path: (lower, upper)})"
                )
        shapes = tuple(tuple(s) for s in shapes) if shapes is not None else ((),) * len(names)
        n = sum(math.prod(s) for s in shapes)
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        if lo.shape != (n,) or hi.shape != (n,):
            raise ValueError(f"lower and upper must have shape ({n},) for {names}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError(f"lower and upper must be finite, got {lo.tolist()}, {hi.tolist()}")
        if not np.all(hi > lo):
            bad = [e for e, a, b in zip(_entries(names, shapes), lo, hi, strict=True) if not b > a]
            raise ValueError(f"upper must exceed lower for every parameter; not for {bad}")
        self.template = template
        self.lower = jnp.asarray(lo)
        self.upper = jnp.asarray(hi)
        self.names = names
        self.shapes = shapes
        if iso_box:
            _check_box(template, lo, hi)
        else:
            _check_box_sampled(self)

    @classmethod
    def iso606(cls, chain: ChainSpec | str, teeth: int) -> DesignSpace:
        """The ISO 606 minimum/maximum limits of ``chain`` on a ``teeth``-tooth sprocket."""
        lim = iso606_limits(chain, teeth)
        template = ToothProfile.iso606(chain, teeth, "mid")
        return cls(template, [lim[n][0] for n in PARAMETERS], [lim[n][1] for n in PARAMETERS])

    @classmethod
    def select(
        cls,
        template: ToothProfile | FreeformProfile,
        bounds: dict[str, tuple[ArrayLike, ArrayLike]],
    ) -> DesignSpace:
        """A box over the chosen leaves of ``template``: ``{path: (lower, upper)}``. Each
        bound is a scalar or an array; the leaf takes the broadcast shape of its
        template value and both bounds (bounds of shape (z,) on a uniform leaf make it a
        per-gap pattern). Example: ``{"seating_radius": (ri_lo·ones(z), ri_hi·ones(z)),
        "ccw.curvature": (k_lo, k_hi)}``. Checked: the box's corners (all of them up to
        6 coordinates; else its middle, its two extreme corners and 64 seeded random
        corners) are valid profiles."""
        if not isinstance(bounds, dict) or not bounds:
            raise TypeError("bounds must be a non-empty dict {leaf path: (lower, upper)}")
        names, shapes, lows, highs = [], [], [], []
        for name, pair in bounds.items():
            leaf = _leaf(template, name)
            lo, hi = checks.pair(f"bounds[{name!r}]", pair, 2, "bounds (lower, upper)")
            shape = np.broadcast_shapes(np.shape(leaf), np.shape(lo), np.shape(hi))
            names.append(name)
            shapes.append(tuple(shape))
            lows.append(np.broadcast_to(np.asarray(lo, dtype=float), shape).ravel())
            highs.append(np.broadcast_to(np.asarray(hi, dtype=float), shape).ravel())
        return cls(template, np.concatenate(lows), np.concatenate(highs), names, shapes)

    @property
    def size(self) -> int:
        """n, the number of coordinates."""
        return int(self.lower.shape[0])

    def values(self, u: ArrayLike) -> Float[Array, " n"]:
        """The parameters (SI) at coordinate ``u``."""
        return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(self._u(u))

    def profile(self, u: ArrayLike) -> ToothProfile | FreeformProfile:
        """The tooth profile at coordinate ``u`` (traceable)."""
        x = self.values(u)
        parts, at = [], 0
        for shape in self.shapes:
            size = math.prod(shape)
            parts.append(x[at : at + size].reshape(shape))
            at += size
        return eqx.tree_at(
            lambda p: [_get(p, n) for n in self.names], self.template, parts,
            is_leaf=lambda v: v is None,
        )  # fmt: skip

    def coordinates(self, profile: ToothProfile | ArrayLike, margin: float = 1e-6) -> Array:
        """The coordinate ``u`` of a profile (or of the parameter values) in the box;
        values on or beyond a bound are pulled ``margin`` (as a fraction of the range)
        inside."""
        checks.real("margin", margin, lo=0.0, hi=0.5, lo_open=True, hi_open=True)
        if isinstance(profile, AbstractProfile):
            t = self.template
            if profile.teeth != t.teeth or not np.allclose(
                [profile.pitch, profile.roller_diameter], [t.pitch, t.roller_diameter]
            ):
                raise ValueError(
                    f"coordinates: the profile ({profile.teeth} teeth, pitch "
                    f"{float(profile.pitch):.6g} m) is not of this design space's sprocket "
                    f"({t.teeth} teeth, pitch {float(t.pitch):.6g} m)"
                )
            x = jnp.concatenate(
                [jnp.broadcast_to(_leaf(profile, n), s).ravel()
                 for n, s in zip(self.names, self.shapes, strict=True)]
            )  # fmt: skip
        else:
            x = self._u(profile, "the parameter values")
        frac = jnp.clip((x - self.lower) / (self.upper - self.lower), margin, 1 - margin)
        return jnp.log(frac) - jnp.log1p(-frac)

    def fraction(self, u: ArrayLike) -> Float[Array, " n"]:
        """Where each parameter sits in its range (0 = lower, 1 = upper)."""
        return jax.nn.sigmoid(self._u(u))

    def _u(self, u, what: str = "u") -> Array:
        return _coordinate(u, what, self.size, self.names)


def _get(obj, name: str):
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _leaf(profile, name: str):
    """The array leaf at dotted path ``name`` of a tooth profile, or ``ValueError``
    listing the leaves there are."""
    obj = profile
    for part in name.split("."):
        obj = None if part.startswith("_") else getattr(obj, part, None)
    if not isinstance(obj, jax.Array | np.ndarray):
        raise ValueError(
            f"{name!r} is not a leaf of this {type(profile).__name__}: use one of "
            f"{_leaf_names(profile)}"
        )
    return obj


def _is_leaf(profile, name: str) -> bool:
    try:
        _leaf(profile, name)
    except ValueError:
        return False
    return True


def _leaf_names(profile) -> list[str]:
    paths = jax.tree_util.tree_flatten_with_path(profile)[0]
    return [".".join(str(k.name) for k in path) for path, _ in paths]


def _entries(names, shapes) -> list[str]:
    """One label per coordinate: ``name`` or ``name[i, j]``."""
    out = []
    for n, s in zip(names, shapes, strict=True):
        out += [n] if s == () else [f"{n}{list(i)}" for i in np.ndindex(s)]
    return out


def _coordinate(u, what: str = "u", n: int = 4, names=PARAMETERS) -> Array:
    """``u`` as a float array of shape (n,), or ``ValueError`` saying how to batch."""
    u = jnp.asarray(u)
    if u.shape != (n,):
        hint = "; for many points use jax.vmap over u" if u.shape[-1:] == (n,) else ""
        per = f"one value per parameter {names}" if n == len(names) else f"the entries of {names}"
        raise ValueError(f"{what} must have shape ({n},), {per}, got shape {u.shape}{hint}")
    if not (jnp.issubdtype(u.dtype, jnp.floating) or jnp.issubdtype(u.dtype, jnp.integer)):
        raise TypeError(f"{what} must be real, got dtype {u.dtype}")
    return u.astype(jnp.result_type(float)) if jnp.issubdtype(u.dtype, jnp.integer) else u


def _check_box_sampled(space: DesignSpace) -> None:
    """The box's corners must be valid profiles (constructing one validates it): all
    corners up to 6 coordinates, else the middle, the two extreme corners and 64 seeded
    random corners."""
    n = space.size
    if n <= 6:
        picks = np.array(list(itertools.product((0, 1), repeat=n)), dtype=float)
    else:
        rng = np.random.default_rng(0)
        picks = np.concatenate(
            [np.full((1, n), 0.5), np.zeros((1, n)), np.ones((1, n)),
             rng.integers(0, 2, (64, n)).astype(float)]
        )  # fmt: skip
    eps = 1e-9
    for pick in picks:
        frac = np.clip(pick, eps, 1 - eps)
        u = np.log(frac) - np.log1p(-frac)
        try:
            p = space.profile(jnp.asarray(u))
            type(p).__check_init__(p)
        except (ValueError, FloatingPointError) as e:
            corner = (
                "middle"
                if np.all(pick == 0.5)
                else ", ".join(
                    f"{lab} {'upper' if b else 'lower'}"
                    for lab, b in zip(_entries(space.names, space.shapes), pick, strict=True)
                )
            )
            if len(corner) > 300:
                corner = corner[:300] + " …"
            raise ValueError(
                f"the design box reaches outside valid tooth profiles: at its corner ({corner}) {e}"
            ) from None


def _check_box(template: ToothProfile, lo: np.ndarray, hi: np.ndarray) -> None:
    """Every corner of the box must be a valid profile once its tip circle is lowered to
    where the flanks meet (what the traced geometry does): a box reaching outside the
    profile's own validity (a seat smaller than the roller, an angle in degrees) would
    hand the optimizer outlines that do not exist."""
    for pick in itertools.product((0, 1), repeat=4):
        vals = {n: (lo, hi)[i][k] for k, (n, i) in enumerate(zip(PARAMETERS, pick, strict=True))}
        kw = dict(
            teeth=template.teeth,
            pitch=float(template.pitch),
            roller_diameter=float(template.roller_diameter),
            **vals,
        )
        try:
            reach = flank_meeting_diameter(**kw)
            kw["tip_diameter"] = min(vals["tip_diameter"], reach * (1 - 1e-9))
            ToothProfile(**kw)
        except (ValueError, FloatingPointError) as e:
            corner = ", ".join(
                f"{n} {'upper' if i else 'lower'}" for n, i in zip(PARAMETERS, pick, strict=True)
            )
            raise ValueError(
                f"the design box reaches outside valid tooth profiles: at its corner ({corner}) {e}"
            ) from None


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


class _Config(eqx.Module):
    """Objective settings: arrays are traced, the rest (static) fixes the compiled shape."""

    objective: AbstractObserver
    member_temperature: Array
    options: SolveOptions
    t1: float = eqx.field(static=True)
    sprocket: int = eqx.field(static=True)
    take_up: float = eqx.field(static=True)
    combine: str = eqx.field(static=True)


def _member(u, space, scene, jac, cfg):
    k = cfg.sprocket
    scene = eqx.tree_at(lambda s: s.sprockets[k].profile, scene, space.profile(u))
    scene = resettle(scene, take_up=cfg.take_up, jacobian=jac)
    return observe(scene, cfg.t1, cfg.objective, options=cfg.options)


def _combine(values, cfg):
    """The members' values (M,) combined into the objective."""
    if cfg.combine == "mean":
        return jnp.mean(values)
    tau = cfg.member_temperature  # soft maximum of the members (log-mean-exp)
    return tau * (jax.nn.logsumexp(values / tau) - math.log(values.shape[0]))


# members: the scenes' array leaves (stack keeps the agreed non-array leaves as they are)
# and their statics Jacobians
_MEMBER_AXES = (None, None, eqx.if_array(0), 0, None)


def _loss(u, space, scenes, jacs, cfg):
    out = eqx.filter_vmap(_member, in_axes=_MEMBER_AXES)(u, space, scenes, jacs, cfg)
    return _combine(out.value, cfg), out


def _member_grad(u, space, scene, jac, cfg):
    """One member's value's gradient in ``u``, and its :class:`Observed`."""
    grad, out = jax.grad(lambda u: (lambda o: (o.value, o))(_member(u, space, scene, jac, cfg)),
                         has_aux=True)(u)  # fmt: skip
    return grad, out


def _combined(values, grads, cfg):
    """The objective and its gradient from every member's value and gradient (the
    chain rule through :func:`_combine`)."""
    value, pullback = jax.vjp(lambda v: _combine(v, cfg), values)
    return value, pullback(jnp.ones_like(value))[0] @ grads


# module level: every ProfileObjective with the same static settings and scene structure
# shares one compiled function
_value = eqx.filter_jit(_loss)
_value_and_grad = eqx.filter_jit(eqx.filter_value_and_grad(_loss, has_aux=True))
# across processes: each process's share of the members, per member; combined after
_members = eqx.filter_jit(eqx.filter_vmap(_member, in_axes=_MEMBER_AXES))
_members_grad = eqx.filter_jit(eqx.filter_vmap(_member_grad, in_axes=_MEMBER_AXES))
_combine_jit = eqx.filter_jit(_combine)
_combined_jit = eqx.filter_jit(_combined)
# the members' statics Jacobians at their settled starts, outside the differentiated
# function: compiled once per scene structure, shared by the value and the gradient
_jacobians = eqx.filter_jit(
    eqx.filter_vmap(
        lambda scene, take_up: statics_jacobian(scene, take_up=take_up),
        in_axes=(eqx.if_array(0), None),
    )
)


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
    members are vmapped and combined by ``combine``: "mean", or "max", a soft maximum of
    the members (log-mean-exp at ``member_temperature``).

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
        build: profile -> settled scene(s) (concrete, outside the gradient).
        t1: end of each solve [s].
        objective: the observer measured (default: the soft peak force below).
        t_start, temperature, reference: the default objective's, as in
            :func:`soft_peak_force`.
        member_temperature: the members' soft maximum's temperature [objective units]
            (default ``temperature``).
        samples: the default objective's parts per step (0: integrated by the solver's
            stages, for adaptive solves; ≥ 1: sampled, for fixed steps).
        sprocket: index of the designed sprocket in the scenes.
        take_up: the take-up the scenes were settled with (closed drives).
        combine: "mean" or "max" over the members.
        throw: raise when a member fails (see above).
        sharding: None, or "auto": members shared among the processes (see above).
        options, **solve_options: as in :func:`~jaxchain.simulate` (``dt=`` for fixed
            steps).
    """

    def __init__(
        self,
        space: DesignSpace,
        build: Callable[[ToothProfile], Scene | Sequence[Scene]],
        *,
        t1: float,
        objective: AbstractObserver | None = None,
        t_start: float = 0.0,
        temperature: float = 50.0,
        reference: float = 0.0,
        member_temperature: float | None = None,
        samples: int = 0,
        sprocket: int = 0,
        take_up: float = 0.0,
        combine: str = "mean",
        throw: bool = True,
        sharding: str | None = None,
        options: SolveOptions | None = None,
        **solve_options,
    ):
        checks.instance("space", space, DesignSpace, "a jc.design.DesignSpace")
        if not callable(build):
            raise TypeError(
                f"build must be a function profile -> scene(s), got {type(build).__name__}"
            )
        checks.choice("combine", combine, ("mean", "max"))
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
        temperature = checks.real("temperature", temperature, lo=0.0, lo_open=True, unit="N")
        reference = checks.real("reference", reference, unit="N")
        t_start = checks.real(
            "t_start", t_start, lo=0.0, hi=t1, hi_open=True, unit=f"s (t1 = {t1:.6g} s)"
        )
        if member_temperature is None:
            member_temperature = temperature
        member_temperature = checks.real(
            "member_temperature", member_temperature, lo=0.0, lo_open=True,
            unit="(objective units)",
        )  # fmt: skip
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
            member_temperature=jnp.asarray(member_temperature, dtype=float),
            options=with_options(options, solve_options, "ProfileObjective"),
            t1=float(t1),
            sprocket=int(sprocket),
            take_up=float(take_up),
            combine=combine,
        )
        self.evaluations = 0  # forward simulations run (ensemble members count each)

    def scenes(self, u) -> Scene | dist.LocalMembers:
        """The settled scenes at ``u``, stacked along a leading ensemble axis (or this
        process's share, where ``build`` returns one)."""
        built = self.build(self.space.profile(self._u(u)))
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
        scenes' statics Jacobians."""
        local, sp = self._share(scenes)
        self._count(local, sp.members if sp else int(np.shape(local.q0)[0]))
        return local, sp, _jacobians(local, self.config.take_up)

    def _across(self, u, local, jacs, sp, grad: bool):
        """Value (and gradient) from this process's share: per member, gathered."""
        if grad:
            grads, out = _members_grad(u, self.space, local, jacs, self.config)
        else:
            grads, out = None, _members(u, self.space, local, jacs, self.config)
        grads, out = dist.gather((grads, out), rows=sp.members)
        if grad:
            value, grads = _combined_jit(out.value, grads, self.config)
        else:
            value = _combine_jit(out.value, self.config)
        return value, grads, out

    def _u(self, u) -> Array:
        u = _coordinate(u, "u", self.space.size, self.space.names)
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
        self.evaluations += n_members

    def _checked(self, value, grad, out: Observed):
        """(value, grad) when every member succeeded; else raise or NaN them."""
        if self.throw:
            raise_if_failed(out.result, None, "ProfileObjective")
        elif not bool(jnp.all(out.result == Result.successful)):
            value = jnp.full_like(value, jnp.nan)
            grad = None if grad is None else jnp.full_like(grad, jnp.nan)
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
        local, sp, jacs = self._prepared(scenes)
        if sp is not None:
            value, _, out = self._across(self._u(u), local, jacs, sp, grad=False)
        else:
            value, out = _value(self._u(u), self.space, local, jacs, self.config)
        return self._checked(value, None, out)[0], out

    def value_and_grad_on(self, u, scenes: Scene) -> tuple[Array, Array, Observed]:
        """:meth:`value_and_grad` on ``scenes`` already built (see :meth:`value_on`)."""
        local, sp, jacs = self._prepared(scenes)
        u = self._u(u)
        if sp is not None:
            value, grad, out = self._across(u, local, jacs, sp, grad=True)
        else:
            (value, out), grad = _value_and_grad(u, self.space, local, jacs, self.config)
        value, grad = self._checked(value, grad, out)
        return value, grad, out
