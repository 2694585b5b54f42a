"""Free-form tooth profiles (asymmetric arc-spline flanks, per-gap patterns): the ISO forms
as special cases, hand-derived depths, brute-force distance to an outline built here
from the definition, continuity across every boundary, gradients against central
differences, symmetries, validation, and scenes built on them."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from jax.flatten_util import ravel_pytree
from matplotlib.path import Path
from scipy.spatial import cKDTree

import jaxchain as jc
from jaxchain._profiles.freeform_shape import with_table

from helpers import modelled

CH = jc.ChainSpec.iso606("08B")
Z = 18
ISO = jc.ToothProfile.iso606(CH, Z, "mid")
RE = float(ISO.flank_radius)
HALF = float(ISO.seating_angle) / 2

depth_many = jax.jit(jax.vmap(lambda p, x: jc.gap_contact(p, x)[0], (None, 0)))
contact_many = jax.jit(jax.vmap(jc.gap_contact, (None, 0)))
sd_many = jax.jit(jax.vmap(jc.signed_distance, (None, 0)))
_point_grads = jax.jit(jax.vmap(jax.grad(lambda q, x: jc.gap_contact(q, x)[0], 1), (None, 0)))
_param_grads = jax.jit(jax.vmap(jax.grad(lambda q, x: jc.gap_contact(q, x)[0]), (None, 0)))


def ring(p, n, rng, inner=-0.45, outer=0.4):
    """``n`` random points round the whole rim, from inside the roots to outside the tips
    (radial band in pitches about the pitch circle)."""
    r = float(p.pitch_radius) + rng.uniform(inner, outer, n) * float(p.pitch)
    a = rng.uniform(-math.pi, math.pi, n)
    return np.stack([r * np.cos(a), r * np.sin(a)], -1)


def pattern(rng, z=Z, k=3, spread=1.0, symmetric=False):
    """A free-form profile with every leaf per gap (values drawn by ``rng``)."""

    def flank():
        return jc.Flank(
            HALF + spread * rng.uniform(-0.06, 0.06, z),
            (1 / RE) * (1 + spread * rng.uniform(-0.2, 0.25, (z, k))),
            np.sort(rng.uniform(0.15, 0.85, (z, k - 1)), -1),
        )

    cw = flank()
    return jc.FreeformProfile(
        teeth=z,
        pitch=CH.pitch,
        roller_diameter=CH.roller_diameter,
        seating_radius=float(ISO.seating_radius) + spread * rng.uniform(0, 60e-6, z),
        seat_offset=spread * rng.uniform(-40e-6, 40e-6, z),
        phase=spread * rng.uniform(-0.003, 0.003, z),
        tip_diameter=float(ISO.tip_diameter) * 0.99,
        cw=cw,
        ccw=cw if symmetric else flank(),
    )


# ----------------------------------------------------------- outline from the definition
def _side_polyline(c, ri, a, kappa, breaks, ra, ds):
    """One side of a gap (canonical frame: gap axis +x, this side y ≥ 0) sampled every
    ≤ ``ds`` of arc length, by marching the definition: seat arc to the junction, then
    each arc of curvature κ tangent to the last, run until the flank reaches its break
    radius (found by bisection on the arc's angle), ending on the tip circle."""
    t = np.linspace(0, a, max(int(ri * a / ds), 2))
    pts = [c + ri * np.stack([-np.cos(t), np.sin(t)], -1)]
    p = pts[0][-1]
    n = (c - p) / ri * -1.0  # unit normal from the junction toward the flank's centre
    r_j = math.hypot(*p)
    targets = [r_j + b * (ra - r_j) for b in breaks] + [ra]
    for kap, target in zip(kappa, targets, strict=True):
        r = 1.0 / kap
        centre = p + r * n
        a0 = math.atan2(*(p - centre)[::-1])

        def at(phi, centre=centre, r=r, a0=a0):
            return centre + r * np.array([math.cos(a0 + phi), math.sin(a0 + phi)])

        lo, hi = 0.0, 1.0
        while math.hypot(*at(hi)) < target:
            hi *= 1.5
            assert hi < math.pi
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if math.hypot(*at(mid)) < target else (lo, mid)
        phi = a0 + np.linspace(0, hi, max(int(r * hi / ds), 2))[1:]
        pts.append(centre + r * np.stack([np.cos(phi), np.sin(phi)], -1))
        p = at(hi)
        n = (centre - p) / r
    return np.concatenate(pts)


def sprocket_polygon(p, ds):
    """The whole sprocket's closed outline, sampled every ≤ ``ds``, sprocket frame."""
    z = p.teeth
    full = lambda x: np.broadcast_to(np.asarray(x, dtype=float), (z,))  # noqa: E731
    per_gap = lambda x, k: np.broadcast_to(np.asarray(x, dtype=float), (z, k))  # noqa: E731
    R = float(p.pitch) / (2 * math.sin(math.pi / z))
    ri, off, phase = full(p.seating_radius), full(p.seat_offset), full(p.phase)
    ra = float(p.tip_diameter) / 2
    k = p.ccw.curvature.shape[-1]
    gaps = []
    for g in range(z):
        c = np.array([R + off[g], 0.0])
        sides = []
        for f in (p.ccw, p.cw):
            sides.append(
                _side_polyline(
                    c,
                    ri[g],
                    full(f.seat_angle)[g],
                    per_gap(f.curvature, k)[g],
                    per_gap(f.breaks, k - 1)[g],
                    ra,
                    ds,
                )  # fmt: skip
            )
        upper, lower = sides[0], sides[1] * [1.0, -1.0]
        pts = np.concatenate([lower[::-1], upper[1:]])
        t = 2 * math.pi * g / z + phase[g]
        rot = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        gaps.append(pts @ rot.T)
    out = []
    for g in range(z):  # each gap, then the tip circle to the next gap's first point
        out.append(gaps[g])
        a0 = math.atan2(*gaps[g][-1][::-1])
        a1 = math.atan2(*gaps[(g + 1) % z][0][::-1])
        a1 = a0 + (a1 - a0) % (2 * math.pi)
        m = max(int(ra * (a1 - a0) / ds), 2)
        ang = np.linspace(a0, a1, m)[1:-1]
        out.append(ra * np.stack([np.cos(ang), np.sin(ang)], -1))
    poly = np.concatenate(out)
    return np.concatenate([poly, poly[:1]])


def polygon_distance(poly, pts):
    """Signed distance from ``pts`` to the closed polyline ``poly`` (positive outside the
    material): exact segment distances over the segments at the 8 nearest vertices."""
    _, idx = cKDTree(poly[:-1]).query(pts, 8)
    best = np.full(len(pts), np.inf)
    n = len(poly) - 1
    for j in range(8):
        for s in (0, -1):
            i = (idx[:, j] + s) % n
            a, b = poly[i], poly[i + 1]
            ab = b - a
            t = np.clip(np.sum((pts - a) * ab, 1) / np.sum(ab * ab, 1), 0, 1)
            best = np.minimum(best, np.linalg.norm(a + t[:, None] * ab - pts, axis=1))
    inside = Path(poly).contains_points(pts)
    return np.where(inside, -best, best)


DS = 4e-6  # chord error ds²/(8 r) ≤ 4e-10 m for radii ≥ 5 mm, 8e-10 m at the 2.5 mm seat


# --------------------------------------------------------------------------- ISO cases
@jax.jit
def _iso_against_freeform(iso, ff, pts):
    """Largest differences of depth, normal, point gradient and (through from_iso, in the
    ISO parameters) parameter gradient between an ISO profile and its free-form twin."""
    k = ff.arcs

    def depth(p, x):
        return jc.gap_contact(p, x)[0]

    def via(q, x):
        return depth(jc.FreeformProfile.from_iso(q, k), x)

    d0, n0 = jax.vmap(jc.gap_contact, (None, 0))(iso, pts)
    d1, n1 = jax.vmap(jc.gap_contact, (None, 0))(ff, pts)
    g0 = jax.vmap(jax.grad(depth, 1), (None, 0))(iso, pts)
    g1 = jax.vmap(jax.grad(depth, 1), (None, 0))(ff, pts)
    p0 = jax.vmap(jax.grad(depth), (None, 0))(iso, pts)
    p1 = jax.vmap(jax.grad(via), (None, 0))(iso, pts)
    names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")
    param = [
        jnp.max(jnp.abs(getattr(p1, n) - getattr(p0, n)))
        / jnp.maximum(1.0, jnp.max(jnp.abs(getattr(p0, n))))
        for n in names
    ]
    return (
        jnp.max(jnp.abs(d1 - d0)), jnp.max(jnp.abs(n1 - n0)), jnp.max(jnp.abs(g1 - g0)),
        jnp.max(jnp.stack(param)),
    )  # fmt: skip


def test_iso_forms_are_special_cases():
    """from_iso with K = 1 and K = 3 arcs, the ISO min, max and mid forms: the same depth
    (to 1e-12 pitch), normal, point gradient and parameter gradient (through from_iso,
    in the ISO parameters; relative to the largest) as the ISO profile, to 1e-12."""
    pts = jnp.asarray(ring(ISO, 600, np.random.default_rng(18)))
    for form in ("min", "max", "mid"):
        iso = jc.ToothProfile.iso606(CH, Z, form)
        for k in (1, 3):
            dd, dn, dg, dp = (
                float(v)
                for v in _iso_against_freeform(iso, jc.FreeformProfile.from_iso(iso, k), pts)
            )
            assert dd <= 1e-12 * float(CH.pitch) and max(dn, dg, dp) <= 1e-12, (
                form,
                k,
                dd,
                dn,
                dg,
                dp,
            )


@pytest.mark.parametrize("chain, z, form", [("12A", 9, "max"), ("06B", 120, "max")])
def test_iso_forms_of_other_sprockets(chain, z, form):
    """A 9-tooth sprocket and a 120-tooth one whose maximum form's tip is lowered to where
    its flanks meet (a pointed tooth): depth and normal as the ISO profile's."""
    iso = jc.ToothProfile.iso606(jc.ChainSpec.iso606(chain), z, form)
    pts = jnp.asarray(ring(iso, 600, np.random.default_rng(z)))
    d0, n0 = contact_many(iso, pts)
    d1, n1 = contact_many(jc.FreeformProfile.from_iso(iso, 3), pts)
    np.testing.assert_allclose(d1, d0, rtol=0, atol=1e-12 * float(iso.pitch))
    np.testing.assert_allclose(n1, n0, rtol=0, atol=1e-12)


def test_split_flank_is_the_same_outline():
    """An ISO flank split into 3 arcs at any break points reads the same."""
    pts = jnp.asarray(ring(ISO, 400, np.random.default_rng(3)))
    d0 = depth_many(ISO, pts)
    for breaks in ([0.1, 0.2], [0.5, 0.95]):
        ff = jc.FreeformProfile.from_iso(ISO, 3)
        ff = jc.FreeformProfile.from_iso(
            ISO, 3, cw=jc.Flank(ff.cw.seat_angle, ff.cw.curvature, breaks), ccw=ff.ccw
        )
        np.testing.assert_allclose(depth_many(ff, pts), d0, rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- exact values
def test_per_gap_seating_radius_hand_depths():
    """A roller on gap k's axis, δ deeper than gap k's own seat bottom, reads depth δ
    (seat centre on the pitch circle: the bottom at radius R − ri[k])."""
    rng = np.random.default_rng(1)
    ri = float(ISO.seating_radius) + rng.uniform(0, 80e-6, Z)
    p = jc.FreeformProfile.from_iso(ISO, 2, seating_radius=ri)
    R, r = float(ISO.pitch_radius), float(ISO.roller_radius)
    for delta in (-5e-6, 0.0, 1e-6, 2e-5):
        rad = R - (ri - r) - delta
        ang = 2 * np.pi * np.arange(Z) / Z
        pts = jnp.asarray(np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1))
        d, n = contact_many(p, pts)
        np.testing.assert_allclose(d, delta, rtol=0, atol=1e-15)
        np.testing.assert_allclose(n, np.stack([np.cos(ang), np.sin(ang)], -1), atol=1e-12)


def test_phase_and_offset_move_the_seat():
    """Gap k's seat centre at radius R + offset[k], angle 2πk/z + phase[k]: a roller
    touching its bottom there reads depth 0."""
    rng = np.random.default_rng(2)
    off, ph = rng.uniform(-30e-6, 30e-6, Z), rng.uniform(-0.002, 0.002, Z)
    p = jc.FreeformProfile.from_iso(ISO, 1, seat_offset=off, phase=ph)
    R, r, ri = float(ISO.pitch_radius), float(ISO.roller_radius), float(ISO.seating_radius)
    ang = 2 * np.pi * np.arange(Z) / Z + ph
    rad = R + off - (ri - r)
    pts = jnp.asarray(np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1))
    np.testing.assert_allclose(depth_many(p, pts), 0.0, atol=1e-15)
    np.testing.assert_array_equal(
        jax.jit(jax.vmap(jc.nearest_gap, (None, 0)))(p, pts), np.arange(Z)
    )


