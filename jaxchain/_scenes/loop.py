"""The exact layout of a closed chain over several sprockets (set-up code: NumPy, not traced).

Geometry as in :mod:`.layout`: sprocket k (zk teeth, angle θk) has its pitch points, the
vertices of a regular zk-gon of circumradius Rk = p_l / (2 sin(π/zk)), one link pitch
p_l apart. The chain runs as one counter-clockwise loop through the sprockets in the order
given. A sprocket inside the loop lies on the chain's left as it travels and is wrapped
counter-clockwise (sense +1); one outside it, an idler on the chain's back, lies on the
chain's right and is wrapped clockwise (sense −1). A span between an inside and an
outside sprocket is a cross tangent.

Span j runs from sprocket j to sprocket j + 1 (mod N) along their *bridge*: the common
supporting line of the two pitch polygons with each polygon on its own side (no pitch
point of either lies beyond it, so the chain does not cut into a sprocket), from the last
pitch point on it of the first polygon to the first of the second. The rollers sit on the
pitch points of each wrap and equally spaced on each span.

Construction (every length in link pitches p_l, so the layout is exact):

1. The driver's angle is θ0 = 0.
2. Going round the loop forward from the driver, and backward from it, each span but the
   two at the take-up sprocket m is made a whole number of pitches by the angle of the
   sprocket at its far end. Turning that sprocket by one tooth angle moves its bridge
   vertex along the polygon continuously except where the bridge jumps to the next vertex;
   there |AB| jumps by exactly one pitch (an edge lies on the line), so |AB| mod p_l is
   continuous and runs once round [0, p_l): a root in every tooth angle, found by a grid
   and a bracketing root find.
3. Sprocket m moves along the outward bisector of its two spans by a shift s; for each s
   its angle makes its arriving span whole (as in 2), and s solves "chain length needed
   = n_links·p_l" (a 1-D bracketing root find; the needed length, spans plus wrapped
   pitches, is continuous in s because a bridge jump trades one span pitch for one
   wrapped roller). Its departing span is then whole as well.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .layout import LoopLayout, brentq, chain_pitch_radius, check_count, check_length, check_teeth

__all__ = ["loop_layout"]

_TOL = 1e-9  # "on a line" tolerance, relative to the link pitch
_GRID = 24  # grid points per tooth angle bracketing a whole span
_MIN_TURN = 0.1  # |take-up vector| = cos α below it: moving the take-up hardly changes length


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _unit(v):
    return v / np.linalg.norm(v)


class _Bad(Exception):
    """A configuration the loop cannot take (no common tangent, a wrap of less than a tooth,
    not one counter-clockwise loop); only raised while searching for the closing shift."""


class Circles:
    """The loop over the pitch circles: tangent spans, wrap arcs and belt length."""

    def __init__(self, centres, radii, sense):
        n = len(radii)
        self.t_out = np.zeros((n, 2))  # span j leaves sprocket j here ...
        self.t_in = np.zeros((n, 2))  # ... and reaches sprocket j + 1 here (index j + 1)
        self.ok = True
        for j in range(n):
            k = (j + 1) % n
            line = _tangent(centres[j], radii[j], sense[j], centres[k], radii[k], sense[k])
            if line is None:
                self.ok = False
                return
            self.t_out[j], self.t_in[k] = line
        self.direction = np.stack([_unit(self.t_in[(j + 1) % n] - self.t_out[j]) for j in range(n)])
        a_in = np.arctan2(*(self.t_in - centres)[:, ::-1].T)
        a_out = np.arctan2(*(self.t_out - centres)[:, ::-1].T)
        self.arc = (sense * (a_out - a_in)) % (2 * math.pi)  # wrap angle of each sprocket
        self.turning = float(np.sum(sense * self.arc))
        spans = np.linalg.norm(self.t_in[(np.arange(n) + 1) % n] - self.t_out, axis=-1)
        self.span_length = spans
        self.length = float(np.sum(spans) + np.sum(radii * self.arc))


def _tangent(ca, ra, sa, cb, rb, sb):
    """Touching points (Ta, Tb) of the directed line from circle a to circle b with circle a
    on side sa and b on side sb (+1: left of the direction of travel), or None."""
    d_vec = cb - ca
    d = float(np.linalg.norm(d_vec))
    k = sb * rb - sa * ra  # n·(cb − ca), n the line's left normal
    if d == 0 or abs(k) >= d:
        return None
    dh = d_vec / d
    n = dh * (k / d) + np.array([-dh[1], dh[0]]) * math.sqrt(1 - (k / d) ** 2)
    return ca - sa * ra * n, cb - sb * rb * n


def _tangent_vertex(pts, centre, q, side, lp, depart):
    """The vertex X of a convex polygon (``pts``, axis ``centre``) such that the line through
    X and the outside point q has the whole polygon on ``side`` of the direction of travel
    (X → q if ``depart``, q → X otherwise). Of vertices on that line (an edge along it),
    the one nearest q: the chain is seated on all of them and spans from the last."""
    w = pts - q
    ref = centre - q
    ang = np.arctan2(_cross(ref, w), w @ ref)
    k = int(np.argmax((side if depart else -side) * ang))
    u = _unit(q - pts[k])
    on = np.nonzero(np.abs(_cross(u, pts - pts[k])) <= _TOL * lp)[0]
    return int(on[np.argmin(np.linalg.norm(pts[on] - q, axis=-1))])


class _Loop:
    """Sprockets of the loop; spans and needed length for given angles and axes."""

    def __init__(self, lp, teeth, sense):
        self.lp = lp
        self.z = np.asarray(teeth)
        self.s = np.asarray(sense)
        self.r = np.array([chain_pitch_radius(lp, int(z)) for z in teeth])
        self.n = len(teeth)

    def points(self, k, theta, centre):
        a = theta + 2 * math.pi * np.arange(self.z[k]) / self.z[k]
        return centre + self.r[k] * np.stack([np.cos(a), np.sin(a)], -1)

    def span(self, j, thetas, centres):
        """(departure vertex on sprocket j, arrival vertex on j + 1, |AB| [m]) of span j."""
        a, b = j, (j + 1) % self.n
        pa, pb = self.points(a, thetas[a], centres[a]), self.points(b, thetas[b], centres[b])
        line = _tangent(centres[a], self.r[a], self.s[a], centres[b], self.r[b], self.s[b])
        if line is None:
            raise _Bad(f"no common tangent from sprocket {a} to {b}")
        ia = int(np.argmin(np.linalg.norm(pa - line[0], axis=-1)))
        ib = int(np.argmin(np.linalg.norm(pb - line[1], axis=-1)))
        for _ in range(4 * (self.z[a] + self.z[b])):
            ja = _tangent_vertex(pa, centres[a], pb[ib], self.s[a], self.lp, depart=True)
            jb = _tangent_vertex(pb, centres[b], pa[ja], self.s[b], self.lp, depart=False)
            if (ja, jb) == (ia, ib):
                return ia, ib, float(np.linalg.norm(pb[ib] - pa[ia]))
            ia, ib = ja, jb
        raise RuntimeError("bridge search did not converge")  # pragma: no cover

    def whole(self, j, k, thetas, centres) -> float:
        """The angle of sprocket k (an end of span j) in [0, 2π/zk) that makes span j a whole
        number of link pitches (module docstring, step 2)."""
        t = np.array(thetas, dtype=float)

        def frac(th):
            t[k] = th
            m = self.span(j, t, centres)[2] / self.lp
            return m - round(m)

        grid = 2 * math.pi / self.z[k] * np.arange(_GRID + 1) / _GRID
        vals = [frac(g) for g in grid]
        for i in range(_GRID):
            v0, v1 = vals[i], vals[i + 1]
            if v0 == 0:
                return float(grid[i])
            if v0 * v1 < 0 and abs(v0) + abs(v1) < 0.5:  # a root, not the wrap at ±1/2
                return float(brentq(frac, grid[i], grid[i + 1], xtol=1e-15, rtol=1e-15))
        raise _Bad(f"span {j} cannot be made whole by turning sprocket {k}")  # pragma: no cover

    def wraps(self, spans) -> np.ndarray:
        """Seated rollers per sprocket: arrival vertex to departure vertex, inclusive."""
        n = self.n
        return np.array(
            [(self.s[k] * (spans[k][0] - spans[(k - 1) % n][1])) % self.z[k] + 1 for k in range(n)]
        )

    def needed(self, thetas, centres):
        """Length of chain [m] the configuration needs: spans plus wrapped pitches."""
        spans = [self.span(j, thetas, centres) for j in range(self.n)]
        wraps = self.wraps(spans)
        return sum(s[2] for s in spans) + self.lp * float(np.sum(wraps - 1)), spans, wraps


def as_centres(centres, n) -> np.ndarray:
    try:
        c = np.asarray(centres, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"centres must be {n} axis positions (x, y) [m], one per sprocket, got {centres!r}"
        ) from None
    if c.shape != (n, 2) or not np.all(np.isfinite(c)):
        raise ValueError(
            f"centres must be {n} finite axis positions (x, y) [m], one per sprocket (teeth "
            f"has {n}), got shape {c.shape}"
        )
    return c


def as_outside(outside, n) -> tuple[int, ...]:
    if isinstance(outside, (str, bytes)) or not isinstance(outside, Sequence | np.ndarray):
        raise ValueError(f"outside must be a sequence of sprocket indices, got {outside!r}")
    out = []
    for k in outside:
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k < n:
            raise ValueError(
                f"outside must hold indices of driven sprockets in [1, {n - 1}] (sprocket 0 "
                f"drives, inside the loop), got {tuple(outside)!r}"
            )
        out.append(int(k))
    if len(set(out)) != len(out):
        raise ValueError(f"outside lists a sprocket twice: {tuple(outside)!r}")
    return tuple(sorted(out))


def _radii(name, values, default, n) -> np.ndarray:
    if values is None:
        return default
    v = np.asarray(values, dtype=float)
    if v.shape != (n,) or not np.all(np.isfinite(v) & (v > 0)):
        raise ValueError(f"{name} must be {n} finite radii > 0 m, one per sprocket, got {values!r}")
    return v


def _segment_distance(p, a, b) -> float:
    ab = b - a
    t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def _segments_cross(a, b, c, d) -> bool:
    d1, d2 = _cross(b - a, c - a), _cross(b - a, d - a)
    d3, d4 = _cross(d - c, a - c), _cross(d - c, b - c)
    return bool(d1 * d2 < 0 and d3 * d4 < 0)


def _check_overlap(centres, tips, what: str) -> None:
    n = len(centres)
    for i in range(n):
        for j in range(i + 1, n):
            d = float(np.linalg.norm(centres[j] - centres[i]))
            if d <= tips[i] + tips[j]:
                raise ValueError(
                    f"{what}sprockets {i} and {j} overlap: their tip circles (radii "
                    f"{tips[i] * 1e3:.4g} and {tips[j] * 1e3:.4g} mm) intersect at a centre "
                    f"distance of {d * 1e3:.4g} mm; place their axes at least "
                    f"{(tips[i] + tips[j]) * 1e3:.4g} mm apart"
                )


def _check_spans(starts, ends, centres, reach, sense, what: str) -> None:
    """No span within reach of a sprocket other than its two ends; no two spans cross."""
    n = len(centres)
    for j in range(n):
        for k in range(n):
            if k in (j, (j + 1) % n):
                continue
            d = _segment_distance(centres[k], starts[j], ends[j])
            if d < reach[k]:
                raise ValueError(
                    f"{what}span {j} (from sprocket {j} to {(j + 1) % n}) cuts through "
                    f"sprocket {k}: it passes {d * 1e3:.4g} mm from its axis, within the tip "
                    f"radius plus a roller radius ({reach[k] * 1e3:.4g} mm); move sprocket {k} "
                    "clear of the chain"
                    + (
                        ", or list it in outside if the chain runs over its back"
                        if sense[k] > 0
                        else ""
                    )
                )
    for i in range(n):
        for j in range(i + 2, n):
            if (j + 1) % n == i:
                continue
            if _segments_cross(starts[i], ends[i], starts[j], ends[j]):
                raise ValueError(
                    f"{what}spans {i} and {j} cross: the sprockets must be listed in the order "
                    "the chain passes them, counter-clockwise round the loop"
                )


def _check_circles(circ: Circles, teeth, sense, what: str) -> None:
    if abs(circ.turning - 2 * math.pi) > 1e-6:
        k = int(np.argmax(circ.arc))
        raise ValueError(
            f"{what}the chain does not run round the sprockets as one counter-clockwise loop "
            f"in the order given (it would turn by {math.degrees(circ.turning):.0f}° in all; "
            f"sprocket {k} would be wrapped by {math.degrees(circ.arc[k]):.0f}°): list the "
            "sprockets counter-clockwise round the loop, and in outside the idlers on the "
            "chain's back"
        )
    for k, (arc, z) in enumerate(zip(circ.arc, teeth, strict=True)):
        if arc < 2 * math.pi / z:
            side = "out of" if sense[k] > 0 else "into"
            raise ValueError(
                f"{what}the chain wraps sprocket {k} by {math.degrees(arc):.3g}°, less than "
                f"one tooth (360°/{z} = {360 / z:.3g}°): move it further {side} the loop"
            )


def loop_layout(
    pitch: float,
    teeth: Sequence[int],
    centres,
    outside: Sequence[int] = (),
    *,
    n_links: int | None = None,
    link_pitch: float | None = None,
    take_up_sprocket: int | None = None,
    tip_radii: Sequence[float] | None = None,
    roller_radius: float | None = None,
) -> LoopLayout:
    """A closed chain over N ≥ 2 sprockets, in an exactly closing configuration (module
    docstring): rollers at the pitch points of consecutive gaps on each wrap; each span a
    straight line of a whole number of link pitches on the bridge of its two pitch
    polygons; every pair of consecutive rollers, the closing pair included, ``link_pitch``
    apart (to rounding). The take-up sprocket moves along the outward bisector of its two
    spans by what closes the loop (a fraction of a pitch for the default ``n_links``).

    Args:
        pitch: chain pitch p [m], > 0.
        teeth: (N,) tooth counts, each in [7, 250]; sprocket 0 drives.
        centres: (N, 2) axis positions [m], in the order the chain passes them,
            counter-clockwise round the loop.
        outside: indices (in [1, N − 1]) of the sprockets outside the loop, idlers on the
            chain's back, wrapped clockwise.
        n_links: even number of links; default the even count nearest the belt length over
            the pitch circles at ``centres``, divided by the link pitch.
        link_pitch: roller spacing laid out [m] (default ``pitch``); used for every length,
            pitch radii included (see :mod:`.layout`).
        take_up_sprocket: the sprocket moved to close the loop, in [1, N − 1] (default
            N − 1, the last).
        tip_radii: (N,) tip radii [m] for the overlap check (default Rk + 0.3125·p, the
            ISO 606 largest tip for a roller of 0.625·p).
        roller_radius: [m] a span must pass every other sprocket at least its tip radius
            plus this (default 0.3125·p).

    Raises:
        ValueError: bad counts or lengths; ``teeth``/``centres``/``outside`` mismatched or
            out of range; sprockets whose tip circles overlap; a span cutting through a
            sprocket or crossing another; an order that is not one counter-clockwise loop;
            a wrap of less than one tooth; an odd ``n_links``, or one too small or too
            large for the take-up to close the loop.
    """
    check_length("pitch", pitch)
    if isinstance(teeth, (str, bytes)) or not isinstance(teeth, Sequence | np.ndarray):
        raise ValueError(f"teeth must be a sequence of tooth counts, got {teeth!r}")
    n = len(teeth)
    if n < 2:
        raise ValueError(f"teeth must hold at least 2 tooth counts (driver, driven), got {n}")
    teeth = tuple(check_teeth(f"teeth[{k}]", z) for k, z in enumerate(teeth))
    centres = as_centres(centres, n)
    outside = as_outside(outside, n)
    lp = check_length("link_pitch", pitch if link_pitch is None else link_pitch)
    m = n - 1 if take_up_sprocket is None else take_up_sprocket
    m = check_count("take_up_sprocket", m, 1, n - 1, " (a driven sprocket; 0 drives)")
    sense = np.array([-1 if k in outside else 1 for k in range(n)])
    loop = _Loop(lp, teeth, sense)
    tips = _radii("tip_radii", tip_radii, loop.r + 0.3125 * pitch, n)
    if roller_radius is None:
        roller_radius = 0.3125 * pitch
    reach = tips + check_length("roller_radius", roller_radius)

    _check_overlap(centres, tips, "centres: ")
    circ = Circles(centres, loop.r, sense)
    if not circ.ok:  # pragma: no cover - tip circles apart: every tangent exists
        raise ValueError("centres: two consecutive sprockets have no common tangent")
    _check_circles(circ, teeth, sense, "centres: ")
    _check_spans(circ.t_out, np.roll(circ.t_in, -1, axis=0), centres, reach, sense, "centres: ")
    if n_links is None:
        n_links = 2 * round(circ.length / (2 * lp))
    n_links = check_count("n_links", n_links, 2)
    if n_links % 2:
        raise ValueError(
            f"n_links must be even (a roller chain without an offset link has an even "
            f"number of links), got {n_links}"
        )
    push = 0.5 * (circ.direction[m - 1] - circ.direction[m])
    if np.linalg.norm(push) < _MIN_TURN:
        raise ValueError(
            f"take_up_sprocket={m}: the chain turns by only "
            f"{math.degrees(circ.arc[m]):.3g}° there, so moving it hardly changes the length "
            "of chain it needs; choose a sprocket with a larger wrap"
        )
    direction = _unit(push)

    # step 2: the spans away from the take-up made whole, forward and backward from θ0 = 0
    thetas = np.zeros(n)
    for j in range(m - 1):
        thetas[j + 1] = loop.whole(j, j + 1, thetas, centres)
    for j in range(n - 1, m, -1):
        thetas[j] = loop.whole(j, j, thetas, centres)

    # step 3: the take-up's shift s closes the loop
    def moved(s):
        c = centres.copy()
        c[m] = c[m] + s * direction
        return c

    def excess(s):  # needed length minus n_links·p_l, in pitches; None: not a loop there
        c = moved(s)
        circ_s = Circles(c, loop.r, sense)
        if not circ_s.ok or abs(circ_s.turning - 2 * math.pi) > 1e-6:
            return None
        if np.any(circ_s.arc < 2 * math.pi / np.asarray(teeth)):
            return None
        t = thetas.copy()
        try:
            t[m] = loop.whole(m - 1, m, t, c)
            return loop.needed(t, c)[0] / lp - n_links
        except _Bad:
            return None

    lo, hi = _shift_limits(centres, tips, m, direction, n_links * lp)
    s_root = _closing_shift(excess, lo, hi, lp, 2 * float(np.linalg.norm(push)), n_links, m)
    c = moved(s_root)
    t = thetas.copy()
    t[m] = loop.whole(m - 1, m, t, c)
    length, spans, wraps = loop.needed(t, c)
    return _assemble(loop, t, c, spans, wraps, n_links, m, direction, s_root, tips, reach)


def _shift_limits(centres, tips, m, direction, cap):
    """Shifts of sprocket m along ``direction`` that keep its tip circle off the others'."""
    lo, hi = -cap, cap
    for j in range(len(centres)):
        if j == m:
            continue
        e = centres[m] - centres[j]
        b = float(e @ direction)
        disc = b * b - float(e @ e) + (tips[m] + tips[j]) ** 2
        if disc <= 0:
            continue
        s1, s2 = -b - math.sqrt(disc), -b + math.sqrt(disc)
        if s2 <= 0:
            lo = max(lo, s2)
        elif s1 >= 0:
            hi = min(hi, s1)
    return lo, hi


