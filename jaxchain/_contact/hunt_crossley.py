"""The HuntCrossley contact law: χ(e) = 3(1 − e)/2."""

from __future__ import annotations

from .base import AbstractPointLaw

__all__ = ["HuntCrossley"]


class HuntCrossley(AbstractPointLaw):
    """F = K·δᵣⁿ·(1 + χ·δ̇/v⁻) with χ = 3(1 − e)/2.

    Hunt & Crossley (1975) in the linearized form. Reproduces e within 0.01 for e ≥ 0.9;
    too little dissipation at low e (e = 0.5 gives e* ≈ 0.66).
    Fields and regularization: see :class:`AbstractPointLaw`.
    """

    @staticmethod
    def chi(e):
        return 1.5 * (1 - e)
