"""Matplotlib helpers for tooth profiles."""

from __future__ import annotations

import math
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .._chain import ChainSpec, as_chain
from .._profiles.contact import signed_distance
from .._profiles.freeform import FreeformProfile
from .._profiles.iso import ToothProfile

__all__ = ["plot_profiles", "plot_sprocket"]


def _seated_roller(prof, gap: int = 0) -> np.ndarray:
    """Centre (sprocket frame) of a roller resting on the bottom of gap ``gap``'s seat."""
    z = prof.teeth
    full = lambda x: float(np.broadcast_to(np.asarray(x, dtype=float), (z,))[gap % z])  # noqa: E731
    off = full(getattr(prof, "seat_offset", 0.0))
    phase = full(getattr(prof, "phase", 0.0))
    rad = float(prof.pitch_radius) + off - (full(prof.seating_radius) - float(prof.roller_radius))
    ang = 2 * math.pi * gap / z + phase
    return rad * np.array([math.cos(ang), math.sin(ang)])


def _gap_outline(prof, n: int, gap: int) -> np.ndarray:
    return prof.outline(n, gap)


def plot_profiles(
    chain: ChainSpec,
    teeth: int,
    *,
    forms: Sequence[str] = ("min", "max"),
    extra: dict[str, ToothProfile | FreeformProfile] | None = None,
    ax=None,
    gaps: int = 1,
    band: bool = True,
):
    """Draw ISO 606 tooth-gap forms of one sprocket, overlaid, with a roller seated.

    The outline is drawn in the gap frame (gap 0 centred on +x rotated to point up),
    in millimetres; ``gaps`` neighbouring gaps on each side are drawn too. ``extra``
    adds other profiles (e.g. an optimized or free-form one, per-gap patterns drawn gap
    by gap) under their labels. ``band`` shades the region between the ISO minimum and
    maximum forms. Returns the Axes.
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
    if band:
        lo, hi = (
            np.concatenate([ToothProfile.iso606(chain, teeth, f).outline(80, g)
                            for g in range(-gaps, gaps + 1)]) @ up.T * 1e3
            for f in ("min", "max")
        )  # fmt: skip
        ax.fill(
            np.concatenate([lo[:, 0], hi[::-1, 0]]), np.concatenate([lo[:, 1], hi[::-1, 1]]),
            color="0.85", lw=0, label="ISO 606 min…max",
        )  # fmt: skip
    for i, (label, prof) in enumerate(profiles.items()):
        pts = np.concatenate([_gap_outline(prof, 80, g) for g in range(-gaps, gaps + 1)])
        pts = pts @ up.T * 1e3
        (line,) = ax.plot(pts[:, 0], pts[:, 1], styles[i % 4], lw=1.4, label=label)
        # roller resting at the bottom of its seat
        centre = _seated_roller(prof)
        rr = float(prof.roller_radius)
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
    # beside the axes: below them it would cover the x label whatever the aspect
    ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=8)
    return ax


def plot_sprocket(
    profile: ToothProfile | FreeformProfile,
    *,
    reference: ToothProfile | FreeformProfile | None = None,
    exaggerate: float | None = None,
    rollers: bool = True,
    ax=None,
):
    """The whole sprocket, with its per-gap pattern made visible: the outline's departure
    from ``reference`` (default: the same profile with every per-gap leaf replaced by its
    mean over the gaps, so that only the pattern shows), measured along the reference's
    normal, drawn ``exaggerate`` times larger (default: the largest departure shown as
    0.1 pitch; none below 1e-5 pitch) over the reference outline (grey), with a roller
    seated in every gap. Millimetres. Returns the Axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 6))
    z = profile.teeth
    if reference is None:
        reference = profile.uniform()
    ref = np.asarray(reference.sprocket_outline(60))
    out = np.asarray(profile.sprocket_outline(60))
    # departure along the reference's normal: its exact signed distance at each point
    sd, normal = jax.jit(jax.vmap(signed_distance, (None, 0)))(reference, jnp.asarray(out))
    sd, normal = np.asarray(sd), np.asarray(normal)
    if exaggerate is None:
        biggest = float(np.abs(sd).max())
        # below 1e-5 pitch (0.13 µm on 08B) a departure is the outline's sampling, not a
        # pattern: magnifying it would draw noise
        real = biggest > 1e-5 * float(profile.pitch)
        exaggerate = max(1.0, 0.1 * float(profile.pitch) / biggest) if real else 1.0
    shown = out + (exaggerate - 1) * sd[:, None] * normal
    ax.plot(ref[:, 0] * 1e3, ref[:, 1] * 1e3, color="0.6", lw=0.8, label="reference")
    ax.plot(shown[:, 0] * 1e3, shown[:, 1] * 1e3, lw=1.2,
            label=f"profile (departure ×{exaggerate:.3g})")  # fmt: skip
    if rollers:
        t = np.linspace(0, 2 * math.pi, 60)
        rr = float(profile.roller_radius)
        for g in range(z):
            c = _seated_roller(profile, g)
            ax.plot((c[0] + rr * np.cos(t)) * 1e3, (c[1] + rr * np.sin(t)) * 1e3,
                    color="C1", lw=0.5)  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"z = {z}: departure from the reference ×{exaggerate:.3g}")
    ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5), fontsize=8)  # beside the axes
    return ax
