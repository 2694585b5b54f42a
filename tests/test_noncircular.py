"""Non-circular sprockets (``jc.FreeformProfile.noncircular``): seats on a closed polygon
of chords exactly one pitch, a continuous 1-Lipschitz outline, and contact gradients in
the pitch curve's harmonics that match central differences."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc

CHAIN = jc.ChainSpec.iso606("08B")
OVAL = ((2, 1.0e-3, 0.3), (4, 2.0e-4, -1.0))


def oval(z=18, harmonics=OVAL, form="min"):
    return jc.FreeformProfile.noncircular(jc.ToothProfile.iso606(CHAIN, z, form), harmonics)


@pytest.mark.parametrize(
    "z, harmonics", [(9, ((2, 4e-4, 0.0),)), (18, OVAL), (42, ((3, 1.0e-3, 1.0),))]
)
def test_chords_are_one_pitch(z, harmonics):
    pts = oval(z, harmonics).pitch_points()
    chords = np.linalg.norm(np.roll(pts, -1, 0) - pts, axis=1)
    np.testing.assert_allclose(chords, CHAIN.pitch, rtol=0, atol=1e-12)
    # the seats follow the curve: the radius swings by about twice the amplitudes
    r = np.hypot(*pts.T)
    assert r.max() - r.min() > 1.5 * harmonics[0][1]


def test_seats_lie_on_the_stated_curve_with_its_phase():
    """Every seat centre (``pitch_points``, in the sprocket's frame) lies on r(θ) = R₀ +
    Σ Aᵢ·sin(nᵢθ + φᵢ) at its own polar angle: r − Σ Aᵢ·sin(nᵢθ + φᵢ) is one constant R₀
    (to the polygon solve's 1e-14 relative tolerance), and R₀ sits between the circle
    through z chords and that circle plus the amplitudes. With cos in place of sin (every
    oval turned by a quarter of its period) the residual would scatter by the amplitudes;
    the largest seat radius lies where the first harmonic's sine peaks."""
    p = oval()
    xy = np.asarray(p.pitch_points())
    theta = np.arctan2(xy[:, 1], xy[:, 0])
    r = np.hypot(xy[:, 0], xy[:, 1])
    wave = sum(a * np.sin(n * theta + ph) for n, a, ph in OVAL)
    r0 = r - wave
    assert np.ptp(r0) < 1e-12, np.ptp(r0)
    circle = float(CHAIN.pitch) / (2 * math.sin(math.pi / 18))
    assert abs(r0.mean() - circle) < sum(a for _, a, _ in OVAL)
    turned = r - sum(a * np.cos(n * theta + ph) for n, a, ph in OVAL)
    assert np.ptp(turned) > 1e-3  # what the sin → cos swap would leave (amplitude 1 mm)
    top = theta[np.argmax(r)] % math.pi  # 2nd order: the oval's long axis, mod π
    assert abs(top - (math.pi / 2 - 0.3) / 2 % math.pi) < math.pi / 18  # within a seat


def test_without_harmonics_it_is_the_base():
    base = jc.ToothProfile.iso606(CHAIN, 18)
    same = jc.FreeformProfile.noncircular(base, ())
    np.testing.assert_allclose(same.seat_offset, 0.0, atol=1e-15)
    np.testing.assert_allclose(same.phase, 0.0, atol=1e-15)
    pt = jnp.array([0.0362, 0.004])
    contact = jax.jit(jc.gap_contact)  # one compile per kind, not op by op
    np.testing.assert_allclose(contact(same, pt)[0], contact(base, pt)[0], atol=1e-15)


def test_outline_is_continuous_and_1_lipschitz():
    """The signed distance along closed circles through the seats, the flanks and the
    tips: never steeper than the path (1-Lipschitz), so continuous across every gap."""
    p = oval()
    sd = jax.jit(jax.vmap(lambda x: jc.signed_distance(p, x)[0]))
    r0 = float(p.pitch_radius)
    for r in (r0 - 2e-3, r0, r0 + 2e-3, r0 + 4e-3):
        a = np.linspace(0.0, 2 * math.pi, 40_001)
        pts = r * np.stack([np.cos(a), np.sin(a)], -1)
        d = np.asarray(sd(jnp.asarray(pts)))
        assert np.all(np.isfinite(d))
        step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        assert np.all(np.abs(np.diff(d)) <= step * (1 + 1e-9) + 1e-15)


def test_contact_gradient_in_the_harmonics_matches_central_differences():
    """d(depth)/d(amplitude, phase) of a roller pressed into seat 3, by AD through the
    polygon's Newton solve (implicit function theorem) and by central differences."""
    base = jc.ToothProfile.iso606(CHAIN, 18)
    seat = oval().pitch_points()[3]
    point = jnp.asarray(seat * (1 - 5e-3 / np.hypot(*seat)))  # 5 mm toward the axis

    @jax.jit
    def depth(h):
        p = jc.FreeformProfile.noncircular(base, ((2, h[0], h[1]), (4, 2e-4, -1.0)))
        return jc.gap_contact(p, point)[0]

    h = jnp.array([1.0e-3, 0.3])
    grad = jax.jit(jax.grad(depth))(h)
    eps = np.array([1e-7, 1e-5])
    fd = [
        (depth(h.at[i].add(eps[i])) - depth(h.at[i].add(-eps[i]))) / (2 * eps[i]) for i in range(2)
    ]
    np.testing.assert_allclose(grad, fd, rtol=1e-5)
    assert abs(float(grad[0])) > 0.1  # it does depend on the amplitude


def test_drawing_and_refusals(tmp_path):
    p = oval()
    path = p.to_dxf(tmp_path / "oval.dxf")
    assert path.stat().st_size > 1000
    with pytest.raises(ValueError, match=r"below z/2 = 9 \(the 18 seats sample"):
        oval(harmonics=((9, 1e-4, 0.0),))
    with pytest.raises(ValueError, match=r"harmonics\[0\]'s amplitude must be a scalar"):
        oval(harmonics=((2, np.array([1e-4, 2e-4]), 0.0),))
    with pytest.raises(ValueError, match=r"harmonics\[0\]'s phase must be finite"):
        oval(harmonics=((2, 1e-4, float("nan")),))
    with pytest.raises(ValueError, match="whole number >= 1"):
        jc.FreeformProfile.noncircular(jc.ToothProfile.iso606(CHAIN, 18), ((1.5, 1e-3, 0.0),))
    with pytest.raises(ValueError, match="must be \\(order, amplitude, phase\\)"):
        jc.FreeformProfile.noncircular(jc.ToothProfile.iso606(CHAIN, 18), ((2, 1e-3),))


@pytest.mark.slow
def test_a_drive_on_an_oval_driver_settles_and_runs():
    """The layout puts the chain on pitch circles; the statics settle it into the oval's
    seats without a warning, and one driver revolution runs with simulate's defaults."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a statics that does not converge warns
        driven = jc.ToothProfile.iso606(CHAIN, 36, "mid")
        profiles = (oval(harmonics=((2, 1.0e-3, 0.0),)), driven)
        scene = jc.scenes.drive(CHAIN, teeth=(18, 36), n_links=80, profiles=profiles)
    sol = jc.simulate(scene, 0.06, n_save=50)
    assert sol.ok
    assert 500.0 < float(sol.peak_contact_force) < 5000.0
