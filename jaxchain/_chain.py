"""ISO 606 roller and bush chains: dimensions from the standard, masses and inertias
derived."""

from __future__ import annotations

import math
from typing import ClassVar, Literal

import equinox as eqx
import numpy as np

from ._checks import fields
from ._materials import STEEL, Material
from ._numerics import is_concrete

__all__ = ["ChainSpec", "as_chain"]

# ISO 606:2015 table 1 (single strand), millimetres and kN:
#   pitch p, roller diameter d1 (max), inner width b1 (min), pin diameter d2 (max),
#   bush bore d3 (min), inner plate depth h2 (max), tensile strength Fu (min).
# The plate thickness is NOT in ISO 606; the values are typical of catalogue chains.
_ISO606 = {
    #        p       d1     b1     d2    d3     h2    Fu    plate t
    "05B": (8.000, 5.00, 3.00, 2.31, 2.36, 7.11, 4.4, 0.80),
    "06B": (9.525, 6.35, 5.72, 3.28, 3.33, 8.26, 8.9, 1.30),
    "08A": (12.70, 7.92, 7.85, 3.98, 4.00, 12.07, 13.9, 1.50),
    "08B": (12.70, 8.51, 7.75, 4.45, 4.50, 11.81, 17.8, 1.60),
    "10A": (15.875, 10.16, 9.40, 5.09, 5.12, 15.09, 21.8, 2.03),
    "10B": (15.875, 10.16, 9.65, 5.08, 5.13, 14.73, 22.2, 1.70),
    "12A": (19.05, 11.91, 12.57, 5.96, 5.98, 18.10, 31.3, 2.42),
    "12B": (19.05, 12.07, 11.68, 5.72, 5.77, 16.13, 28.9, 1.85),
    "16A": (25.40, 15.88, 15.75, 7.94, 7.96, 24.13, 55.6, 3.25),
    "16B": (25.40, 15.88, 17.02, 8.28, 8.33, 21.08, 60.0, 3.10),
}

# ISO 606:2015 table 1, the bush chains (no roller; d1 is the bush diameter), same
# columns; they are the ASME B29.1 chains 25 and 35. Cross-checked against ASME B29.1's
# general chain dimensions (inch), e.g. engineersedge.com "Roller Chain Dimensions per
# ASME/ANSI B29.1M" and amesweb.info "Roller Chain Dimensions Table": bushing diameter
# 0.130 / 0.200 in (3.30 / 5.08 mm), width 0.125 / 0.188 in (b1 min 3.10 / 4.68 mm), pin
# 0.0905 / 0.141 in nominal (max +0.0005 in: 2.31 / 3.60 mm), bush hole pin + 0.0015 in
# (2.34 / 3.62 mm), roller link plate height 0.95p (6.02 / 9.05 mm), tensile strength
# 780 / 1760 lb (3.5 / 7.9 kN). Plate thickness: B29.1's 0.030 / 0.050 in.
_ISO606_BUSH = {
    #        p      d1    b1    d2    d3    h2    Fu   plate t
    "04C": (6.35, 3.30, 3.10, 2.31, 2.34, 6.02, 3.5, 0.76),
    "06C": (9.525, 5.08, 4.68, 3.60, 3.62, 9.05, 7.9, 1.27),
}
_KNOWN = (*_ISO606_BUSH, *_ISO606)


def _stadium_inertia(length: float, height: float) -> tuple[float, float]:
    """Area and polar second moment (about its centre) of a stadium: a length × height
    rectangle with semicircular ends of diameter ``height`` (per unit thickness, unit density)."""
    a = height / 2
    area_rect = length * height
    j_rect = area_rect * (length**2 + height**2) / 12
    area_half = math.pi * a**2 / 2
    e = 4 * a / (3 * math.pi)  # centroid of a half disc from its flat side
    j_half_cg = area_half * a**2 / 2 - area_half * e**2
    j_half = j_half_cg + area_half * (length / 2 + e) ** 2
    return area_rect + 2 * area_half, j_rect + 2 * j_half


