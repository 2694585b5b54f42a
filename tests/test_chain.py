"""ChainSpec: the standard's numbers, derived masses against catalogue values, validation."""

import dataclasses
import math

import pytest

import jaxchain as jc

# ISO 606 table values (mm): p, d1, b1, d2, d3, h2 — typed from the standard.
ISO = {
    "06B": (9.525, 6.35, 5.72, 3.28, 3.33, 8.26),
    "08A": (12.70, 7.92, 7.85, 3.98, 4.00, 12.07),
    "08B": (12.70, 8.51, 7.75, 4.45, 4.50, 11.81),
    "10A": (15.875, 10.16, 9.40, 5.09, 5.12, 15.09),
    "12A": (19.05, 11.91, 12.57, 5.96, 5.98, 18.10),
    "16B": (25.40, 15.88, 17.02, 8.28, 8.33, 21.08),
}
# Typical catalogue mass per metre [kg/m] of single-strand chains (manufacturers' tables).
CATALOGUE_MASS = {"06B": 0.41, "08A": 0.62, "08B": 0.70, "10A": 1.02, "12A": 1.50, "16B": 2.70}


@pytest.mark.parametrize("name", sorted(ISO))
def test_iso606_dimensions(name):
    c = jc.ChainSpec.iso606(name)
    p, d1, b1, d2, d3, h2 = (v * 1e-3 for v in ISO[name])
    got = (c.pitch, c.roller_diameter, c.inner_width, c.pin_diameter, c.bush_bore, c.plate_height)
    for g, want in zip(got, (p, d1, b1, d2, d3, h2), strict=True):
        assert math.isclose(g, want, rel_tol=1e-12)
    assert math.isclose(c.pin_clearance, (d3 - d2) / 2, rel_tol=1e-12)


@pytest.mark.parametrize("name", sorted(ISO))
def test_derived_mass_close_to_catalogue(name):
    """Masses are derived from steel density and geometry (the standard gives none):
    they must land within 25 % of catalogue chains' mass per metre."""
    c = jc.ChainSpec.iso606(name)
    rel = c.mass_per_length / CATALOGUE_MASS[name] - 1
    assert abs(rel) < 0.25, f"{name}: derived {c.mass_per_length:.3f} kg/m ({rel:+.0%})"


def test_inertia_magnitudes_are_physical():
    """A link's polar inertia lies between that of its mass at the pin centres' radius
    without plates (lower bound for pins/bushes) and that of all its mass at p/2 + h2/2."""
    c = jc.ChainSpec.iso606("08B")
    for m, j in (
        (c.roller_link_mass, c.roller_link_inertia),
        (c.pin_link_mass, c.pin_link_inertia),
    ):
        assert 0.1 * m * (c.pitch / 2) ** 2 < j < m * (c.pitch / 2 + c.plate_height / 2) ** 2
    # roller: hollow cylinder between bore and OD
    r_o, r_i = c.roller_diameter / 2, c.roller_bore / 2
    assert c.roller_mass * r_i**2 < c.roller_inertia < c.roller_mass * r_o**2


def test_unknown_chain_lists_known():
    with pytest.raises(ValueError, match=r"unknown ISO 606 chain '99Z'.*08B.*16B"):
        jc.ChainSpec.iso606("99Z")


def test_lowercase_name_accepted():
    assert jc.ChainSpec.iso606("08b").name == "08B"


def test_direct_construction_validated():
    c = jc.ChainSpec.iso606("08B")
    fields = {f.name: getattr(c, f.name) for f in dataclasses.fields(c)}
    with pytest.raises(ValueError, match="pitch must be > 0"):
        jc.ChainSpec(**{**fields, "pitch": -1.0})
    with pytest.raises(ValueError, match="pin_diameter < bush_bore"):
        jc.ChainSpec(**{**fields, "pin_diameter": 5e-3})
    with pytest.raises(ValueError, match="roller_diameter < pitch"):
        jc.ChainSpec(**{**fields, "roller_diameter": 13e-3})
