"""Drives and strands described as data (``jc.scenes.DriveSpec``, ``SprocketSpec``,
``StrandSpec``): a spec builds exactly the scene of the builder's keyword arguments, fills
what a sprocket leaves out with the builder's defaults, and names what is wrong."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc

from helpers import modelled

S = jc.scenes


def same_scene(a, b):
    """Equal structure, static fields and every array leaf."""
    la, ta = jax.tree_util.tree_flatten(a)
    lb, tb = jax.tree_util.tree_flatten(b)
    assert ta == tb
    for x, y in zip(la, lb, strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_the_default_spec_is_the_default_drive():
    spec = S.DriveSpec(settle=False)
    assert [s.teeth for s in spec.sprockets] == [18, 36]
    assert spec.arguments()["load_torque"] == 20.0
    same_scene(spec.build(), jc.scenes.drive(model=jc.scenes.ChainModel(settle=False)))


def test_of_gathers_the_per_sprocket_arguments_and_builds_the_same_scene():
    """A loop over three sprockets, one outside, with loads and inertias per driven
    sprocket and a free-form driver: ``DriveSpec.of`` takes drive's arguments, ``build``
    gives drive's scene."""
    iso = jc.ToothProfile.iso606(jc.ChainSpec.iso606("08B"), 18, "mid")
    kw = dict(
        teeth=(18, 12, 27),
        centres=((0.0, 0.0), (0.26, 0.12), (0.22, -0.18)),
        outside=(1,),
        load_torque=(0.0, 15.0),
        driven_inertia=(2e-4, 3e-3),
        profiles=(jc.FreeformProfile.from_iso(iso, 2), None, None),
        pretension=150.0,
        settle=False,
    )
    spec = S.DriveSpec.of("08B", **kw)
    assert spec.sprockets[1].outside and spec.sprockets[2].load == 15.0
    assert spec.sprockets[0].load is None  # the driver
    chain = jc.ChainSpec.iso606("08B")
    explicit = dict(kw)
    explicit["profiles"] = (
        kw["profiles"][0],
        jc.ToothProfile.iso606(chain, 12, "mid"),
        jc.ToothProfile.iso606(chain, 27, "mid"),
    )
    same_scene(spec.build(), jc.scenes.drive("08B", **modelled(**explicit)))
    # a sweep is a replace; a change of one sprocket is with_sprocket
    faster = spec.replace(speed_rpm=2000.0).build()
    assert float(faster.sprockets[0].speed) == pytest.approx(2000.0 * np.pi / 30)
    heavier = spec.with_sprocket(2, load=25.0)
    assert heavier.arguments()["load_torque"] == (0.0, 25.0)
    assert spec.arguments()["load_torque"] == (0.0, 15.0)  # frozen: the original stays


def test_an_inertia_left_out_is_the_builders_default():
    """One driven inertia given, the other left out: the one left out is the steel disc
    drive() takes by default."""
    spec = S.DriveSpec(
        sprockets=(
            S.SprocketSpec(18, centre=(0.0, 0.0), load=None),
            S.SprocketSpec(27, centre=(0.22, -0.18), load=15.0),
            S.SprocketSpec(12, centre=(0.26, 0.12), load=0.0, inertia=2e-4),
        ),
        settle=False,
    )
    built = spec.build()
    default = jc.scenes.drive(
        teeth=(18, 27, 12),
        centres=((0.0, 0.0), (0.22, -0.18), (0.26, 0.12)),
        load_torque=(15.0, 0.0),
        model=jc.scenes.ChainModel(settle=False),
    )
    assert float(built.sprockets[2].inertia) == 2e-4
    assert float(built.sprockets[1].inertia) == float(default.sprockets[1].inertia)


def test_elements_are_added_to_the_built_scene():
    class Nothing(jc.elements.AbstractElement):
        def effect(self, t, y, scene, state):
            return jc.elements.Effect(body=jnp.zeros_like(y.q))

    el = Nothing()
    spec = S.DriveSpec(elements=[el], settle=False)
    assert spec.elements == (el,)
    assert spec.build().force_elements[-1] is el


def test_a_strand_spec_is_the_engagement_scene():
    prof = jc.ToothProfile.iso606(jc.ChainSpec.iso606("08B"), 12, "min")
    spec = S.StrandSpec(
        sprocket=S.SprocketSpec(12, profile=prof, load=None),
        n_entry=3,
        tension=800.0,
        settle=False,
    )
    same_scene(
        spec.build(),
        jc.scenes.engagement(
            "08B",
            12,
            profile=prof,
            n_entry=3,
            tension=800.0,
            model=jc.scenes.ChainModel(settle=False),
        ),
    )
    scenes = [spec.replace(tension=t) for t in (500.0, 1000.0)]
    assert [s.arguments()["tension"] for s in scenes] == [500.0, 1000.0]


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: S.DriveSpec(sprockets=(S.SprocketSpec(18, load=None),)), "2 or more"),
        (lambda: S.DriveSpec(sprockets=(S.SprocketSpec(18), S.SprocketSpec(36))), "driver"),
        (
            lambda: S.DriveSpec(
                sprockets=(S.SprocketSpec(18, load=None), S.SprocketSpec(36, load=None))
            ),
            r"sprockets\[1\] are driven",
        ),
        (
            lambda: S.DriveSpec(
                sprockets=(S.SprocketSpec(18, centre=(0, 0), load=None), S.SprocketSpec(36))
            ),
            "centre of every sprocket",
        ),
        (lambda: S.StrandSpec(sprocket=18), "SprocketSpec"),
        # what the strand does not use is refused, not dropped
        (lambda: S.StrandSpec(sprocket=S.SprocketSpec(18, load=5.0)), "does not use.*load"),
        (
            lambda: S.StrandSpec(sprocket=S.SprocketSpec(18, load=None, centre=(0.1, 0.0))),
            "does not use its sprocket's centre",
        ),
        (
            lambda: S.StrandSpec(sprocket=S.SprocketSpec(18, load=None, inertia=1e-3)),
            "does not use its sprocket's inertia.*DriveSpec",
        ),
        (
            lambda: S.DriveSpec.of(
                teeth=(18, 36, 27), centres=((0, 0), (0.3, 0), (0.1, 0.2)), load_torque=(1.0,)
            ),
            r"load_torque must be one value .* \(2 for 3 sprockets\)",
        ),
        (lambda: S.DriveSpec.of(teeth=(18, 36, 27)), "give their axes in centres"),
    ],
)
def test_a_bad_spec_names_the_fix(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_values_are_checked_by_the_builder():
    """A spec carries values as given; the builder checks them with its own messages."""
    spec = S.DriveSpec(speed_rpm=-5.0, settle=False)
    with pytest.raises(ValueError, match="speed_rpm"):
        spec.build()
    # a changed copy is equal to one made so
    assert spec.replace(speed_rpm=1000.0) == S.DriveSpec(settle=False)
    assert eqx.tree_equal(spec.sprockets, S.DriveSpec().sprockets)