class ChainSpec(eqx.Module):
    """Dimensions and mass properties of a single-strand roller or bush chain. SI units.

    Build one from the standard with :meth:`iso606` (roller chains such as ``"08B"``,
    bush chains ``"04C"`` and ``"06C"``), a bush chain of your own with
    :meth:`bush_chain`; direct construction takes every field as a keyword and is
    validated.

    A *bush chain* (``kind="bush"``) has no roller: the bush, pressed into the inner
    link's plates, engages the teeth. Its ``roller_diameter`` is the bush diameter d1
    (equal to ``bush_diameter``; the ISO 606 tooth forms take it as d1), ``roller_bore``
    equals ``bush_diameter`` (no bush/roller clearance), and ``roller_mass`` and
    ``roller_inertia`` are 0: the bushes' mass is in the inner (``roller_link``) link's.

    Attributes:
        name: designation, e.g. ``"08B"`` (static).
        pitch: p [m].
        roller_diameter: d1, the standard's maximum [m]; a bush chain's bush diameter.
        inner_width: b1, width between inner plates, the standard's minimum [m].
        pin_diameter: d2, the standard's maximum [m].
        bush_bore: d3, the standard's minimum [m].
        bush_diameter: bush outer diameter [m]. Not in ISO 606 for a roller chain: taken
            as d3 + 0.45·(d1 − d3), typical of catalogue chains; a bush chain's is d1.
        roller_bore: roller inner diameter [m] = bush_diameter + 2·roller_clearance (a
            bush chain: bush_diameter).
        plate_height: h2, inner plate depth, the standard's maximum [m] (used for both
            inner and outer plates).
        plate_thickness: [m]. Not in ISO 606: typical catalogue value.
        tensile_strength: the standard's minimum [N].
        roller_link_mass, pin_link_mass, roller_mass: [kg] (see :meth:`iso606`); the
            roller link is the inner link (plates and bushes), a bush chain's roller_mass 0.
        roller_link_inertia, pin_link_inertia, roller_inertia: polar moments about the
            body's own centre, out of plane [kg·m²] (a bush chain's roller_inertia 0).
        kind: ``"roller"`` or ``"bush"`` (static; default ``"roller"``).
    """

    name: str = eqx.field(static=True)
    pitch: float
    roller_diameter: float
    inner_width: float
    pin_diameter: float
    bush_bore: float
    bush_diameter: float
    roller_bore: float
    plate_height: float
    plate_thickness: float
    tensile_strength: float
    roller_link_mass: float
    pin_link_mass: float
    roller_mass: float
    roller_link_inertia: float
    pin_link_inertia: float
    roller_inertia: float
    kind: Literal["roller", "bush"] = eqx.field(static=True, default="roller")

    known: ClassVar[tuple[str, ...]] = _KNOWN

    def __check_init__(self):
        if self.kind not in ("roller", "bush"):
            raise ValueError(
                f"ChainSpec.kind must be 'roller' (rollers on the bushes engage the teeth) or "
                f"'bush' (no roller: the bushes engage), got {self.kind!r}"
            )
        if not is_concrete(self):
            return
        positive = [
            "pitch", "roller_diameter", "inner_width", "pin_diameter", "bush_bore",
            "bush_diameter", "roller_bore", "plate_height", "plate_thickness",
            "tensile_strength", "roller_link_mass", "pin_link_mass", "roller_mass",
            "roller_link_inertia", "pin_link_inertia", "roller_inertia",
        ]  # fmt: skip
        roller_only = ("roller_mass", "roller_inertia")
        rules = [
            (f, lambda v: v > 0, "> 0")
            if self.has_roller or f not in roller_only
            else (f, lambda v: v == 0, "0 in a bush chain (it has no roller)")
            for f in positive
        ]
        fields(self, rules)
        shaped = {f: np.shape(getattr(self, f)) for f in positive if np.shape(getattr(self, f))}
        if shaped:
            raise TypeError(f"ChainSpec fields must be scalars (one chain), got shapes {shaped}")
        if not self.has_roller:
            for f in ("roller_diameter", "roller_bore"):
                if getattr(self, f) != self.bush_diameter:
                    raise ValueError(
                        f"ChainSpec.{f} must equal bush_diameter ({self.bush_diameter} m) in a "
                        f"bush chain (no roller: d1 is the bush diameter), got "
                        f"{getattr(self, f)} m; ChainSpec.bush_chain(...) builds one"
                    )
        order = [
            ("pin_diameter", "bush_bore"),
            ("bush_bore", "bush_diameter"),
            *([("bush_diameter", "roller_bore"), ("roller_bore", "roller_diameter")]
              if self.has_roller else []),
            ("roller_diameter", "pitch"),
            ("roller_diameter", "plate_height"),
        ]  # fmt: skip
        for a, b in order:
            if not getattr(self, a) < getattr(self, b):
                raise ValueError(
                    f"ChainSpec needs {a} < {b}, got {getattr(self, a)} >= {getattr(self, b)} m"
                )

    # ------------------------------------------------------------------ derived
    @property
    def has_roller(self) -> bool:
        """Whether rollers engage the teeth (``kind == "roller"``); False for a bush chain."""
        return self.kind == "roller"

    @property
    def roller_radius(self):
        """d1 / 2 [m]."""
        return self.roller_diameter / 2

    @property
    def pin_clearance(self):
        """Radial clearance of the pin in the bush, (d3 − d2)/2 [m]."""
        return (self.bush_bore - self.pin_diameter) / 2

    @property
    def roller_clearance(self):
        """Radial clearance of the roller on the bush, (roller_bore − bush_diameter)/2 [m]
        (0 in a bush chain)."""
        return (self.roller_bore - self.bush_diameter) / 2

    @property
    def mass_per_length(self):
        """Mass per metre of chain [kg/m]: one roller link, one pin link, two rollers per 2p."""
        return (self.roller_link_mass + self.pin_link_mass + 2 * self.roller_mass) / (
            2 * self.pitch
        )

    # ------------------------------------------------------------------ factory
    @classmethod
    def iso606(cls, name: str, *, material: Material = STEEL) -> ChainSpec:
        """The ISO 606 chain ``name``: a roller chain (``"05B"`` … ``"16B"``, ``"08A"`` …
        ``"16A"``) or a bush chain (``"04C"``, ``"06C"``: ANSI 25 and 35, no roller).

        Dimensions p, d1, b1, d2, d3, h2 and the tensile strength are the standard's.
        ISO 606 gives no masses; they are derived from ``material.density`` and the
        geometry: plates as stadiums (p × h2 with semicircular ends) less their holes,
        pins/bushes/rollers as (hollow) cylinders. Lengths: bush b1 + 2t, pin b1 + 4t + 1.5t
        (heads), roller 0.95·b1. Plate thickness and a roller chain's bush diameter are
        typical catalogue values, not the standard's (a bush chain's bush diameter is d1).
        The derived mass per metre agrees with catalogue values to within about 25 % (see
        tests/test_chain.py and tests/test_bush_chain.py).

        Raises:
            ValueError: unknown designation (the message lists the known ones).
        """
        if not isinstance(name, str):
            raise TypeError(
                f"ChainSpec.iso606: name must be an ISO 606 designation such as '08B', got "
                f"{type(name).__name__} {name!r}; known chains: {', '.join(_KNOWN)}"
            )
        _check_material("ChainSpec.iso606", material)
        key = name.strip().upper()
        if key in _ISO606_BUSH:
            p, d1, b1, d2, d3, h2, fu, t = _ISO606_BUSH[key]
            kind = "bush"
        elif key in _ISO606:
            p, d1, b1, d2, d3, h2, fu, t = _ISO606[key]
            kind = "roller"
        else:
            raise ValueError(f"unknown ISO 606 chain {name!r}; known chains: {', '.join(_KNOWN)}")
        mm = 1e-3
        p, d1, b1, d2, d3, h2, t = (v * mm for v in (p, d1, b1, d2, d3, h2, t))
        return _derived(cls, key, kind, p, d1, b1, d2, d3, h2, fu * 1e3, t, material)

    @classmethod
    def bush_chain(
        cls,
        *,
        pitch: float,
        bush_diameter: float,
        inner_width: float,
        pin_diameter: float,
        bush_bore: float,
        plate_height: float,
        plate_thickness: float,
        tensile_strength: float,
        name: str = "custom bush chain",
        material: Material = STEEL,
    ) -> ChainSpec:
        """A bush chain of your own (no roller: its bushes engage the teeth), every
        length in metres, ``tensile_strength`` in newtons. Masses and inertias are
        derived as :meth:`iso606` derives them: inner links of two plates (holes of
        ``bush_diameter``) and two bushes (``bush_diameter`` over ``bush_bore``, b1 + 2t
        long), pin links of two plates and two pins; no roller. For other masses, build
        one with ``dataclasses.replace`` or construct ``ChainSpec(..., kind="bush")``.

        >>> chain = jc.ChainSpec.bush_chain(pitch=8e-3, bush_diameter=4.5e-3,
        ...     inner_width=4e-3, pin_diameter=2.8e-3, bush_bore=2.85e-3,
        ...     plate_height=7.5e-3, plate_thickness=1e-3, tensile_strength=6e3)
        """
        from . import _checks as checks

        _check_material("ChainSpec.bush_chain", material)
        if not isinstance(name, str):
            raise TypeError(f"ChainSpec.bush_chain: name must be a str, got {name!r}")
        dims = {
            "pitch": pitch, "bush_diameter": bush_diameter, "inner_width": inner_width,
            "pin_diameter": pin_diameter, "bush_bore": bush_bore,
            "plate_height": plate_height, "plate_thickness": plate_thickness,
        }  # fmt: skip
        got = {k: checks.real(k, v, lo=0.0, lo_open=True, unit="m") for k, v in dims.items()}
        fu = checks.real("tensile_strength", tensile_strength, lo=0.0, lo_open=True, unit="N")
        return _derived(
            cls, name, "bush", got["pitch"], got["bush_diameter"], got["inner_width"],
            got["pin_diameter"], got["bush_bore"], got["plate_height"], fu,
            got["plate_thickness"], material,
        )  # fmt: skip


