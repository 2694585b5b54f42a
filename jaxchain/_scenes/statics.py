"""Static equilibrium of a scene's initial configuration.

A layout puts every wrapped roller at the centre of its seat, out of contact; under
tension the chain would then snap into the seats at t = 0 and the start-up transient would
dwarf the meshing impacts. ``equilibrate`` moves the chain bodies to the static
equilibrium at t = 0 with the driver held, in scaled unknowns (displacements in pitches,
forces in units of the largest applied force), in two steps:

1. dynamic relaxation: pseudo-time integration of the free unknowns with the bodies' own
   masses, no velocity in the forces, symplectic Euler at a step below the stiffest
   element's stability limit, and kinetic damping (every velocity zeroed whenever the
   kinetic energy stops growing: each reset takes out one oscillation's energy). It needs
   no Jacobian and is indifferent to free play: a roller floating in its bush clearance, or
   a chain whose joints must all close before it carries anything, is a mechanism to a
   Newton solver (zero stiffness until contact) but simply falls into contact here.
   Driven axes move under their take-up force and driven angles under their load torque
   at the same time. A step found unstable (forces growing past any applied one) is
   halved and the relaxation restarted.
2. if the relaxation did not reach the tolerance: a trust-region least-squares polish
   (optimistix dogleg) from where it stopped, with a vanishing spring to the start (1e-6
   in scaled units) so bodies left floating in free play do not make it rank-deficient;
   convergence is judged on the true forces without it.

Open strands: inside the residual each anchor's guide stays level with its body, so the
anchor pulls with exactly its tension (its spring only holds the line across). A solve
that moves anything by a pitch or more is rejected.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import ArrayLike

from .. import _checks as checks
from .._dynamics import DriveState, dof_inertia, dof_layout, dof_start, forces, n_dofs
from .._numerics import is_concrete
from .._programs import stored
from .._scene import Scene

__all__ = ["equilibrate", "resettle", "statics_jacobian"]


def _unpack(scene, x, pitch):
    """Scene and state for the unknowns x: body displacements (pitches; angles in
    pitch/1 m rad), then per sprocket an angle change and an axis shift along its take-up
    direction (pitches), then per element coordinate (a tensioner arm's angle, ...) a
    change in pitch/1 m of its unit (rad or m)."""
    n, ns = scene.n_bodies, len(scene.sprockets)
    q = scene.q0 + x[: 3 * n].reshape(n, 3) * pitch
    theta = jnp.stack([s.angle0 for s in scene.sprockets]) + x[3 * n : 3 * n + ns] * pitch
    shift = x[3 * n + ns : 3 * n + 2 * ns] * pitch
    dirs, _ = _take_up(scene)
    centres = [s.centre + shift[k] * dirs[k] for k, s in enumerate(scene.sprockets)]
    scene = eqx.tree_at(lambda sc: [s.centre for s in sc.sprockets], scene, centres)
    dof = rate = None
    if n_dofs(scene):
        dof = dof_start(scene)[0] + x[3 * n + 2 * ns :] * pitch
        rate = jnp.zeros_like(dof)
    y = DriveState(
        q=q, v=jnp.zeros_like(q), theta=theta, omega=jnp.zeros_like(theta), dof=dof, dof_rate=rate
    )
    return scene, y


def _force_scales(scene) -> list:
    """The forces the elements name as typical of what they apply at rest [N]."""
    out = [el.force_scale(scene) for el in scene.force_elements]
    return [jnp.asarray(f, float) for f in out if f is not None]


def _axis_dir(scene, k):
    """Unit vector from the first sprocket's axis to sprocket k's (x for the first)."""
    d = scene.sprockets[k].centre - scene.sprockets[0].centre
    nrm = jnp.sqrt(jnp.sum(d * d))
    return jnp.where(nrm > 0, d / jnp.where(nrm > 0, nrm, 1.0), jnp.array([1.0, 0.0]))


def _take_up(scene):
    """(S, 2) unit directions in which the take-up moves each axis and (S,) the force on
    it per newton of take-up: a sprocket's ``take_up_vector`` split into direction and
    length, or (``None``) the whole take-up on each driven sprocket away from the first
    sprocket's axis."""
    dirs, gains = [], []
    for k, s in enumerate(scene.sprockets):
        if s.take_up_vector is None:
            dirs.append(_axis_dir(scene, k))
            gains.append(jnp.asarray(1.0 if s.driven else 0.0))
        else:
            v = s.take_up_vector
            nrm = jnp.sqrt(jnp.sum(v * v))
            dirs.append(jnp.where(nrm > 0, v / jnp.where(nrm > 0, nrm, 1.0), 0.0))
            gains.append(nrm)
    return jnp.stack(dirs), jnp.stack(gains)


def _residual(x, args):
    """Scaled force residual. Unknowns not set free are pinned at their value in x_pin:
    body angles of points, sprocket angles unless free[k], axes unless take_up[k] > 0."""
    scene, pitch, force_scale, rot_mask, free, take_up, x_pin, reg = args
    n, ns = scene.n_bodies, len(scene.sprockets)
    sc, y = _unpack(scene, x, pitch)
    if sc.anchors is not None:  # guides level with their bodies: anchors pull with exactly T
        an = sc.anchors
        along = jnp.sum((y.q[an.body, :2] - an.origin) * an.direction, -1)
        sc = eqx.tree_at(lambda s: s.anchors.origin, sc, an.origin + along[:, None] * an.direction)
    fr = forces(0.0, y, sc)
    pin = x - x_pin
    res = fr.body / force_scale
    # torques in units of force_scale·pitch; bodies that cannot turn (points) are pinned
    res = res.at[:, 2].set(jnp.where(rot_mask, res[:, 2] / pitch, pin[: 3 * n].reshape(n, 3)[:, 2]))
    loads = jnp.stack([s.load(0.0) for s in scene.sprockets])  # held at the start
    moment = jnp.where(
        free, (fr.sprocket_torque - loads) / (force_scale * pitch), pin[3 * n : 3 * n + ns]
    )
    dirs, _ = _take_up(scene)
    pull = jnp.sum(fr.sprocket_force * dirs, -1) + take_up
    axis = jnp.where(take_up > 0, pull / force_scale, pin[3 * n + ns : 3 * n + 2 * ns])
    parts = [res.reshape(-1), moment, axis]
    if fr.dof_force is not None:  # each element coordinate: its generalized force
        parts.append(fr.dof_force / (force_scale * pitch))
    # a vanishing spring (reg, scaled units) to the start: a roller floating in its bush's
    # free play has no force anywhere in it, which would make the problem rank-deficient
    return jnp.concatenate(parts) - reg * (x - x_pin)


def _rotating_bodies(scene: Scene) -> jax.Array:
    """Bodies that carry a torque: some force element or roller sits off their centre."""
    n = scene.n_bodies
    used = jnp.zeros(n, bool)
    for g in scene.pairs:
        used = used.at[g.a].max(jnp.any(g.ra != 0, axis=-1))
        used = used.at[g.b].max(jnp.any(g.rb != 0, axis=-1))
    return used.at[scene.roller_body].max(jnp.any(scene.roller_offset != 0, axis=-1))


@eqx.filter_jit
def _solve(scene, force_scale, max_steps, x0, free, take_up):
    pitch = scene.sprockets[0].profile.pitch
    args = (scene, pitch, force_scale, _rotating_bodies(scene), free, take_up, x0, 1e-6)
    sol = optx.least_squares(
        _residual,
        optx.Dogleg(rtol=1e-10, atol=1e-12),
        x0,
        args,
        max_steps=max_steps,
        throw=False,
    )
    # converged means the true forces balance: judge without the regularizing spring
    res = _residual(sol.value, args[:-1] + (0.0,))
    return sol.value, sol.result, jnp.max(jnp.abs(res)) * force_scale


# The Newton polish's linear solves are LAPACK calls inside XLA's program: two such
# programs executing at once (scenes settled in threads) can take every thread of XLA's
# CPU pool and wait for each other, so they run one at a time. The relaxation, the usual
# path, holds no such call and runs side by side.
_LAPACK = threading.Lock()


def _free_unknowns(scene, free, take_up):
    """Which unknowns move: body positions; body angles of bodies that carry a torque;
    sprocket angles where ``free``; axes under a take-up."""
    rot = _rotating_bodies(scene)
    body = jnp.stack([jnp.ones_like(rot), jnp.ones_like(rot), rot], -1).reshape(-1)
    return jnp.concatenate([body, free, take_up > 0, jnp.ones(n_dofs(scene), bool)])


def _accelerations(scene, pitch, force_scale):
    """Acceleration per unit of scaled residual for each unknown (the bodies' own masses;
    a sprocket axis moves with the mass of a disc of its inertia at its pitch radius)."""
    m, j = scene.mass, scene.inertia
    body = jnp.stack([force_scale / (m * pitch), force_scale / (m * pitch), force_scale / j], -1)
    spr_j = jnp.stack([s.inertia for s in scene.sprockets])
    spr_m = jnp.stack([2 * s.inertia / s.profile.pitch_radius**2 for s in scene.sprockets])
    arm = [] if not n_dofs(scene) else [force_scale / dof_inertia(scene)]
    return jnp.concatenate(
        [body.reshape(-1), force_scale / spr_j, force_scale / (spr_m * pitch), *arm]
    )


def _stable_step(scene: Scene, force: float) -> float:
    """The symplectic-Euler stability limit 2/ω for the stiffest force element at
    ``force`` on the lightest body (ω² ≤ 8k/m bounds a body between two such elements,
    turning included)."""
    force = jnp.asarray(force, float)
    ks = [el.max_stiffness(scene, force) for el in scene.force_elements]
    k = max(float(v) for v in ks if v is not None)
    return 2.0 / math.sqrt(8.0 * k / float(jnp.min(scene.mass)))


@eqx.filter_jit
def _relax(scene, force_scale, x0, free, take_up, dt, max_steps, tolerance):
    """Dynamic relaxation with kinetic damping (module docstring). Returns the unknowns,
    the largest true force residual [N], the steps taken and whether it stayed stable."""
    pitch = scene.sprockets[0].profile.pitch
    args = (scene, pitch, force_scale, _rotating_bodies(scene), free, take_up, x0, 0.0)
    mask = _free_unknowns(scene, free, take_up)
    acc = jnp.where(mask, _accelerations(scene, pitch, force_scale), 0.0)
    weight = jnp.where(mask, 1.0 / jnp.where(mask, acc, 1.0), 0.0)  # kinetic energy ∝ Σ v²/acc

    def residual(x):
        return jnp.where(mask, _residual(x, args), 0.0)

    # One force evaluation in the compiled loop, none outside it: the first pass (i = -1,
    # zero residual, so nothing moves) only evaluates the start and fixes the limit.
    def step(c):  # steps, x, v, kinetic energy, residual at x, best worst, step of best, limit
        i, x, v, ke_prev, r, best, at, limit = c
        v = v + dt * acc * r
        ke = jnp.sum(weight * v * v)
        peak = ke < ke_prev  # the kinetic energy stopped growing: take it out
        v = jnp.where(peak, 0.0, v)
        x = x + dt * v
        r = residual(x)
        worst = jnp.max(jnp.abs(r)) * force_scale
        gain = worst < 0.5 * best
        return (
            i + 1,
            x,
            v,
            jnp.where(peak, 0.0, ke),
            r,
            jnp.where(gain, worst, best),
            jnp.where(gain, i + 1, at),
            jnp.where(i < 0, 1e3 * jnp.maximum(force_scale, worst), limit),  # beyond: unstable
        )

    def going(c):
        i, _, _, _, r, _, at, limit = c
        worst = jnp.max(jnp.abs(r)) * force_scale
        stalled = i - at > jnp.maximum(20_000, at)  # round-off floor: no halving for as long
        return (i < 0) | ((i < max_steps) & (worst > tolerance) & (worst < limit) & ~stalled)

    zero = jnp.zeros((), x0.dtype)
    init = (-1, x0, jnp.zeros_like(x0), zero, jnp.zeros_like(x0), zero + jnp.inf, 0, zero + jnp.inf)
    steps, x, _, _, r, _, _, limit = jax.lax.while_loop(going, step, init)
    worst = jnp.max(jnp.abs(r)) * force_scale
    return x, worst, steps, jnp.isfinite(worst) & (worst < limit)


_relax = stored("jaxchain.statics.relax")(_relax)  # traced once across processes


def equilibrate(
    scene: Scene,
    *,
    take_up: float = 0.0,
    max_steps: int = 1000,
    tolerance: float = 1e-6,
    relax_steps: int = 400_000,
) -> Scene:
    """The scene with its initial positions, driven sprocket angles and (with ``take_up``)
    driven axis positions at static equilibrium (module docstring: dynamic relaxation,
    then a Newton polish if needed). Velocities are kept. Warns and returns the input if
    no equilibrium is found.

    Args:
        take_up: force [N] pushing the take-up axes while the scene settles (a
            tensioner): each driven sprocket's away from the first sprocket's, along their
            centre line (two-sprocket drives), or the take-up sprocket's of a loop over
            several sprockets along the outward bisector of its spans, by take_up·cos α
            (each sprocket's ``take_up_vector``). The chain then carries take_up/2 in each
            span at the take-up before the load. After settling the axis stays where it
            came to rest. A closed chain needs this: its rollers' free play in the seats
            swallows any pretension built into the layout's link stretch.
        max_steps: most steps of the trust-region polish.
        tolerance: largest force residual accepted, relative to the largest applied
            force (tension, take-up/2 or load torque over pitch radius).
        relax_steps: most steps of the dynamic relaxation (each one force evaluation).
    """
    checks.instance("scene", scene, Scene, "a jaxchain Scene (built by jc.scenes.*)")
    checks.element_coordinates(scene, "equilibrate")
    take_up = checks.real("take_up", take_up, lo=0.0, unit="N")
    checks.integer("max_steps", max_steps, lo=1)
    checks.integer("relax_steps", relax_steps, lo=0)
    checks.real("tolerance", tolerance, lo=0.0, lo_open=True, unit="(relative force residual)")
    moving = scene
    scene = _at_rest(scene)
    ns = len(scene.sprockets)
    driven = jnp.array([s.driven for s in scene.sprockets])
    push = take_up * _take_up(scene)[1]
    force_scale = max(1.0, take_up / 2)
    if scene.anchors is not None:
        force_scale = max(force_scale, float(jnp.max(scene.anchors.tension)))
    for s in scene.sprockets:
        force_scale = max(force_scale, float(s.load_torque / s.profile.pitch_radius))
    for f in _force_scales(scene):
        force_scale = max(force_scale, float(f))
    fs = jnp.asarray(force_scale)
    n = scene.n_bodies
    x0 = jnp.zeros(3 * n + 2 * ns + n_dofs(scene))
    tol = tolerance * force_scale
    dt = _stable_step(scene, 4 * force_scale)
    for _ in range(4):  # an unstable step is halved
        # relaxed far below the tolerance (or to its round-off floor): cheap, linear
        # convergence, and the balance of moments is then as good as a Newton solve's
        x, worst, _, stable = _relax(
            scene, fs, x0, driven, push, *map(jnp.asarray, (dt, relax_steps, 1e-4 * tol))
        )  # arrays, not Python numbers: a new step or tolerance does not recompile
        if bool(stable):
            break
        dt /= 2
    if not (bool(stable) and float(worst) <= tol):
        with _LAPACK:  # its linear solves: one such program at a time (below)
            x, _, worst = jax.block_until_ready(
                _solve(scene, fs, max_steps, x if bool(stable) else x0, driven, push)
            )
    u = np.abs(np.asarray(x))  # read on the host: no small program per scene size
    moved = float(u[: 3 * n].reshape(n, 3)[:, :2].max()) if n else 0.0
    shifted = float(u[3 * n + ns : 3 * n + 2 * ns].max())
    if not (float(worst) <= tol and max(moved, shifted) < 1.0):  # settles by < a pitch
        warnings.warn(
            f"static equilibrium of the initial configuration not found (largest force "
            f"residual {float(worst):.3g} N, largest move {max(moved, shifted):.3g} pitches): "
            "starting from the layout, expect a larger start-up transient",
            stacklevel=2,
        )
        return moving  # the layout, guides still moving
    return _finish_jitted(moving, x)


def _finish(scene: Scene, x) -> Scene:
    """``scene`` moved by the unknowns ``x`` (anchors' guides level with their bodies)."""
    pitch = scene.sprockets[0].profile.pitch
    ns = len(scene.sprockets)
    settled, y = _unpack(scene, x, pitch)
    if settled.anchors is not None:  # guides level with their bodies: each pulls exactly T
        an = settled.anchors
        along = jnp.sum((y.q[an.body, :2] - an.origin) * an.direction, -1)
        settled = eqx.tree_at(
            lambda sc: sc.anchors.origin, settled, an.origin + along[:, None] * an.direction
        )
    settled = eqx.tree_at(lambda sc: sc.q0, settled, y.q)
    for i, start, k in dof_layout(settled):  # each element starts where it settled
        el = settled.force_elements[i].with_dof_start(y.dof[start : start + k])
        settled = settled.with_force_element(i, el)
    for k in range(ns):
        settled = eqx.tree_at(lambda sc, k=k: sc.sprockets[k].angle0, settled, y.theta[k])
    return settled


# one program per scene structure for the settled scene (eagerly, its dozens of array
# operations compiled a small program each)
_finish_jitted = eqx.filter_jit(_finish)


def _at_rest(scene: Scene) -> Scene:
    """The scene as its statics see it: guides still (no damper force from their speed),
    and the joints' oil films left out (a film carries no load at rest, and its squeeze
    damping would only slow the relaxation down)."""
    if any(g.lubricated for g in scene.pairs):
        scene = dataclasses.replace(scene, pairs=tuple(g.dry() for g in scene.pairs))
    if scene.anchors is None:
        return scene
    return eqx.tree_at(lambda sc: sc.anchors.speed, scene, jnp.zeros_like(scene.anchors.speed))


def _resettle_args(scene: Scene, take_up) -> tuple:
    """The residual's arguments at ``scene``'s start (guides at rest), unknowns zero."""
    rest = _at_rest(scene)
    ns, n = len(scene.sprockets), scene.n_bodies
    pitch = scene.sprockets[0].profile.pitch
    driven = jnp.array([s.driven for s in scene.sprockets])
    push = jnp.asarray(take_up, dtype=float) * _take_up(scene)[1]
    scale = [jnp.asarray(1.0), jnp.max(push) / 2]
    if scene.anchors is not None:
        scale.append(jnp.max(scene.anchors.tension))
    scale += [s.load_torque / s.profile.pitch_radius for s in scene.sprockets]
    scale += _force_scales(scene)
    fs = jax.lax.stop_gradient(jnp.max(jnp.stack([jnp.asarray(v, float) for v in scale])))
    x0 = jnp.zeros(3 * n + 2 * ns + n_dofs(scene), dtype=scene.q0.dtype)
    return (rest, pitch, fs, _rotating_bodies(scene), driven, push, x0, 0.0)


def _start_residual(scene: Scene, take_up) -> tuple:
    """:func:`_resettle_args` and the residual there (unknowns zero)."""
    args = _resettle_args(scene, take_up)
    return args, _residual(args[-2], args)


def _check(scene, take_up) -> None:
    """A Scene, and a take-up >= 0 where it is concrete."""
    checks.instance("scene", scene, Scene, "a jaxchain Scene (built by jc.scenes.*)")
    if is_concrete(take_up):
        checks.real("take_up", take_up, lo=0.0, unit="N")


def _jacobian(args) -> jax.Array:
    # the vanishing spring keeps bodies floating in free play (zero rows) from making the
    # Jacobian singular; at x0 it adds nothing to the residual
    return jax.lax.stop_gradient(jax.jacfwd(_residual)(args[-2], args[:-1] + (1e-6,)))


@eqx.filter_jit
def statics_jacobian(scene: Scene, *, take_up: ArrayLike = 0.0) -> jax.Array:
    """The Jacobian of the (scaled) static force residual at ``scene``'s start, the matrix
    :func:`resettle` solves with. Compute it once on a settled scene and pass it to every
    :func:`resettle` of that scene (``jacobian=``): the differentiated function then
    carries no Jacobian of its own (a smaller program to compile, the same derivative).
    Works traced and under ``vmap`` (one Jacobian per ensemble member)."""
    _check(scene, take_up)
    return _jacobian(_resettle_args(scene, take_up))


@eqx.filter_jit  # called eagerly, the Jacobian would dispatch op by op (30 s)
def resettle(scene: Scene, *, take_up: ArrayLike = 0.0, jacobian: ArrayLike | None = None) -> Scene:
    """One Newton step of the statics from ``scene``'s current start: the equilibrium of a
    settled scene whose parameters (a tooth profile, a tension) were changed a little.

    Differentiable, with the implicit-function derivative of the equilibrium: the step
    is ``−J⁻¹ r`` with the residual ``r`` taken through the changed parameters and the
    Jacobian ``J`` held constant, so at the parameters the scene was settled for the
    step is zero and its derivative is ``−J⁻¹ ∂r/∂parameters`` — exactly how the static
    equilibrium moves. Use it inside a differentiated function on a scene settled by
    :func:`equilibrate` (with the same ``take_up``) at the current parameter values.
    Works traced (inside ``jit``/``grad``/``vmap``).

    ``jacobian``: ``J`` from :func:`statics_jacobian` of the settled scene (same
    ``take_up``), computed outside the differentiated function; by default ``J`` is
    computed here, at the changed parameters (the two agree where the step is zero, so
    the derivative there is the same).
    """
    _check(scene, take_up)
    args, r = _start_residual(scene, take_up)
    jac = _jacobian(args) if jacobian is None else jax.lax.stop_gradient(jnp.asarray(jacobian))
    if jac.shape != (r.size, r.size):
        raise ValueError(
            f"resettle: jacobian must be {r.size}x{r.size} (statics_jacobian of this "
            f"scene), got shape {jac.shape}"
        )
    return _finish(scene, -jnp.linalg.solve(jac, r))


def resettle_by_inverse(scene: Scene, take_up: float, inverse: jax.Array) -> Scene:
    """:func:`resettle` with the inverse of its Jacobian given (traced code only): the
    step a matrix product, so the program holds no linear-algebra library call (two such
    calls executing at once can take every thread of XLA's CPU pool and wait for each
    other; without one, independent programs run side by side on threads)."""
    _, r = _start_residual(scene, take_up)
    return _finish(scene, -(jax.lax.stop_gradient(inverse) @ r))
