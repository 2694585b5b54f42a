"""Static equilibrium of a scene's initial configuration.

A layout puts every wrapped roller at the centre of its seat, out of contact; under
tension the chain would then snap into the seats at t = 0 and the start-up transient would
dwarf the meshing impacts. ``equilibrate`` moves the chain bodies to the static
equilibrium at t = 0 with the driver held, by a trust-region least-squares solve
(optimistix dogleg) of the force residual in scaled variables (displacements in pitches,
forces in units of the largest applied force). In stages, because out of contact several
unknowns have no stiffness yet:

1. closed chains: the driven axes are moved out along the centre line by twice the seat
   clearance (the driven wrap with them, the spans stretched evenly) and held, and the
   chain settles into contact;
2. then the driven axes are set free under a take-up force (each span then carries half
   of it) and the driven sprockets' angles under their full load torque;
3. open strands: inside the residual each anchor's guide stays level with its body, so
   the anchor pulls with exactly its tension (its spring only holds the line across).

A vanishing spring to the start (1e-6 in scaled units) keeps bodies floating in free
play (a roller inside its bush clearance) from making the problem rank-deficient;
convergence is judged on the true forces without it, and a solve that moves anything by
a pitch or more is rejected. Lumped chains settle; clearance chains (joint free play on
top of the seats') do not yet, and their scenes start from the layout by default.
"""

from __future__ import annotations

import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import ArrayLike

from .._dynamics import DriveState, forces
from .._scene import Scene

__all__ = ["equilibrate", "resettle"]


def _unpack(scene, x, pitch):
    """Scene and state for the unknowns x: body displacements (pitches; angles in
    pitch/1 m rad), then per sprocket an angle change and an axis shift along the centre
    line (pitches)."""
    n, ns = scene.n_bodies, len(scene.sprockets)
    q = scene.q0 + x[: 3 * n].reshape(n, 3) * pitch
    theta = jnp.stack([s.angle0 for s in scene.sprockets]) + x[3 * n : 3 * n + ns] * pitch
    shift = x[3 * n + ns :] * pitch
    centres = [s.centre + shift[k] * _axis_dir(scene, k) for k, s in enumerate(scene.sprockets)]
    scene = eqx.tree_at(lambda sc: [s.centre for s in sc.sprockets], scene, centres)
    y = DriveState(q=q, v=jnp.zeros_like(q), theta=theta, omega=jnp.zeros_like(theta))
    return scene, y


def _axis_dir(scene, k):
    """Unit vector from the first sprocket's axis to sprocket k's (x for the first)."""
    d = scene.sprockets[k].centre - scene.sprockets[0].centre
    nrm = jnp.sqrt(jnp.sum(d * d))
    return jnp.where(nrm > 0, d / jnp.where(nrm > 0, nrm, 1.0), jnp.array([1.0, 0.0]))


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
    loads = jnp.stack([s.load_torque for s in scene.sprockets])
    moment = jnp.where(
        free, (fr.sprocket_torque - loads) / (force_scale * pitch), pin[3 * n : 3 * n + ns]
    )
    dirs = jnp.stack([_axis_dir(scene, k) for k in range(ns)])
    pull = jnp.sum(fr.sprocket_force * dirs, -1) + take_up
    axis = jnp.where(take_up > 0, pull / force_scale, pin[3 * n + ns :])
    # a vanishing spring (reg, scaled units) to the start: a roller floating in its bush's
    # free play has no force anywhere in it, which would make the problem rank-deficient
    return jnp.concatenate([res.reshape(-1), moment, axis]) - reg * (x - x_pin)


def _take_up_guess(scene, x, push, pitch):
    """Start for a take-up: each pushed axis moved out by twice the largest seat clearance,
    and with it every body in proportion to its distance along the centre line (the
    driven wrap translates with its sprocket, the spans stretch evenly)."""
    n, ns = scene.n_bodies, len(scene.sprockets)
    play = max(float(s.profile.seat_clearance) for s in scene.sprockets)
    c0 = scene.sprockets[0].centre
    for k in range(1, ns):
        if not float(push[k]) > 0:
            continue
        e = _axis_dir(scene, k)
        dist = jnp.sum((scene.sprockets[k].centre - c0) * e)
        along = jnp.clip(jnp.sum((scene.q0[:, :2] - c0) * e, -1) / dist, 0.0, 1.0)
        shift = 2 * play
        xb = x[: 3 * n].reshape(n, 3).at[:, :2].add((shift / pitch) * along[:, None] * e)
        x = x.at[: 3 * n].set(xb.reshape(-1)).at[3 * n + ns + k].set(shift / pitch)
    return x


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


