"""The span-level chain (``fidelity="spans"``): no rollers, the chain's free spans as
axial springs between the tangent points of the sprockets' pitch curves.

Each sprocket's pitch curve is the closed curve through its seat centres,
r(φ) = a₀ + Σₘ (aₘ cos mφ + bₘ sin mφ) in the sprocket frame (least squares through the
seats; a circle of the pitch radius for a round sprocket; the oval of a non-circular one
exactly up to its fitted order). The chain is inextensible where it is wrapped and does
not slip on a sprocket, so the chain material at a point of a pitch curve stays there
while wrapped. Span j (from sprocket j to j + 1 round the loop) then holds the unstretched
length

    u_j(θ) = C_j + s_{j+1}·S_{j+1}(φ_{j+1}) − s_j·S_j(φ_j),

S_k the arc length of sprocket k's pitch curve up to the sprocket-frame angle φ_k of the
span's tangent point, s_k = +1 for a sprocket inside the loop (−1 outside), C_j set by
the start. Its stretch is e_j = L_j(θ) − u_j(θ), L_j the tangent-to-tangent length: a
function of the sprocket angles θ alone. The tension is

    T_j = k_j·ramp(e_j) + c_j·ramp'(e_j)·ė_j,   ramp(e) = (e + √(e² + w²))/2

(a chain does not push: below zero stretch the tension fades smoothly over w = 1 N/k_j),
with the potential V = Σ k_j·∫ramp and the sprocket torques τ = −Σ_j T_j ∂e_j/∂θ: the
energy balance closes exactly and everything is smooth in the angles and in the pitch
curves' leaves. For round sprockets ∂e_j/∂θ_k = ±R_k: the tension difference over the
pitch radius. Polygonal action enters only through a non-circular pitch curve; the
spans carry no mass (their transverse vibration is left out).

The tangent line of span j (unit normal n at angle β, pointing away from the sprockets
inside the loop) touches both pitch curves: n·x_a′(φ_a) = 0, n·x_b′(φ_b) = 0 and
n·(x_a − x_b) = 0 in (β, φ_a, φ_b). Three Newton steps on that 3×3 system from the round
sprockets' tangent solve it, unrolled so that their derivatives are exact.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from .base import AbstractElement, Effect
from .tensioners import arm_coordinates

__all__ = ["Spans", "SpanGeometry", "pitch_curve_coefficients", "scaled_curve"]

#: Newton steps of the tangent line and its two tangent points (quadratic convergence
#: from the round sprockets' line; ample for pitch curves within a few % of round)
_TANGENT_STEPS = 3
#: samples per revolution of the arc-length integrand (its Fourier series); harmonics kept
_ARC_SAMPLES = 64
_ARC_HARMONICS = 16


def pitch_curve_coefficients(radius, angle, order: int):
    """(2·order + 1,) coefficients (a₀, a₁, b₁, …) of the least-squares trigonometric
    curve r(φ) through the seats at sprocket-frame polar ``radius`` (z,) [m] and ``angle``
    (z,) [rad]; differentiable in both."""
    m = jnp.arange(1, order + 1)
    cols = [jnp.ones_like(angle)]
    cols += [f(mm * angle) for mm in m for f in (jnp.cos, jnp.sin)]
    a = jnp.stack(cols, -1)
    return jnp.linalg.solve(a.T @ a, a.T @ radius)


def _radius(coef, phi):
    """r, r', r'' of the pitch curve at sprocket-frame angle ``phi``."""
    order = (coef.shape[-1] - 1) // 2
    m = jnp.arange(1, order + 1, dtype=phi.dtype)
    a, b = coef[1::2], coef[2::2]
    c, s = jnp.cos(m * phi), jnp.sin(m * phi)
    r = coef[0] + jnp.sum(a * c + b * s)
    dr = jnp.sum(m * (b * c - a * s))
    ddr = -jnp.sum(m * m * (a * c + b * s))
    return r, dr, ddr


def _curve(coef, phi):
    """The point p(φ) and its derivatives p', p'' (sprocket frame)."""
    r, dr, ddr = _radius(coef, phi)
    e = jnp.stack([jnp.cos(phi), jnp.sin(phi)])
    t = jnp.stack([-e[1], e[0]])
    return r * e, dr * e + r * t, (ddr - r) * e + 2 * dr * t