def _check_material(where: str, material) -> None:
    if not isinstance(material, Material):
        raise TypeError(
            f"{where}: material must be a jc.Material, got {type(material).__name__} {material!r}"
        )


def _derived(cls, name, kind, p, d1, b1, d2, d3, h2, fu, t, material) -> ChainSpec:
    """A chain of these dimensions [m] and tensile strength ``fu`` [N], masses and
    inertias derived from ``material`` (:meth:`ChainSpec.iso606`). A roller chain's bush
    diameter is the catalogue-typical d3 + 0.45·(d1 − d3), its roller 0.95·b1 long on a
    radial clearance of 0.005·d1; a bush chain's bush is d1 and it has no roller."""
    rho = material.density
    if kind == "roller":
        d_bush = d3 + 0.45 * (d1 - d3)
        roller_clearance = 0.005 * d1
        d_rbore = d_bush + 2 * roller_clearance
    else:
        d_bush = d_rbore = d1

    area, j = _stadium_inertia(p, h2)

    def plate(hole_d):
        hole_a = math.pi * hole_d**2 / 4
        m = rho * t * (area - 2 * hole_a)
        jj = rho * t * (j - 2 * (hole_a * hole_d**2 / 8 + hole_a * (p / 2) ** 2))
        return m, jj

    def tube(d_out, d_in, length):
        m = rho * length * math.pi * (d_out**2 - d_in**2) / 4
        return m, m * (d_out**2 + d_in**2) / 8

    m_ip, j_ip = plate(d_bush)
    m_op, j_op = plate(d2)
    m_b, j_b = tube(d_bush, d3, b1 + 2 * t)
    m_p, j_p = tube(d2, 0.0, b1 + 5.5 * t)
    m_r, j_r = tube(d1, d_rbore, 0.95 * b1) if kind == "roller" else (0.0, 0.0)
    offset = (p / 2) ** 2
    return cls(
        name=name,
        pitch=p,
        roller_diameter=d1,
        inner_width=b1,
        pin_diameter=d2,
        bush_bore=d3,
        bush_diameter=d_bush,
        roller_bore=d_rbore,
        plate_height=h2,
        plate_thickness=t,
        tensile_strength=fu,
        roller_link_mass=2 * m_ip + 2 * m_b,
        pin_link_mass=2 * m_op + 2 * m_p,
        roller_mass=m_r,
        roller_link_inertia=2 * j_ip + 2 * (j_b + m_b * offset),
        pin_link_inertia=2 * j_op + 2 * (j_p + m_p * offset),
        roller_inertia=j_r,
        kind=kind,
    )


def as_chain(chain: ChainSpec | str) -> ChainSpec:
    """A :class:`ChainSpec` from itself or an ISO 606 designation ("08B"); ``TypeError``
    for anything else."""
    if isinstance(chain, str):
        return ChainSpec.iso606(chain)
    if not isinstance(chain, ChainSpec):
        raise TypeError(
            "chain must be an ISO 606 designation such as '08B' or a jaxchain ChainSpec, "
            f"got {type(chain).__name__} {chain!r}"
        )
    return chain