# --------------------------------------------------------------------------- brute force
@settings(max_examples=12)
@given(seed=st.integers(0, 2**31), spread=st.floats(0.2, 1.0))
def test_property_distance_equals_brute_force(seed, spread):
    """Random valid asymmetric per-gap profiles (K = 3, every leaf per gap): the signed
    distance equals the distance to the outline marched here from the definition, to
    1e-9 m, with unit normals and depth ≤ roller radius + |distance|."""
    rng = np.random.default_rng(seed)
    try:
        p = pattern(rng, spread=spread)
    except ValueError:
        assume(False)
    poly = sprocket_polygon(p, DS)
    pts = ring(p, 300, rng)
    sd, n = sd_many(p, jnp.asarray(pts))
    want = polygon_distance(poly, pts)
    np.testing.assert_allclose(np.asarray(sd), want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(n), axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("k, z", [(1, 9), (2, 25)])
def test_uniform_asymmetric_equals_brute_force(k, z):
    """Uniform (scalar) leaves, the two sides different: the same agreement."""
    iso = jc.ToothProfile.iso606(CH, z, "mid")
    re, a = float(iso.flank_radius), float(iso.seating_angle) / 2
    p = jc.FreeformProfile.from_iso(
        iso,
        k,
        cw=jc.Flank(a - 0.08, np.linspace(1.2, 0.8, k) / re, np.linspace(0, 1, k + 1)[1:-1]),
        ccw=jc.Flank(a + 0.05, np.linspace(0.8, 1.1, k) / re, np.linspace(0, 1, k + 1)[1:-1] ** 2),
        phase=0.002,
        seat_offset=-20e-6,
    )
    pts = ring(p, 1500, np.random.default_rng(k))
    np.testing.assert_allclose(
        np.asarray(sd_many(p, jnp.asarray(pts))[0]),
        polygon_distance(sprocket_polygon(p, DS), pts),
        rtol=0,
        atol=1e-9,
    )


# --------------------------------------------------------------------------- continuity
def _sweep(p, a, b, n=4001):
    t = np.linspace(0, 1, n)[:, None]
    pts = jnp.asarray(a + t * (b - a))
    d = np.asarray(sd_many(p, pts)[0])
    step = np.linalg.norm(b - a) / (n - 1)
    return d, step


def test_one_lipschitz_across_every_boundary():
    """Sweeps through every gap's seat, across every tooth (flank arcs, their junctions,
    tip corners, tip, the switch between two differently shaped gaps) and across every
    gap axis (where the pair of gaps read changes), at several radii: the signed distance
    changes by at most the distance moved."""
    p = pattern(np.random.default_rng(7))
    R, pitch = float(p.pitch_radius), float(p.pitch)
    worst = 0.0
    for g in range(Z):
        t0 = 2 * np.pi * g / Z
        for dr in (-0.3, -0.15, -0.05, 0.0, 0.1, 0.2, 0.35):
            r = R + dr * pitch
            a = r * np.array([math.cos(t0 - 0.6 * np.pi / Z), math.sin(t0 - 0.6 * np.pi / Z)])
            b = r * np.array([math.cos(t0 + 1.6 * np.pi / Z), math.sin(t0 + 1.6 * np.pi / Z)])
            d, step = _sweep(p, a, b)
            worst = max(worst, np.max(np.abs(np.diff(d))) / step)
        # radially down the gap axis and down the tooth's nominal centre line
        for ang in (t0, t0 + np.pi / Z):
            u = np.array([math.cos(ang), math.sin(ang)])
            d, step = _sweep(p, (R - 0.5 * pitch) * u, (R + 0.5 * pitch) * u)
            worst = max(worst, np.max(np.abs(np.diff(d))) / step)
    assert worst <= 1 + 1e-6, worst


# --------------------------------------------------------------------------- gradients
def test_parameter_gradients_match_central_differences():
    """AD against central differences in every leaf entry (per-gap entries included), at
    points in the seat, on both flanks and on the tip of three gaps; the gradient of a
    point is zero in the entries of every gap but the two it lies between."""
    p = pattern(np.random.default_rng(11))
    flat, unravel = ravel_pytree(p)
    h = 1e-9 * np.maximum(np.abs(np.asarray(flat)), 1e-3)
    eye = np.eye(flat.size) * h
    R = float(p.pitch_radius)
    # which entries belong to which gap: perturb a gap's entries, see which leaves move
    owner = np.asarray(ravel_pytree(jax.tree_util.tree_map(lambda x: (
        jnp.broadcast_to(jnp.arange(Z, dtype=float).reshape((Z,) + (1,) * (x.ndim - 1)), x.shape)
        if x.ndim and x.shape[0] == Z else jnp.full(x.shape, -1.0)), p))[0])  # fmt: skip
    pts = []
    for g in (0, 5, Z - 1):
        t = 2 * np.pi * g / Z
        for dr, da in ((-0.45, 0.0), (-0.2, 0.45), (-0.2, -0.45), (0.1, 0.2), (0.35, 1.0)):
            a = t + da * np.pi / Z
            pts.append((R + dr * float(p.pitch)) * np.array([math.cos(a), math.sin(a)]))

    @jax.jit
    def check(x):
        f = lambda v: jc.gap_contact(unravel(v), x)[0]  # noqa: E731
        up = jax.vmap(f)(flat + eye)
        down = jax.vmap(f)(flat - eye)
        return jax.grad(f)(flat), (up - down) / (2 * h)

    for x in pts:
        ad, fd = (np.asarray(v) for v in check(jnp.asarray(x)))
        scale = np.abs(fd * h).max() / h  # per-entry: compare in units of depth change
        np.testing.assert_allclose(
            ad * h, fd * h, rtol=1e-5, atol=1e-7 * np.abs(fd * h).max() + 1e-17
        )
        turns = math.atan2(x[1], x[0]) * Z / (2 * math.pi)
        k0 = math.floor(turns) % Z
        near = {k0, (k0 + 1) % Z, -1}
        far = ~np.isin(owner, list(near))
        assert np.all(ad[far] == 0), x
        assert np.all(np.isfinite(scale))


def test_gradients_finite_everywhere():
    p = pattern(np.random.default_rng(5))
    pts = np.concatenate(
        [ring(p, 500, np.random.default_rng(6), -1.5, 1.5), [[0.0, 0.0], [1e-12, 0.0]]]
    )
    g = _point_grads(p, jnp.asarray(pts))
    gp = _param_grads(p, jnp.asarray(pts))
    assert np.all(np.isfinite(np.asarray(g)))
    assert all(np.all(np.isfinite(np.asarray(x))) for x in jax.tree_util.tree_leaves(gp))


# --------------------------------------------------------------------------- symmetry
def test_mirror_symmetry_of_a_symmetric_pattern():
    """Both sides alike and the pattern mirror-symmetric about gap 0's axis (gap −k is
    gap k mirrored): mirrored points read the same depth, mirrored normals."""
    rng = np.random.default_rng(9)
    base = pattern(rng, symmetric=True)
    mirror_idx = (-np.arange(Z)) % Z

    def sym(x, odd=False):
        x = np.asarray(x)
        return 0.5 * (x + (-1 if odd else 1) * x[mirror_idx])

    f = jc.Flank(
        sym(base.cw.seat_angle), np.asarray(base.cw.curvature)[0], np.asarray(base.cw.breaks)[0]
    )
    p = jc.FreeformProfile.from_iso(
        ISO, 3, cw=f, ccw=f, seating_radius=sym(base.seating_radius),
        seat_offset=sym(base.seat_offset), phase=sym(base.phase, odd=True),
    )  # fmt: skip
    pts = jnp.asarray(ring(p, 800, rng))
    m = jnp.array([1.0, -1.0])
    d, n = contact_many(p, pts)
    dm, nm = contact_many(p, pts * m)
    np.testing.assert_allclose(dm, d, rtol=0, atol=1e-15)
    np.testing.assert_allclose(nm, n * m, rtol=0, atol=1e-11)


def test_pitch_rotation_of_a_uniform_profile():
    """Uniform leaves: rotating a point by one pitch reads the same depth, normal rotated."""
    p = jc.FreeformProfile.from_iso(
        ISO, 2, cw=jc.Flank(HALF - 0.05, [1.1 / RE, 0.9 / RE], [0.4]), phase=0.001
    )
    pts = jnp.asarray(ring(p, 500, np.random.default_rng(4)))
    t = 2 * np.pi / Z
    rot = jnp.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    d, n = contact_many(p, pts)
    d2, n2 = contact_many(p, pts @ rot.T)
    np.testing.assert_allclose(d2, d, rtol=0, atol=1e-15)
    np.testing.assert_allclose(n2, n @ rot.T, rtol=0, atol=1e-11)


# --------------------------------------------------------------------------- validation
def _flank(**kw):
    f = dict(seat_angle=HALF, curvature=[1 / RE, 1 / RE], breaks=[0.5])
    f.update(kw)
    return jc.Flank(**f)


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(seating_radius=float(CH.roller_diameter) / 2), "roller must fit inside every seat"),
        (dict(seating_radius=np.full(Z, 5e-3)[:-1]), r"one value per gap, shape \(18,\)"),
        (dict(seat_offset=2e-3), r"seat_offset of gap 0 must be within"),
        (dict(phase=0.1), r"phase of gap 0 must be within"),
        (dict(ccw=_flank(seat_angle=1.7)), r"ccw.seat_angle of gap 0 must be in \[30°, 85°\]"),
        (dict(cw=_flank(curvature=[1 / RE, -1 / RE])), r"cw.curvature\[1\] of gap 0 must be"),
        (dict(cw=_flank(breaks=[1.2])), r"cw.breaks of gap 0 must increase strictly"),
        (dict(cw=_flank(curvature=[1 / RE, 1 / RE, 1 / RE], breaks=[0.5])), "shapes must be"),
        (dict(cw=jc.Flank(HALF, [1 / RE])), "same number of arcs"),
        (dict(ccw=_flank(curvature=[200.0, 200.0])), "does not rise to the tip circle"),
        (dict(tip_diameter=0.06), "must exceed the seat/flank junctions"),
        (dict(tip_diameter=float(ISO.tip_diameter) * 1.03), "wide on the tip circle"),
        (dict(min_tip_width=5e-3), r"at least min_tip_width = 5 mm"),
        (dict(phase=np.where(np.arange(Z) == 3, 0.04, 0.0)), "seats of gaps 2 and 3"),
        (dict(tip_diameter=np.full(2, 0.08)), "tip_diameter must be a scalar"),
    ],
)
def test_validation_errors_say_what_and_the_range(change, match):
    kw = dict(
        teeth=Z,
        pitch=CH.pitch,
        roller_diameter=CH.roller_diameter,
        seating_radius=ISO.seating_radius,
        tip_diameter=ISO.tip_diameter,
        cw=_flank(),
        ccw=_flank(),
    )
    kw.update(change)
    with pytest.raises(ValueError, match=match):
        jc.FreeformProfile(**kw)