def scaled_curve(coef, perimeter):
    """The pitch curve ``coef`` scaled so that its length is ``perimeter`` (z chain pitches:
    the seat polygon's chords; so the mean speed ratio of two sprockets is exactly the
    ratio of their tooth counts), and its arc length as a Fourier series (mean, a (M,),
    b (M,)): S(φ) = mean·φ + Σ (aₘ sin mφ − bₘ (cos mφ − 1))/m."""
    n = _ARC_SAMPLES
    phi = 2 * jnp.pi * jnp.arange(n, dtype=coef.dtype) / n
    r, dr, _ = jax.vmap(_radius, in_axes=(None, 0))(coef, phi)
    spec = jnp.fft.rfft(jnp.sqrt(r * r + dr * dr)) / n
    scale = perimeter / (2 * jnp.pi * spec[0].real)
    k = slice(1, _ARC_HARMONICS + 1)
    return scale * coef, (
        scale * spec[0].real,
        2 * scale * spec[k].real,
        -2 * scale * spec[k].imag,
    )


def _arc_length(mean, a, b, phi):
    m = jnp.arange(1, a.shape[0] + 1, dtype=phi.dtype)
    return mean * phi + jnp.sum((a * jnp.sin(m * phi) - b * (jnp.cos(m * phi) - 1)) / m)


def _ramp(e, w):
    return 0.5 * (e + jnp.sqrt(e * e + w * w))


def _ramp_potential(e, w):
    s = jnp.sqrt(e * e + w * w)
    return 0.25 * (e * e + e * s + w * w * jnp.arcsinh(e / w))


class SpanGeometry(NamedTuple):
    """The spans at one instant (:meth:`Spans.geometry`)."""

    length: Array  # (J,) L_j, tangent point to tangent point round any shoe [m]
    unstretched: Array  # (J,) u_j [m]
    arms: Array  # (J, 2) the span line's moment arm about its start's and end's axes [m]
    shoe_lever: Array  # (A,) ∂L/∂ψ of the span under each tensioner shoe [m/rad]


