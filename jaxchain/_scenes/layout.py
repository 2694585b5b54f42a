"""Initial configurations of roller-chain drives (set-up code: NumPy, not traced).

Geometry (SI units, world frame). A sprocket with z teeth and rotation angle θ has its
tooth gap k centred on the ray at world angle θ + 2πk/z from its axis. The *pitch point*
of gap k, where a seated roller's centre sits, lies on that ray at the pitch radius

    R = p_l / (2 sin(π/z)),

so consecutive pitch points are exactly one link pitch p_l apart: the pitch points of a
sprocket are the vertices of a regular z-gon, its *pitch polygon*. Rollers are points
(their centres); consecutive rollers are one link pitch apart (straight-line distance).

Link pitch. ``link_pitch`` (default ``pitch``) is the roller spacing laid out, e.g. a bit
more than the sprockets' pitch for a chain stretched by its pretension. *Every* length of
the layout uses it, pitch radii included, so the layout is exact: it is the layout of a
chain of pitch p_l on sprockets with the same tooth counts. Against the true sprockets
(pitch p) the seated rollers then sit (p_l − p)/(2 sin(π/z)) radially outside the pitch
circle, riding high in their gaps as an elongated chain does. ``pitch`` itself only sets
the default and the error messages.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._profiles.base import MAX_TEETH, MIN_TEETH

__all__ = [
    "DriveLayout",
    "LoopLayout",
    "StrandLayout",
    "closed_drive_layout",
    "strand_layout",
    "transport_velocity",
]


def brentq(f, a: float, b: float, **options) -> float:
    """SciPy's Brent root find on [a, b], SciPy imported at the first call (its import
    takes 0.2 s, and a strand's layout needs no root find)."""
    from scipy.optimize import brentq as brent

    return brent(f, a, b, **options)


_TOL = 1e-9  # "on a line" / "on the right side" tolerance, relative to the link pitch


class DriveLayout(NamedTuple):
    """A closed chain over a driver (axis at the origin) and a driven sprocket (axis at
    (C, 0)). Rollers are ordered along the chain in the direction it travels when the
    driver turns counter-clockwise: from the driver's first seated roller at the top-span
    end, CCW round the driver, along the bottom span, CCW round the driven sprocket, and
    back along the top span.

    Attributes:
        centre_distance: C [m], the exact closing centre distance.
        n_links: number of rollers (= pitches) of the loop, even.
        rollers: (n_links, 2) roller centres, world frame [m].
        theta: (2,) sprocket angles θ1, θ2 [rad]: gap k of sprocket i is centred at world
            angle θi + 2πk/zi about its axis.
        sprocket_of: (n_links,) 0 seated on the driver, 1 on the driven sprocket, −1 on a
            span.
        gap_of: (n_links,) the gap a seated roller sits in, −1 on a span.
        wrap: (2,) number of seated rollers on the driver and on the driven sprocket.
        span: (2,) number of pitches of the bottom and of the top span (equal: the layout
            is symmetric about the x axis).
    """

    centre_distance: float
    n_links: int
    rollers: np.ndarray
    theta: np.ndarray
    sprocket_of: np.ndarray
    gap_of: np.ndarray
    wrap: np.ndarray
    span: np.ndarray


