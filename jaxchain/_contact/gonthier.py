"""The Gonthier contact law: χ(e) = (1 − e²)/e."""

from __future__ import annotations

from .base import AbstractPointLaw

__all__ = ["Gonthier"]


class Gonthier(AbstractPointLaw):
    """F = K·δᵣⁿ·(1 + χ·δ̇/v⁻) with χ = (1 − e²)/e.

    Gonthier et al. (2004). Best at low e: within 0.0053 of e for e ≤ 0.42 and 0.013
    for e ≤ 0.5; too dissipative at high e (worst 0.032 low, e = 0.8 gives e* ≈ 0.77).
    Fields and regularization: see :class:`AbstractPointLaw`.
    """

    @staticmethod
    def chi(e):
        return (1 - e**2) / e
