"""Matplotlib helpers for tooth profiles."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from . import _checks as checks
from ._chain import ChainSpec, as_chain
from ._profile import ToothProfile

__all__ = ["plot_profiles"]


def plot_profiles(
    chain: ChainSpec,
    teeth: int,
    *,
    forms: Sequence[str] = ("min", "max"),
    extra: dict[str, ToothProfile] | None = None,
    ax=None,
    gaps: int = 1,
):
    """Draw ISO 606 tooth-gap forms of one sprocket, overlaid, with a roller seated.

    The outline is drawn in the gap frame (gap 0 centred on +x rotated to point up),
    in millimetres; ``gaps`` neighbouring gaps on each side are drawn too. ``extra``
    adds other profiles (e.g. an optimized one) under their labels. Returns the Axes.
    """
    import matplotlib.pyplot as plt

    chain = as_chain(chain)
    checks.integer("gaps", gaps, lo=0, hi=10)
    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    profiles = {f"ISO 606 {f} form": ToothProfile.iso606(chain, teeth, f) for f in forms}
    profiles.update(extra or {})
    up = np.array([[0.0, -1.0], [1.0, 0.0]])  # rotate +x to +y
    styles = ["-", "--", "-.", ":"]
    for i, (label, prof) in enumerate(profiles.items()):
        pts = np.concatenate([prof.outline(80, g) for g in range(-gaps, gaps + 1)])
        pts = pts @ up.T * 1e3
        (line,) = ax.plot(pts[:, 0], pts[:, 1], styles[i % 4], lw=1.4, label=label)
        # roller resting at the bottom of its seat
        geo = prof.geometry()
        c = np.asarray(geo.seat_centre)
        rr = float(prof.roller_radius)
        centre = c - np.array([float(prof.seating_radius) - rr, 0.0])
        t = np.linspace(0, 2 * math.pi, 120)
        roller = (centre + rr * np.stack([np.cos(t), np.sin(t)], -1)) @ up.T * 1e3
        ax.plot(roller[:, 0], roller[:, 1], styles[i % 4], color=line.get_color(), lw=0.8)
    prof = next(iter(profiles.values()))
    r = float(prof.pitch_radius) * 1e3
    t = np.linspace(-(gaps + 0.5), gaps + 0.5, 200) * 2 * math.pi / teeth + math.pi / 2
    ax.plot(r * np.cos(t), r * np.sin(t), color="0.6", lw=0.6, label="pitch circle")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"{chain.name}, z = {teeth}: ISO 606 tooth-gap forms")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=3, fontsize=8)
    return ax
