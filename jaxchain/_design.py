"""Tooth-profile design: a smooth box-bounded parametrization and a smooth peak-force
objective computed inside the ODE solve (see :mod:`jaxchain.design`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ._chain import ChainSpec
from ._dynamics import forces, initial_state, rates
from ._numerics import is_concrete
from ._profile import ToothProfile, iso606_limits
from ._scene import Scene
from ._scenes.statics import resettle
from ._simulate import Result, _classify

__all__ = [
    "PARAMETERS",
    "DesignSpace",
    "PeakForce",
    "soft_peak_force",
    "window_weight",
    "ProfileObjective",
]

EXP_CAP = 60.0  # forces beyond reference + 60·temperature saturate the soft maximum

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


def window_weight(t, t_start, rise):
    """Smooth (C¹) window: 0 before ``t_start − rise/2``, 1 after ``t_start + rise/2``; its
    integral over [t0, t1] is ``t1 − t_start`` when the ramp lies inside."""
    s = jnp.clip((t - t_start) / rise + 0.5, 0.0, 1.0)
    return s * s * (3 - 2 * s)


class PeakForce(NamedTuple):
    """Result of :func:`soft_peak_force`."""

    soft: Float[Array, ""]  # smooth peak of the roller/tooth normal force [N]
    result: Result
    num_steps: Array


def _soft_field(t, state, args):
    y, _ = state
    scene, t_start, rise, reference, temperature = args
    fr = forces(t, y, scene)
    f = jnp.sum(fr.roller_normal, axis=0)  # (R,) over sprockets
    w = window_weight(t, t_start, rise)
    # exponent smoothly capped at EXP_CAP: a trial step the adaptive controller will reject
    # can see absurd forces, and exp overflowing there turns the whole gradient into NaN
    # (0·inf in the backward pass of the step's accept/reject select)
    e = (f - reference) / temperature
    e = e - jax.nn.softplus(e - EXP_CAP)
    return rates(t, y, scene, fr), w * jnp.sum(jnp.exp(e))


@eqx.filter_jit
def _soft_solve(
    scene,
    t0,
    t1,
    t_start,
    rise,
    reference,
    temperature,
    solver,
    controller,
    dt0,
    max_steps,
    adjoint,
):
    y0 = (initial_state(scene), jnp.zeros((), scene.q0.dtype))
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(_soft_field),
        solver,
        t0,
        t1,
        dt0,
        y0,
        args=(scene, t_start, rise, reference, temperature),
        saveat=diffrax.SaveAt(t1=True),
        stepsize_controller=controller,
        max_steps=max_steps,
        adjoint=adjoint,
        throw=False,
    )
    y1, acc = jax.tree_util.tree_map(lambda x: x[-1], sol.ys)
    span = t1 - t_start
    soft = reference + temperature * jnp.log(jnp.maximum(acc, 1e-300) / span)
    size = jnp.max(jnp.abs(scene.q0[:, :2])) + 1.0
    finite = (
        jnp.isfinite(soft)
        & jnp.all(jnp.isfinite(y1.q))
        & jnp.all(jnp.abs(y1.q[:, :2]) < 1e3 * size)
    )
    return soft, _classify(sol.result, finite), sol.stats["num_steps"]


def soft_peak_force(
    scene: Scene,
    t1: ArrayLike,
    *,
    t_start: ArrayLike = 0.0,
    rise: ArrayLike | None = None,
    temperature: ArrayLike = 50.0,
    reference: ArrayLike = 0.0,
    solver: diffrax.AbstractSolver | None = None,
    dt: float | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_steps: int = 200_000,
    adjoint: diffrax.AbstractAdjoint | None = None,
) -> PeakForce:
    """Smooth peak of the roller/tooth normal force over time and rollers:

        P = F_ref + τ·log( (1/(t1 − t_start)) ∫ w(t) Σ_i exp((F_i(t) − F_ref)/τ) dt )

    a log-mean-exp ("soft maximum") of temperature τ = ``temperature`` [N] over the
    window ``w`` (from ``t_start``, smooth over ``rise``), integrated by the ODE solver
    itself as one extra state: exact in continuous time (no sampling of the peak between
    save points), differentiable, and free (the forces are those of the vector field).
    τ → 0 gives the sharp maximum; otherwise P lies below it by about
    τ·log(window / time spent near the peak) and above it by at most τ·log(rollers near
    the peak). ``reference`` shifts the exponent, which saturates smoothly 60·τ above it
    (an overflow guard: use a force of the order of the peak, e.g. a baseline's).

    ``dt`` gives fixed steps (``diffrax.ConstantStepSize``; a smooth function of every
    parameter, as needed for gradients checked against finite differences), with the
    number of steps ⌈(t1 − t0)/dt⌉ and recursive checkpointing at every step (exact
    discrete gradient; memory = steps × state). Without ``dt``, adaptive steps (PID,
    ``rtol``/``atol`` in the max norm).
    """
    if solver is None:
        solver = diffrax.Tsit5()
    if is_concrete((t1, t_start, temperature)):
        if not float(temperature) > 0:
            raise ValueError(f"temperature must be > 0 N, got {temperature}")
        if not 0.0 <= float(t_start) < float(t1):
            raise ValueError(f"t_start must be in [0, t1 = {float(t1):.6g}) s, got {t_start}")
    n = None
    if dt is not None:
        if not dt > 0:
            raise ValueError(f"dt must be > 0 s, got {dt}")
        n = max(1, math.ceil(float(t1) / dt - 1e-9))  # the step count fixes the shapes
    t1 = jnp.asarray(t1, dtype=float)
    t0 = jnp.asarray(0.0, dtype=float)
    t_start = jnp.asarray(t_start, dtype=float)
    if rise is None:
        rise = 0.05 * (t1 - t_start)
    rise = jnp.asarray(rise, dtype=float)
    if n is not None:
        controller = diffrax.ConstantStepSize()
        dt0 = t1 / n
        max_steps = n
        adjoint = adjoint or diffrax.RecursiveCheckpointAdjoint(checkpoints=n)
    else:
        controller = diffrax.PIDController(
            rtol=jnp.asarray(rtol, dtype=float),
            atol=jnp.asarray(atol, dtype=float),
            norm=optx.max_norm,
            pcoeff=0.2,
            icoeff=0.4,
        )
        dt0 = None
        adjoint = adjoint or diffrax.RecursiveCheckpointAdjoint()
    scene = jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, dtype=jnp.result_type(x)) if eqx.is_inexact_array(x) else x,
        scene,
    )
    soft, result, steps = _soft_solve(
        scene,
        t0,
        t1,
        t_start,
        rise,
        jnp.asarray(reference, dtype=float),
        jnp.asarray(temperature, dtype=float),
        solver,
        controller,
        dt0,
        max_steps,
        adjoint,
    )
    return PeakForce(soft, result, steps)


class _Config(eqx.Module):
    """Objective settings: arrays are traced, the rest (static) fixes the compiled shape."""

    t_start: Array
    temperature: Array
    reference: Array
    t1: float = eqx.field(static=True)
    dt: float | None = eqx.field(static=True)
    solver: object = eqx.field(static=True)
    rtol: float = eqx.field(static=True)
    atol: float = eqx.field(static=True)
    max_steps: int = eqx.field(static=True)
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
        solver=cfg.solver,
        dt=cfg.dt,
        rtol=cfg.rtol,
        atol=cfg.atol,
        max_steps=cfg.max_steps,
    )


def _loss(u, space, scenes, cfg):
    out = jax.vmap(_member, in_axes=(None, None, 0, None))(u, space, scenes, cfg)
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

    Args:
        space: the :class:`DesignSpace`.
        build: profile -> settled scene(s) (concrete, outside the gradient).
        sprocket: index of the designed sprocket in the scenes.
        t1, t_start, temperature, reference, dt, solver, rtol, atol, max_steps: as in
            :func:`soft_peak_force`.
        take_up: the take-up the scenes were settled with (closed drives).
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
        dt: float | None = None,
        solver: diffrax.AbstractSolver | None = None,
        rtol: float = 1e-6,
        atol: float = 1e-9,
        max_steps: int = 200_000,
        sprocket: int = 0,
        take_up: float = 0.0,
        combine: str = "mean",
    ):
        if combine not in ("mean", "max"):
            raise ValueError(f"combine must be 'mean' or 'max', got {combine!r}")
        if not temperature > 0:
            raise ValueError(f"temperature must be > 0 N, got {temperature}")
        if not 0.0 <= t_start < t1:
            raise ValueError(f"t_start must be in [0, t1 = {t1:.6g}) s, got {t_start}")
        self.space = space
        self.build = build
        self.config = _Config(
            t_start=jnp.asarray(t_start, dtype=float),
            temperature=jnp.asarray(temperature, dtype=float),
            reference=jnp.asarray(reference, dtype=float),
            t1=float(t1),
            dt=None if dt is None else float(dt),
            solver=solver,
            rtol=float(rtol),
            atol=float(atol),
            max_steps=int(max_steps),
            sprocket=int(sprocket),
            take_up=float(take_up),
            combine=combine,
        )
        self.evaluations = 0  # forward simulations run (ensemble members count each)

    def scenes(self, u) -> Scene:
        """The settled scenes at ``u``, stacked along a leading ensemble axis."""
        built = self.build(self.space.profile(jnp.asarray(u, dtype=float)))
        built = [built] if isinstance(built, Scene) else list(built)
        return jax.tree_util.tree_map(lambda *x: jnp.stack(x), *built)

    def _v(self, u, scenes):
        return _value(jnp.asarray(u, dtype=float), self.space, scenes, self.config)

    def _vg(self, u, scenes):
        return _value_and_grad(jnp.asarray(u, dtype=float), self.space, scenes, self.config)

    def _count(self, scenes):
        self.evaluations += jax.tree_util.tree_leaves(scenes)[0].shape[0]

    def value(self, u) -> tuple[Array, PeakForce]:
        """Objective at ``u`` [N] and the members' :class:`PeakForce`."""
        scenes = self.scenes(u)
        self._count(scenes)
        return self._v(u, scenes)

    def value_and_grad(self, u) -> tuple[Array, Array, PeakForce]:
        """Objective [N], its gradient in ``u`` [N], and the members' results."""
        scenes = self.scenes(u)
        self._count(scenes)
        (value, out), grad = self._vg(u, scenes)
        return value, grad, out