class LoopLayout(NamedTuple):
    """A closed chain over N sprockets, run as one counter-clockwise loop through them in
    the order given (built by :func:`~jaxchain.scenes.loop_layout`). Sprocket 0 drives;
    span j runs from sprocket j to sprocket j + 1 (mod N). Rollers are ordered along the
    chain in its direction of travel: from the first seated roller of sprocket 0 round
    its wrap, along span 0, round sprocket 1, and so on back to sprocket 0.

    Attributes:
        n_links: number of rollers (= pitches) of the loop, even.
        rollers: (n_links, 2) roller centres, world frame [m].
        centres: (N, 2) sprocket axes [m]: the ones given, the take-up's moved to close.
        theta: (N,) sprocket angles [rad]: gap k of sprocket i is centred at world angle
            θi + 2πk/zi about its axis.
        teeth: (N,) tooth counts.
        sense: (N,) +1 for a sprocket inside the loop (wrapped counter-clockwise), −1 for
            one outside it (an idler on the chain's back, wrapped clockwise).
        sprocket_of: (n_links,) the sprocket a roller is seated on, −1 on a span.
        gap_of: (n_links,) the gap a seated roller sits in, −1 on a span.
        wrap: (N,) seated rollers on each sprocket (≥ 1).
        span: (N,) link pitches of each span (≥ 1).
        take_up: index of the sprocket moved to close the loop (the take-up sprocket).
        take_up_direction: (2,) unit direction it moved along: the outward bisector of
            its two spans (moving along it lengthens both).
        take_up_shift: how far it moved [m] (negative: inward).
        take_up_vector: (2,) the force on the take-up axis per newton of a take-up that
            leaves take_up/2 in each of its spans: (u_in − u_out)/2, u the unit
            directions of travel of its arriving and departing spans, |·| = cos α with 2α
            the angle between the spans seen from the sprocket.
        link_pitch: roller spacing laid out [m].
    """

    n_links: int
    rollers: np.ndarray
    centres: np.ndarray
    theta: np.ndarray
    teeth: np.ndarray
    sense: np.ndarray
    sprocket_of: np.ndarray
    gap_of: np.ndarray
    wrap: np.ndarray
    span: np.ndarray
    take_up: int
    take_up_direction: np.ndarray
    take_up_shift: float
    take_up_vector: np.ndarray
    link_pitch: float


class StrandLayout(NamedTuple):
    """An open strand over one sprocket (axis at the origin), ordered along the direction
    of travel for a counter-clockwise sprocket: entry span (far end first), seated rollers,
    exit span.

    Attributes:
        rollers: (n, 2) roller centres [m], n = n_entry + wrap + n_exit.
        sprocket_of: (n,) 0 seated, −1 on a span.
        gap_of: (n,) gap of a seated roller (0 … wrap − 1, CCW), −1 on a span.
        theta: sprocket angle [rad]: gap k is centred at world angle θ + 2πk/z.
        entry_dir: (2,) unit direction of the entry span, pointing away from the sprocket.
        exit_dir: (2,) unit direction of the exit span, pointing away from the sprocket.
    """

    rollers: np.ndarray
    sprocket_of: np.ndarray
    gap_of: np.ndarray
    theta: float
    entry_dir: np.ndarray
    exit_dir: np.ndarray


# ----------------------------------------------------------------------------- checks
def check_teeth(name: str, z) -> int:
    if (
        isinstance(z, bool)
        or not isinstance(z, (int, np.integer))
        or not (MIN_TEETH <= z <= MAX_TEETH)
    ):
        raise ValueError(f"{name} must be an integer in [{MIN_TEETH}, {MAX_TEETH}], got {z!r}")
    return int(z)


def check_length(name: str, x) -> float:
    x = float(x)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name} must be a finite length > 0 m, got {x!r}")
    return x


def check_count(name: str, n, lo: int, hi: int | None = None, why: str = "") -> int:
    ok = not isinstance(n, bool) and isinstance(n, (int, np.integer))
    ok = ok and n >= lo and (hi is None or n <= hi)
    if not ok:
        rng = f"[{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise ValueError(f"{name} must be an integer {rng}{why}, got {n!r}")
    return int(n)


def chain_pitch_radius(link_pitch: float, z: int) -> float:
    """R = p_l / (2 sin(π/z)): radius of the pitch points [m]."""
    return link_pitch / (2 * math.sin(math.pi / z))


def _pitch_points(link_pitch: float, z: int, theta: float) -> np.ndarray:
    """(z, 2) pitch points of gaps 0 … z − 1 about the sprocket's own axis [m]."""
    a = theta + 2 * math.pi * np.arange(z) / z
    return chain_pitch_radius(link_pitch, z) * np.stack([np.cos(a), np.sin(a)], -1)


