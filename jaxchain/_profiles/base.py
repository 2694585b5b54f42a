"""The sprocket-kind protocol: what a tooth profile gives the drive
(:class:`AbstractProfile`) and what the roller/tooth contact reads of it
(:class:`AbstractShape`).

A new kind of sprocket subclasses both: its profile gives its outline, its contact shape,
and (optionally) its free-form form and seat centres; its shape gives the signed
distance from a roller centre to the tooth material and the gap nearest to it.
"""

from __future__ import annotations

import abc
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .cad import write_dxf
from .record import save_profile

__all__ = [
    "AbstractProfile",
    "AbstractShape",
    "MIN_TEETH",
    "MAX_TEETH",
    "REACH_MARGIN",
    "check_teeth",
    "gap_rotation",
]

MIN_TEETH = 7
MAX_TEETH = 250

REACH_MARGIN = 1.05  # roller radii beyond the tip circle a roller may still touch


def check_teeth(teeth):
    if not isinstance(teeth, (int, np.integer)) or isinstance(teeth, bool):
        raise ValueError(f"teeth must be an integer, got {teeth!r}")
    if not MIN_TEETH <= teeth <= MAX_TEETH:
        raise ValueError(f"teeth must be in [{MIN_TEETH}, {MAX_TEETH}], got {teeth}")


# bits of the largest gap index (MAX_TEETH − 1)
GAP_BITS = (MAX_TEETH - 1).bit_length()


def gap_rotation(k, z, dtype):
    """Rotation matrix by 2πk/z, the angle of gap k (integer in [0, z)), as the product
    of the rotations by 2π·2ᵇ/z of k's set bits: no cos/sin per point (2·8 per profile).
    Per-point trig was ~20 % of the engagement's vector field. Each factor is computed
    directly (not by repeated squaring, whose angle error doubles per squaring): the
    product differs from cos/sin of 2πk/z by ≤ 1.5e-15 (every k of every tooth count
    7…250)."""
    z = jnp.asarray(z, dtype)
    c, s = jnp.ones((), dtype), jnp.zeros((), dtype)
    for b in range(GAP_BITS):
        a = 2 * jnp.pi * jnp.mod(2.0**b, z) / z
        wc, ws = jnp.cos(a), jnp.sin(a)
        bit = ((k >> b) & 1) == 1
        c, s = jnp.where(bit, c * wc - s * ws, c), jnp.where(bit, c * ws + s * wc, s)
    return jnp.array([[c, -s], [s, c]])


class AbstractShape(eqx.Module):
    """What the roller/tooth contact reads of a sprocket: the tooth material's signed
    distance from a point and the gap nearest to it, in the sprocket frame. Array leaves
    only (its tooth count too), so the shapes of one kind stack along a leading axis and
    one vmapped contact reads every sprocket."""

    @property
    @abc.abstractmethod
    def roller_radius(self) -> Array:
        """Radius of the roller that engages it [m]."""

    @abc.abstractmethod
    def signed_distance(self, point: Float[Array, 2]) -> tuple[Array, Array]:
        """Signed distance [m] from ``point`` (sprocket frame) to the tooth material,
        positive in a gap, and its gradient (unit normal, sprocket frame). Continuous in
        the point and the shape's leaves everywhere, finite gradients."""

    @abc.abstractmethod
    def nearest_gap(self, point: Float[Array, 2]) -> Array:
        """Index (integer array, in [0, z)) of the gap that owns ``point``."""

    def prepared(self) -> AbstractShape:
        """This shape with what depends on its leaves alone computed ahead, once per
        solve (default: itself)."""
        return self


