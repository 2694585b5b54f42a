"""jaxchain: differentiable roller-chain drive simulation in JAX.

Enable float64 yourself (the library never changes global JAX configuration)::

    import jax
    jax.config.update("jax_enable_x64", True)
"""

from . import (
    contact as contact,
    design as design,
    distributed as distributed,
    elements as elements,
    loads as loads,
    observers as observers,
    scenes as scenes,
)
from ._chain import ChainSpec as ChainSpec
from ._dynamics import (
    DriveState as DriveState,
    element_effects as element_effects,
    energy as energy,
    initial_state as initial_state,
    roller_kinematics as roller_kinematics,
    roller_normal_forces as roller_normal_forces,
    vector_field as vector_field,
)
from ._elements.anchors import Anchors as Anchors
from ._elements.pairs import (
    ClearanceJoints as ClearanceJoints,
    LinkSprings as LinkSprings,
    PairGroup as PairGroup,
)
from ._materials import STEEL as STEEL, Material as Material, effective_modulus as effective_modulus
from ._plots.drive import (
    animate as animate,
    plot_forces as plot_forces,
    plot_snapshot as plot_snapshot,
    plot_speed as plot_speed,
    plot_tensions as plot_tensions,
)
from ._plots.profiles import plot_profiles as plot_profiles, plot_sprocket as plot_sprocket
from ._profiles.base import AbstractProfile as AbstractProfile, AbstractShape as AbstractShape
from ._profiles.contact import (
    gap_contact as gap_contact,
    nearest_gap as nearest_gap,
    signed_distance as signed_distance,
)
from ._profiles.freeform import Flank as Flank, FreeformProfile as FreeformProfile
from ._profiles.io import load_profile as load_profile
from ._profiles.iso import (
    ProfileGeometry as ProfileGeometry,
    ToothProfile as ToothProfile,
    iso606_limits as iso606_limits,
)
from ._scene import Scene as Scene, Sprocket as Sprocket
from ._solve.adjoint import StepResidualsAdjoint as StepResidualsAdjoint
from ._solve.ensemble import (
    EnsembleSolution as EnsembleSolution,
    simulate_ensemble as simulate_ensemble,
)
from ._solve.options import DEFAULT_DT0 as DEFAULT_DT0, SolveOptions as SolveOptions
from ._solve.result import (
    Result as Result,
    SolveError as SolveError,
    result_messages as result_messages,
    result_names as result_names,
)
from ._solve.simulate import Solution as Solution, simulate as simulate
from ._statistics import (
    Engagements as Engagements,
    PeakComparison as PeakComparison,
    PeakStatistics as PeakStatistics,
    compare_peaks as compare_peaks,
    engagement_peaks as engagement_peaks,
    peak_statistics as peak_statistics,
)

__version__ = "0.1.0"

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractProfile",
    "AbstractShape",
    "Anchors",
    "ChainSpec",
    "ClearanceJoints",
    "DEFAULT_DT0",
    "DriveState",
    "Engagements",
    "EnsembleSolution",
    "Flank",
    "FreeformProfile",
    "LinkSprings",
    "Material",
    "PairGroup",
    "PeakComparison",
    "PeakStatistics",
    "ProfileGeometry",
    "Result",
    "STEEL",
    "Scene",
    "Solution",
    "SolveError",
    "SolveOptions",
    "Sprocket",
    "StepResidualsAdjoint",
    "ToothProfile",
    "animate",
    "compare_peaks",
    "contact",
    "design",
    "distributed",
    "effective_modulus",
    "element_effects",
    "elements",
    "energy",
    "engagement_peaks",
    "gap_contact",
    "initial_state",
    "iso606_limits",
    "load_profile",
    "loads",
    "nearest_gap",
    "observers",
    "peak_statistics",
    "plot_forces",
    "plot_profiles",
    "plot_snapshot",
    "plot_speed",
    "plot_sprocket",
    "plot_tensions",
    "result_messages",
    "result_names",
    "roller_kinematics",
    "roller_normal_forces",
    "scenes",
    "signed_distance",
    "simulate",
    "simulate_ensemble",
    "vector_field",
]