def _angle_from(x: float, lo: float) -> float:
    """x reduced to [lo, lo + 2π)."""
    return lo + (x - lo) % (2 * math.pi)


# ------------------------------------------------------------------ closed drive
class _Closure(NamedTuple):
    c: float  # exact centre distance
    a: int  # driver gap of the top span's driver end A
    b: int  # driven gap of the top span's driven end B
    wrap1: int
    wrap2: int
    n_top: int  # pitches of each span


class _Family:
    """Configurations symmetric about the x axis with fixed sprocket angles (θ1, θ2), each
    0 or π/z (a pitch point on the axis, or the axis midway between two); only the centre
    distance C varies.

    The top span runs from the driven sprocket's pitch point B to the driver's pitch point A
    where (A, B) is the *upper bridge* of the two pitch polygons: the common supporting line
    with both polygons below it (the chain cannot cut a sprocket). Where a polygon edge lies
    on that line, A is its end nearer B and B the end nearer A: every pitch point on the
    line is seated. The bottom span is its mirror image, so the wraps are

        wrap1 = z1 (π − φA)/π + 1,   wrap2 = z2 ψB/π + 1,

    with φA, ψB the angles of A and B about their axes, and the loop needs the length
    L(C) = (wrap1 + wrap2 − 2)·p_l + 2|AB|: continuous (where the bridge jumps to the next
    vertex, |AB| changes by p_l and each wrap by one) and increasing in C.
    """

    def __init__(self, lp: float, z1: int, z2: int, th1: float, th2: float):
        self.lp, self.z1, self.z2, self.th1, self.th2 = lp, z1, z2, th1, th2
        self.r1, self.r2 = chain_pitch_radius(lp, z1), chain_pitch_radius(lp, z2)
        self.p1 = _pitch_points(lp, z1, th1)
        self.p2 = _pitch_points(lp, z2, th2)  # about the driven axis
        self._l1, self._l2 = self.p1.tolist(), self.p2.tolist()

    def bridge(self, c: float) -> tuple[int, int]:
        """Gaps (a, b) of the upper bridge at centre distance c: start at the pitch points
        nearest the circles' common tangent and climb (the merge step of a convex hull:
        move an end to a neighbour lying above the line, until none does)."""
        z1, z2, lp = self.z1, self.z2, self.lp
        l1 = self._l1
        l2 = [(x + c, y) for x, y in self._l2]  # driven pitch points, world frame
        ang = math.pi / 2 + math.asin(max(-1.0, min(1.0, (self.r2 - self.r1) / c)))
        a = round((ang - self.th1) * z1 / (2 * math.pi)) % z1
        b = round((ang - self.th2) * z2 / (2 * math.pi)) % z2

        def height(p):  # |AB| × (height of p above the line AB)
            (ax, ay), (bx, by) = l1[a], l2[b]
            return (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax)

        for _ in range(z1 + z2 + 4):
            tol = _TOL * lp * math.dist(l1[a], l2[b])
            up1 = [k for k in ((a + 1) % z1, (a - 1) % z1) if height(l1[k]) > tol]
            up2 = [k for k in ((b + 1) % z2, (b - 1) % z2) if height(l2[k]) > tol]
            if up1:
                a = up1[0]
            elif up2:
                b = up2[0]
            else:
                break
        else:  # pragma: no cover - the climb is monotone
            raise RuntimeError("upper bridge search did not converge")
        # seat every pitch point on the line: move A right along it, B left along it
        for _ in range(z1):
            k = max((a + 1) % z1, (a - 1) % z1, key=lambda k: l1[k][0])
            if not (l1[k][0] > l1[a][0] and abs(height(l1[k])) <= tol):
                break
            a = k
        for _ in range(z2):
            k = min((b + 1) % z2, (b - 1) % z2, key=lambda k: l2[k][0])
            if not (l2[k][0] < l2[b][0] and abs(height(l2[k])) <= tol):
                break
            b = k
        return a, b

    def wraps(self, a: int, b: int) -> tuple[int, int]:
        """Seated rollers on the driver (A round the left to its mirror image) and on the
        driven sprocket (B's mirror image round the right to B)."""
        phi = _angle_from(self.th1 + 2 * math.pi * a / self.z1, -math.pi / 2)
        psi = _angle_from(self.th2 + 2 * math.pi * b / self.z2, -math.pi / 2)
        return round(self.z1 * (math.pi - phi) / math.pi) + 1, round(self.z2 * psi / math.pi) + 1

    def length(self, c: float) -> float:
        """L(C): length of chain [m] the family's configuration needs at centre distance c."""
        a, b = self.bridge(c)
        w1, w2 = self.wraps(a, b)
        (ax, ay), (bx, by) = self._l1[a], self._l2[b]
        return (w1 + w2 - 2) * self.lp + 2 * math.hypot(bx + c - ax, by - ay)

    def closure(self, n: int, c_min: float) -> _Closure | None:
        """The configuration closing with n links (None if it needs C < c_min or wraps a
        sprocket by less than one roller). L(C) = n·p_l is solved by a bracketing root
        find, which fixes A, B and the wraps; then C is exact: |A − B(C)| = n_top·p_l."""
        lp = self.lp
        f = lambda c: self.length(c) / lp - n  # noqa: E731
        if f(c_min) > 1e-12:
            return None
        c_hi = n * lp / 2 + self.r1 + self.r2 + lp  # L(C) ≥ 2|AB| ≥ 2(C − R1 − R2) > n·p_l
        c = brentq(f, c_min, c_hi, xtol=1e-15 * c_hi, rtol=1e-15, maxiter=200)
        a, b = self.bridge(c)
        w1, w2 = self.wraps(a, b)
        if w1 < 1 or w2 < 1:
            return None
        twice = n - w1 - w2 + 2
        if twice < 2 or twice % 2:  # pragma: no cover - parity is set by the family
            raise RuntimeError(f"internal error: span of {twice}/2 pitches")
        n_top = twice // 2
        (ax, ay), (bx, by) = self._l1[a], self._l2[b]
        c_exact = ax - bx + math.sqrt((n_top * lp) ** 2 - (by - ay) ** 2)
        a_pt, b_pt = self.p1[a], self.p2[b] + np.array([c_exact, 0.0])
        u = b_pt - a_pt
        pts = np.concatenate([self.p1, self.p2 + np.array([c_exact, 0.0])]) - a_pt
        height = (u[0] * pts[:, 1] - u[1] * pts[:, 0]) / np.linalg.norm(u)
        if abs(c_exact - c) > 1e-6 * lp or height.max() > _TOL * lp:  # pragma: no cover
            raise RuntimeError("internal error: the closing span is not a supporting line")
        return _Closure(c_exact, a, b, w1, w2, n_top)