class AbstractProfile(eqx.Module):
    """A sprocket's tooth profile: what every kind (ISO 606 :class:`ToothProfile`,
    :class:`~jaxchain.FreeformProfile`) has, and what it derives alike from its ``teeth``,
    ``pitch``, ``roller_diameter``, ``seating_radius`` and ``tip_diameter``: the pitch
    circle, the reach of its teeth, its CAD export and its saving as JSON. Scenes,
    builders and design spaces accept any of its kinds.

    Each kind gives its outline (``outline(n, gap)``: one gap's tooth-gap outline, (n, 2)
    [m] in the sprocket frame; ``sprocket_outline(n)``: the whole sprocket's) and its
    contact shape (``contact_shape()``, an :class:`AbstractShape`). Its ``teeth`` is a
    static field (``eqx.field(static=True)``): counts set the traced program's shapes."""

    # (each kind also has a ``tip_diameter`` [m], the diameter its teeth reach: declared in
    # the kinds, after their own seat fields, so that their fields keep their order, and
    # checked at construction)
    teeth: eqx.AbstractVar[int]
    pitch: eqx.AbstractVar[Array]
    roller_diameter: eqx.AbstractVar[Array]
    seating_radius: eqx.AbstractVar[Array]

    def __check_init__(self):
        if not hasattr(self, "tip_diameter"):
            raise TypeError(
                f"{type(self).__name__}: a profile kind needs a tip_diameter field [m], the "
                "diameter its teeth reach (what reach_radius, the contact slots and the "
                "meshing events read)"
            )

    @abc.abstractmethod
    def outline(self, n: int = 60, gap: int = 0) -> np.ndarray:
        """Gap ``gap``'s outline, (n-ish, 2) points [m] in the sprocket frame."""

    @abc.abstractmethod
    def sprocket_outline(self, n: int = 30) -> np.ndarray:
        """The whole sprocket's closed outline, (N, 2) points [m]."""

    @abc.abstractmethod
    def contact_shape(self) -> AbstractShape:
        """What the roller/tooth contact reads of this profile (an :class:`AbstractShape`,
        its tooth count an array leaf, so the shapes of one kind stack across sprockets)."""

    def freeform(self, arcs: int | None = None):
        """The same outline as a :class:`~jaxchain.FreeformProfile` with ``arcs`` arcs per
        flank (None: the fewest that hold it). A drive whose sprockets are of different
        kinds reads them all in this form, and the DXF export writes its arcs. A kind
        whose outline is not an arc spline does not implement it (``TypeError``); its
        sprockets are then read one by one."""
        raise TypeError(f"{type(self).__name__} has no free-form (arc-spline) form")

    @property
    def arcs(self) -> int:
        """K, arcs per flank (1 for a kind whose flanks are single arcs)."""
        return 1

    def pitch_points(self) -> np.ndarray:
        """(z, 2) the seat centres [m], sprocket frame: where the rollers of a chain
        wrapped at rest sit. Seat k on the pitch circle at angle 2πk/z by default."""
        z = self.teeth
        a = 2 * np.pi * np.arange(z) / z
        r = float(self.pitch_radius)
        return r * np.stack([np.cos(a), np.sin(a)], -1)

    def pitch_polar(self) -> tuple[Array, Array]:
        """The seat centres in polar form, sprocket frame, as arrays of the profile's
        leaves (differentiable): radius (z,) [m] and angle (z,) [rad]. Seat k on the pitch
        circle at angle 2πk/z by default."""
        z = self.teeth
        r = jnp.asarray(self.pitch_radius)
        return jnp.broadcast_to(r, (z,)), 2 * jnp.pi * jnp.arange(z, dtype=r.dtype) / z

    def outline_arcs(self) -> list[tuple]:
        """The sprocket's closed outline as circular arcs, counter-clockwise round the
        sprocket: ``(centre (2,), radius, start angle, end angle)`` [m, rad], each arc
        counter-clockwise about its centre from start to end (the DXF convention); by
        default, its free-form form's."""
        return self.freeform().outline_arcs()

    def uniform(self) -> AbstractProfile:
        """This profile with every per-gap leaf replaced by its mean over the gaps (the
        profile itself for a kind whose gaps are all alike)."""
        return self

    @property
    def pitch_diameter(self) -> Array:
        """d = p / sin(π/z) [m] (the nominal pitch circle; seats may be offset from it)."""
        return self.pitch / jnp.sin(jnp.pi / self.teeth)

    @property
    def pitch_radius(self) -> Array:
        return self.pitch_diameter / 2

    @property
    def roller_radius(self) -> Array:
        return self.roller_diameter / 2

    @property
    def reach_radius(self) -> Array:
        """The farthest from the axis a roller's centre can be and still touch a tooth [m]:
        the tip radius plus 1.05 roller radii (the 5 % covers the contact onset's
        regularization). Contact slots, their check and the meshing events read it."""
        return self.tip_diameter / 2 + REACH_MARGIN * self.roller_radius

    @property
    def seat_clearance(self) -> Array:
        """ri − d1/2 [m]: radial play of a roller centred in its seat (per gap where ri
        is per gap)."""
        return self.seating_radius - self.roller_radius

    def to_dxf(self, path) -> Path:
        """Write the whole sprocket's closed outline to ``path`` as exact DXF ARC entities
        in millimetres (axis at the origin, gap 0 on +x), for CAD/CNC. Returns the path."""
        return write_dxf(self.outline_arcs(), path)

    def save(self, path) -> Path:
        """Write the profile to ``path`` as human-readable JSON (every field; floats exact),
        to keep or share a design; ``jc.load_profile(path)`` reads it back equal leaf for
        leaf. Returns the path. Raises ``TypeError`` for a traced profile (inside ``jit``,
        ``grad`` or ``vmap``)."""
        return save_profile(self, path)
