"""Materials: elastic constants and density."""

from __future__ import annotations

import equinox as eqx

__all__ = ["Material", "STEEL", "effective_modulus"]


class Material(eqx.Module):
    """An isotropic elastic material.

    Attributes:
        youngs_modulus: Young's modulus E [Pa].
        poisson_ratio: Poisson's ratio ν [-].
        density: mass density ρ [kg/m³].
    """

    youngs_modulus: float = 206e9
    poisson_ratio: float = 0.3
    density: float = 7850.0

    def __check_init__(self):
        from ._numerics import is_concrete

        if not is_concrete(self):
            return
        from ._checks import fields

        fields(
            self,
            [
                ("youngs_modulus", lambda v: v > 0, "> 0 Pa"),
                ("poisson_ratio", lambda v: (v > -1.0) & (v < 0.5), "in (-1, 0.5)"),
                ("density", lambda v: v > 0, "> 0 kg/m³"),
            ],
        )


#: Through-hardened chain/sprocket steel (E = 206 GPa, ν = 0.3, ρ = 7850 kg/m³).
STEEL = Material()


def effective_modulus(a: Material, b: Material):
    """Contact modulus E* with 1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂ [Pa]."""
    for name, m in (("a", a), ("b", b)):
        if not isinstance(m, Material):
            raise TypeError(
                f"effective_modulus: {name} must be a jc.Material, got {type(m).__name__} {m!r}"
            )
    return 1.0 / (
        (1 - a.poisson_ratio**2) / a.youngs_modulus + (1 - b.poisson_ratio**2) / b.youngs_modulus
    )