def equilibrate(
    scene: Scene, *, take_up: float = 0.0, max_steps: int = 1000, tolerance: float = 1e-6
) -> Scene:
    """The scene with its initial positions, driven sprocket angles and (with ``take_up``)
    driven axis positions at static equilibrium. Velocities are kept. Warns and returns
    the input if the solve fails.

    Args:
        take_up: force [N] pushing each driven sprocket's axis away from the first
            sprocket's, along their centre line, while it settles (a tensioner): the chain
            then carries take_up/2 in each span before the load. After settling the axis
            stays where it came to rest. A closed chain needs this: its rollers' free play
            in the seats swallows any pretension built into the layout's link stretch.
        tolerance: largest force residual accepted, relative to the largest applied
            force (tension, take-up/2 or load torque over pitch radius).
    """
    moving = scene
    scene = _at_rest(scene)
    ns = len(scene.sprockets)
    driven = jnp.array([s.driven for s in scene.sprockets])
    push = jnp.where(driven, take_up, 0.0)
    force_scale = max(1.0, take_up / 2)
    if scene.anchors is not None:
        force_scale = max(force_scale, float(jnp.max(scene.anchors.tension)))
    for s in scene.sprockets:
        force_scale = max(force_scale, float(s.load_torque / s.profile.pitch_radius))
    fs = jnp.asarray(force_scale)
    n = scene.n_bodies
    pitch = scene.sprockets[0].profile.pitch
    x = jnp.zeros(3 * n + 2 * ns)
    # Sprockets held first, each driven axis pushed out by twice the largest seat clearance
    # so the rollers' free play is taken up: the rollers settle into contact. Then the
    # driven angles (load) and axes (take-up) are set free: from out of contact they would
    # have no stiffness yet.
    if bool(jnp.any(driven)):
        x = _take_up_guess(scene, x, push, pitch)
        x, _, _ = _solve(scene, fs, max_steps, x, jnp.zeros(ns, bool), jnp.zeros(ns))
    x, result, worst = _solve(scene, fs, max_steps, x, driven, push)
    moved = float(jnp.max(jnp.abs(x[: 3 * n].reshape(n, 3)[:, :2]))) if n else 0.0
    shifted = float(jnp.max(jnp.abs(x[3 * n + ns :])))
    if (
        result != optx.RESULTS.successful
        or not float(worst) <= tolerance * force_scale
        or not max(moved, shifted) < 1.0  # a settled chain moves by less than a pitch
    ):
        warnings.warn(
            f"static equilibrium of the initial configuration not found (largest force "
            f"residual {float(worst):.3g} N, largest move {max(moved, shifted):.3g} pitches): "
            "starting from the layout, expect a larger start-up transient",
            stacklevel=2,
        )
        return moving  # the layout, guides still moving
    return _finish(moving, x)


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
    for k in range(ns):
        settled = eqx.tree_at(lambda sc, k=k: sc.sprockets[k].angle0, settled, y.theta[k])
    return settled


def _at_rest(scene: Scene) -> Scene:
    if scene.anchors is None:  # at rest: guides still (no damper force from their speed)
        return scene
    return eqx.tree_at(lambda sc: sc.anchors.speed, scene, jnp.zeros_like(scene.anchors.speed))


def resettle(scene: Scene, *, take_up: ArrayLike = 0.0) -> Scene:
    """One Newton step of the statics from ``scene``'s current start: the equilibrium of a
    settled scene whose parameters (a tooth profile, a tension) were changed a little.

    Differentiable, with the implicit-function derivative of the equilibrium: the step
    is ``−J⁻¹ r`` with the residual ``r`` taken through the changed parameters and the
    Jacobian ``J`` held constant, so at the parameters the scene was settled for the
    step is zero and its derivative is ``−J⁻¹ ∂r/∂parameters`` — exactly how the static
    equilibrium moves. Use it inside a differentiated function on a scene settled by
    :func:`equilibrate` (with the same ``take_up``) at the current parameter values.
    Works traced (inside ``jit``/``grad``/``vmap``).
    """
    rest = _at_rest(scene)
    ns, n = len(scene.sprockets), scene.n_bodies
    pitch = scene.sprockets[0].profile.pitch
    driven = jnp.array([s.driven for s in scene.sprockets])
    push = jnp.where(driven, jnp.asarray(take_up, dtype=float), 0.0)
    scale = [jnp.asarray(1.0), jnp.max(push) / 2]
    if scene.anchors is not None:
        scale.append(jnp.max(scene.anchors.tension))
    scale += [s.load_torque / s.profile.pitch_radius for s in scene.sprockets]
    fs = jax.lax.stop_gradient(jnp.max(jnp.stack([jnp.asarray(v, float) for v in scale])))
    x0 = jnp.zeros(3 * n + 2 * ns, dtype=scene.q0.dtype)
    args = (rest, pitch, fs, _rotating_bodies(scene), driven, push, x0, 0.0)
    r = _residual(x0, args)
    jac = jax.lax.stop_gradient(jax.jacfwd(_residual)(x0, args))
    return _finish(scene, -jnp.linalg.solve(jac, r))