class Spans(AbstractElement):
    """The free spans of the span-level chain (module docstring).

    Span j runs from sprocket ``start[j]`` to ``end[j]`` (j + 1 round the loop), as one
    straight segment, or as two with a tensioner's shoe between them: the shoe is a circle
    of the chain's pitch line on the chain's back, carried by its arm (the scene's
    ``DriveState.arm``), that the chain slides over (no friction: the span's tension is the
    same on both sides). Its length counts both segments and the arc wrapped on the shoe.

    Attributes:
        start, end: (J,) sprocket indices of each span's ends.
        sense: (S,) +1 for a sprocket inside the loop, −1 outside.
        coefficients: (S, 2M + 1) each sprocket's pitch curve, scaled to its perimeter
            (:func:`scaled_curve`).
        arc_mean, arc_cos, arc_sin: (S,), (S, H), (S, H) its arc length's series.
        normal_angle: (G,) world angle of each segment's outward normal at the start (its
            tangent-line solve starts there).
        base: (J,) C_j [m], the spans' unstretched lengths' constants.
        stiffness: (J,) k_j [N/m].
        damping: (J,) c_j [N·s/m].
        segment_from, segment_to: (G,) each straight segment's end nodes: sprocket k is
            node k, shoe a node S + a. A span's segments are consecutive.
        segment_span: (G,) the span each segment belongs to.
        shoe_radius: (A,) radius of the chain's pitch line round each shoe [m].
        shoe_pivot: (A, 2) its arm's pivot [m].
        shoe_offset: (A, 2) the shoe's centre from the pivot at arm angle ``shoe_angle``.
        shoe_angle: (A,) that arm angle [rad].
    """

    start: Int[Array, " J"]
    end: Int[Array, " J"]
    sense: Float[Array, " S"]
    coefficients: Float[Array, "S C"]
    arc_mean: Float[Array, " S"]
    arc_cos: Float[Array, "S H"]
    arc_sin: Float[Array, "S H"]
    normal_angle: Float[Array, " G"]
    base: Float[Array, " J"]
    stiffness: Float[Array, " J"]
    damping: Float[Array, " J"]
    segment_from: Int[Array, " G"]
    segment_to: Int[Array, " G"]
    segment_span: Int[Array, " G"]
    shoe_radius: Float[Array, " A"]
    shoe_pivot: Float[Array, "A 2"]
    shoe_offset: Float[Array, "A 2"]
    shoe_angle: Float[Array, " A"]

    @property
    def n_shoes(self) -> int:
        return int(self.shoe_radius.shape[0])

    def shoe_centres(self, arm):
        """(A, 2) the shoes' centres at arm angles ``arm`` (A,)."""
        d = arm - self.shoe_angle
        c, s = jnp.cos(d), jnp.sin(d)
        o = self.shoe_offset
        rotated = jnp.stack([c * o[:, 0] - s * o[:, 1], s * o[:, 0] + c * o[:, 1]], -1)
        return self.shoe_pivot + rotated

    def segments(self, theta, centres, arm=None):
        """Every straight segment's tangent line: (length (G,), node-frame angles of its
        tangent points φ_a, φ_b (G,), its points x_a, x_b (G, 2), unit normal n (G, 2))."""
        na = self.n_shoes
        shoe_c = self.shoe_centres(jnp.zeros(0) if arm is None else arm)
        node_c = jnp.concatenate([centres, shoe_c])
        node_rot = jnp.concatenate([theta, jnp.zeros(na, theta.dtype)])
        node_sense = jnp.concatenate([self.sense, -jnp.ones(na, self.sense.dtype)])
        circle = jnp.zeros((na, self.coefficients.shape[1]), self.coefficients.dtype)
        node_coef = jnp.concatenate([self.coefficients, circle.at[:, 0].set(self.shoe_radius)])

        def one(ja, jb, beta):
            sa, sb = node_sense[ja], node_sense[jb]
            ca, cb = node_coef[ja], node_coef[jb]
            rot = [(jnp.cos(node_rot[k]), jnp.sin(node_rot[k])) for k in (ja, jb)]

            def world(k, v):
                c, s = rot[k]
                return jnp.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]])

            # node-frame angles of the tangent points: the world angle of s·n less the
            # node's (unwrapped) angle, continuous in time
            pa = beta + jnp.where(sa > 0, 0.0, jnp.pi) - node_rot[ja]
            pb = beta + jnp.where(sb > 0, 0.0, jnp.pi) - node_rot[jb]
            for _ in range(_TANGENT_STEPS):
                n = jnp.stack([jnp.cos(beta), jnp.sin(beta)])
                t = jnp.stack([-n[1], n[0]])
                xa, da, dda = (world(0, v) for v in _curve(ca, pa))
                xb, db, ddb = (world(1, v) for v in _curve(cb, pb))
                xa, xb = xa + node_c[ja], xb + node_c[jb]
                # tangency at both ends and one line: F = (n·x_a', n·x_b', n·(x_a − x_b)) = 0
                f1, f2, f3 = n @ da, n @ db, n @ (xa - xb)
                j11, j12 = t @ da, n @ dda
                j21, j23 = t @ db, n @ ddb
                j31, j32, j33 = t @ (xa - xb), f1, -f2
                # Cramer's rule on [[j11, j12, 0], [j21, 0, j23], [j31, j32, j33]]
                det = j11 * (-j23 * j32) - j12 * (j21 * j33 - j23 * j31)
                d_beta = (f1 * (-j23 * j32) - j12 * (f2 * j33 - j23 * f3)) / det
                d_pa = (j11 * (f2 * j33 - j23 * f3) - f1 * (j21 * j33 - j23 * j31)) / det
                d_pb = (
                    j11 * (0 * f3 - f2 * j32) - j12 * (j21 * f3 - f2 * j31) + f1 * (j21 * j32)
                ) / det
                beta, pa, pb = beta - d_beta, pa - d_pa, pb - d_pb
            n = jnp.stack([jnp.cos(beta), jnp.sin(beta)])
            t = jnp.stack([-n[1], n[0]])  # travel direction, start → end
            xa = node_c[ja] + world(0, _curve(ca, pa)[0])
            xb = node_c[jb] + world(1, _curve(cb, pb)[0])
            return t @ (xb - xa), pa, pb, xa, xb, n

        return jax.vmap(one)(self.segment_from, self.segment_to, self.normal_angle)

    def geometry(self, theta, centres, arm=None) -> SpanGeometry:
        """Each span at sprocket angles ``theta`` (S,), axes ``centres`` (S, 2) and
        tensioner arm angles ``arm`` (A,) (None without shoes)."""
        nj = self.start.shape[0]
        seg_len, pa, pb, xa, xb, n = self.segments(theta, centres, arm)
        g = jnp.arange(self.segment_span.shape[0])
        first = jax.ops.segment_min(g, self.segment_span, nj)
        last = jax.ops.segment_max(g, self.segment_span, nj)
        length = jax.ops.segment_sum(seg_len, self.segment_span, nj)
        lever = jnp.zeros(0, theta.dtype)
        if self.n_shoes:
            into, out = self._shoe_segments()
            # the arc wrapped on the shoe (the chain runs clockwise round it)
            wrap = self.shoe_radius * (pb[into] - pa[out])
            length = length + jax.ops.segment_sum(wrap, self.segment_span[into], nj)
            # ∂L/∂c = t_in − t_out (the chain pulls the shoe with T·(t_out − t_in)), and the
            # shoe's centre turns about the pivot: ∂c/∂ψ = perp(c − pivot)
            travel = jnp.stack([-n[:, 1], n[:, 0]], -1)
            r = self.shoe_centres(arm) - self.shoe_pivot
            perp = jnp.stack([-r[:, 1], r[:, 0]], -1)
            lever = jnp.sum((travel[into] - travel[out]) * perp, -1)
        sa, sb = self.sense[self.start], self.sense[self.end]
        arms = jnp.stack(
            [
                sa * jnp.sum(n[first] * (xa[first] - centres[self.start]), -1),
                sb * jnp.sum(n[last] * (xb[last] - centres[self.end]), -1),
            ],
            -1,
        )

        def arc(k, phi):  # sprocket k's arc length up to φ
            return jax.vmap(_arc_length)(self.arc_mean[k], self.arc_cos[k], self.arc_sin[k], phi)

        u = self.base + sb * arc(self.end, pb[last]) - sa * arc(self.start, pa[first])
        return SpanGeometry(length, u, arms, lever)

    def stretch(self, theta, centres, arm=None):
        """(J,) e_j = L_j − u_j [m]."""
        geo = self.geometry(theta, centres, arm)
        return geo.length - geo.unstretched

    def _width(self):
        return 1.0 / self.stiffness  # 1 N of tension

    def tensions(self, theta, omega, centres, arm=None, arm_rate=None):
        """(T (J,) [N], sprocket torques (S,) [N·m], arm torques (A,) [N·m]) at angles
        ``theta``, speeds ``omega`` and tensioner arm angles and rates.

        ∂e_j/∂θ is the span line's moment arm about each end's axis (−s_a·h_a at its
        start, +s_b·h_b at its end: the chain's force acts along the line), ∂e_j/∂ψ the
        shoe's lever; the torques are −T·∂e/∂(θ, ψ) and the stretch rate their transpose
        at (ω, ψ̇)."""
        geo = self.geometry(theta, centres, arm)
        e = geo.length - geo.unstretched
        ga = -self.sense[self.start] * geo.arms[:, 0]  # ∂e_j/∂θ_start
        gb = self.sense[self.end] * geo.arms[:, 1]  # ∂e_j/∂θ_end
        rate = ga * omega[self.start] + gb * omega[self.end]
        if self.n_shoes:
            span = self._shoe_span()
            rate = rate.at[span].add(geo.shoe_lever * arm_rate)
        w = self._width()
        opening = 0.5 * (1 + e / jnp.sqrt(e * e + w * w))  # ramp'(e)
        tension = self.stiffness * _ramp(e, w) + self.damping * opening * rate
        torque = jnp.zeros_like(theta).at[self.start].add(-tension * ga)
        torque = torque.at[self.end].add(-tension * gb)
        arm_torque = (
            -tension[self._shoe_span()] * geo.shoe_lever if self.n_shoes else jnp.zeros(0, e.dtype)
        )
        return tension, torque, arm_torque

    def _shoe_segments(self):
        """(A,), (A,) the segments into and out of each shoe: the one ending and the one
        starting there."""
        node = self.sense.shape[0] + jnp.arange(self.n_shoes)
        into = jnp.argmax(self.segment_to[None, :] == node[:, None], axis=1)
        out = jnp.argmax(self.segment_from[None, :] == node[:, None], axis=1)
        return into, out

    def _shoe_span(self):
        """(A,) the span each shoe presses on."""
        return self.segment_span[self._shoe_segments()[0]]

    def effect(self, t, y, scene, state) -> Effect:
        centres = jnp.stack([s.centre for s in scene.sprockets])
        tension, torque, arm_torque = self.tensions(
            y.theta, y.omega, centres, *arm_coordinates(y, self.n_shoes)
        )
        if not self.n_shoes:
            return Effect(body=jnp.zeros_like(y.q), sprocket_torque=torque, tension=tension)
        return Effect(
            body=jnp.zeros_like(y.q),
            sprocket_torque=torque,
            tension=tension,
            arm_torque=arm_torque,
            report={"arm_torque": arm_torque},
        )

    def energy(self, t, y, scene) -> Array:
        centres = jnp.stack([s.centre for s in scene.sprockets])
        e = self.stretch(y.theta, centres, arm_coordinates(y, self.n_shoes)[0])
        return jnp.sum(self.stiffness * _ramp_potential(e, self._width()))

    def outputs(self, t, y, scene, effect) -> dict[str, Array]:
        return {"span_tension": effect.tension}

    def max_stiffness(self, scene, force) -> Array:
        return jnp.max(self.stiffness)
