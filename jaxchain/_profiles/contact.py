"""Contact of a roller with its nearest tooth gap, read in the tooth-fixed frame, for any
sprocket kind: the kind's contact shape gives the signed distance from the roller centre
to the tooth material (exact for the ISO and free-form kinds: :mod:`.iso_shape`,
:mod:`.freeform_shape`), and

    depth  = roller radius − signed distance   (> 0: overlap)
    normal = ∂(signed distance)/∂(point)       (unit, pushes the roller out of the tooth)

Both are continuous in the point and the profile's leaves everywhere, with finite
gradients. The sprockets of one drive are stacked into one vmapped contact
(:func:`gap_shapes`).
"""

from __future__ import annotations

from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._numerics import stack
from .base import AbstractProfile, AbstractShape
from .freeform import FreeformProfile, stack_shapes
from .iso import ToothProfile

__all__ = ["gap_contact", "signed_distance", "nearest_gap", "gap_shapes", "prepare_shapes"]


def gap_shapes(profiles: Sequence[AbstractProfile]):
    """The sprockets' contact shapes, stacked for one vmapped contact where they can be.

    Shapes of one kind and leaf shapes stack as they are (ISO-type profiles of any tooth
    counts, free-form profiles alike in K and per-gap leaves). Otherwise every profile is
    read in its free-form form with the largest K (an ISO flank split into arcs of its own
    curvature is the same outline), per-gap leaves padded to the largest tooth count. A
    kind without a free-form form leaves a tuple of shapes, read one by one."""
    shapes = [p.contact_shape() for p in profiles]
    if _stackable(shapes):
        return jax.tree_util.tree_map(lambda *xs: stack(xs), *shapes)
    try:
        arcs = max(p.arcs for p in profiles)
        return stack_shapes([p.freeform(arcs) for p in profiles])
    except TypeError:
        return tuple(shapes)


def _stackable(shapes) -> bool:
    """One pytree structure and the same leaf shapes in every shape."""
    first = jax.tree_util.tree_structure(shapes[0])
    if any(jax.tree_util.tree_structure(s) != first for s in shapes[1:]):
        return False
    leaves = [[np.shape(x) for x in jax.tree_util.tree_leaves(s)] for s in shapes]
    return all(x == leaves[0] for x in leaves[1:])


def prepare_shapes(shapes):
    """:func:`gap_shapes` output with each shape's :meth:`~AbstractShape.prepared` form."""
    if isinstance(shapes, tuple):
        return tuple(s.prepared() for s in shapes)
    return jax.vmap(lambda s: s.prepared())(shapes)


def _shape(profile, caller: str) -> AbstractShape:
    """The contact shape of ``profile`` (a profile of any kind, or a shape)."""
    if isinstance(profile, AbstractShape):
        return profile
    if not isinstance(profile, AbstractProfile):
        raise TypeError(
            f"{caller}: profile must be a jc.ToothProfile, jc.FreeformProfile or another "
            f"jc.AbstractProfile, got {type(profile).__name__} {profile!r}"
        )
    try:
        return profile.contact_shape()
    except ValueError as e:
        raise ValueError(f"{caller}: {e}") from None


def _point(point, caller: str) -> Array:
    """``point`` as a float array of shape (2,), or ``ValueError`` saying how to batch."""
    point = jnp.asarray(point)
    if point.shape != (2,):
        batch = point.ndim > 1 and point.shape[-1] == 2
        raise ValueError(
            f"{caller}: point must be one roller centre (x, y) of shape (2,), got shape "
            f"{point.shape}"
            + (
                f"; for many points use jax.vmap: jax.vmap(lambda x: jc.{caller}(profile, "
                "x))(points)"
                if batch
                else ""
            )
        )
    return point if jnp.issubdtype(point.dtype, jnp.floating) else point.astype(float)


def nearest_gap(profile: ToothProfile | FreeformProfile, point: Float[Array, 2]) -> Array:
    """Index k (integer array, in [0, z)) of the tooth gap nearest to ``point`` (sprocket
    frame); 0 for a non-finite point (an index has no NaN: the distance it feeds is NaN).
    For a free-form profile: the gap whose half pitch holds the point's polar angle."""
    point = _point(point, "nearest_gap")
    return _shape(profile, "nearest_gap").nearest_gap(point)


def signed_distance(
    profile: ToothProfile | FreeformProfile, point: Float[Array, 2]
) -> tuple[Float[Array, ""], Float[Array, 2]]:
    """Signed distance [m] from ``point`` (sprocket frame) to the tooth material, positive in
    the gap, and its gradient (unit normal, sprocket frame); NaN (both) for a NaN point."""
    point = _point(point, "signed_distance")
    return _shape(profile, "signed_distance").signed_distance(point)


def gap_contact(
    profile: ToothProfile | FreeformProfile, point: Float[Array, 2] | ArrayLike
) -> tuple[Float[Array, ""], Float[Array, 2]]:
    """Contact of a roller centred at ``point`` with its nearest tooth gap.

    Args:
        profile: the sprocket's tooth profile (any kind), or its contact shape.
        point: roller centre (2,) in the sprocket frame [m].

    Returns:
        ``(depth, normal)``: depth [m] = roller radius − signed distance from the centre to
        the tooth (> 0: overlap); normal (2,), unit, sprocket frame, pushing the roller out
        of the tooth (the gradient of the signed distance, so ∂depth/∂point = −normal).

    Defined, finite and continuous for any point in the plane; differentiable in
    ``point`` and in the profile's array leaves; jit- and vmap-able (vmap over points, or
    over profiles built with the same ``teeth``, or over a :class:`GapShape` stack).
    """
    shape, point = _shape(profile, "gap_contact"), _point(point, "gap_contact")
    sd, normal = shape.signed_distance(point)
    return shape.roller_radius - sd, normal
