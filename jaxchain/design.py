"""Tooth-profile design: parameters in a box, smooth peak-force objectives.

space = jc.design.DesignSpace.iso606(chain, 18)        # ISO 606 limits, u ∈ ℝ⁴
profile = space.profile(u)                              # always inside the standard
peak = jc.design.soft_peak_force(scene, t1, temperature=50.0, dt=2e-6)
objective = jc.design.ProfileObjective(space, build, t1=..., dt=...)
value, grad, members = objective.value_and_grad(u)
"""

from ._design import (
    PARAMETERS as PARAMETERS,
    DesignSpace as DesignSpace,
    PeakForce as PeakForce,
    ProfileObjective as ProfileObjective,
    soft_peak_force as soft_peak_force,
    window_weight as window_weight,
)