def test_type_errors():
    with pytest.raises(TypeError, match="must be a jc.Flank"):
        jc.FreeformProfile.from_iso(ISO, 1, cw=(HALF, 1 / RE))
    with pytest.raises(TypeError, match="jc.ToothProfile"):
        jc.FreeformProfile.from_iso("08B", 1)
    with pytest.raises(ValueError, match=r"arcs must be an integer in \[1, 16\]"):
        jc.FreeformProfile.from_iso(ISO, 0)


# --------------------------------------------------------------------------- in scenes
def test_jit_vmap_and_no_retrace():
    """One trace for new values of the same structure; vmap over a batch of profiles."""
    traces = []

    @jax.jit
    def f(p, x):
        traces.append(1)
        return jc.gap_contact(p, x)[0]

    rng = np.random.default_rng(12)
    x = jnp.asarray(ring(ISO, 1, rng)[0])
    a, b = pattern(rng), pattern(rng)
    f(a, x), f(b, x)
    assert len(traces) == 1
    batch = jax.tree_util.tree_map(lambda u, v: jnp.stack([u, v]), a, b)
    d = jax.jit(jax.vmap(lambda p: jc.gap_contact(p, x)[0]))(batch)
    np.testing.assert_allclose(d, [f(a, x), f(b, x)], rtol=1e-14)