def _families(lp: float, z1: int, z2: int) -> list[_Family]:
    """The two symmetric families with an even link count. A loop reflected in the x axis
    keeps two rollers on the axis or none; the driven sprocket has one there iff θ2 = 0,
    the driver iff (θ1 = 0) == (z1 even). Order: θ2 = 0 first (the tie-break)."""
    h1, h2 = math.pi / z1, math.pi / z2
    th1 = 0.0 if z1 % 2 == 0 else h1
    return [_Family(lp, z1, z2, th1, 0.0), _Family(lp, z1, z2, h1 - th1, h2)]


def _even_ceil(x: float) -> int:
    return 2 * math.ceil(x / 2 - 1e-9)


def _best_closure(fams, n: int, c_min: float) -> tuple[_Family, _Closure] | None:
    """Of the families' closures with n links, the one with the larger centre distance
    (the one a chain pulled taut between free sprockets settles into); ties: the first."""
    best = None
    for fam in fams:
        cl = fam.closure(n, c_min)
        if cl is not None and (best is None or cl.c > best[1].c + _TOL * fam.lp):
            best = (fam, cl)
    return best


def closed_drive_layout(
    pitch: float,
    z1: int,
    z2: int,
    *,
    centre_distance: float | None = None,
    n_links: int | None = None,
    link_pitch: float | None = None,
) -> DriveLayout:
    """A closed (open-belt) chain over a driver (z1 teeth, axis at the origin) and a driven
    sprocket (z2 teeth, axis at (C, 0), C > 0), in an exactly closing configuration.

    Rollers on each wrap arc sit at the pitch points of consecutive gaps; each span is a
    straight line of a whole number of pitches from the last seated roller on one sprocket
    to the first on the other, with its rollers equally spaced: every pair of consecutive
    rollers, the closing pair included, is ``link_pitch`` apart (to rounding).

    The configuration is symmetric about the x axis (each sprocket has a pitch point on
    the axis or the axis midway between two; the two spans are mirror images). Each span
    lies on the *upper (lower) bridge* of the pitch polygons: their common supporting line
    (no pitch point of either sprocket lies beyond it, so the chain does not cut through a
    sprocket), its ends the outermost pitch points on it, which fixes the wraps. The
    centre distance is the root of "chain length needed = n_links·link_pitch" (a 1-D root
    find that settles the span ends), then solved exactly for the span of whole pitches.
    Two symmetric families give an even link count; of their two closing centre distances
    the larger is used.

    Args:
        pitch: chain pitch p [m], > 0.
        z1, z2: driver and driven tooth counts, in [7, 250].
        centre_distance: requested C [m]; the returned C is the closing one of the even
            link count whose closing C is nearest (it differs by a fraction of a pitch).
        n_links: even number of links (a chain without an offset link has an even count).
            Give exactly one of ``centre_distance`` and ``n_links``.
        link_pitch: roller spacing laid out [m] (default ``pitch``); used for every length,
            pitch radii included (see the module docstring).

    Raises:
        ValueError: bad tooth counts or lengths, both or neither of ``centre_distance`` /
            ``n_links``, an odd ``n_links``, a centre distance below R1 + R2 + p (the
            pitch radii plus one pitch), or a link count too small to wrap both sprockets
            at such a centre distance.
    """
    check_length("pitch", pitch)
    z1 = check_teeth("z1", z1)
    z2 = check_teeth("z2", z2)
    lp = check_length("link_pitch", pitch if link_pitch is None else link_pitch)
    if (centre_distance is None) == (n_links is None):
        got = "neither" if centre_distance is None else "both"
        raise ValueError(f"give exactly one of centre_distance and n_links, got {got}")
    r1, r2 = chain_pitch_radius(lp, z1), chain_pitch_radius(lp, z2)
    c_min = r1 + r2 + lp
    fams = _families(lp, z1, z2)
    n_min = min(_even_ceil(f.length(c_min) / lp) for f in fams)
    if n_links is not None:
        n = check_count(
            "n_links", n_links, n_min, why=f" for z1={z1}, z2={z2} (to wrap both sprockets)"
        )
        if n % 2:
            raise ValueError(
                f"n_links must be even (a roller chain without an offset link has an even "
                f"number of links), got {n}"
            )
        best = _best_closure(fams, n, c_min)
    else:
        c_req = float(centre_distance)
        if not (math.isfinite(c_req) and c_req >= c_min):
            raise ValueError(
                f"centre_distance must be >= R1 + R2 + p = {c_min:.6g} m for z1={z1}, z2={z2},"
                f" p={lp:.6g} m (the pitch radii plus one link pitch), got {centre_distance!r}"
            )
        m = [f.length(c_req) / lp for f in fams]  # closes at C_req with m links (not integer)
        lo = max(n_min, _even_ceil(min(m)) - 4)
        cands = [_best_closure(fams, n, c_min) for n in range(lo, _even_ceil(max(m)) + 5, 2)]
        cands = [x for x in cands if x is not None]
        best = min(cands, key=lambda x: abs(x[1].c - c_req)) if cands else None
    if best is None:  # pragma: no cover - defensive: for C >= R1 + R2 + p every wrap >= 1
        raise ValueError(
            f"at this centre distance the chain would wrap less than one tooth of a sprocket "
            f"(z1={z1}, z2={z2}); increase centre_distance or n_links"
        )
    return _assemble(*best)


