"""gap_contact: exact values at hand-derivable positions, symmetry, continuity across every
region boundary, AD against central finite differences, and property-based checks."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, strategies as st
from scipy.spatial import cKDTree

import jaxchain as jc
from jaxchain._profiles.iso import flank_meeting_diameter

from helpers import central_fd

CH = jc.ChainSpec.iso606("08B")
PROFILES = {
    (name, z, form): jc.ToothProfile.iso606(jc.ChainSpec.iso606(name), z, form)
    for name, z in (("08B", 18), ("08B", 9), ("12A", 40))
    for form in ("min", "max")
}

contact = jax.jit(jc.gap_contact)
contact_many = jax.jit(jax.vmap(jc.gap_contact, in_axes=(None, 0)))
# gradients of the depth in the points and in the profile's parameters, many points at
# once (jitted: an eager vmap of a grad traces every call anew)
_point_grads = jax.jit(jax.vmap(jax.grad(lambda q, x: jc.gap_contact(q, x)[0], 1), (None, 0)))
_param_grads = jax.jit(jax.vmap(jax.grad(lambda q, x: jc.gap_contact(q, x)[0]), (None, 0)))


def polar(r, a):
    return jnp.array([r * math.cos(a), r * math.sin(a)])


def params(p):
    g = p.geometry()
    return (
        np.asarray(g.seat_centre),
        np.asarray(g.junction),
        np.asarray(g.flank_centre),
        np.asarray(g.tip_corner),
        float(g.tip_radius),
        float(p.seating_radius),
        float(p.flank_radius),
        float(p.roller_radius),
    )


# --------------------------------------------------------------------------- exact values
@pytest.mark.parametrize("key", sorted(PROFILES))
def test_touching_positions_have_zero_depth(key):
    """A roller placed tangent to the seat bottom, the seat at the junction, the flank, the
    tip and the tip corner has depth 0 and the normal along the contact line."""
    p = PROFILES[key]
    c, j, f, k, ra, ri, re, r = params(p)
    u = (j - c) / ri
    z = p.teeth
    cases = [
        (c - [ri - r, 0.0], [1.0, 0.0]),  # seat bottom: normal radially out
        (c + (ri - r) * u, -u),  # seat at the junction
        (f + (re + r) * (-u), -u),  # flank at the junction (same point, other side)
    ]
    # flank, half way to the corner
    a0, a1 = math.atan2(*(j - f)[::-1]), math.atan2(*(k - f)[::-1])
    mid = np.array([math.cos((a0 + a1) / 2), math.sin((a0 + a1) / 2)])
    cases.append((f + (re + r) * mid, mid))
    # tip, on the tooth centre line
    cases.append(
        (np.asarray(polar(ra + r, math.pi / z)), [math.cos(math.pi / z), math.sin(math.pi / z)])
    )
    # rolling over the flank/tip corner: anywhere between the two normals at K
    nf, nt = (k - f) / re, k / ra
    for t in (0.0, 0.3, 0.7, 1.0):
        n = (1 - t) * nf + t * nt
        n /= np.linalg.norm(n)
        cases.append((k + r * n, n))
    for pt, n in cases:
        for gap in (0, 3, z - 1):  # any gap, by rotation
            ga = 2 * math.pi * gap / z
            rot = np.array([[math.cos(ga), -math.sin(ga)], [math.sin(ga), math.cos(ga)]])
            for mirror in (1.0, -1.0):
                m = np.array([1.0, mirror])
                d, nn = contact(p, jnp.asarray(rot @ (np.asarray(pt) * m)))
                assert abs(float(d)) < 1e-12, (pt, float(d))
                np.testing.assert_allclose(nn, rot @ (np.asarray(n) * m), atol=1e-9)


def test_depth_is_overlap_along_the_normal():
    """Pushing the roller by s along -normal from touching raises the depth by exactly s."""
    p = PROFILES[("08B", 18, "min")]
    c, j, f, k, ra, ri, re, r = params(p)
    for pt in (c - [ri - r, 0.0], f + (re + r) * (-(j - c) / ri)):
        d0, n = contact(p, jnp.asarray(pt))
        for s in (-3e-5, -1e-6, 1e-7, 1e-5):  # |s| < seat clearance 42.5 µm
            d, _ = contact(p, jnp.asarray(pt) - s * n)
            np.testing.assert_allclose(float(d) - float(d0), s, rtol=1e-8, atol=1e-15)


def test_roller_at_seat_centre_is_finite():
    """Exactly at the seat centre: depth = r − ri (the seat clearance, negative), finite
    gradients, unit normal."""
    p = PROFILES[("08B", 18, "min")]
    c = p.geometry().seat_centre
    d, n = contact(p, c)
    np.testing.assert_allclose(float(d), float(p.roller_radius - p.seating_radius), rtol=1e-12)
    np.testing.assert_allclose(float(jnp.linalg.norm(n)), 1.0)
    g = _point_grads(p, c[None])
    gp = _param_grads(p, c[None])
    assert np.all(np.isfinite(g))
    assert all(np.isfinite(x) for x in jax.tree_util.tree_leaves(gp))
    # in the seat region depth = r − ri + |x − c|: ∂/∂ri = −1
    np.testing.assert_allclose(float(gp.seating_radius[0]), -1.0, rtol=1e-12)


def test_sprocket_axis_and_far_points_finite():
    p = PROFILES[("08B", 18, "min")]
    pts = jnp.array([[0.0, 0.0], [1e-9, 0.0], [1.0, 2.0], [-0.05, 0.01], [0.0, -0.02]])
    d, n = contact_many(p, pts)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(n))
    g = _point_grads(p, pts)
    assert np.all(np.isfinite(g))
    # the axis is deep inside the sprocket: depth = r + (distance to the seat bottom)
    c, _, _, _, _, ri, _, r = params(p)
    np.testing.assert_allclose(float(d[0]), r + (c[0] - ri), rtol=1e-12)


# --------------------------------------------------------------------------- symmetry
@pytest.mark.parametrize("key", sorted(PROFILES))
def test_mirror_and_pitch_rotation(key):
    p = PROFILES[key]
    z = p.teeth
    rng = np.random.default_rng(0)
    r = float(p.pitch_radius) + rng.uniform(-8e-3, 6e-3, 400)
    a = rng.uniform(-math.pi, math.pi, 400)
    pts = jnp.asarray(np.stack([r * np.cos(a), r * np.sin(a)], -1))
    d, n = contact_many(p, pts)
    dm, nm = contact_many(p, pts * jnp.array([1.0, -1.0]))  # mirror in gap 0's axis
    np.testing.assert_allclose(dm, d, atol=1e-13)
    np.testing.assert_allclose(nm, n * jnp.array([1.0, -1.0]), atol=1e-9)
    ang = 2 * math.pi / z
    rot = jnp.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    dr, nr = contact_many(p, pts @ rot.T)  # gap k → gap k+1
    np.testing.assert_allclose(dr, d, atol=1e-13)
    np.testing.assert_allclose(nr, n @ rot.T, atol=1e-9)


# --------------------------------------------------------------------------- continuity
def _assert_lipschitz(p, pts):
    """Depth is r − (distance to a closed set): 1-Lipschitz. Consecutive points of a fine
    sweep must not differ by more than their spacing (a jump of any size fails)."""
    d, n = contact_many(p, pts)
    step = np.linalg.norm(np.diff(np.asarray(pts), axis=0), axis=1)
    dd = np.abs(np.diff(np.asarray(d)))
    assert np.all(dd <= step * (1 + 1e-6) + 1e-15), (dd / step).max()
    return np.asarray(d), np.asarray(n)


@pytest.mark.parametrize("key", sorted(PROFILES))
def test_continuity_across_every_boundary(key):
    p = PROFILES[key]
    c, j, f, k, ra, ri, re, r = params(p)
    z = p.teeth
    u = (j - c) / ri
    t = np.linspace(-1, 1, 4001)[:, None]
    # 1. seat/flank junction: sweep tangentially through the contact point at J
    tang = np.array([u[1], -u[0]])
    d, n = _assert_lipschitz(p, jnp.asarray(c + (ri - r) * u + 2e-3 * t * tang))
    # the normal turns continuously through the junction (C¹ outline): it is the
    # direction from c (seat) or from F (flank), so |Δn| ≤ |Δx| / (ri − r) here; a jump
    # at the junction would be O(1)
    step = 2e-3 * (t[1, 0] - t[0, 0])
    assert np.max(np.linalg.norm(np.diff(n, axis=0), axis=1)) < 1.01 * step / (ri - r)
    # 2. flank/tip corner: sweep along the tip circle offset, across K's angle
    ak = math.atan2(k[1], k[0])
    ang = ak + 0.6 * (math.pi / z) * t[:, 0]
    pts = np.stack([(ra + 0.5 * r) * np.cos(ang), (ra + 0.5 * r) * np.sin(ang)], -1)
    _assert_lipschitz(p, jnp.asarray(pts))
    # 3. the switch of nearest gap at half pitch, at several radii (in gap, on the tip,
    #    inside the tooth)
    for rad in (ra + r, ra + 0.1 * r, ra - 0.3 * r, float(c[0]), float(c[0]) - ri - r):
        ang = math.pi / z + 0.2 * (math.pi / z) * t[:, 0]
        pts = np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1)
        d, _ = _assert_lipschitz(p, jnp.asarray(pts))
        np.testing.assert_allclose(d, d[::-1], atol=1e-12)  # symmetric about the centre line
    # 4. contact onset: depth crosses 0 linearly along the normal
    pt0 = f + (re + r) * (-u)
    _assert_lipschitz(p, jnp.asarray(pt0 + 1e-4 * t * u))
    # 5. through the seat centre and the gap axis
    _assert_lipschitz(p, jnp.asarray(c + 3e-3 * t * np.array([1.0, 0.0])))
    _assert_lipschitz(p, jnp.asarray(c + 3e-3 * t * np.array([0.0, 1.0])))


def test_normal_is_continuous_in_the_contact_layer():
    """Where a roller can actually touch (|depth| < seat clearance), the normal field is
    continuous: sweep a full circle of roller centres through the contact layer."""
    p = PROFILES[("08B", 18, "max")]
    R = float(p.pitch_radius)
    a = np.linspace(-math.pi / 18, 3 * math.pi / 18, 20001)
    for off in np.linspace(-1.0, 1.0, 9):
        # follow the outline: take points along rays from the seat centre of each gap
        rad = R + off * 1e-3
        pts = np.stack([rad * np.cos(a), rad * np.sin(a)], -1)
        d, n = contact_many(p, jnp.asarray(pts))
        layer = np.abs(np.asarray(d)) < 0.9 * float(p.seat_clearance)
        dn = np.linalg.norm(np.diff(np.asarray(n), axis=0), axis=1)
        both = layer[1:] & layer[:-1]
        assert np.all(dn[both] < 2e-2)


# --------------------------------------------------------------------------- gradients
def _region_points(p):
    """Points in every region, slightly in and out of contact, away from the medial axis."""
    c, j, f, k, ra, ri, re, r = params(p)
    pts = []
    for s in (-3e-6, 2e-6):
        for phi in np.radians([180, 160, 130]):  # seat (bottom, middle, near J)
            if phi <= math.pi - float(p.seating_angle) / 2:
                continue
            pts.append(c + (ri - r + s) * np.array([math.cos(phi), math.sin(phi)]))
        a0, a1 = math.atan2(*(j - f)[::-1]), math.atan2(*(k - f)[::-1])
        for w in (0.1, 0.5, 0.9):  # flank
            a = a0 + w * (a1 - a0)
            pts.append(f + (re + r - s) * np.array([math.cos(a), math.sin(a)]))
        ak = math.atan2(k[1], k[0])
        a = ak + 0.5 * (math.pi / p.teeth - ak)
        pts.append((ra + r - s) * np.array([math.cos(a), math.sin(a)]))  # tip
        nk = (k - f) / re + k / ra
        pts.append(k + (r - s) * nk / np.linalg.norm(nk))  # corner
    pts.append(c + 0.3 * (ri - r) * np.array([-0.9, 0.3]))  # inside the seat, not touching
    return np.array(pts)


@pytest.mark.parametrize("key", [("08B", 18, "min"), ("08B", 9, "max"), ("12A", 40, "min")])
def test_ad_matches_central_fd_in_point(key):
    p = PROFILES[key]
    depth = jax.jit(lambda x: jc.gap_contact(p, x)[0])
    grad = jax.jit(jax.grad(lambda x: jc.gap_contact(p, x)[0]))
    worst = 0.0
    for x in _region_points(p):
        g = np.asarray(grad(jnp.asarray(x)))
        fd = central_fd(depth, x, 1e-9)
        worst = max(worst, np.max(np.abs(g - fd)))
        # and the returned normal is −∂depth/∂x
        np.testing.assert_allclose(-g, contact(p, jnp.asarray(x))[1], atol=1e-9)
    assert worst < 1e-6, worst  # |∇| = 1: absolute error of a unit vector


@pytest.mark.parametrize("key", [("08B", 18, "min"), ("08B", 9, "max"), ("12A", 40, "min")])
def test_ad_matches_central_fd_in_parameters(key):
    p = PROFILES[key]
    names = (
        "pitch",
        "roller_diameter",
        "seating_radius",
        "seating_angle",
        "flank_radius",
        "tip_diameter",
    )

    def depth_of(theta, x):
        q = jc.ToothProfile(teeth=p.teeth, **dict(zip(names, theta, strict=True)))
        return jc.gap_contact(q, x)[0]

    theta0 = np.array([float(getattr(p, n)) for n in names])
    grad = jax.jit(jax.grad(depth_of))
    f = jax.jit(depth_of)
    for x in _region_points(p):
        g = np.asarray(grad(jnp.asarray(theta0), jnp.asarray(x)))
        fd = np.zeros(6)
        for i in range(6):
            h = 1e-7 * abs(theta0[i])
            e = np.zeros(6)
            e[i] = h
            fd[i] = (
                float(f(jnp.asarray(theta0 + e), x)) - float(f(jnp.asarray(theta0 - e), x))
            ) / (2 * h)
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-9)


def test_parameter_derivatives_by_hand():
    """Seat region: depth = r − ri + |x − c| ⇒ ∂/∂ri = −1, ∂/∂re = 0, ∂/∂d1 = 1/2.
    Flank region: depth = r − |x − F| + re with F = c + (ri + re)u ⇒
    ∂/∂re = 1 + n·u, ∂/∂ri = n·u (n the unit normal)."""
    p = PROFILES[("08B", 18, "min")]
    c, j, f, k, ra, ri, re, r = params(p)
    u = (j - c) / ri
    g = jax.jit(jax.grad(lambda q, x: jc.gap_contact(q, x)[0]))
    x = c + (ri - r) * np.array([-1.0, 0.2]) / np.hypot(1, 0.2)
    gs = g(p, jnp.asarray(x))
    np.testing.assert_allclose(
        [gs.seating_radius, gs.flank_radius, gs.roller_diameter], [-1, 0, 0.5], atol=1e-12
    )
    a0, a1 = math.atan2(*(j - f)[::-1]), math.atan2(*(k - f)[::-1])
    n = np.array([math.cos((a0 + a1) / 2), math.sin((a0 + a1) / 2)])
    gf = g(p, jnp.asarray(f + (re + r) * n))
    np.testing.assert_allclose(float(gf.flank_radius), 1 + n @ u, rtol=1e-9)
    np.testing.assert_allclose(float(gf.seating_radius), n @ u, rtol=1e-9)


def test_gradient_finite_on_the_boundaries_themselves():
    """Points exactly on region boundaries (junction ray, corner rays, the half-pitch line,
    the gap axis) and exactly touching: finite gradients in point and parameters."""
    p = PROFILES[("08B", 18, "min")]
    c, j, f, k, ra, ri, re, r = params(p)
    u = (j - c) / ri
    z = p.teeth
    pts = [
        c + (ri - r) * u,
        k + r * (k - f) / re,
        k + r * k / ra,
        np.asarray(polar(ra + r, math.pi / z)),
        np.asarray(polar(ra - r, math.pi / z)),
        c + np.array([1e-3, 0.0]),
        c,
        f,
        np.zeros(2),
        j,
        k,
    ]
    gx = _point_grads(p, jnp.asarray(np.array(pts)))
    gp = _param_grads(p, jnp.asarray(np.array(pts)))
    assert np.all(np.isfinite(gx))
    assert all(np.all(np.isfinite(v)) for v in jax.tree_util.tree_leaves(gp))


# --------------------------------------------------------------------------- properties
valid_profiles = st.builds(
    lambda name, z, fr: _profile_in_box(name, z, fr),
    st.sampled_from(["06B", "08A", "08B", "10A", "12A", "16B"]),
    st.sampled_from(
        [9, 11, 17, 25, 40, 77, 120]
    ),  # few distinct z: teeth is static (one compile each)
    st.tuples(*[st.floats(0, 1)] * 4),
)


def _profile_in_box(name, z, fr):
    ch = jc.ChainSpec.iso606(name)
    lim = jc.iso606_limits(ch, z)
    names = ("seating_radius", "seating_angle", "flank_radius", "tip_diameter")
    kw = {n: lim[n][0] + f * (lim[n][1] - lim[n][0]) for n, f in zip(names, fr, strict=True)}
    mx = jc.ToothProfile.iso606(ch, z, "min")  # its tip is the largest the standard allows
    reach = flank_meeting_diameter(teeth=z, pitch=ch.pitch, **kw)
    kw["tip_diameter"] = min(kw["tip_diameter"], float(mx.tip_diameter), reach * (1 - 1e-6))
    return jc.ToothProfile(teeth=z, pitch=ch.pitch, roller_diameter=ch.roller_diameter, **kw)


def _polyline_distance(poly, pts):
    """Exact distance from pts to the polyline through ``poly`` (nearest vertex, then the
    two segments around it)."""
    _, i = cKDTree(poly).query(pts)
    best = np.full(len(pts), np.inf)
    for a_i, b_i in ((i - 1, i), (i, i + 1)):
        a_i, b_i = np.clip(a_i, 0, len(poly) - 1), np.clip(b_i, 0, len(poly) - 1)
        a, b = poly[a_i], poly[b_i]
        ab = b - a
        t = np.clip(np.sum((pts - a) * ab, 1) / np.maximum(np.sum(ab * ab, 1), 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(pts - (a + t[:, None] * ab), axis=1))
    return best


@given(p=valid_profiles, seed=st.integers(0, 2**31))
def test_property_distance_is_exact_and_bounded(p, seed):
    """Over random valid profiles and random points around the rim (±1 pitch about gap 0,
    from well inside the root to well outside the tip): finite values and gradients, unit
    normals, |signed distance| equal to the distance to a densely sampled outline (chord
    error ~1e-12 m), depth ≤ r − (|x| − ra), and mirror symmetry."""
    rng = np.random.default_rng(seed)
    z = p.teeth
    R = float(p.pitch_radius)
    rr = rng.uniform(max(R - 2 * float(p.pitch), 0.02 * R), R + 1.5 * float(p.pitch), 64)
    a = rng.uniform(-1.0, 1.0, 64) * 2 * math.pi / z
    pts = np.stack([rr * np.cos(a), rr * np.sin(a)], -1)
    d, n = contact_many(p, jnp.asarray(pts))
    d, n = np.asarray(d), np.asarray(n)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(n))
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    r = float(p.roller_radius)
    ra = float(p.geometry().tip_radius)
    assert np.all(d <= r - (np.linalg.norm(pts, axis=1) - ra) + 1e-12)
    outline = np.concatenate([p.outline(3000, g)[:-1] for g in (-2, -1, 0, 1, 2)])
    brute = _polyline_distance(outline, pts)
    np.testing.assert_allclose(np.abs(r - d), brute, atol=1e-9)
    g = _point_grads(p, jnp.asarray(pts))
    assert np.all(np.isfinite(g))
    dm, _ = contact_many(p, jnp.asarray(pts * [1.0, -1.0]))
    np.testing.assert_allclose(dm, d, atol=1e-12)


@given(p=valid_profiles)
def test_property_parameter_gradients_finite(p):
    pts = jnp.asarray(_region_points(p))
    gp = _param_grads(p, pts)
    assert all(np.all(np.isfinite(v)) for v in jax.tree_util.tree_leaves(gp))


# --------------------------------------------------------------------------- tracing
def test_no_retrace_and_vmap_over_profiles():
    traces = []

    @jax.jit
    def f(q, x):
        traces.append(1)
        return jc.gap_contact(q, x)

    p1 = PROFILES[("08B", 18, "min")]
    p2 = PROFILES[("08B", 18, "max")]
    x = p1.geometry().seat_centre - jnp.array([0.1e-3, 0.0])
    f(p1, x)
    f(p2, x + 1e-5)
    assert len(traces) == 1
    batch = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), p1, p2)
    d, n = jax.vmap(jc.gap_contact, in_axes=(0, None))(batch, x)
    np.testing.assert_allclose(
        d, [float(jc.gap_contact(p1, x)[0]), float(jc.gap_contact(p2, x)[0])]
    )


def test_nearest_gap_index():
    p = PROFILES[("08B", 18, "min")]
    z = p.teeth
    for k in range(z):
        for da in (-0.49, 0.0, 0.49):
            x = polar(float(p.pitch_radius), 2 * math.pi * (k + da) / z)
            assert int(jc.nearest_gap(p, x)) == k


def test_gap_rotation_matches_cos_sin_for_every_gap_of_every_tooth_count():
    """The gap rotation is built from per-profile factors (no trig per point): it must
    still be the rotation by 2πk/z, to round-off, for every k of every allowed z."""
    from jaxchain._profiles.base import MAX_TEETH, MIN_TEETH, gap_rotation as _gap_rotation

    z = np.arange(MIN_TEETH, MAX_TEETH + 1)[:, None]
    k = np.arange(MAX_TEETH)[None, :]
    zz, kk = np.broadcast_arrays(z, k)
    rot = jax.jit(jax.vmap(lambda k, z: _gap_rotation(k, z, jnp.float64)))(
        jnp.asarray(kk.ravel(), jnp.int32), jnp.asarray(zz.ravel(), jnp.float64)
    )
    a = 2 * np.pi * kk.ravel() / zz.ravel()
    want = np.stack([np.cos(a), -np.sin(a), np.sin(a), np.cos(a)], -1).reshape(-1, 2, 2)
    valid = (kk < zz).ravel()  # gap indices are in [0, z)
    assert np.max(np.abs(np.asarray(rot) - want)[valid]) < 3e-15