_field = jax.jit(lambda s: jc.vector_field(0.0, jc.initial_state(s), s))


def _same_field(a, b, rtol):
    da, db = _field(a), _field(b)
    for u, v in zip(jax.tree_util.tree_leaves(da), jax.tree_util.tree_leaves(db), strict=True):
        np.testing.assert_allclose(v, u, rtol=rtol, atol=rtol * float(np.abs(u).max()))
    return db


@pytest.mark.parametrize("fidelity", ["lumped", "clearance"])
def test_scenes_read_free_form_sprockets(fidelity):
    """The ISO form as a free-form profile gives the ISO scene's vector field: engagement
    in both fidelities, and (lumped) a drive mixing a free-form driver, z = 18, with an
    ISO driven sprocket, z = 36, in one vmapped contact; a per-gap pattern's is finite."""
    kw = dict(speed_rpm=600, fidelity=fidelity, settle=False)
    iso = jc.scenes.engagement(CH, Z, **modelled(**kw, model=jc.scenes.ChainModel(form="mid")))
    ff = jc.scenes.engagement(CH, Z, **modelled(profile=jc.FreeformProfile.from_iso(ISO, 3), **kw))
    _same_field(iso, ff, 1e-9)
    if fidelity != "lumped":
        return
    z2 = jc.ToothProfile.iso606(CH, 36, "mid")
    d_iso = jc.scenes.drive(
        CH, **modelled(teeth=(Z, 36), n_links=60, **kw, model=jc.scenes.ChainModel(form="mid"))
    )
    d_ff = jc.scenes.drive(
        CH,
        **modelled(
            teeth=(Z, 36), n_links=60, profiles=(jc.FreeformProfile.from_iso(ISO, 2), z2), **kw
        ),
    )
    _same_field(d_iso, d_ff, 1e-9)
    pat = jc.scenes.engagement(CH, Z, **modelled(profile=pattern(np.random.default_rng(3)), **kw))
    dy = _field(pat)
    assert all(np.all(np.isfinite(np.asarray(x))) for x in jax.tree_util.tree_leaves(dy))


