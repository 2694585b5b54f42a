"""The fidelity as an object (jaxchain._scenes.fidelity): each builder takes it or its
name and builds the same scene; each fidelity refuses what of a model it cannot use, gives
its own default joint friction and layout stretch (against the closed forms they stand
for), and a bad fidelity is refused naming the valid ones. No solve: scenes from their
layouts."""

import warnings

import jax
import numpy as np
import pytest

import jaxchain as jc

RAW = jc.scenes.ChainModel(settle=False)


def _same(a, b):
    la, lb = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    assert len(la) == len(lb)
    for x, y in zip(la, lb, strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


@pytest.mark.parametrize(
    ("name", "obj"), [("lumped", jc.scenes.Lumped()), ("clearance", jc.scenes.Clearance())]
)
def test_the_object_and_its_name_build_the_same_scene(name, obj):
    by_name = jc.scenes.engagement(n_entry=3, fidelity=name, model=RAW)
    by_obj = jc.scenes.engagement(n_entry=3, fidelity=obj, model=RAW)
    assert by_obj.fidelity == by_name.fidelity == name and isinstance(by_obj.fidelity, str)
    _same(by_name, by_obj)
    spec = jc.scenes.DriveSpec(fidelity=obj, settle=False)
    _same(spec.build(), jc.scenes.drive(fidelity=name, model=RAW))
    assert obj == name and obj != "spans" and hash(obj) == hash(name) and str(obj) == name


def test_the_span_level_chain_by_object():
    _same(jc.scenes.drive(fidelity=jc.scenes.SpanLevel()), jc.scenes.drive(fidelity="spans"))
    with pytest.raises(ValueError, match="fidelity='spans' has no rollers to mesh"):
        jc.scenes.engagement(fidelity=jc.scenes.SpanLevel())
    with pytest.raises(ValueError, match="does not use restitution"):
        jc.scenes.SpanLevel().check(jc.scenes.ChainModel(restitution=0.5))
    with pytest.raises(ValueError, match="no rollers, links or joints to build"):
        jc.scenes.SpanLevel().bodies(None, None, None, closed=True, restitution=0.7,
                                     rollers_on_bush="joint", link_load=0.0,
                                     damping_ratio=0.05, pin_law=None, bush_law=None,
                                     joint_friction=None, lubrication=None)  # fmt: skip


def test_each_fidelity_s_defaults_and_refusals():
    chain = jc.ChainSpec.iso606("08B")
    lumped, clearance = jc.scenes.as_fidelity("lumped"), jc.scenes.as_fidelity("clearance")
    assert lumped.joint_friction() is jc.scenes.JOINT_FRICTION
    assert clearance.joint_friction() is jc.scenes.CLEARANCE_JOINT_FRICTION
    assert jc.scenes.default_joint_friction("clearance") is jc.scenes.CLEARANCE_JOINT_FRICTION
    # the layout's stretch per link at 1 kN: the elastic link's T/k, and the pin/bush
    # joint's clearance plus its contact's deflection under T
    k = jc.scenes.link_stiffness(chain, 1000.0)
    assert lumped.stretch(chain, 1000.0) == pytest.approx(1000.0 / k, rel=1e-15)
    law = jc.scenes.joint_law(chain, "pin", 1.0)
    expected = float(law.clearance) + float(law.deflection(1000.0))
    assert clearance.stretch(chain, 1000.0) == pytest.approx(expected, rel=1e-15)
    assert 1e-6 < lumped.stretch(chain, 1000.0) < clearance.stretch(chain, 1000.0) < 1e-3
    # the clearance chain pairs its rollers (roller link, pin link): an even count
    assert [clearance.even_rollers(n) for n in (8, 9)] == [8, 10]
    assert [lumped.even_rollers(n) for n in (8, 9)] == [8, 9]
    oil = jc.scenes.ChainModel(lubrication=jc.contact.OilFilm(viscosity=0.01))
    clearance.check(oil)  # an oil film acts in its joints
    with pytest.raises(ValueError, match="fidelity='lumped' has no clearance joints"):
        lumped.check(oil)


def test_a_bad_fidelity_is_refused_and_the_older_check_warns():
    with pytest.raises(ValueError, match="fidelity must be one of 'lumped', 'clearance', 'spans'"):
        jc.scenes.as_fidelity("exact")
    with pytest.raises(TypeError, match=r"jc.scenes.Lumped\(\), Clearance\(\), SpanLevel\(\)"):
        jc.scenes.engagement(fidelity=2)
    with pytest.warns(DeprecationWarning, match="as_fidelity"):
        jc.scenes.ChainModel().check_fidelity("clearance")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(ValueError, match="has no clearance joints"):
            jc.scenes.ChainModel(lubrication=jc.contact.OilFilm(0.01)).check_fidelity("lumped")
