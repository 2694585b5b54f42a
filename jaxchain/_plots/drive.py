"""Matplotlib helpers for simulated drives: force, tension and speed histories, snapshots
of the drive and animations.

Inputs are SI (a :class:`~jaxchain.Solution` and its :class:`~jaxchain.Scene`); plots are
in millimetres, milliseconds, newtons and rpm. Matplotlib is imported inside the
functions, so importing jaxchain does not import it.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .. import _checks as checks
from .._scene import Scene
from .._solve.simulate import Solution

__all__ = ["plot_forces", "plot_tensions", "plot_snapshot", "animate", "plot_speed"]

_COLOR_BY = ("force", "speed", None)
_CMAP = "YlOrRd"
_MOVIE_SUFFIXES = (".gif", ".mp4")


def _solution(sol, caller: str, scene=None) -> None:
    """``sol`` must be one solution (and ``scene`` a scene, if given)."""
    if not isinstance(sol, Solution):
        raise TypeError(
            f"{caller}: sol must be a jc.Solution (from jc.simulate), got {type(sol).__name__}"
        )
    if sol.is_ensemble:
        raise TypeError(f"{caller}: sol is an ensemble's solution; plot one member: sol.member(i)")
    if scene is not None and not isinstance(scene, Scene):
        raise TypeError(f"{caller}: scene must be a jaxchain Scene, got {type(scene).__name__}")


def _new_ax(ax, figsize=(8, 4.5)):
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def _select(values: np.ndarray, which, top: int, kind: str) -> list[int]:
    """Columns of ``values`` (T, n) to plot: ``which`` or the ``top`` largest peaks."""
    n = values.shape[1]
    if which is not None:
        idx = [int(i) for i in np.atleast_1d(np.asarray(which))]
        bad = [i for i in idx if not -n <= i < n]
        if bad:
            raise ValueError(f"{kind} index {bad} out of range: the solution has {n} {kind}s")
        return [i % n for i in idx]
    if not isinstance(top, (int, np.integer)) or top < 1:
        raise ValueError(f"top must be a positive integer, got {top!r}")
    peaks = np.max(values, axis=0) if values.shape[0] else np.zeros(n)
    order = [int(i) for i in np.argsort(-peaks, kind="stable") if peaks[i] > 0]
    return sorted(order[:top])


def _plot_histories(ax, ts, values, idx, kind):
    """One line per column with its peak marked; returns [(t, value, color)] of the peaks."""
    t_ms = np.asarray(ts) * 1e3
    peaks = []
    for i in idx:
        y = values[:, i]
        (line,) = ax.plot(t_ms, y, lw=1.2, label=f"{kind} {i}")
        if y.size:
            j = int(np.argmax(y))
            ax.plot(t_ms[j], y[j], "o", ms=5, color=line.get_color(), label="_nolegend_")
            peaks.append((t_ms[j], y[j], line.get_color()))
    ax.set_xlabel("time [ms]")
    if t_ms.size:
        ax.set_xlim(t_ms[0], t_ms[-1])
    ax.grid(True, lw=0.4, alpha=0.5)
    return peaks


def _annotate_peaks(ax, peaks, fontsize=8):
    """Label each peak with its value; labels that would overlap are stacked downwards,
    with a leader line to their marker. Call once the axis limits are final."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.06 * (hi - lo))  # headroom for the top label
    to_pt = 72.0 / ax.figure.dpi
    h = 1.3 * fontsize
    placed = []  # label boxes (x0, x1, y0, y1) [pt, display]
    for t, v, color in sorted(peaks, key=lambda p: -p[1]):
        text = f"{v:.0f} N"
        x, y = ax.transData.transform((t, v)) * to_pt
        w = 0.62 * fontsize * len(text)
        x0, y0 = x + 4, y + 4
        moved = True
        while moved:
            moved = False
            for bx0, bx1, by0, by1 in placed:
                if x0 < bx1 and bx0 < x0 + w and y0 < by1 and by0 < y0 + h:
                    y0 = by0 - h - 1
                    moved = True
        placed.append((x0, x0 + w, y0, y0 + h))
        shifted = y0 < y + 4 - 0.5
        ax.annotate(
            text,
            (t, v),
            xytext=(x0 - x, y0 - y),
            textcoords="offset points",
            fontsize=fontsize,
            color=color,
            va="bottom",
            arrowprops={"arrowstyle": "-", "color": color, "lw": 0.6} if shifted else None,
        )