def _assemble(fam: _Family, cl: _Closure) -> DriveLayout:
    """Rollers in the order of travel for a CCW driver; span rollers by equal division."""
    z1, z2, c = fam.z1, fam.z2, cl.c
    p2 = fam.p2 + np.array([c, 0.0])
    g1 = (cl.a + np.arange(cl.wrap1)) % z1  # A round the left to A' (mirror of A)
    g2 = (cl.b - cl.wrap2 + 1 + np.arange(cl.wrap2)) % z2  # B' round the right to B
    t = (np.arange(1, cl.n_top) / cl.n_top)[:, None]
    a_end, b_end = fam.p1[g1[-1]], p2[g2[0]]
    bottom = a_end + t * (b_end - a_end)
    top = p2[cl.b] + t * (fam.p1[cl.a] - p2[cl.b])
    rollers = np.concatenate([fam.p1[g1], bottom, p2[g2], top])
    span = np.full(cl.n_top - 1, -1)
    sprocket_of = np.concatenate([np.zeros(cl.wrap1, int), span, np.ones(cl.wrap2, int), span])
    gap_of = np.concatenate([g1, span, g2, span])
    return DriveLayout(
        centre_distance=float(c),
        n_links=len(rollers),
        rollers=rollers,
        theta=np.array([fam.th1, fam.th2]),
        sprocket_of=sprocket_of,
        gap_of=gap_of,
        wrap=np.array([cl.wrap1, cl.wrap2]),
        span=np.array([cl.n_top, cl.n_top]),
    )


