"""Designing a tooth and its cushion ring together (``jc.design.SprocketDesign``): the
design space over both, the ring's leaves reaching the scene inside the differentiated
objective (with the statics' implicit derivative), AD against central differences, and
errors that name the fix."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain.design import DesignSpace, ProfileObjective, SprocketDesign

from helpers import fixed_step_joints, tooth_period

CHAIN = jc.ChainSpec.iso606("08B")
Z, RPM = 18, 1000.0
PERIOD = tooth_period(RPM, Z)
TOOTH = jc.ToothProfile.iso606(CHAIN, Z, "mid")
RING = jc.elements.CushionRing(0.0302)  # seated plate edges at 30.108 mm
LAW = jc.scenes.roller_law(CHAIN, 0.7, width=3e-6)  # onset resolved by 4 µs steps
SPACE = DesignSpace.select(
    SprocketDesign(TOOTH, RING),
    {
        "profile.seating_radius": jc.iso606_limits(CHAIN, Z)["seating_radius"],
        "cushion.radius": (0.0300, 0.0304),
        "cushion.stiffness": (2e7, 1e8),
    },
)


def _build(design, cushion=True):
    return jc.scenes.engagement(
        CHAIN,
        Z,
        speed_rpm=RPM,
        profile=design.profile,
        n_entry=3,
        model=jc.scenes.ChainModel(
            cushion=design.cushion if cushion else None,
            roller_contact=LAW,
            joint_friction=fixed_step_joints(),
        ),
    )


def _objective(build=_build):
    return ProfileObjective(
        SPACE, build, t1=2 * PERIOD, t_start=PERIOD, temperature=50.0, reference=2000.0,
        dt=4e-6, samples=8,
    )  # fmt: skip


def test_space_maps_coordinates_onto_tooth_and_ring():
    u = jnp.array([0.4, -0.7, 1.1])
    design = SPACE.design(u)
    assert isinstance(design, SprocketDesign)
    x = np.asarray(SPACE.values(u))
    assert float(design.profile.seating_radius) == pytest.approx(x[0], rel=1e-15)
    assert float(design.cushion.radius) == pytest.approx(x[1], rel=1e-15)
    assert float(design.cushion.stiffness) == pytest.approx(x[2], rel=1e-15)
    # what is not designed stays the template's
    assert float(design.cushion.damping) == float(RING.damping)
    assert float(design.profile.flank_radius) == float(TOOTH.flank_radius)
    assert SPACE.profile(u) == design.profile
    np.testing.assert_allclose(SPACE.coordinates(design), u, atol=1e-9)
    with pytest.raises(TypeError, match="designs a SprocketDesign; got a ToothProfile"):
        SPACE.coordinates(TOOTH)


def test_box_reaching_an_invalid_ring_is_refused():
    with pytest.raises(ValueError, match="outside valid designs.*cushion.radius lower"):
        DesignSpace.select(SprocketDesign(TOOTH, RING), {"cushion.radius": (-1e-3, 0.03)})
    with pytest.raises(ValueError, match="'cushion.faces' is not a leaf"):
        DesignSpace.select(SprocketDesign(TOOTH, RING), {"cushion.faces": (1, 2)})
    with pytest.raises(TypeError, match="SprocketDesign.cushion must be"):
        SprocketDesign(TOOTH, 0.0302)
    with pytest.raises(TypeError, match="SprocketDesign.profile must be a tooth profile"):
        SprocketDesign(RING)


def test_scene_without_the_ring_is_refused():
    obj = _objective(lambda d: _build(d, cushion=False))
    with pytest.raises(ValueError, match="scene has none on sprocket 0.*cushion=design.cushion"):
        obj.value(jnp.zeros(3))


def test_design_is_placed_on_its_sprocket():
    """What the objective differentiates: the design's tooth and ring swapped into a
    scene built with another ring, leaf for leaf (the other sprocket's parts and the
    ring's static geometry untouched)."""
    from jaxchain._design.sprocket import place

    u = jnp.array([-0.8, 1.3, 0.6])
    scene = _build(SPACE.design(jnp.zeros(3)))
    placed = place(scene, SPACE.design(u), 0)
    (el,) = [e for e in placed.elements if isinstance(e, jc.elements.CushionContacts)]
    want = SPACE.design(u)
    for leaf in ("radius", "stiffness", "damping", "exponent", "width"):
        assert float(getattr(el.rings[0], leaf)) == float(getattr(want.cushion, leaf))
    assert placed.sprockets[0].profile == want.profile
    assert el.sprockets == (0,) and el.sides == _ring_of(scene).sides
    with pytest.raises(ValueError, match="1 face.*sprocket 0 2"):
        place(scene, SprocketDesign(TOOTH, jc.elements.CushionRing(0.03, faces=1)), 0)


def _ring_of(scene):
    (el,) = [e for e in scene.elements if isinstance(e, jc.elements.CushionContacts)]
    return el


@pytest.mark.slow
def test_gradient_in_tooth_and_ring_matches_central_differences():
    """Forward mode through 4 µs fixed steps over two tooth periods (window over the
    second) and the statics' implicit derivative in the ring's radius and stiffness (a
    larger, stiffer ring settles the seated links higher), against central differences
    of the same objective with the scenes held, per coordinate. Measured |AD − FD| /
    |∇J|: 3.2e-7, 4.5e-9, 4.8e-8 at h = 1e-5 (∇J = [−0.53, −547, −119] N)."""
    obj = _objective()
    u = jnp.array([0.2, 0.3, -0.4])
    scenes = obj.scenes(u)
    value, grad, _ = obj.value_and_grad_on(u, scenes)  # a failed member would raise
    assert 100.0 < float(value) < 5000.0
    grad = np.asarray(grad)
    scale = np.linalg.norm(grad)
    assert grad[1] < 0  # a larger ring holds the strand off the teeth
    assert abs(grad[2]) > 1e-3 * scale  # the stiffness reaches the objective
    h = 1e-5
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        hi = float(obj.value_and_grad_on(u + e, scenes)[0])
        lo = float(obj.value_and_grad_on(u - e, scenes)[0])
        fd = (hi - lo) / (2 * h)
        assert math.isfinite(fd)
        assert abs(grad[i] - fd) < 1e-5 * scale, (i, grad[i], fd)
