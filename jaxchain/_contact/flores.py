"""The Flores contact law: χ(e) = 8(1 − e)/(5e)."""

from __future__ import annotations

from .base import AbstractPointLaw

__all__ = ["Flores"]


class Flores(AbstractPointLaw):
    """F = K·δᵣⁿ·(1 + χ·δ̇/v⁻) with χ = 8(1 − e)/(5e).

    Flores et al. (2011). Usable over the whole range of e, always slightly too
    dissipative: within 0.03 of e for e ≥ 0.5, worst 0.045 low at e ≈ 0.24
    (e = 0.3 gives e* ≈ 0.256).
    Fields and regularization: see :class:`AbstractPointLaw`.
    """

    @staticmethod
    def chi(e):
        return 1.6 * (1 - e) / e
