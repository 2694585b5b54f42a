"""Tooth-profile design: a smooth box-bounded parametrization and a smooth peak-force
objective computed inside the ODE solve (see :mod:`jaxchain.design`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._chain import ChainSpec
from ._ensemble import stack
from ._numerics import is_concrete
from ._observers import EXP_CAP as EXP_CAP, SoftPeak, window_weight as window_weight
from ._options import SolveOptions, with_options
from ._profile import ToothProfile, iso606_limits
from ._result import Result, raise_if_failed
from ._scene import Scene
from ._scenes.statics import resettle
from ._solve import check_horizon, solve, strong_scene

__all__ = [
    "PARAMETERS",
    "DesignSpace",
    "PeakForce",
    "soft_peak_force",
    "window_weight",
    "ProfileObjective",
]

PARAMETERS = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")


class DesignSpace(eqx.Module):
    """Tooth-profile parameters inside a box, reached through a smooth unconstrained
    coordinate ``u``: ``x = lower + (upper − lower)·sigmoid(u)``.

    Every ``u`` in ℝ⁴ gives a profile inside the box (ISO 606 limits by default), so an
    unconstrained optimizer (optax) can never leave the standard; the map is smooth with
    finite derivatives everywhere. ``u = 0`` is the middle of the box.

    Attributes:
        template: the profile whose other fields (teeth, pitch, roller diameter) are kept.
        lower, upper: (4,) box of ``PARAMETERS`` (seating radius [m], seating angle [rad],
            flank radius [m], tip diameter [m]).
    """

    template: ToothProfile
    lower: Float[Array, " 4"]
    upper: Float[Array, " 4"]

    def __init__(self, template: ToothProfile, lower: ArrayLike, upper: ArrayLike):
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        if lo.shape != (4,) or hi.shape != (4,):
            raise ValueError(f"lower and upper must have shape (4,) for {PARAMETERS}")
        if not np.all(hi > lo):
            bad = [n for n, a, b in zip(PARAMETERS, lo, hi, strict=True) if not b > a]
            raise ValueError(f"upper must exceed lower for every parameter; not for {bad}")
        self.template = template
        self.lower = jnp.asarray(lo)
        self.upper = jnp.asarray(hi)

    @classmethod
    def iso606(cls, chain: ChainSpec, teeth: int) -> DesignSpace:
        """The ISO 606 minimum/maximum limits of ``chain`` on a ``teeth``-tooth sprocket."""
        lim = iso606_limits(chain, teeth)
        template = ToothProfile.iso606(chain, teeth, "mid")
        return cls(template, [lim[n][0] for n in PARAMETERS], [lim[n][1] for n in PARAMETERS])

    def values(self, u: ArrayLike) -> Float[Array, " 4"]:
        """The parameters (SI) at coordinate ``u``."""
        return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(jnp.asarray(u))

    def profile(self, u: ArrayLike) -> ToothProfile:
        """The tooth profile at coordinate ``u`` (traceable)."""
        x = self.values(u)
        return eqx.tree_at(
            lambda p: [getattr(p, n) for n in PARAMETERS],
            self.template,
            [x[i] for i in range(4)],
        )

    def coordinates(self, profile: ToothProfile | ArrayLike, margin: float = 1e-6) -> Array:
        """The coordinate ``u`` of a profile (or of 4 parameter values) in the box; values
        on or beyond a bound are pulled ``margin`` (as a fraction of the range) inside."""
        if isinstance(profile, ToothProfile):
            x = jnp.stack([getattr(profile, n) for n in PARAMETERS])
        else:
            x = jnp.asarray(profile, dtype=float)
        frac = jnp.clip((x - self.lower) / (self.upper - self.lower), margin, 1 - margin)
        return jnp.log(frac) - jnp.log1p(-frac)

    def fraction(self, u: ArrayLike) -> Float[Array, " 4"]:
        """Where each parameter sits in its range (0 = lower, 1 = upper)."""
        return jax.nn.sigmoid(jnp.asarray(u))


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
    options: SolveOptions | None = None,
    **solve_options,
) -> PeakForce:
    """Smooth peak of the roller/tooth normal force over [t_start, t1] (from t0 = 0): the
    :class:`~jaxchain.observers.SoftPeak` observer integrated by the one solve
    (``rise`` defaults to 5 % of the window).

    Solve options as in :func:`~jaxchain.simulate` (``options=`` and/or keywords).
    ``dt`` gives fixed steps, ⌈t1/dt⌉ of them with every step checkpointed (a smooth
    function of every parameter, as needed for gradients checked against finite
    differences); without it, adaptive steps (PID, ``rtol``/``atol`` in the max norm).

    The outcome is reported, not raised: ``PeakForce.result`` is classified exactly as
    ``simulate`` classifies the same solve (:class:`ProfileObjective` raises).
    """
    opts = with_options(options, solve_options, "soft_peak_force")
    if is_concrete((t1, t_start, temperature)):
        if not float(temperature) > 0:
            raise ValueError(f"temperature must be > 0 N, got {temperature}")
        if not 0.0 <= float(t_start) < float(t1):
            raise ValueError(f"t_start must be in [0, t1 = {float(t1):.6g}) s, got {t_start}")
    resolved = opts.resolve(0.0, t1)  # before t1 becomes an array: dt's step count
    t0 = jnp.asarray(0.0, dtype=float)
    t1 = jnp.asarray(t1, dtype=float)
    t_start = jnp.asarray(t_start, dtype=float)
    rise = 0.05 * (t1 - t_start) if rise is None else rise
    observer = SoftPeak(t_start, rise, temperature, reference)
    scene = strong_scene(scene, "soft_peak_force")
    check_horizon(scene, t1, "soft_peak_force")
    traj = solve(scene, t0, t1, None, resolved, (observer,))
    return PeakForce(traj.observed[0], traj.result, traj.stats["num_steps"])


class _Config(eqx.Module):
    """Objective settings: arrays are traced, the rest (static) fixes the compiled shape."""

    t_start: Array
    temperature: Array
    reference: Array
    options: SolveOptions
    t1: float = eqx.field(static=True)
    sprocket: int = eqx.field(static=True)
    take_up: float = eqx.field(static=True)
    combine: str = eqx.field(static=True)


def _member(u, space, scene, cfg):
    k = cfg.sprocket
    scene = eqx.tree_at(lambda s: s.sprockets[k].profile, scene, space.profile(u))
    scene = resettle(scene, take_up=cfg.take_up)
    return soft_peak_force(
        scene,
        cfg.t1,
        t_start=cfg.t_start,
        temperature=cfg.temperature,
        reference=cfg.reference,
        options=cfg.options,
    )


def _loss(u, space, scenes, cfg):
    # members: the scenes' array leaves (stack keeps the agreed non-array leaves as they are)
    member_axes = (None, None, eqx.if_array(0), None)
    out = eqx.filter_vmap(_member, in_axes=member_axes)(u, space, scenes, cfg)
    if cfg.combine == "mean":
        value = jnp.mean(out.soft)
    else:  # soft maximum of the members at the same temperature
        tau = cfg.temperature
        value = tau * (jax.nn.logsumexp(out.soft / tau) - math.log(out.soft.shape[0]))
    return value, out


# module level: every ProfileObjective with the same static settings and scene structure
# shares one compiled function
_value = eqx.filter_jit(_loss)
_value_and_grad = eqx.filter_jit(eqx.filter_value_and_grad(_loss, has_aux=True))


class ProfileObjective:
    """The design objective: smooth peak roller/tooth force of the scenes built for a
    tooth profile, as a function of the design coordinate ``u``.

    For each evaluation the scenes are built and settled for the concrete profile at
    ``u`` (``build(profile) -> Scene`` or a list of scenes: an ensemble of operating
    points, which must share one structure); inside the differentiated function the
    profile is swapped in and :func:`~jaxchain.scenes.resettle` carries the static
    equilibrium's dependence on the profile into the gradient (implicit function
    theorem). Ensemble members are vmapped and combined by ``combine`` ("mean" or
    "max", a soft maximum of the members at the same temperature).

    A member whose solve failed makes the evaluation fail: ``RuntimeError`` naming the
    members and what to change (``throw=True``, the default), or with ``throw=False`` a
    NaN value and gradient, the members' codes in the returned :class:`PeakForce` — never
    a plausible number from a failed solve.

    Args:
        space: the :class:`DesignSpace`.
        build: profile -> settled scene(s) (concrete, outside the gradient).
        t1, t_start, temperature, reference: as in :func:`soft_peak_force`.
        sprocket: index of the designed sprocket in the scenes.
        take_up: the take-up the scenes were settled with (closed drives).
        combine: "mean" or "max" over the members.
        throw: raise when a member fails (see above).
        options, **solve_options: as in :func:`~jaxchain.simulate` (``dt=`` for fixed
            steps).
    """

    def __init__(
        self,
        space: DesignSpace,
        build: Callable[[ToothProfile], Scene | Sequence[Scene]],
        *,
        t1: float,
        t_start: float = 0.0,
        temperature: float = 50.0,
        reference: float = 0.0,
        sprocket: int = 0,
        take_up: float = 0.0,
        combine: str = "mean",
        throw: bool = True,
        options: SolveOptions | None = None,
        **solve_options,
    ):
        if combine not in ("mean", "max"):
            raise ValueError(f"combine must be 'mean' or 'max', got {combine!r}")
        if not temperature > 0:
            raise ValueError(f"temperature must be > 0 N, got {temperature}")
        if not 0.0 <= t_start < t1:
            raise ValueError(f"t_start must be in [0, t1 = {t1:.6g}) s, got {t_start}")
        self.space = space
        self.build = build
        self.throw = bool(throw)
        self.config = _Config(
            t_start=jnp.asarray(t_start, dtype=float),
            temperature=jnp.asarray(temperature, dtype=float),
            reference=jnp.asarray(reference, dtype=float),
            options=with_options(options, solve_options, "ProfileObjective"),
            t1=float(t1),
            sprocket=int(sprocket),
            take_up=float(take_up),
            combine=combine,
        )
        self.evaluations = 0  # forward simulations run (ensemble members count each)

    def scenes(self, u) -> Scene:
        """The settled scenes at ``u``, stacked along a leading ensemble axis."""
        built = self.build(self.space.profile(jnp.asarray(u, dtype=float)))
        return stack([built] if isinstance(built, Scene) else list(built))

    def _count(self, scenes):
        check_horizon(scenes, self.config.t1, "ProfileObjective", members=True)
        self.evaluations += jax.tree_util.tree_leaves(scenes)[0].shape[0]

    def _checked(self, value, grad, out: PeakForce):
        """(value, grad) when every member succeeded; else raise or NaN them."""
        if self.throw:
            raise_if_failed(out.result, None, "ProfileObjective")
        elif not bool(jnp.all(out.result == Result.successful)):
            value = jnp.full_like(value, jnp.nan)
            grad = None if grad is None else jnp.full_like(grad, jnp.nan)
        return value, grad

    def value(self, u) -> tuple[Array, PeakForce]:
        """Objective at ``u`` [N] and the members' :class:`PeakForce`."""
        return self.value_on(u, self.scenes(u))

    def value_and_grad(self, u) -> tuple[Array, Array, PeakForce]:
        """Objective [N], its gradient in ``u`` [N], and the members' results."""
        return self.value_and_grad_on(u, self.scenes(u))

    def value_on(self, u, scenes: Scene) -> tuple[Array, PeakForce]:
        """:meth:`value` on ``scenes`` already built (``self.scenes(u0)``) and held: the
        profile at ``u`` is swapped in and resettled to first order — the same model the
        gradient at ``u0`` sees, for finite-difference checks."""
        self._count(scenes)
        value, out = _value(jnp.asarray(u, dtype=float), self.space, scenes, self.config)
        return self._checked(value, None, out)[0], out

    def value_and_grad_on(self, u, scenes: Scene) -> tuple[Array, Array, PeakForce]:
        """:meth:`value_and_grad` on ``scenes`` already built (see :meth:`value_on`)."""
        self._count(scenes)
        u = jnp.asarray(u, dtype=float)
        (value, out), grad = _value_and_grad(u, self.space, scenes, self.config)
        value, grad = self._checked(value, grad, out)
        return value, grad, out