def transport_velocity(
    layout: DriveLayout | LoopLayout, omega1: float, z1: int | None = None, z2: int | None = None
) -> np.ndarray:
    """(n_links, 2) roller velocities [m/s] of rigid transport at driver speed ``omega1``
    [rad/s] (CCW > 0), every other sprocket k turning at ωk = ±ω1·z1/zk (minus for one
    outside the loop, which turns clockwise). For a :class:`DriveLayout` give the tooth
    counts ``z1``, ``z2``; a :class:`LoopLayout` carries its own (leave them out).

    Seated rollers move with their sprocket: v = ω × (x − axis). Span rollers get the
    velocity interpolated linearly (by index, i.e. by arc length) between the span's two
    end rollers. That is not exactly rigid: the end velocities' components along the span
    differ (the polygonal effect: ω1 R1 cos γ1 ≠ ω2 R2 cos γ2, γ the angle between the
    span and the sprocket tangent at its end), so the span's links start with a small
    rate of stretch, at most that difference divided by the span's pitch count.
    """
    if isinstance(layout, LoopLayout):
        if z1 is not None or z2 is not None:
            raise ValueError(
                "transport_velocity: a LoopLayout carries its tooth counts; leave z1 and z2 out"
            )
        teeth = np.asarray(layout.teeth)
        omegas = tuple(
            float(omega1) * int(teeth[0]) / int(z) * int(s)
            for z, s in zip(teeth, layout.sense, strict=True)
        )
        return _rigid_transport(layout.rollers, layout.sprocket_of, layout.centres, omegas)
    z1 = check_teeth("z1", z1)
    z2 = check_teeth("z2", z2)
    axes = np.array([[0.0, 0.0], [float(layout.centre_distance), 0.0]])
    omegas = (float(omega1), float(omega1) * z1 / z2)
    return _rigid_transport(layout.rollers, layout.sprocket_of, axes, omegas)