def test_a_per_gap_pattern_simulates():
    """An engagement on a sprocket with asymmetric flanks and per-gap seating radius and
    phase (the structure notebook 02 meshes: its solve reuses this compiled program):
    a settled start, a successful solve, a peak force of the ISO engagement's size."""
    rng = np.random.default_rng(0)
    k = 1 / RE
    profile = jc.FreeformProfile.from_iso(
        ISO,
        3,
        cw=jc.Flank(HALF - 0.05, [1.2 * k, k, 0.9 * k], [0.3, 0.6]),
        ccw=jc.Flank(HALF + 0.03, [0.9 * k, k, k], [0.3, 0.6]),
        seating_radius=float(ISO.seating_radius) + rng.uniform(0, 60e-6, Z),
        phase=rng.uniform(-1e-3, 1e-3, Z),
    )
    scene = jc.scenes.engagement(CH, Z, speed_rpm=1000.0, profile=profile)
    sol = jc.simulate(scene, 2 * 60.0 / (Z * 1000.0))
    assert sol.result == jc.Result.successful
    assert 300 < float(sol.peak_contact_force) < 4000


def test_a_table_computed_ahead_reads_the_same():
    """What a solve does before its loop (every gap's outline table computed once:
    ``with_table``) changes no distance or normal beyond rounding (fused
    differently). Its gradients: the per-gap design gradient's check against central
    differences (``test_orders.py``) runs through it."""
    p = pattern(np.random.default_rng(5))
    shape, pts = p.shape(), jnp.asarray(ring(p, 300, np.random.default_rng(6)))
    for a, b in zip(sd_many(shape, pts), sd_many(with_table(shape), pts), strict=True):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- CAD