def _closing_shift(excess, lo, hi, lp, slope, n_links, m) -> float:
    """Root of ``excess`` (pitches, ≈ slope·s/p_l) in (lo, hi), bracketed from s = 0 by
    steps toward it; where ``excess`` is None (no loop there) the search closes in."""
    g0 = excess(0.0)
    if g0 is None:  # pragma: no cover - the nominal layout was checked
        raise RuntimeError("the nominal layout has no length")
    if g0 == 0:
        return 0.0
    sign = -1.0 if g0 > 0 else 1.0
    limit = lo if sign < 0 else hi
    a, ga, b = 0.0, g0, None
    for _ in range(400):
        if b is None:
            b = a + sign * (abs(ga) * lp / slope * 1.25 + 0.05 * lp)
            if sign * (b - limit) >= 0:
                b = limit - sign * 1e-6 * lp
        gb = excess(b)
        if gb is None:  # not a loop at b: the limit lies between a and b
            limit = b
            if abs(limit - a) < 1e-3 * lp:
                break
            b = 0.5 * (a + limit)
            continue
        if ga * gb <= 0:
            return float(brentq(excess, min(a, b), max(a, b), xtol=1e-14 * lp, rtol=1e-15))
        if abs(b - limit) <= 2e-6 * lp:
            a, ga = b, gb
            break
        a, ga, b = b, gb, None
    few = g0 > 0
    reach = ga + n_links  # links needed at the farthest shift that is still a loop
    bound = 2 * math.ceil(reach / 2 - 1e-9) if few else 2 * math.floor(reach / 2 + 1e-9)
    raise ValueError(
        f"n_links={n_links} is too {'few' if few else 'many'} to close this loop: at the "
        f"centres given the chain needs {g0 + n_links:.2f} links, and the take-up sprocket "
        f"{m} can move {'inward' if few else 'outward'} only {abs(a) * 1e3:.4g} mm (then it "
        "meets another sprocket, or the chain wraps a sprocket by less than a tooth); use "
        f"an even n_links {'>=' if few else '<='} {bound}, or move the sprockets"
    )