def _rigid_transport(rollers, sprocket_of, axes, omegas) -> np.ndarray:
    """Seated rollers turning with their sprocket (axes (S, 2), speeds omegas (S,)), span
    rollers interpolated by index between their span's end rollers."""
    x = np.asarray(rollers, dtype=float)
    sof = np.asarray(sprocket_of)
    n = len(x)
    v = np.zeros_like(x)
    for s in range(len(omegas)):
        r = x[sof == s] - axes[s]
        v[sof == s] = omegas[s] * np.stack([-r[:, 1], r[:, 0]], -1)
    seated = np.nonzero(sof >= 0)[0]
    if len(seated) == 0:
        raise ValueError("layout has no seated roller: spans have no ends to move with")
    for i, j in zip(seated, np.roll(seated, -1), strict=True):
        gap = (j - i) % n or n  # pitches from seated roller i to the next seated j
        idx = (i + np.arange(1, gap)) % n
        t = (np.arange(1, gap) / gap)[:, None]
        v[idx] = v[i] + t * (v[j] - v[i])
    return v


# ------------------------------------------------------------------------ strand
def strand_layout(
    pitch: float,
    z: int,
    *,
    wrap: int,
    n_entry: int,
    n_exit: int,
    theta: float = 0.0,
    link_pitch: float | None = None,
) -> StrandLayout:
    """An open strand over one sprocket (axis at the origin): ``wrap`` rollers seated in
    consecutive gaps, centred on the top of the sprocket (symmetric about the +y axis), and
    two straight spans continuing the end chords of the wrap arc.

    A counter-clockwise sprocket draws the chain in on the right (+x) side, the *entry*
    span, and lets it out on the left, the *exit* span. Each span is the straight
    continuation of the chord between the two seated rollers at its end (the strand is
    straight through the last seated roller, and the span lies on that edge of the pitch
    polygon, a supporting line: it does not cut the sprocket). Rollers are ordered along
    the direction of travel: entry span far end first, seated rollers CCW, exit span.

    Args:
        pitch: chain pitch p [m], > 0.
        z: tooth count, in [7, 250].
        wrap: seated rollers, in [2, z − 1].
        n_entry, n_exit: rollers on the entry and exit spans, >= 1 each.
        theta: rotation [rad] of the whole layout (sprocket and strand) about the axis,
            CCW; 0 centres the wrap on +y. (The returned ``theta`` is the sprocket angle.)
        link_pitch: roller spacing laid out [m] (default ``pitch``); used for every length,
            pitch radius included (see the module docstring).

    For wrap >= z/2 + 2 the spans converge below the sprocket, and long ones cross.
    """
    check_length("pitch", pitch)
    z = check_teeth("z", z)
    wrap = check_count("wrap", wrap, 2, z - 1, f" (2 to z - 1 seated rollers, z={z})")
    n_entry = check_count("n_entry", n_entry, 1)
    n_exit = check_count("n_exit", n_exit, 1)
    lp = check_length("link_pitch", pitch if link_pitch is None else link_pitch)
    theta = float(theta)
    if not math.isfinite(theta):
        raise ValueError(f"theta must be a finite angle in rad, got {theta!r}")
    th = theta + math.pi / 2 - (wrap - 1) * math.pi / z  # sprocket angle: gap 0 = first seat
    seated = _pitch_points(lp, z, th)[:wrap]
    entry_dir = seated[0] - seated[1]
    entry_dir /= np.linalg.norm(entry_dir)
    exit_dir = seated[-1] - seated[-2]
    exit_dir /= np.linalg.norm(exit_dir)
    entry = seated[0] + lp * np.arange(n_entry, 0, -1)[:, None] * entry_dir
    exit_ = seated[-1] + lp * np.arange(1, n_exit + 1)[:, None] * exit_dir
    span = lambda k: np.full(k, -1)  # noqa: E731
    return StrandLayout(
        rollers=np.concatenate([entry, seated, exit_]),
        sprocket_of=np.concatenate([span(n_entry), np.zeros(wrap, int), span(n_exit)]),
        gap_of=np.concatenate([span(n_entry), np.arange(wrap), span(n_exit)]),
        theta=math.remainder(th, 2 * math.pi),
        entry_dir=entry_dir,
        exit_dir=exit_dir,
    )