@pytest.mark.parametrize("which", ["iso", "pattern"])
def test_dxf_round_trip(tmp_path, which):
    """Read back with ezdxf: one ARC per seat, flank arc and tip (z·(2K + 2)), in mm;
    radii are the profile's (ri per gap, 1/κ, da/2); every arc's end points lie on the
    outline and each meets exactly one other arc's end point (a closed chain), to 1e-9 m."""
    import ezdxf

    p = ISO if which == "iso" else pattern(np.random.default_rng(8))
    k = 1 if which == "iso" else p.arcs
    doc = ezdxf.readfile(p.to_dxf(tmp_path / "sprocket.dxf"))
    assert doc.units == ezdxf.units.MM
    arcs = list(doc.modelspace().query("ARC"))
    assert len(arcs) == Z * (2 * k + 2)
    radii = np.array([a.dxf.radius for a in arcs]) * 1e-3
    ri = np.broadcast_to(np.asarray(p.seating_radius), (Z,))
    if which == "iso":
        kap = np.full((Z, 2), 1 / float(p.flank_radius))
    else:
        kap = np.concatenate([np.asarray(p.cw.curvature), np.asarray(p.ccw.curvature)], 1)
    want = np.sort(np.concatenate([ri, 1 / kap.ravel(), np.full(Z, float(p.tip_diameter) / 2)]))
    np.testing.assert_allclose(np.sort(radii), want, rtol=0, atol=1e-12)
    ends = (
        np.array(
            [[[a.start_point.x, a.start_point.y], [a.end_point.x, a.end_point.y]] for a in arcs]
        ).reshape(-1, 2)
        * 1e-3
    )
    np.testing.assert_allclose(sd_many(p, jnp.asarray(ends))[0], 0.0, atol=1e-9)
    dist = np.linalg.norm(ends[:, None] - ends[None], axis=-1)
    np.fill_diagonal(dist, np.inf)
    same_arc = np.arange(len(ends))[:, None] // 2 == np.arange(len(ends))[None] // 2
    dist[same_arc] = np.inf
    assert np.all(np.sum(dist < 1e-9, 1) == 1)


