"""The LankaraniNikravesh contact law: χ(e) = 3(1 − e²)/4."""

from __future__ import annotations

from .base import AbstractPointLaw

__all__ = ["LankaraniNikravesh"]


class LankaraniNikravesh(AbstractPointLaw):
    """F = K·δᵣⁿ·(1 + χ·δ̇/v⁻) with χ = 3(1 − e²)/4.

    Lankarani & Nikravesh (1990). Derived for e near 1; reproduces e within 0.015 for e
    ≥ 0.9 and dissipates far too little below (e = 0.5 gives e* ≈ 0.73).
    Fields and regularization: see :class:`AbstractPointLaw`.
    """

    @staticmethod
    def chi(e):
        return 0.75 * (1 - e**2)
