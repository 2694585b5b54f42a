"""What a design changes on a sprocket: its tooth profile and, optionally, its cushion
ring (see :class:`SprocketDesign`)."""

from __future__ import annotations

import equinox as eqx

from .._elements.cushion import CushionContacts, CushionRing
from .._profiles.base import AbstractProfile

__all__ = ["SprocketDesign", "place", "profile_of"]


class SprocketDesign(eqx.Module):
    """A sprocket's designed parts: its tooth profile and its cushion ring, as one design.

    Give it to :meth:`DesignSpace.select <jaxchain.design.DesignSpace.select>` as the
    template to design the tooth and the ring together, with dotted paths into either
    part: ``{"profile.seating_radius": (lo, hi), "cushion.radius": (lo, hi),
    "cushion.stiffness": (lo, hi)}``. :class:`~jaxchain.design.ProfileObjective` then
    hands the whole design to its ``build`` (which must put the ring on the designed
    sprocket: ``jc.scenes.engagement(..., profile=d.profile, cushion=d.cushion)``) and
    swaps both parts into the scene inside the differentiated function, so the gradient
    covers the ring's leaves too.

    Attributes:
        profile: the tooth profile (any :class:`~jaxchain.AbstractProfile`).
        cushion: the sprocket's :class:`~jaxchain.elements.CushionRing`, or None.
    """

    profile: AbstractProfile
    cushion: CushionRing | None = None

    def __check_init__(self):
        if not isinstance(self.profile, AbstractProfile):
            raise TypeError(
                "SprocketDesign.profile must be a tooth profile (jc.ToothProfile, "
                f"jc.FreeformProfile, ...), got {type(self.profile).__name__}"
            )
        if self.cushion is not None and not isinstance(self.cushion, CushionRing):
            raise TypeError(
                "SprocketDesign.cushion must be a jc.elements.CushionRing or None, got "
                f"{type(self.cushion).__name__}"
            )


def profile_of(design) -> AbstractProfile:
    """The tooth profile of a design (a profile, or a :class:`SprocketDesign`)."""
    return design.profile if isinstance(design, SprocketDesign) else design


def place(scene, design, sprocket: int = 0):
    """``scene`` with ``design`` on sprocket ``sprocket``: its profile, and its ring in
    place of that sprocket's ring (traceable; the ring must be there already, built with
    the scene, with as many faces).

    Raises:
        ValueError: a design with a ring on a scene without one on that sprocket, or a
            ring of another face count.
    """
    if not isinstance(design, SprocketDesign):
        return eqx.tree_at(lambda s: s.sprockets[sprocket].profile, scene, design)
    scene = eqx.tree_at(lambda s: s.sprockets[sprocket].profile, scene, design.profile)
    if design.cushion is None:
        return scene
    for i, el in enumerate(scene.elements):
        if isinstance(el, CushionContacts) and sprocket in el.sprockets:
            j = el.sprockets.index(sprocket)
            if el.rings[j].faces != design.cushion.faces:
                raise ValueError(
                    f"the design's cushion ring has {design.cushion.faces} face(s), the "
                    f"scene's ring on sprocket {sprocket} {el.rings[j].faces}: build the "
                    "scene with the design's ring"
                )
            return eqx.tree_at(lambda s, i=i, j=j: s.elements[i].rings[j], scene, design.cushion)
    raise ValueError(
        f"the design has a cushion ring, but the scene has none on sprocket {sprocket}: "
        "build it with the design's ring (cushion=design.cushion in the builder)"
    )