# --------------------------------------------------------------------------- design space
def test_design_space_over_chosen_leaves():
    """A box over per-gap seating radius and phase, a uniform flank's curvatures and one
    seat angle: u = 0 is the middle, coordinates() inverts profile(), the gradient of a
    contact in u reaches only the entries of the gaps it reads, and a box reaching
    outside valid profiles is refused naming the corner."""
    from jaxchain.design import DesignSpace

    ff = jc.FreeformProfile.from_iso(ISO, 3)
    ri, k = float(ISO.seating_radius), 1 / RE
    space = DesignSpace.select(
        ff,
        {
            "seating_radius": (np.full(Z, ri), np.full(Z, ri + 60e-6)),
            "phase": (np.full(Z, -1e-3), np.full(Z, 1e-3)),
            "ccw.curvature": (np.full(3, 0.85 * k), np.full(3, 1.15 * k)),
            "cw.seat_angle": (HALF - 0.05, HALF + 0.03),
        },
    )
    assert space.size == 2 * Z + 3 + 1
    p = space.profile(jnp.zeros(space.size))
    np.testing.assert_allclose(p.seating_radius, np.full(Z, ri + 30e-6), rtol=1e-12)
    np.testing.assert_allclose(p.ccw.curvature, np.full(3, k), rtol=1e-12)
    np.testing.assert_allclose(p.cw.seat_angle, HALF - 0.01, rtol=1e-12)
    u = jnp.asarray(np.random.default_rng(0).normal(size=space.size))
    np.testing.assert_allclose(space.coordinates(space.profile(u)), u, atol=1e-9)
    x = jnp.asarray([float(ISO.pitch_radius) - 1e-4, 3e-4])  # in gap 0, ccw side
    g = np.asarray(jax.jit(jax.grad(lambda u: jc.gap_contact(space.profile(u), x)[0]))(u))
    reads = {0, Z, 2 * Z, 2 * Z + 1, 2 * Z + 2, 2 * Z + 3, 1, Z + 1}  # gaps 0 and 1
    assert np.all(g[[i for i in range(space.size) if i not in reads]] == 0)
    assert np.any(g != 0)
    with pytest.raises(ValueError, match=r"corner \(cw.seat_angle lower\) cw.seat_angle"):
        DesignSpace.select(ff, {"cw.seat_angle": (0.2, 1.4)})
    with pytest.raises(ValueError, match="'nope' is not a leaf of this FreeformProfile"):
        DesignSpace.select(ff, {"nope": (0.0, 1.0)})
    with pytest.raises(ValueError, match=r"u must have shape \(40,\)"):
        space.profile(jnp.zeros(4))


def test_plots_draw_free_form_and_patterns(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    p = pattern(np.random.default_rng(3))
    ax = jc.plot_profiles(CH, Z, extra={"pattern": p})
    assert len(ax.lines) >= 2 * 3 + 1
    ax2 = jc.plot_sprocket(p)
    assert len(ax2.lines) == 2 + Z  # reference, exaggerated profile, a roller per gap
    ax2.figure.savefig(tmp_path / "sprocket.png")
    assert (tmp_path / "sprocket.png").stat().st_size > 10_000
    assert not ax2.get_title().endswith("×1")  # the pattern is magnified
    # a uniform sprocket has no pattern: its sampling noise is not magnified into one
    assert jc.plot_sprocket(p.uniform()).get_title().endswith("×1")
    # legends beside the axes, clear of their x labels
    for a in (ax, ax2):
        box = a.get_legend().get_window_extent(a.figure.canvas.get_renderer())
        label = a.xaxis.label.get_window_extent(a.figure.canvas.get_renderer())
        assert not box.overlaps(label)
