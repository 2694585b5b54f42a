"""Force elements: everything that acts on a drive's bodies, one protocol.

element = MyDamper(...)                       # a subclass of AbstractElement
scene = scene.add_elements(element)           # simulate, settle, design as usual
scene.elements                                # the drive's own parts, then the added

A subclass implements ``effect(t, y, scene, state) -> Effect`` (generalized forces on
the chain's bodies, torques on sprockets and tensioner arms, the rates of its own
states) and may add its stored ``energy``, its ``outputs`` (saved by ``simulate``), its
``max_stiffness`` (the statics' stable step) and ``n_states`` (states of its own).

An element that moves (a tensioner arm, an idler on a slide) declares coordinates of
its own: ``n_dofs``, ``dof_inertia``, ``dof_start`` and ``with_dof_start`` (where the
statics settled it). It reads them as ``state`` (an :class:`ElementState`) and drives
them through ``Effect.dof_force``; the equations of motion, the energy and the statics
carry them with the chain (``DriveState.dof``).
"""

from ._elements.anchors import Anchors as Anchors
from ._elements.base import (
    AbstractElement as AbstractElement,
    Effect as Effect,
    ElementState as ElementState,
)
from ._elements.cushion import (
    CushionContacts as CushionContacts,
    CushionRing as CushionRing,
)
from ._elements.gravity import Gravity as Gravity
from ._elements.joint_friction import JointFriction as JointFriction
from ._elements.pairs import (
    ClearanceJoints as ClearanceJoints,
    LinkSprings as LinkSprings,
    PairGroup as PairGroup,
)
from ._elements.rollers import RollerTeeth as RollerTeeth
from ._elements.shoes import Shoes as Shoes
from ._elements.spans import SpanGeometry as SpanGeometry, Spans as Spans
from ._elements.tensioners import Tensioners as Tensioners

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractElement",
    "Anchors",
    "ClearanceJoints",
    "CushionContacts",
    "CushionRing",
    "Effect",
    "ElementState",
    "Gravity",
    "JointFriction",
    "LinkSprings",
    "PairGroup",
    "RollerTeeth",
    "Shoes",
    "SpanGeometry",
    "Spans",
    "Tensioners",
]