def plot_forces(
    sol: Solution,
    *,
    rollers: int | Sequence[int] | None = None,
    ax=None,
    top: int = 5,
):
    """Roller/sprocket normal-force histories [N] against time [ms].

    Args:
        sol: a :class:`~jaxchain.Solution`.
        rollers: roller indices to draw; default the ``top`` rollers with the largest peak
            force (rollers that never touch a tooth are left out), in roller order.
        ax: Axes to draw into (default: a new figure).
        top: how many rollers to draw by default.

    Each roller's peak over the save times is marked and annotated; the dashed line is
    ``sol.peak_contact_force``, the peak over every solver step too (it can exceed the
    saved peaks when an impact falls between save times). Returns the Axes.
    """
    _solution(sol, "plot_forces")
    ax = _new_ax(ax)
    force = np.asarray(sol.roller_sprocket_force, dtype=float)
    idx = _select(force, rollers, top, "roller")
    peaks = _plot_histories(ax, sol.ts, force, idx, "roller")
    peak = float(sol.peak_contact_force)
    if np.isfinite(peak):
        ax.axhline(
            peak, ls="--", lw=1.0, color="0.35", label=f"peak over all solver steps: {peak:.0f} N"
        )
    ax.set_ylim(bottom=0)
    _annotate_peaks(ax, peaks)
    ax.set_ylabel("roller–sprocket normal force [N]")
    ax.set_title("Roller–sprocket contact forces")
    ax.legend(fontsize=8, loc="upper right")
    return ax


def plot_tensions(
    sol: Solution,
    *,
    links: int | Sequence[int] | None = None,
    ax=None,
    top: int = 5,
    spans: bool | None = None,
):
    """Tension histories [N] against time [ms]: a closed drive's free spans, or links.

    Args:
        sol: a :class:`~jaxchain.Solution`.
        links: link indices to draw; default the ``top`` links with the largest peak
            tension, in link order.
        ax: Axes to draw into (default: a new figure).
        top: how many links to draw by default.
        spans: draw each free span's mean tension (``sol.span_tension``: span j runs from
            sprocket j to j + 1) instead of links; default: spans for a closed drive when
            no ``links`` are given, links otherwise.

    Each line's peak over the save times is marked and annotated. A lumped chain's links
    are two-way springs: a link between two seated rollers can be squeezed, and its
    negative tension (compression) is then labelled so. Returns the Axes.
    """
    _solution(sol, "plot_tensions")
    ax = _new_ax(ax)
    if spans is None:
        spans = links is None and sol.span_tension is not None
    if spans:
        if sol.span_tension is None:
            raise ValueError(
                "plot_tensions: spans=True needs a closed drive's span tensions "
                "(sol.span_tension is None for a strand); draw links instead"
            )
        tension = np.asarray(sol.span_tension, dtype=float)
        n = tension.shape[1]
        idx = list(range(n))
        kind, title = "span", "Span tensions (mean over each free span's links)"
    else:
        tension = np.asarray(sol.link_tension, dtype=float)
        idx = _select(tension, links, top, "link")
        kind, title = "link", "Link tensions"
    peaks = _plot_histories(ax, sol.ts, tension, idx, kind)
    if spans:  # say where each span runs
        for line in ax.get_lines():
            j = line.get_label().removeprefix("span ")
            if j.isdigit():
                line.set_label(f"span {j}: sprocket {j} → {(int(j) + 1) % n}")
    low = np.min(tension[:, idx]) if (tension.size and idx) else 0.0
    if low < 0:
        ax.axhline(0.0, lw=0.6, color="0.5", label="_nolegend_")
        ax.text(
            0.01, 0.02, "below 0: compression (the lumped links are two-way springs)",
            transform=ax.transAxes, fontsize=7, color="0.35",
        )  # fmt: skip
    _annotate_peaks(ax, peaks)
    ax.set_ylabel(f"{kind} tension [N]")
    ax.set_title(title)
    if idx:
        ax.legend(fontsize=8, loc="best")
    return ax


