"""Cushion rings: rings beside a sprocket's teeth that the link plates' lower edges press
on before the rollers seat, softening the roller/tooth impact at the onset of meshing
(elastomer rings as in Cloyes US 8,083,624 and BorgWarner US 6,179,741).

Two parts: :class:`CushionRing`, what a user gives a builder (the ring's own parameters),
and :class:`CushionContacts`, the force element a builder makes of it, bound to the
scene's sprockets and links (:meth:`CushionContacts.attach`).

Geometry. A ring is the circle of radius R about its sprocket's axis c. Link e's plate
edge facing the sprocket is the segment A–B parallel to the link's pitch line (roller or
bush centre x_a to x_b), offset by half the plate height h toward the sprocket:
A = x_a + σ·(h/2)·n, B = x_b + σ·(h/2)·n, n the left normal of x_b − x_a and σ = +1
where the sprocket lies on the left of the chain's order (−1 on its right: an idler on
the chain's back), fixed per sprocket when the scene is built. The edge's point nearest
the axis is P = A + s·(B − A), s = clip((c − A)·(B − A)/|B − A|², 0, 1); the ring is
compressed by δ = R − |P − c| and pushes the edge along the outward radial
m = (P − c)/|P − c| (the distance to a segment is C¹ away from it).

Forces on the bodies. The edge force F = f·m acts at the plate's material point P. On
the two bodies holding x_a and x_b it is split by the lever rule, (1 − s)·F and s·F, plus
the couple ±(σ(h/2)·(u·F)/|B − A|)·n (u the unit pitch-line direction) that carries the
moment of F about the pitch line: together a force system equivalent to F at P, the
exact generalized force −∂V/∂q of the ring's potential. In the lumped chain the two
bodies are the link's rollers; in the clearance chain both are the link itself (points
±p/2 in its frame), where the system is F at P with its torque. The reaction −F acts on
the sprocket's axis; it passes through the axis, so it puts no torque on the sprocket.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .. import _checks as checks
from .._chain import as_chain
from .._checks import fields, file_header, read_json_file, write_text_file
from .._kinematics import perp, points, rot, scatter
from .._numerics import is_concrete, safe_norm, safe_normalize, safe_pow, smooth_ramp
from .base import AbstractElement, Effect
from .pairs import LinkSprings

__all__ = ["CushionRing", "CushionContacts", "as_cushions", "FORMAT", "VERSION"]

FORMAT = "jaxchain.cushion"
VERSION = 1
_UNITS = "SI: radius and width in m, stiffness in N/m^exponent, damping in s/m"
_HEADER = ("format", "version", "kind", "units")
_CLAMP = 0.05  # half-width of the C¹ no-pull clamp on the damping bracket [-]


def _force(stiffness, exponent, damping, width, depth, rate):
    """F = K·ρ(δ)ⁿ·ramp(1 + (3/2)·α·δ̇) [N], ρ the C¹ onset (smooth_ramp, half-width w)."""
    elastic = stiffness * safe_pow(smooth_ramp(depth, width), exponent)
    return elastic * smooth_ramp(1.0 + 1.5 * damping * rate, _CLAMP)


def _potential(stiffness, exponent, width, depth):
    """∫ K·ρ(x)ⁿ dx from the onset −w to δ [J], in closed form: the blend
    ρ = (x + w)²/(4w) on |x| < w, then ρ = x."""
    k, n, w = stiffness, exponent, width
    lo = jnp.clip(depth, -w, w)
    blend = k * safe_pow(lo + w, 2 * n + 1) / ((2 * n + 1) * (4 * w) ** n)
    hi = jnp.maximum(depth, w)
    tail = k * (safe_pow(hi, n + 1) - w ** (n + 1)) / (n + 1)
    return blend + tail


class CushionRing(eqx.Module):
    """A cushion ring beside a sprocket's teeth (one face or both), as a user gives it to a
    builder: ``jc.scenes.engagement(..., cushion=ring)``, ``SprocketSpec(cushion=ring)``.

    Each plate edge facing the sprocket that comes within ``radius`` of the axis
    compresses the ring by δ and is pushed out along the radial by, per face,

        F = K·ρ(δ)ⁿ·ramp(1 + (3/2)·α·δ̇)    [N]

    (Hunt–Crossley: ρ the C¹ onset of half-width ``width``, δ̇ > 0 approaching, the
    bracket clamped at 0 by a C¹ ramp so the force never pulls); ``faces`` rings act on
    the plates of both sides alike. The ring is frictionless (no tangential force between
    plate and ring) and continuous (no pads between the gaps).

    Defaults: an HNBR ring of about 90 Shore A, 1 mm of elastomer bonded on a steel
    carrier, for 08B-size plates. A straight edge of width b pressed into a thin layer
    (thickness H, compression modulus E_c) on a circle of radius R gives, layer as a
    Winkler foundation, F = (4/3)·√(2R)·(b·E_c/H)·δ^{3/2}: hence n = 3/2, and with
    b = 1.6 mm (08B plate), R = 30 mm, H = 1 mm and E_c ≈ 90 MPa (the elastomer's
    dynamic modulus at mesh frequencies, ≈ 60 MPa, 3–5× its static one, times ≈ 1.5 for
    the bonded layer's confinement), K ≈ 5·10⁷ N/m^{3/2}: 50 N at 0.1 mm, 140 N at
    0.2 mm, 260 N at 0.3 mm per plate edge. α = 0.5 s/m gives a restitution of 0.66 at
    1 m/s (0.87 at 0.3 m/s, :func:`jc.contact.hysteresis_restitution
    <jaxchain.contact.hysteresis_restitution>` of χ = (3/2)·α·v): a rebound resilience
    e² ≈ 0.45, typical of HNBR. These are estimates: measure a real ring's K, n, α.

    Attributes:
        radius: R, the ring's outer radius about the sprocket axis [m], > 0
            (differentiable). 08B on 18 teeth: seated plate edges at ≈ 30.1 mm.
        stiffness: K per plate edge and face [N/mⁿ], > 0 (differentiable).
        exponent: n [-], in [1, 3].
        damping: α, Hunt–Crossley's damping [s/m], ≥ 0 (differentiable); 0: elastic.
        width: the compression onset's regularization half-width [m], > 0: the force
            is C¹ in δ and starts at δ = −width.
        faces: rings on 1 or 2 faces of the sprocket (static).
    """

    radius: Float[Array, ""]
    stiffness: Float[Array, ""]
    exponent: Float[Array, ""]
    damping: Float[Array, ""]
    width: Float[Array, ""]
    faces: int = eqx.field(static=True)

    def __init__(
        self,
        radius: ArrayLike,
        *,
        stiffness: ArrayLike = 5e7,
        exponent: ArrayLike = 1.5,
        damping: ArrayLike = 0.5,
        width: ArrayLike = 1e-6,
        faces: int = 2,
    ):
        if isinstance(faces, (bool, np.bool_)) or not isinstance(faces, (int, np.integer)):
            raise TypeError(
                f"CushionRing.faces must be the integer 1 or 2 (rings on one face or on both), "
                f"got {type(faces).__name__} {faces!r}"
            )
        if faces not in (1, 2):
            raise ValueError(
                f"CushionRing.faces must be 1 or 2 (rings on one face or on both), got {faces}"
            )
        self.faces = int(faces)
        for name, value in (
            ("radius", radius),
            ("stiffness", stiffness),
            ("exponent", exponent),
            ("damping", damping),
            ("width", width),
        ):
            checks.real_values(f"CushionRing.{name}", value, "a real number")
            setattr(self, name, jnp.asarray(value, dtype=float))

    def __check_init__(self):
        if not is_concrete(self):
            return
        for name in ("radius", "stiffness", "exponent", "damping", "width"):
            if np.shape(getattr(self, name)) != ():
                raise ValueError(
                    f"CushionRing.{name} must be a scalar, got shape "
                    f"{np.shape(getattr(self, name))} (one ring per sprocket: give each "
                    "sprocket its own CushionRing)"
                )
        fields(
            self,
            [
                ("radius", lambda v: v > 0, "> 0 m (the ring's outer radius about the axis)"),
                ("stiffness", lambda v: v > 0, "> 0 N/m^exponent"),
                ("exponent", lambda v: (v >= 1) & (v <= 3), "in [1, 3]"),
                ("damping", lambda v: v >= 0, ">= 0 s/m (0: elastic)"),
                ("width", lambda v: (v > 0) & (v <= 1e-4), "in (0, 1e-4] m (C¹ onset)"),
            ],
        )

    def force(self, depth: ArrayLike, rate: ArrayLike = 0.0) -> Array:
        """Force of the ring(s) on one plate edge [N], every face: compression ``depth``
        δ [m] (> 0 compressed), its rate ``rate`` δ̇ [m/s] (> 0 compressing)."""
        k, n, a, w = self.stiffness, self.exponent, self.damping, self.width
        return self.faces * _force(k, n, a, w, jnp.asarray(depth), jnp.asarray(rate))

    def potential(self, depth: ArrayLike) -> Array:
        """Elastic energy the ring(s) store under one plate edge at compression ``depth``
        [J], every face."""
        return self.faces * _potential(self.stiffness, self.exponent, self.width, depth)

    def tangent_stiffness(self, force: ArrayLike) -> Array:
        """dF/dδ [N/m] of the static force (every face) where it is ``force`` [N]."""
        k = self.faces * self.stiffness
        n = self.exponent
        return n * k * safe_pow(jnp.asarray(force) / k, (n - 1) / n)

    # ---------------------------------------------------------------- files
    def save(self, path: str | Path) -> Path:
        """Write the ring to ``path`` as JSON (every parameter; floats exact);
        :meth:`load` reads it back equal. Returns the path."""
        if not is_concrete(self):
            raise TypeError(
                "CushionRing.save: the ring is traced (inside jit, grad or vmap), so its "
                "values are not known; save the concrete ring, outside the transformation"
            )
        data = {"format": FORMAT, "version": VERSION, "kind": "CushionRing", "units": _UNITS}
        for name in ("radius", "stiffness", "exponent", "damping", "width"):
            data[name] = float(np.asarray(getattr(self, name)))
        data["faces"] = self.faces
        text = json.dumps(data, indent=2, allow_nan=False) + "\n"
        return write_text_file(path, text, "cushion ring")

    @classmethod
    def load(cls, path: str | Path) -> CushionRing:
        """The ring saved at ``path`` by :meth:`save`, validated as at construction.

        Raises:
            FileNotFoundError, IsADirectoryError: no file at ``path``.
            ValueError: not JSON, not a jaxchain cushion ring, a newer format version, or
                parameters that do not make a valid ring (the message names the file).
        """
        return read_json_file(path, "cushion ring", _from_dict)


def _from_dict(data) -> CushionRing:
    file_header(
        data, format=FORMAT, version=VERSION, what="cushion ring", writer="CushionRing.save"
    )
    if data.get("kind") != "CushionRing":
        raise ValueError(f"unknown kind {data.get('kind')!r}; known kinds: CushionRing")
    names = ("radius", "stiffness", "exponent", "damping", "width", "faces")
    given = {k: v for k, v in data.items() if k not in _HEADER}
    missing = [n for n in names if n not in given]
    unknown = [n for n in given if n not in names]
    if missing or unknown:
        raise ValueError(
            "fields do not match a CushionRing"
            + (f"; missing {missing}" if missing else "")
            + (f"; unknown {unknown}" if unknown else "")
            + f" (its fields: {list(names)})"
        )
    for n in names[:-1]:
        v = given[n]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"CushionRing.{n} must be a number, got {v!r}")
    radius = given.pop("radius")
    return CushionRing(radius, **given)


def as_cushions(cushion, n: int) -> tuple[CushionRing | None, ...]:
    """A builder's ``cushion`` argument checked: None (no ring), or one entry per sprocket
    (``n``), each a :class:`CushionRing` or None."""
    if cushion is None:
        return (None,) * n
    if isinstance(cushion, CushionRing):
        raise TypeError(
            f"cushion: a drive takes one entry per sprocket ({n}), each a "
            "jc.elements.CushionRing or None (a ring's radius belongs to one sprocket's size); "
            "e.g. cushion=(ring, " + ", ".join(["None"] * (n - 1)) + ") for a ring on the driver"
        )
    if isinstance(cushion, (str, bytes)) or not isinstance(cushion, Sequence):
        raise TypeError(
            f"cushion must be None or a sequence of {n} entries (one per sprocket), each a "
            f"jc.elements.CushionRing or None, got {type(cushion).__name__} {cushion!r}"
        )
    if len(cushion) != n:
        raise ValueError(
            f"cushion must hold {n} entries (one per sprocket, None where there is no ring), "
            f"got {len(cushion)}"
        )
    for k, c in enumerate(cushion):
        if c is not None and not isinstance(c, CushionRing):
            raise TypeError(
                f"cushion[{k}] must be a jc.elements.CushionRing or None, got "
                f"{type(c).__name__} {c!r}"
            )
    return tuple(cushion)


class CushionContacts(AbstractElement):
    """Cushion rings on some of a scene's sprockets against its links' plate edges (the
    module docstring gives the geometry and the forces). Built from the user's
    :class:`CushionRing` s by :meth:`attach` (the builders do it); one element holds every
    ring of a scene, evaluated in one vectorized call over rings and links.

    Saved output: ``"cushion_force"``, (L,) the rings' force on each link [N] (every ring
    and face), in ``Solution.element_outputs``.

    Attributes:
        rings: the rings, one per entry of ``sprockets``; their ``radius``, ``stiffness``
            and ``damping`` are the differentiable leaves
            (``scene.elements[i].rings[k].radius``).
        sprockets: the sprocket each ring sits on (static).
        sides: σ = +1 where that sprocket lies on the left of the chain's order (link e
            from x_a to x_b), −1 on its right (static; from the built layout).
        a, b: (L,) the bodies holding each link's two ends (lumped: its rollers;
            clearance: the link itself, twice).
        ra, rb: (L, 2) those ends in their bodies' frames [m].
        half_height: half the link plates' height h/2 [m] (ISO 606 h2, every plate).
    """

    rings: tuple[CushionRing, ...]
    sprockets: tuple[int, ...] = eqx.field(static=True)
    sides: tuple[int, ...] = eqx.field(static=True)
    a: Int[Array, " L"]
    b: Int[Array, " L"]
    ra: Float[Array, "L 2"]
    rb: Float[Array, "L 2"]
    half_height: Float[Array, ""]

    def __check_init__(self):
        if not (len(self.rings) == len(self.sprockets) == len(self.sides) > 0):
            raise ValueError(
                "CushionContacts: rings, sprockets and sides must hold one entry per ring (at "
                f"least one), got {len(self.rings)}, {len(self.sprockets)}, {len(self.sides)}"
            )
        for r in self.rings:
            if not isinstance(r, CushionRing):
                raise TypeError(
                    "CushionContacts: rings must be jc.elements.CushionRing, got "
                    f"{type(r).__name__}"
                )
        if any(s not in (1, -1) for s in self.sides):
            raise ValueError(f"CushionContacts: sides must be +1 or -1, got {self.sides}")

    @classmethod
    def attach(cls, scene, rings: Sequence[CushionRing | None], chain):
        """``scene`` with the element of ``rings`` (one entry per sprocket, a
        :class:`CushionRing` or None; a scene of one sprocket also takes the ring alone)
        added to its force elements (unchanged when every entry is None); ``chain``: the
        :class:`~jaxchain.ChainSpec` (or ISO 606 designation) its chain was built of (its
        plate height, and its pitch for the clearance chain's links). The statics is not
        run: settle the returned scene (:func:`~jaxchain.scenes.equilibrate`) for a start
        at rest on the rings.

        Raises:
            ValueError: a scene without links (the span-level chain) or with rings
                already, a ring count that is not the sprocket count, or a ring at or
                above its sprocket's seated links' pitch line.
        """
        if any(isinstance(e, CushionContacts) for e in scene.elements):
            raise ValueError(
                "the scene has cushion rings already: give every sprocket's ring in one "
                "attach (one entry per sprocket), to the scene without them"
            )
        if isinstance(rings, CushionRing) and len(scene.sprockets) == 1:
            rings = (rings,)
        rings = as_cushions(rings, len(scene.sprockets))
        on = [k for k, r in enumerate(rings) if r is not None]
        if not on:
            return scene
        chain = as_chain(chain)
        if scene.fidelity == "lumped":
            g = next(g for g in scene.pairs if isinstance(g.element, LinkSprings))
            a, b = np.asarray(g.a), np.asarray(g.b)
            ra = rb = np.zeros((len(a), 2))
        elif scene.fidelity == "clearance":
            # link bodies come first, each link's ends at ±p/2 in its frame
            half = chain.pitch / 2
            a = b = np.arange(scene.n_links)
            ra = np.tile([-half, 0.0], (len(a), 1))
            rb = np.tile([half, 0.0], (len(a), 1))
        else:
            raise ValueError(
                f"cushion rings press on link plates: fidelity={scene.fidelity!r} has no "
                "links; use fidelity='lumped' or 'clearance'"
            )
        h2 = chain.plate_height / 2
        xa, xb = _world(scene.q0, a, ra), _world(scene.q0, b, rb)
        sides = []
        for k in on:
            spr = scene.sprockets[k]
            z = int(spr.profile.teeth)
            rp = float(np.max(np.asarray(spr.profile.pitch_radius)))
            line = rp * math.cos(math.pi / z)
            radius = float(np.asarray(rings[k].radius))
            if radius >= line:
                raise ValueError(
                    f"cushion ring on sprocket {k}: radius {radius * 1e3:.4g} mm reaches the "
                    f"pitch line of the seated links ({line * 1e3:.4g} mm from the axis); its "
                    f"seated plate edges sit at about {(line - h2) * 1e3:.4g} mm: choose a "
                    "radius a few tenths of a millimetre above that at most"
                )
            sides.append(_side(xa, xb, np.asarray(spr.centre), rp, spr.sense))
        element = cls(
            rings=tuple(rings[k] for k in on),
            sprockets=tuple(on),
            sides=tuple(sides),
            a=jnp.asarray(a),
            b=jnp.asarray(b),
            ra=jnp.asarray(ra, dtype=float),
            rb=jnp.asarray(rb, dtype=float),
            half_height=jnp.asarray(h2, dtype=float),
        )
        return scene.add_elements(element)

    # ---------------------------------------------------------------- contact
    def _contacts(self, y, scene):
        """Per ring and link: compression δ (K, L) [m], its rate δ̇ (K, L) [m/s], the
        outward radial m (K, L, 2) and the lever coordinate s (K, L); then the links'
        unit pitch direction u (L, 2), pitch-line length (L,) and the arms (L, 2) of their
        ends from their bodies' origins."""
        cs = rot(y.q[:, 2])
        xa, va, arm_a = points(y.q, y.v, self.a, self.ra, cs)
        xb, vb, arm_b = points(y.q, y.v, self.b, self.rb, cs)
        d = xb - xa
        dv = vb - va
        length = safe_norm(d)
        u = safe_normalize(d, jnp.array([1.0, 0.0], dtype=d.dtype))
        n = perp(u)
        du = (dv - u * jnp.sum(u * dv, -1, keepdims=True)) / jnp.maximum(length, 1e-12)[:, None]
        dn = perp(du)
        centres = jnp.stack([scene.sprockets[k].centre for k in self.sprockets])
        sides = jnp.asarray(self.sides, dtype=d.dtype)
        radii = jnp.stack([r.radius for r in self.rings])
        d2 = jnp.maximum(length * length, 1e-24)

        def one(centre, side, radius):
            off = side * self.half_height * n
            edge_a = xa + off
            s = jnp.clip(jnp.sum((centre - edge_a) * d, -1) / d2, 0.0, 1.0)
            p = edge_a + s[:, None] * d
            rel = p - centre
            m = safe_normalize(rel, -side * n)
            depth = radius - safe_norm(rel)
            vp = va + s[:, None] * dv + side * self.half_height * dn
            return depth, -jnp.sum(m * vp, -1), m, s

        depth, rate, m, s = jax.vmap(one)(centres, sides, radii)
        return depth, rate, m, s, u, length, arm_a, arm_b

    def _stacked(self, name):
        return jnp.stack([getattr(r, name) for r in self.rings])

    def _normal(self, depth, rate):
        """(K, L) force of each ring on each link [N], every face."""
        faces = jnp.asarray([float(r.faces) for r in self.rings], dtype=depth.dtype)
        f = jax.vmap(_force)(
            *(self._stacked(k) for k in ("stiffness", "exponent", "damping", "width")),
            depth,
            rate,
        )
        return faces[:, None] * f

    def effect(self, t, y, scene, state) -> Effect:
        depth, rate, m, s, u, length, arm_a, arm_b = self._contacts(y, scene)
        fn = self._normal(depth, rate)
        f = fn[..., None] * m  # (K, L, 2) on the links
        sides = jnp.asarray(self.sides, dtype=fn.dtype)
        # the couple that carries F's moment about the pitch line (module docstring)
        along = jnp.sum(u[None] * f, -1)
        c = (sides[:, None] * self.half_height * along / jnp.maximum(length, 1e-12))[..., None]
        n = perp(u)[None]
        on_a = jnp.sum((1.0 - s)[..., None] * f + c * n, 0)
        on_b = jnp.sum(s[..., None] * f - c * n, 0)
        nb = scene.n_bodies
        body = scatter(nb, self.a, arm_a, on_a) + scatter(nb, self.b, arm_b, on_b)
        pull = -jnp.sum(f, 1)  # (K, 2) on each ring's sprocket axis
        ns = len(scene.sprockets)
        axis = jnp.zeros((ns, 2), fn.dtype).at[jnp.asarray(self.sprockets)].add(pull)
        return Effect(body=body, sprocket_force=axis, report={"cushion_normal": fn})

    def energy(self, t, y, scene) -> Array:
        depth = self._contacts(y, scene)[0]
        faces = jnp.asarray([float(r.faces) for r in self.rings], dtype=depth.dtype)
        e = jax.vmap(_potential)(
            *(self._stacked(k) for k in ("stiffness", "exponent", "width")), depth
        )
        return jnp.sum(faces[:, None] * e)

    def outputs(self, t, y, scene, effect: Effect) -> dict[str, Array]:
        return {"cushion_force": jnp.sum(effect.report["cushion_normal"], 0)}

    def max_stiffness(self, scene, force) -> Array:
        return jnp.max(jnp.stack([r.tangent_stiffness(force) for r in self.rings]))


def _world(q, body, offset) -> np.ndarray:
    """World positions of body-fixed points (NumPy, at build time)."""
    q = np.asarray(q)
    c, s = np.cos(q[body, 2]), np.sin(q[body, 2])
    x = c * offset[:, 0] - s * offset[:, 1]
    y = s * offset[:, 0] + c * offset[:, 1]
    return q[body, :2] + np.stack([x, y], -1)


def _side(xa, xb, centre, pitch_radius, sense) -> int:
    """+1 if the sprocket at ``centre`` lies on the left of the links near it (their
    midpoints within its pitch radius: the wrapped ones), −1 on their right; the
    sprocket's running sense where no link is near."""
    d = xb - xa
    rel = centre - 0.5 * (xa + xb)
    near = np.sum(rel * rel, -1) < pitch_radius**2
    left = d[:, 0] * rel[:, 1] - d[:, 1] * rel[:, 0]
    total = float(np.sum(np.sign(left[near])))
    if total == 0.0:
        return int(sense)
    return 1 if total > 0 else -1
