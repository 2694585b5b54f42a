"""Tooth-profile design: parameters in a box, smooth objectives computed inside the solve.

space = jc.design.DesignSpace.iso606(chain, 18)        # ISO 606 limits, u ∈ ℝ⁴
space = jc.design.DesignSpace.select(profile, {"seating_radius": (lo, hi), ...})  # any leaves
profile = space.profile(u)                              # always inside the box
design = jc.design.SprocketDesign(profile, jc.elements.CushionRing(radius=30.3e-3))
space = jc.design.DesignSpace.select(design, {"profile.seating_radius": (lo, hi),
                                              "cushion.radius": (r_lo, r_hi)})  # tooth + ring
peak = jc.design.soft_peak_force(scene, t1, temperature=50.0, dt=2e-6)
noise = jc.design.observe(scene, t1, jc.observers.BandLevel.mesh_band(18, 0.2, 2.2))
objective = jc.design.ProfileObjective(space, build, t1=..., dt=...)      # soft peak force
objective = jc.design.ProfileObjective(space, build, t1=..., objective=band, combine="max")
objective = jc.design.ProfileObjective(..., combine=jc.design.SoftMax(0.5))  # worst, softly
value, grad, members = objective.value_and_grad(u)
check = jc.design.remeasure([build(profile) for build in members], t1, t_start=t0)  # tight
sample = jc.design.engagement_sample(strand)            # a strand's per-engagement peaks
"""

from ._design.objective import (
    AbstractReduction as AbstractReduction,
    Mean as Mean,
    Observed as Observed,
    PeakForce as PeakForce,
    Penalized as Penalized,
    ProfileObjective as ProfileObjective,
    SoftMax as SoftMax,
    Worst as Worst,
    observe as observe,
    soft_peak_force as soft_peak_force,
    window_weight as window_weight,
)
from ._design.remeasure import (
    engagement_sample as engagement_sample,
    remeasure as remeasure,
    second_law as second_law,
    sharp_peak as sharp_peak,
    solve_each as solve_each,
    solve_threads as solve_threads,
)
from ._design.space import PARAMETERS as PARAMETERS, DesignSpace as DesignSpace
from ._design.sprocket import SprocketDesign as SprocketDesign, profile_of as profile_of

#: the public names (what the API reference and ``import *`` show)
__all__ = [
    "AbstractReduction",
    "DesignSpace",
    "Mean",
    "Observed",
    "PARAMETERS",
    "PeakForce",
    "Penalized",
    "ProfileObjective",
    "SoftMax",
    "SprocketDesign",
    "Worst",
    "engagement_sample",
    "observe",
    "profile_of",
    "remeasure",
    "second_law",
    "sharp_peak",
    "soft_peak_force",
    "solve_each",
    "solve_threads",
    "window_weight",
]