def plot_speed(sol: Solution, *, ax=None, scene: Scene | None = None, relative: bool = True):
    """Sprocket speeds against time [ms] (positive counter-clockwise).

    ``relative`` (default): each sprocket's speed fluctuation, (ω − ω̄)/ω̄ in per cent of
    its own mean over the solution (the mean in the legend [rpm]), so that a driven
    sprocket's polygonal speed variation shows beside the driver's constant speed;
    otherwise the speeds themselves [rpm]. With ``scene`` the lines are labelled with each
    sprocket's role (driver, driven, or idler: a loop's sprocket without load) and tooth
    count. Returns the Axes.
    """
    _solution(sol, "plot_speed", scene)
    checks.flag("relative", relative)
    ax = _new_ax(ax)
    t_ms = np.asarray(sol.ts) * 1e3
    rpm = np.asarray(sol.sprocket_speed, dtype=float) * 60 / (2 * math.pi)
    for k in range(rpm.shape[1]):
        label = f"sprocket {k}"
        if scene is not None and k < len(scene.sprockets):
            spr = scene.sprockets[k]
            role = "driven" if spr.driven else "driver"
            idle = len(scene.sprockets) > 2 and spr.torque_load.is_zero()
            if spr.driven and idle:
                role = "idler"
            label += f" ({role}, z = {spr.profile.teeth})"
        mean = float(np.mean(rpm[:, k])) if rpm.shape[0] else math.nan
        if relative and mean != 0:
            ax.plot(t_ms, 100 * (rpm[:, k] / mean - 1), lw=1.2, label=f"{label}: {mean:.1f} rpm")
        else:
            ax.plot(t_ms, rpm[:, k], lw=1.2, label=label)
    ax.set_xlabel("time [ms]")
    if relative:
        ax.set_ylabel("speed − its mean [% of the mean]")
        ax.set_title("Sprocket speed fluctuation")
    else:
        ax.set_ylabel("sprocket speed [rpm]")
        ax.set_title("Sprocket speeds")
    if t_ms.size:
        ax.set_xlim(t_ms[0], t_ms[-1])
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize=8, loc="best")
    return ax


# ----------------------------------------------------------------------------- snapshots


def _check_index(sol: Solution, index: int) -> int:
    n = int(np.shape(sol.ts)[0])
    if not isinstance(index, (int, np.integer)) or not -n <= index < n:
        raise IndexError(f"index {index!r} out of range: the solution has {n} save times")
    return int(index) % n


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])  # rows: R(angle) @ p


