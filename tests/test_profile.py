"""ToothProfile: ISO 606 numbers worked by hand, derived geometry, validation, plotting."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc

CH08B = jc.ChainSpec.iso606("08B")
CH12A = jc.ChainSpec.iso606("12A")

# Hand-worked from ISO 606's formulas (mm, degrees).
# 08B (p = 12.7, d1 = 8.51), z = 18: d = 12.7 / sin 10° = 73.1364
#   ri 0.505·8.51 = 4.29755 … + 0.069·∛8.51 = 0.069·2.04166 = 0.14087 → 4.43842
#   α 120 − 5 = 115 … 140 − 5 = 135
#   re 0.12·8.51·20 = 20.424 … 0.008·8.51·504 = 34.3123
#   da 73.1364 + 12.7·(1 − 1.6/18) − 8.51 = 76.1975 … 73.1364 + 15.875 − 8.51 = 80.5014
# 08B, z = 12: d = 12.7 / sin 15° = 49.0690; α 112.5 … 132.5;
#   re 0.12·8.51·14 = 14.2968 … 0.008·8.51·324 = 22.0579
#   da 49.0690 + 12.7·(1 − 1.6/12) − 8.51 = 51.5657 … 56.4340
# 12A (p = 19.05, d1 = 11.91), z = 25: d = 19.05 / sin 7.2° = 151.9948
#   ri 6.01455 … 6.01455 + 0.069·2.28417 = 6.17216; α 116.4 … 136.4
#   re 0.12·11.91·27 = 38.5884 … 0.008·11.91·805 = 76.7004
#   da 151.9948 + 19.05·0.936 − 11.91 = 157.9156 … 151.9948 + 23.8125 − 11.91 = 163.8973
HAND = [
    (CH08B, 18, 73.1364, (4.29755, 4.43842), (115, 135), (20.424, 34.3123), (76.1975, 80.5014)),
    (
        CH08B,
        12,
        49.0690,
        (4.29755, 4.43842),
        (112.5, 132.5),
        (14.2968, 22.0579),
        (51.5657, 56.4340),
    ),
    (
        CH12A,
        25,
        151.9948,
        (6.01455, 6.17216),
        (116.4, 136.4),
        (38.5884, 76.7004),
        (157.9156, 163.8973),
    ),
]


@pytest.mark.parametrize("chain,z,d,ri,alpha,re,da", HAND)
def test_iso606_forms_by_hand(chain, z, d, ri, alpha, re, da):
    mn = jc.ToothProfile.iso606(chain, z, "min")
    mx = jc.ToothProfile.iso606(chain, z, "max")
    mid = jc.ToothProfile.iso606(chain, z, "mid")
    close = lambda a, b: np.testing.assert_allclose(float(a), b, rtol=2e-5)  # noqa: E731
    close(mn.pitch_diameter * 1e3, d)
    # minimum gap form = (ri min, α max, re max, da max); maximum = the opposite corners
    close(mn.seating_radius * 1e3, ri[0])
    close(mx.seating_radius * 1e3, ri[1])
    close(np.degrees(mn.seating_angle), alpha[1])
    close(np.degrees(mx.seating_angle), alpha[0])
    close(mn.flank_radius * 1e3, re[1])
    close(mx.flank_radius * 1e3, re[0])
    close(mn.tip_diameter * 1e3, da[1])
    close(mx.tip_diameter * 1e3, da[0])
    close(mid.flank_radius * 1e3, (re[0] + re[1]) / 2)
    lim = jc.iso606_limits(chain, z)
    np.testing.assert_allclose(np.array(lim["tip_diameter"]) * 1e3, da, rtol=2e-5)


@pytest.mark.parametrize("z", [9, 12, 18, 30, 60, 120])
@pytest.mark.parametrize("form", ["min", "max", "mid"])
@pytest.mark.parametrize("name", ["06B", "08A", "08B", "10A", "12A", "16B"])
def test_derived_geometry_definitions(name, z, form):
    """J on the seat circle at α/2 from the inward radial, F on the ray c→J at ri + re,
    K on both the flank and the tip circle, all inside the half pitch: checked from the
    definitions, for every ISO form of every chain and tooth count."""
    p = jc.ToothProfile.iso606(jc.ChainSpec.iso606(name), z, form)
    g = p.geometry()
    c, j, f, k = (np.asarray(v) for v in (g.seat_centre, g.junction, g.flank_centre, g.tip_corner))
    ri, re, ra = float(p.seating_radius), float(p.flank_radius), float(p.tip_diameter) / 2
    np.testing.assert_allclose(c, [float(p.pitch_radius), 0.0], atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(j - c), ri, rtol=1e-12)
    ang = math.atan2(j[1] - c[1], -(j[0] - c[0]))  # from the inward radial
    np.testing.assert_allclose(ang, float(p.seating_angle) / 2, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(f - c), ri + re, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(f - j), re, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(k - f), re, rtol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(k), ra, rtol=1e-10)
    assert 0 < math.atan2(j[1], j[0]) < math.atan2(k[1], k[0]) < math.pi / z


def test_outline_is_c1_at_junction_and_closed():
    p = jc.ToothProfile.iso606(CH08B, 18, "mid")
    pts = p.outline(2000)
    steps = np.diff(pts, axis=0)
    lens = np.linalg.norm(steps, axis=1)
    assert lens.max() < 1e-4  # no jumps in the outline
    # the tangent turns smoothly (C¹): no kink except the flank/tip corner (convex, two of
    # them in one pitch)
    t = steps / lens[:, None]
    turn = np.degrees(np.arccos(np.clip(np.sum(t[1:] * t[:-1], axis=1), -1, 1)))
    big = np.nonzero(turn > 2.0)[0]
    assert len(big) == 2, turn[big]
    k = np.asarray(p.geometry().tip_corner)
    for i in big:  # the kinks sit at ±K
        assert min(np.linalg.norm(pts[i + 1] - k), np.linalg.norm(pts[i + 1] - k * [1, -1])) < 1e-9
    # ends on the tooth centre lines ±π/z
    for end, sign in ((pts[0], -1), (pts[-1], 1)):
        np.testing.assert_allclose(math.atan2(end[1], end[0]), sign * math.pi / 18, atol=1e-12)
    full = p.sprocket_outline(20)
    np.testing.assert_allclose(full[0], full[-1])


def test_fields_are_differentiable_leaves():
    p = jc.ToothProfile.iso606(CH08B, 18, "mid")
    leaves = jax.tree_util.tree_leaves(p)
    assert len(leaves) == 6 and all(jnp.issubdtype(x.dtype, jnp.floating) for x in leaves)
    g = jax.grad(lambda q: q.pitch_diameter + q.geometry().tip_corner[0])(p)
    assert all(np.isfinite(float(x)) for x in jax.tree_util.tree_leaves(g))
    assert float(g.tip_diameter) > 0  # K moves out with the tip circle


def _kw(p, **over):
    kw = dict(
        teeth=p.teeth, pitch=p.pitch, roller_diameter=p.roller_diameter,
        seating_radius=p.seating_radius, seating_angle=p.seating_angle,
        flank_radius=p.flank_radius, tip_diameter=p.tip_diameter,
    )  # fmt: skip
    kw.update(over)
    return kw


@pytest.mark.parametrize(
    "over,match",
    [
        ({"teeth": 5}, r"teeth must be in \[7, 250\], got 5"),
        ({"teeth": 300}, r"teeth must be in \[7, 250\]"),
        ({"teeth": 18.0}, r"teeth must be an integer"),
        ({"seating_radius": 4.0e-3}, r"seating_radius must be in \(roller radius 0.004255"),
        ({"seating_radius": 7.0e-3}, r"seating_radius must be in .*pitch/2"),
        ({"seating_angle": 120.0}, r"seating_angle must be in \[90°, 170°\].*radians"),
        ({"seating_angle": 1.0}, r"seating_angle must be in \[90°, 170°\]"),
        ({"flank_radius": 1e-3}, r"flank_radius must be in \[0.0102"),
        ({"flank_radius": 1.0}, r"flank_radius must be in"),
        ({"tip_diameter": 0.06}, r"tip_diameter must be in \(.*above the seat/flank junction"),
        ({"tip_diameter": 0.09}, r"tip_diameter must be in .*before\s+the tooth's centre line"),
        ({"roller_diameter": 0.02}, r"roller_diameter must be in \(0, pitch"),
        ({"pitch": -1.0}, r"pitch must be > 0"),
    ],
)
def test_validation_messages(over, match):
    p = jc.ToothProfile.iso606(CH08B, 18, "mid")
    with pytest.raises(ValueError, match=match):
        jc.ToothProfile(**_kw(p, **over))


def test_bad_form_and_teeth_in_factory():
    with pytest.raises(ValueError, match="form must be 'min', 'max' or 'mid'"):
        jc.ToothProfile.iso606(CH08B, 18, "avg")
    with pytest.raises(ValueError, match="teeth must be in"):
        jc.iso606_limits(CH08B, 3)


def test_traced_construction_skips_validation_and_vmaps():
    """Inside vmap/jit the fields are tracers: construction must not try to validate them,
    and a batch of profiles is usable."""
    p = jc.ToothProfile.iso606(CH08B, 18, "mid")

    def build(ri):
        return jc.ToothProfile(**_kw(p, seating_radius=ri))

    ris = jnp.linspace(4.30e-3, 4.43e-3, 5)
    batch = jax.vmap(build)(ris)
    np.testing.assert_allclose(batch.seating_radius, ris)
    d = jax.vmap(lambda q: q.seat_clearance)(batch)
    np.testing.assert_allclose(d, ris - CH08B.roller_diameter / 2)


def test_plot_profiles(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = jc.plot_profiles(CH08B, 18)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["ISO 606 min…max", "ISO 606 min form", "ISO 606 max form", "pitch circle"]
    out = tmp_path / "forms.png"
    ax.figure.savefig(out)
    assert out.stat().st_size > 10_000
    plt.close("all")
