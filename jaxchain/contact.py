"""Contact force laws: normal (hysteresis-damped, conformal cylinders), friction, oil film.

law = jc.contact.LankaraniNikravesh(stiffness=K, exponent=1.5, restitution=e)
f = law.normal_force(depth, depth_rate, impact_speed)
"""

from ._contact.base import (
    AbstractContactLaw as AbstractContactLaw,
    AbstractHysteresisLaw as AbstractHysteresisLaw,
    hysteresis_restitution as hysteresis_restitution,
)
from ._contact.dahl import DahlFriction as DahlFriction
from ._contact.film_base import AbstractFilmLaw as AbstractFilmLaw
from ._contact.flores import Flores as Flores
from ._contact.friction import CoulombFriction as CoulombFriction
from ._contact.friction_base import AbstractFrictionLaw as AbstractFrictionLaw
from ._contact.gonthier import Gonthier as Gonthier
from ._contact.hunt_crossley import HuntCrossley as HuntCrossley
from ._contact.johnson import (
    JohnsonCylinder as JohnsonCylinder,
    johnson_dimensionless_force as johnson_dimensionless_force,
)
from ._contact.lankarani_nikravesh import LankaraniNikravesh as LankaraniNikravesh
from ._contact.oil_film import OilFilm as OilFilm
from ._contact.stiffness import (
    effective_radius as effective_radius,
    hertz_stiffness as hertz_stiffness,
)

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractContactLaw",
    "AbstractFilmLaw",
    "AbstractFrictionLaw",
    "AbstractHysteresisLaw",
    "CoulombFriction",
    "DahlFriction",
    "Flores",
    "Gonthier",
    "HuntCrossley",
    "JohnsonCylinder",
    "LankaraniNikravesh",
    "OilFilm",
    "effective_radius",
    "hertz_stiffness",
    "hysteresis_restitution",
    "johnson_dimensionless_force",
]