class _Snapshot:
    """The artists of one drawn drive state, and how to move them to another save index."""

    def __init__(self, scene: Scene, sol: Solution, ax, color_by, colorbar: bool, frame=None):
        import matplotlib.collections as mcoll
        import matplotlib.patches as mpatches

        if color_by not in _COLOR_BY:
            raise ValueError(f"color_by must be one of {_COLOR_BY}, got {color_by!r}")
        self.ax = ax
        self.color_by = color_by
        self.ts = np.asarray(sol.ts, dtype=float)
        self.pos = np.asarray(sol.roller_position, dtype=float) * 1e3  # (T, R, 2) mm
        self.angle = np.asarray(sol.sprocket_angle, dtype=float)
        self.closed = scene.anchors is None
        if color_by == "force":
            self.values = np.asarray(sol.roller_sprocket_force, dtype=float)
            label = "roller–sprocket normal force [N]"
        elif color_by == "speed":
            self.values = np.linalg.norm(np.asarray(sol.roller_velocity, dtype=float), axis=-1)
            label = "roller speed [m/s]"
        else:
            self.values = None
        n_spr = len(scene.sprockets)
        if self.angle.shape[1] != n_spr or self.pos.shape[1] != scene.n_rollers:
            raise ValueError(
                f"scene and solution do not match: the scene has {n_spr} sprockets and "
                f"{scene.n_rollers} rollers, the solution {self.angle.shape[1]} and "
                f"{self.pos.shape[1]}"
            )

        self.outlines, self.centres, self.sprocket_patches = [], [], []
        for spr in scene.sprockets:
            outline = np.asarray(spr.profile.sprocket_outline(), dtype=float) * 1e3
            centre = np.asarray(spr.centre, dtype=float) * 1e3
            patch = mpatches.Polygon(
                outline + centre, closed=True, fc="0.88", ec="0.25", lw=0.8, zorder=1
            )
            ax.add_patch(patch)
            ax.plot(*centre, "+", color="0.25", ms=8, zorder=1)
            self.outlines.append(outline)
            self.centres.append(centre)
            self.sprocket_patches.append(patch)

        self.shoes = _ShoeArtists(scene, sol, ax)
        (self.chain_line,) = ax.plot([], [], "-", color="0.3", lw=1.0, zorder=2, label="chain")
        d = 2e3 * float(scene.roller_radius)
        n_r = self.pos.shape[1]
        self.rollers = mcoll.EllipseCollection(
            np.full(n_r, d),
            np.full(n_r, d),
            np.zeros(n_r),
            units="xy",
            offsets=self.pos[0],
            offset_transform=ax.transData,
            edgecolors="k",
            linewidths=0.5,
            zorder=3,
        )
        if self.values is None:
            self.rollers.set_facecolor("0.7")
        else:
            import matplotlib as mpl

            shown = self.values if frame is None else self.values[frame]  # scale over these
            vmax = float(np.max(shown)) if shown.size else 0.0
            vmax = vmax if vmax > 0 else 1.0
            # rollers out of contact (force exactly 0) are masked: drawn white
            self.rollers.set_cmap(mpl.colormaps[_CMAP].with_extremes(bad="white"))
            self.rollers.set_clim(0.0, vmax)
            self.rollers.set_array(self._colors(0))
        ax.add_collection(self.rollers, autolim=False)
        self.colorbar = None
        if self.values is not None and colorbar:
            self.colorbar = ax.figure.colorbar(self.rollers, ax=ax, label=label, shrink=0.8)
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        self.title = ax.set_title("")
        self.radius_mm = d / 2

    def _colors(self, i: int):
        v = self.values[i]
        return np.ma.masked_equal(v, 0.0) if self.color_by == "force" else v

    def update(self, i: int):
        for patch, outline, centre, angle in zip(
            self.sprocket_patches, self.outlines, self.centres, self.angle[i], strict=True
        ):
            patch.set_xy(_rotate(outline, float(angle)) + centre)
        p = self.pos[i]
        if self.closed:
            p_line = np.concatenate([p, p[:1]])
        else:
            p_line = p
        self.chain_line.set_data(p_line[:, 0], p_line[:, 1])
        self.rollers.set_offsets(p)
        if self.values is not None:
            self.rollers.set_array(self._colors(i))
        self.title.set_text(f"Drive at t = {self.ts[i] * 1e3:.2f} ms")
        moved = self.shoes.update(i)
        return [*self.sprocket_patches, *moved, self.chain_line, self.rollers, self.title]

    def limits(self, frames) -> None:
        """Fix the view on the sprockets and the rollers of ``frames`` (with a margin)."""
        xlim, ylim = _extent(self.outlines, self.centres, self.pos[list(frames)], self.radius_mm)
        self.ax.set_xlim(*xlim)
        self.ax.set_ylim(*ylim)


