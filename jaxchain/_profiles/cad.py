"""CAD export of a sprocket's outline: DXF ARC entities, millimetres (via ezdxf)."""

from __future__ import annotations

import math
from pathlib import Path

__all__ = ["write_dxf"]


def write_dxf(arcs: list[tuple], path: str | Path) -> Path:
    """Write a sprocket's closed outline, its ``arcs`` (``profile.outline_arcs()``), to
    ``path`` as DXF ARC entities in millimetres (layer ``SPROCKET``; the axis at the
    origin, gap 0 on +x). Returns the path."""
    import ezdxf

    path = Path(path)
    doc = ezdxf.new("R2010", setup=False)
    doc.units = ezdxf.units.MM
    doc.layers.add("SPROCKET")
    msp = doc.modelspace()
    for centre, radius, a0, a1 in arcs:
        msp.add_arc(
            (1e3 * centre[0], 1e3 * centre[1]),
            1e3 * radius,
            math.degrees(a0),
            math.degrees(a1),
            dxfattribs={"layer": "SPROCKET"},
        )
    doc.saveas(path)
    return path
