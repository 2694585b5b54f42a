"""The HuntCrossley contact law: χ(e) = 3(1 − e)/2."""

from __future__ import annotations

import jax.numpy as jnp

from .base import AbstractHysteresisLaw

__all__ = ["HuntCrossley"]


class HuntCrossley(AbstractHysteresisLaw):
    """F = K·δᵣⁿ·(1 + χ·δ̇/v⁻) with χ = 3(1 − e)/2.

    Hunt & Crossley (1975) in the linearized form. Reproduces e within 0.01 for e ≥ 0.9;
    too little dissipation at low e (e = 0.5 gives e* ≈ 0.66).
    Fields and regularization: see :class:`AbstractHysteresisLaw`.
    """

    def damping_factor(self):
        e = jnp.asarray(self.restitution)
        return 1.5 * (1 - e)