def shoe_outline(mid, normal, curvature, half_length, thickness, n: int = 41):
    """(2n, 2) closed outline of a shoe [m]: its face (an arc of ``curvature``, or a
    straight line, ``half_length`` each side of ``mid``) and its back ``thickness``
    behind it, at the layout."""
    mid, normal = np.asarray(mid, float), np.asarray(normal, float)
    t = np.array([normal[1], -normal[0]])
    s = np.linspace(-half_length, half_length, n)
    if curvature > 0:
        radius = 1.0 / curvature
        centre = mid - normal * radius
        a = s * curvature
        ray = np.cos(a)[:, None] * normal + np.sin(a)[:, None] * t
        face, back = centre + radius * ray, centre + (radius - thickness) * ray
    else:
        face = mid + s[:, None] * t
        back = face - thickness * normal
    return np.concatenate([face, back[::-1]])


class _ShoeArtists:
    """Tensioner shoes (turning with their arms, pivot and arm drawn) and guides."""

    def __init__(self, scene: Scene, sol: Solution, ax):
        import matplotlib.patches as mpatches

        self.patches, self.outlines, self.arms = [], [], []
        sh = scene.shoes
        if sh is None:
            return
        thick = 3.0 * float(scene.roller_radius)
        na = sh.n_tensioners
        self.angle = None
        if na:
            tn = scene.tensioners
            self.pivot = np.asarray(tn.pivot, float)
            self.ref = np.asarray(tn.layout_angle, float)
            self.angle = np.asarray(sol.tensioner_angle, float)
        for k in range(sh.count):
            outline = shoe_outline(
                sh.mid[k], sh.normal[k], float(sh.curvature[k]), float(sh.half_length[k]), thick
            )
            tensioner = k < na
            patch = mpatches.Polygon(
                outline * 1e3,
                closed=True,
                fc="#f2c48a" if tensioner else "#a9c4de",
                ec="0.25",
                lw=0.8,
                zorder=1,
                label="tensioner shoe" if tensioner else "guide",
            )
            ax.add_patch(patch)
            self.patches.append(patch)
            self.outlines.append(outline)
            if tensioner:
                (arm,) = ax.plot([], [], "-o", color="#b8742a", lw=2.0, ms=4, zorder=1)
                ax.plot(*(self.pivot[k] * 1e3), "o", color="0.2", ms=5, zorder=1)
                self.arms.append(arm)

    def update(self, i: int) -> list:
        for k, arm in enumerate(self.arms):
            turn = float(self.angle[i, k] - self.ref[k])
            pivot = self.pivot[k]
            moved = _rotate(self.outlines[k] - pivot, turn) + pivot
            self.patches[k].set_xy(moved * 1e3)
            mid = moved[len(moved) // 4]
            arm.set_data([pivot[0] * 1e3, mid[0] * 1e3], [pivot[1] * 1e3, mid[1] * 1e3])
        return [*self.patches, *self.arms]


def _extent(outlines, centres, pos, radius_mm):
    """x and y limits [mm] holding the sprockets and the rollers at ``pos`` (..., 2) [mm]."""
    pts = [np.reshape(pos, (-1, 2))]
    for outline, centre in zip(outlines, centres, strict=True):
        r = float(np.max(np.linalg.norm(outline, axis=1)))
        pts.append(centre + np.array([[-r, -r], [r, r]]))
    pts = np.concatenate(pts)
    lo, hi = pts.min(0), pts.max(0)
    pad = 0.04 * float(np.max(hi - lo)) + 2 * radius_mm
    return (lo[0] - pad, hi[0] + pad), (lo[1] - pad, hi[1] + pad)


def _snapshot_figure(scene: Scene, sol: Solution, frames):
    """A new figure sized to the drive's aspect ratio (plus room for title, labels, colorbar)."""
    import matplotlib.pyplot as plt

    outlines = [np.asarray(s.profile.sprocket_outline(4)) for s in scene.sprockets]
    centres = [np.asarray(s.centre, dtype=float) for s in scene.sprockets]
    pos = np.asarray(sol.roller_position, dtype=float)[list(frames)]
    xlim, ylim = _extent(outlines, centres, pos, float(scene.roller_radius))
    aspect = (ylim[1] - ylim[0]) / (xlim[1] - xlim[0])
    width = 6.0
    height = float(np.clip(width * aspect, 2.0, 8.0)) + 1.2
    return plt.figure(figsize=(width + 1.6, height), layout="constrained")


def plot_snapshot(
    scene: Scene,
    sol: Solution,
    index: int = -1,
    *,
    ax=None,
    color_by: str | None = "force",
    scale: str = "frame",
):
    """The drive at save index ``index``: sprockets, chain and rollers, in millimetres.

    Each sprocket's tooth outline is drawn turned by its angle at that time about its
    axis (marked +); the chain is a polyline through the roller centres (closed for a
    closed chain); rollers are circles of the roller radius coloured by ``color_by``:
    ``"force"`` (roller–sprocket normal force [N]), ``"speed"`` (roller speed [m/s]) or
    None (uncoloured, no colorbar). ``scale``: the colour scale spans the values at that
    time (``"frame"``, the default: the rollers that carry the load stand out) or the
    whole solution (``"run"``: snapshots at different times compare, as the frames of
    :func:`animate` do). Returns the Axes.
    """
    _solution(sol, "plot_snapshot", scene)
    i = _check_index(sol, index)
    checks.choice("scale", scale, ("frame", "run"))
    if ax is None:
        ax = _snapshot_figure(scene, sol, [i]).add_subplot()
    snap = _Snapshot(scene, sol, ax, color_by, colorbar=True, frame=i if scale == "frame" else None)
    snap.update(i)
    snap.limits([i])
    return ax


def animate(
    scene: Scene,
    sol: Solution,
    path: str | os.PathLike,
    *,
    fps: float = 30,
    stride: int = 1,
    dpi: float = 80,
    color_by: str | None = "force",
    fig=None,
) -> Path:
    """Write an animation of the drive (snapshots as in :func:`plot_snapshot`) to ``path``.

    Args:
        scene, sol: the scene and its solution.
        path: ``.gif`` (Pillow, always available) or ``.mp4`` (needs ffmpeg).
        fps: frames per second of the animation.
        stride: draw every ``stride``-th save time.
        dpi: resolution of the frames.
        color_by: as in :func:`plot_snapshot`.
        fig: a Figure to draw into (cleared first); default a new one, closed afterwards.

    The view is fixed on everything the animation shows; each frame only moves the
    artists of the first. Returns the path written.
    """
    import matplotlib.animation as manimation
    import matplotlib.pyplot as plt

    _solution(sol, "animate", scene)
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _MOVIE_SUFFIXES:
        raise ValueError(
            f"unsupported animation file type {path.suffix!r} ({path.name}): use one of "
            f"{', '.join(_MOVIE_SUFFIXES)} (.mp4 needs ffmpeg)"
        )
    if suffix == ".mp4" and not manimation.writers.is_available("ffmpeg"):
        raise ValueError(
            f"writing {path.name} needs ffmpeg, which matplotlib cannot find: write a .gif "
            "instead, or install ffmpeg (on PATH, or set rcParams['animation.ffmpeg_path'])"
        )
    if not isinstance(stride, (int, np.integer)) or stride < 1:
        raise ValueError(f"stride must be a positive integer, got {stride!r}")
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    frames = range(0, int(np.shape(sol.ts)[0]), int(stride))
    if len(frames) == 0:
        raise ValueError("the solution has no save times to animate")

    own = fig is None
    if own:
        fig = _snapshot_figure(scene, sol, frames)
    else:
        fig.clear()
    try:
        ax = fig.add_subplot()
        snap = _Snapshot(scene, sol, ax, color_by, colorbar=True)
        snap.limits(frames)
        snap.update(frames[0])
        fig.canvas.draw()  # lay out once, then keep the axes still while the title changes
        fig.set_layout_engine("none")
        if suffix == ".gif":
            writer = manimation.PillowWriter(fps=fps)
        else:
            writer = manimation.FFMpegWriter(fps=fps)
        with writer.saving(fig, str(path), dpi):
            for i in frames:
                snap.update(i)
                writer.grab_frame()
    finally:
        if own:
            plt.close(fig)
    return path
