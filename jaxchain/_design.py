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

from . import _checks as checks
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
        checks.instance("template", template, ToothProfile, "a jc.ToothProfile")
        lo = np.asarray(lower, dtype=float)
        hi = np.asarray(upper, dtype=float)
        if lo.shape != (4,) or hi.shape != (4,):
            raise ValueError(f"lower and upper must have shape (4,) for {PARAMETERS}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError(f"lower and upper must be finite, got {lo.tolist()}, {hi.tolist()}")
        if not np.all(hi > lo):
            bad = [n for n, a, b in zip(PARAMETERS, lo, hi, strict=True) if not b > a]
            raise ValueError(f"upper must exceed lower for every parameter; not for {bad}")
        _check_box(template, lo, hi)
        self.template = template
        self.lower = jnp.asarray(lo)
        self.upper = jnp.asarray(hi)

    @classmethod
    def iso606(cls, chain: ChainSpec | str, teeth: int) -> DesignSpace:
        """The ISO 606 minimum/maximum limits of ``chain`` on a ``teeth``-tooth sprocket."""
        lim = iso606_limits(chain, teeth)
        template = ToothProfile.iso606(chain, teeth, "mid")
        return cls(template, [lim[n][0] for n in PARAMETERS], [lim[n][1] for n in PARAMETERS])

    def values(self, u: ArrayLike) -> Float[Array, " 4"]:
        """The parameters (SI) at coordinate ``u``."""
        return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(_coordinate(u))

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
        checks.real("margin", margin, lo=0.0, hi=0.5, lo_open=True, hi_open=True)
        if isinstance(profile, ToothProfile):
            t = self.template
            if profile.teeth != t.teeth or not np.allclose(
                [profile.pitch, profile.roller_diameter], [t.pitch, t.roller_diameter]
            ):
                raise ValueError(
                    f"coordinates: the profile ({profile.teeth} teeth, pitch "
                    f"{float(profile.pitch):.6g} m) is not of this design space's sprocket "
                    f"({t.teeth} teeth, pitch {float(t.pitch):.6g} m)"
                )
            x = jnp.stack([getattr(profile, n) for n in PARAMETERS])
        else:
            x = _coordinate(profile, "the parameter values")
        frac = jnp.clip((x - self.lower) / (self.upper - self.lower), margin, 1 - margin)
        return jnp.log(frac) - jnp.log1p(-frac)

    def fraction(self, u: ArrayLike) -> Float[Array, " 4"]:
        """Where each parameter sits in its range (0 = lower, 1 = upper)."""
        return jax.nn.sigmoid(_coordinate(u))


def _coordinate(u, what: str = "u") -> Array:
    """``u`` as a float array of shape (4,), or ``ValueError`` saying how to batch."""
    u = jnp.asarray(u)
    if u.shape != (4,):
        hint = "; for many points use jax.vmap over u" if u.shape[-1:] == (4,) else ""
        raise ValueError(
            f"{what} must have shape (4,), one value per parameter {PARAMETERS}, got shape "
            f"{u.shape}{hint}"
        )
    if not (jnp.issubdtype(u.dtype, jnp.floating) or jnp.issubdtype(u.dtype, jnp.integer)):
        raise TypeError(f"{what} must be real, got dtype {u.dtype}")
    return u.astype(jnp.result_type(float)) if jnp.issubdtype(u.dtype, jnp.integer) else u


def _check_box(template: ToothProfile, lo: np.ndarray, hi: np.ndarray) -> None:
    """Every corner of the box must be a valid profile once its tip circle is lowered to
    where the flanks meet (what the traced geometry does): a box reaching outside the
    profile's own validity (a seat smaller than the roller, an angle in degrees) would
    hand the optimizer outlines that do not exist."""
    from ._profile import _flank_centre_line_radius, _np_geometry_of

    for pick in itertools.product((0, 1), repeat=4):
        vals = {n: (lo, hi)[i][k] for k, (n, i) in enumerate(zip(PARAMETERS, pick, strict=True))}
        kw = dict(
            teeth=template.teeth,
            pitch=float(template.pitch),
            roller_diameter=float(template.roller_diameter),
            **vals,
        )
        try:
            reach = 2 * _flank_centre_line_radius(_np_geometry_of(**kw), vals["flank_radius"])
            kw["tip_diameter"] = min(vals["tip_diameter"], reach * (1 - 1e-9))
            ToothProfile(**kw)
        except (ValueError, FloatingPointError) as e:
            corner = ", ".join(
                f"{n} {'upper' if i else 'lower'}" for n, i in zip(PARAMETERS, pick, strict=True)
            )
            raise ValueError(
                f"the design box reaches outside valid tooth profiles: at its corner ({corner}) {e}"
            ) from None


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
    if is_concrete((t1, t_start, temperature, reference, rise)):
        t1 = checks.real("t1", t1, lo=0.0, lo_open=True, unit="s")
        checks.real("temperature", temperature, lo=0.0, lo_open=True, unit="N")
        checks.real("reference", reference, unit="N")
        checks.real("t_start", t_start, lo=0.0, hi=t1, hi_open=True, unit=f"s (t1 = {t1:.6g} s)")
        if rise is not None:
            checks.real("rise", rise, lo=0.0, unit="s (0: a step)")
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
        sprocket = checks.integer("sprocket", sprocket, lo=0)
        take_up = checks.real("take_up", take_up, lo=0.0, unit="N")
        checks.flag("throw", throw)
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
        built = self.build(self.space.profile(self._u(u)))
        return stack([built] if isinstance(built, Scene) else list(built))

    def _u(self, u) -> Array:
        u = _coordinate(u)
        if is_concrete(u) and not np.all(np.isfinite(np.asarray(u))):
            raise ValueError(f"ProfileObjective: u must be finite, got {np.asarray(u)}")
        return u

    def _count(self, scenes):
        check_horizon(scenes, self.config.t1, "ProfileObjective", members=True)
        n_sprockets = len(scenes.sprockets)
        if self.config.sprocket >= n_sprockets:
            raise ValueError(
                f"ProfileObjective: sprocket={self.config.sprocket} but the scenes have "
                f"{n_sprockets} sprocket(s); index the designed one in [0, {n_sprockets - 1}]"
            )
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
        value, out = _value(self._u(u), self.space, scenes, self.config)
        return self._checked(value, None, out)[0], out

    def value_and_grad_on(self, u, scenes: Scene) -> tuple[Array, Array, PeakForce]:
        """:meth:`value_and_grad` on ``scenes`` already built (see :meth:`value_on`)."""
        self._count(scenes)
        u = self._u(u)
        (value, out), grad = _value_and_grad(u, self.space, scenes, self.config)
        value, grad = self._checked(value, grad, out)
        return value, grad, out