def _assemble(loop, thetas, centres, spans, wraps, n_links, m, direction, shift, tips, reach):
    """Rollers in the order of travel; checks of the closed loop."""
    lp, n = loop.lp, loop.n
    counts = []
    for j, (_, _, length) in enumerate(spans):
        k = round(length / lp)
        if k < 1 or abs(length - k * lp) > 1e-9 * lp:  # pragma: no cover - by construction
            raise RuntimeError(f"internal error: span {j} is {length / lp!r} pitches")
        counts.append(k)
    rollers, sprocket_of, gap_of = [], [], []
    starts, ends = [], []
    for k in range(n):
        pts = loop.points(k, thetas[k], centres[k])
        gaps = (spans[(k - 1) % n][1] + loop.s[k] * np.arange(wraps[k])) % loop.z[k]
        rollers.append(pts[gaps])
        sprocket_of.append(np.full(wraps[k], k))
        gap_of.append(gaps)
        nxt = (k + 1) % n
        a = pts[spans[k][0]]
        b = loop.points(nxt, thetas[nxt], centres[nxt])[spans[k][1]]
        starts.append(a)
        ends.append(b)
        t = (np.arange(1, counts[k]) / counts[k])[:, None]
        rollers.append(a + t * (b - a))
        sprocket_of.append(np.full(counts[k] - 1, -1))
        gap_of.append(np.full(counts[k] - 1, -1))
    rollers = np.concatenate(rollers)
    if len(rollers) != n_links:  # pragma: no cover - the root find closes the length
        raise RuntimeError(f"internal error: {len(rollers)} rollers for {n_links} links")
    what = f"n_links={n_links} (sprocket {m} moved {shift * 1e3:.4g} mm to close the loop): "
    _check_overlap(centres, tips, what)
    _check_spans(np.array(starts), np.array(ends), centres, reach, loop.s, what)
    step = np.roll(rollers, -1, axis=0) - rollers
    turn = np.arctan2(
        _cross(step, np.roll(step, -1, axis=0)), np.sum(step * np.roll(step, -1, 0), -1)
    )
    if abs(float(np.sum(turn)) - 2 * math.pi) > 1e-6:  # pragma: no cover - checked on circles
        raise ValueError(f"{what}the chain does not form one counter-clockwise loop")
    u = [_unit(e - s) for s, e in zip(starts, ends, strict=True)]
    return LoopLayout(
        n_links=int(n_links),
        rollers=rollers,
        centres=np.array(centres, dtype=float),
        theta=np.array(thetas, dtype=float),
        teeth=np.array(loop.z),
        sense=np.array(loop.s),
        sprocket_of=np.concatenate(sprocket_of),
        gap_of=np.concatenate(gap_of),
        wrap=np.array(wraps),
        span=np.array(counts),
        take_up=int(m),
        take_up_direction=np.array(direction, dtype=float),
        take_up_shift=float(shift),
        take_up_vector=0.5 * (u[m - 1] - u[m]),
        link_pitch=float(lp),
    )
