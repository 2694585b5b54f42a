"""A sprocket kind defined in this file alone (``jc.AbstractProfile`` + ``jc.AbstractShape``):
a wheel whose gaps are round holes (a pin-gear-like outline). The contact, the builders,
the statics, the solve and save/load read it with no change anywhere else; beside a sprocket of
another kind it is read on its own."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc

from helpers import tooth_period

CHAIN = jc.ChainSpec.iso606("08B")


class RoundShape(jc.AbstractShape):
    """Round seats of radius ``seating_radius`` on the pitch circle, cut into a disc of
    diameter ``tip_diameter``: the gap is the union of the hole and the outside of the
    disc, its signed distance the larger of theirs (continuous, 1-Lipschitz)."""

    teeth: jax.Array
    pitch: jax.Array
    roller_diameter: jax.Array
    seating_radius: jax.Array
    tip_diameter: jax.Array

    @property
    def roller_radius(self):
        return self.roller_diameter / 2

    def nearest_gap(self, point):
        theta = jax.lax.stop_gradient(jnp.arctan2(point[1], point[0]))
        k = jnp.round(theta * self.teeth / (2 * jnp.pi))
        return jnp.mod(k, self.teeth).astype(jnp.int32)

    def _value(self, point):
        k = self.nearest_gap(point)
        a = 2 * jnp.pi * k / self.teeth
        centre = (
            self.pitch / (2 * jnp.sin(jnp.pi / self.teeth)) * jnp.stack([jnp.cos(a), jnp.sin(a)])
        )
        hole = self.seating_radius - jnp.sqrt(jnp.sum((point - centre) ** 2))
        outside = jnp.sqrt(jnp.sum(point**2)) - self.tip_diameter / 2
        return jnp.maximum(hole, outside)

    def signed_distance(self, point):
        return self._value(point), jax.grad(self._value)(point)


class RoundGapProfile(jc.AbstractProfile):
    teeth: int = eqx.field(static=True)  # a count: static, as in every kind
    pitch: jax.Array
    roller_diameter: jax.Array
    seating_radius: jax.Array
    tip_diameter: jax.Array

    def contact_shape(self):
        return RoundShape(
            jnp.asarray(float(self.teeth)), self.pitch, self.roller_diameter,
            self.seating_radius, self.tip_diameter,
        )  # fmt: skip

    def outline(self, n=60, gap=0):
        a = 2 * math.pi * gap / self.teeth
        c = float(self.pitch_radius) * np.array([math.cos(a), math.sin(a)])
        t = np.linspace(a + math.pi / 2, a + 3 * math.pi / 2, n)
        return c + float(self.seating_radius) * np.stack([np.cos(t), np.sin(t)], -1)

    def sprocket_outline(self, n=30):
        pts = np.concatenate([self.outline(n, k) for k in range(self.teeth)])
        return np.concatenate([pts, pts[:1]])


def round_gaps(teeth=18):
    """Seats of radius 0.55·d1 and a tip circle 0.05·d1 outside the pitch circle: each
    hole opens wider than a roller (2·√(0.55² − 0.05²)·d1 > d1), so rollers enter and
    leave."""
    ref = jc.ToothProfile.iso606(CHAIN, teeth)
    d1 = CHAIN.roller_diameter
    return RoundGapProfile(
        teeth, ref.pitch, ref.roller_diameter, jnp.asarray(0.55 * d1),
        2 * (ref.pitch_radius + 0.05 * d1),
    )  # fmt: skip


def test_contact_reads_the_new_kind():
    """Depth and normal at a seat, inside a tooth and beyond the tip."""
    p = round_gaps()
    r = float(p.pitch_radius)
    # a roller pressed 0.1 mm into the seat's bottom, on the gap axis of gap 3
    a = 2 * math.pi * 3 / 18
    pt = (r - (0.55 - 0.5) * CHAIN.roller_diameter - 1e-4) * np.array([math.cos(a), math.sin(a)])
    depth, normal = jc.gap_contact(p, pt)
    assert float(depth) == pytest.approx(1e-4, rel=1e-9)
    np.testing.assert_allclose(normal, [math.cos(a), math.sin(a)], atol=1e-12)
    assert int(jc.nearest_gap(p, pt)) == 3
    # far outside the sprocket: free
    assert float(jc.gap_contact(p, [0.2, 0.0])[0]) < -0.1

    # differentiable in its leaves: a seat larger by 1 m overlaps the roller 1 m less
    def depth_at(ri):
        return jc.gap_contact(
            RoundGapProfile(18, p.pitch, p.roller_diameter, ri, p.tip_diameter), pt
        )[0]

    assert float(jax.grad(depth_at)(p.seating_radius)) == pytest.approx(-1.0)


def test_simulate_with_the_new_kind_alone_and_beside_another():
    """An engagement on the round-gap sprocket settles and meshes; a drive with a round-gap
    driver and an ISO driven sprocket (shapes that do not stack: read one by one) runs."""
    sc = jc.scenes.engagement(CHAIN, 18, profile=round_gaps(), n_entry=3)
    sol = jc.simulate(sc, tooth_period(1000, 18), n_save=5)
    assert sol.ok, sol.message
    # the next roller meshes at the end of the period: the force rises to the last save
    # (525 N from the settled start to 4668 N), where the peak record's top is that
    # sample; against rtol 1e-8 (no new compile) the same to 2e-8 (bound 1e-6)
    f = np.asarray(sol.roller_sprocket_force).max(axis=1)
    assert np.all(np.diff(f) > 0) and f[-1] > 5 * f[0]
    peak = float(sol.peak_contact_force)
    assert peak == pytest.approx(f[-1], rel=1e-12)
    tight = jc.simulate(sc, tooth_period(1000, 18), n_save=5, rtol=1e-8, atol=1e-11)
    assert peak == pytest.approx(float(tight.peak_contact_force), rel=1e-6)
    mixed = jc.scenes.drive(
        CHAIN,
        teeth=(18, 18),
        n_links=40,
        speed_rpm=600,
        load_torque=5.0,
        profiles=(round_gaps(), jc.ToothProfile.iso606(CHAIN, 18)),
    )
    sol = jc.simulate(mixed, tooth_period(600, 18), n_save=3)
    assert sol.ok, sol.message
    assert float(sol.peak_contact_force) > 10.0
    assert float(jnp.max(sol.roller_sprocket_force)) > 10.0


def test_the_new_kind_saves_and_loads(tmp_path):
    """A kind defined in this file alone saves as JSON and loads back leaf for leaf, as
    itself: defining its class is all it takes."""
    p = round_gaps()
    back = jc.load_profile(p.save(tmp_path / "round.json"))
    assert type(back) is RoundGapProfile and back.teeth == p.teeth
    for a, b in zip(jax.tree_util.tree_leaves(p), jax.tree_util.tree_leaves(back), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_a_kind_must_say_how_far_its_teeth_reach():
    """``tip_diameter`` (what the contact slots and the meshing events read) is checked at
    construction."""

    class NoTip(jc.AbstractProfile):
        teeth: int = eqx.field(static=True)
        pitch: jax.Array
        roller_diameter: jax.Array
        seating_radius: jax.Array

        def contact_shape(self):
            raise NotImplementedError

        def outline(self, n=60, gap=0):
            raise NotImplementedError

        def sprocket_outline(self, n=30):
            raise NotImplementedError

    with pytest.raises(TypeError, match="needs a tip_diameter"):
        NoTip(18, jnp.asarray(0.0127), jnp.asarray(0.0085), jnp.asarray(0.0043))


def test_what_the_new_kind_does_not_give_is_said():
    """No arc-spline form: the DXF export says so."""
    with pytest.raises(TypeError, match="RoundGapProfile has no free-form"):
        round_gaps().to_dxf("never.dxf")
    pts = round_gaps().pitch_points()
    np.testing.assert_allclose(np.hypot(*pts.T), float(round_gaps().pitch_radius))
