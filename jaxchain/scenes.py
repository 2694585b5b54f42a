"""Scene builders: a scene is data (bodies, force elements, sprockets, loads).

scene = jc.scenes.drive("08B", teeth=(18, 36), speed_rpm=1000, fidelity="lumped")
scene = jc.scenes.drive("08B", teeth=(18, 36, 27), centres=((0, 0), (0.3, 0.05), (0.15, 0.25)))
scene = jc.scenes.engagement("08B", teeth=18, tension=1000)
scene = jc.scenes.engagement("08B", teeth=18, fidelity=jc.scenes.Clearance())  # or "clearance"

or described as data first (sweeps are ``spec.replace(...)``):

spec = jc.scenes.DriveSpec.of("08B", teeth=(18, 36), speed_rpm=1000)
scene = spec.replace(speed_rpm=2000).build()
"""

from ._scenes.build import (
    BUSH_TOOTH_FRICTION as BUSH_TOOTH_FRICTION,
    CLEARANCE_JOINT_FRICTION as CLEARANCE_JOINT_FRICTION,
    JOINT_FRICTION as JOINT_FRICTION,
    default_tooth_friction as default_tooth_friction,
    joint_law as joint_law,
    link_stiffness as link_stiffness,
    roller_law as roller_law,
)
from ._scenes.fidelity import (
    AbstractFidelity as AbstractFidelity,
    Clearance as Clearance,
    Lumped as Lumped,
    SpanLevel as SpanLevel,
    as_fidelity as as_fidelity,
    default_joint_friction as default_joint_friction,
)
from ._scenes.layout import (
    LoopLayout as LoopLayout,
    closed_drive_layout as closed_drive_layout,
    strand_layout as strand_layout,
    transport_velocity as transport_velocity,
)
from ._scenes.loop import loop_layout as loop_layout
from ._scenes.model import ChainModel as ChainModel
from ._scenes.shoes import (
    POLYAMIDE as POLYAMIDE,
    SHOE_FRICTION as SHOE_FRICTION,
    Guide as Guide,
    Tensioner as Tensioner,
    shoe_law as shoe_law,
)
from ._scenes.spans import SpanShoe as SpanShoe, span_element as span_element
from ._scenes.spec import (
    DriveSpec as DriveSpec,
    SprocketSpec as SprocketSpec,
    StrandSpec as StrandSpec,
    drive as drive,
    engagement as engagement,
)
from ._scenes.statics import (
    equilibrate as equilibrate,
    resettle as resettle,
    statics_jacobian as statics_jacobian,
)
from ._solve.stack import stack as stack

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractFidelity",
    "BUSH_TOOTH_FRICTION",
    "CLEARANCE_JOINT_FRICTION",
    "ChainModel",
    "Clearance",
    "DriveSpec",
    "Guide",
    "JOINT_FRICTION",
    "LoopLayout",
    "Lumped",
    "POLYAMIDE",
    "SHOE_FRICTION",
    "SpanLevel",
    "SpanShoe",
    "SprocketSpec",
    "StrandSpec",
    "Tensioner",
    "as_fidelity",
    "closed_drive_layout",
    "default_joint_friction",
    "default_tooth_friction",
    "drive",
    "engagement",
    "equilibrate",
    "joint_law",
    "link_stiffness",
    "loop_layout",
    "resettle",
    "roller_law",
    "shoe_law",
    "span_element",
    "stack",
    "statics_jacobian",
    "strand_layout",
    "transport_velocity",
]
