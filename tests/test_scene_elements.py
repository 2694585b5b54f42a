"""A scene is its elements: every force element, built-in or the user's, lives in
``Scene.elements``, the built-in parts in the order of ``ROLES`` (the order the equations
of motion sum them), the others after; the scene's named parts (``pairs``,
``joint_friction``, ``roller_law``, ``friction``, ``gravity``, ...) are views of those
elements, and the same names as keywords put a part in place. The scene, the dynamics and
the solve import no concrete element (read from the source; no solve here)."""

import ast
import dataclasses
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxchain as jc
from jaxchain._scene import ROLES

ROOT = Path(__file__).resolve().parents[1] / "jaxchain"


class Push(jc.elements.AbstractElement):
    """A constant force on body 0 (a user's element)."""

    force: jnp.ndarray

    def effect(self, t, y, scene, state):
        return jc.elements.Effect(body=jnp.zeros_like(y.q).at[0, :2].add(self.force))


@pytest.fixture(scope="module")
def strand():
    """An engagement strand from its layout (no statics): links, joint friction, anchors,
    the roller/tooth contact and gravity."""
    return jc.scenes.engagement("08B", 18, model=jc.scenes.ChainModel(settle=False))


def roles(scene):
    return [el.role for el in scene.elements]


def test_the_built_in_parts_are_elements_in_their_order(strand):
    got = roles(strand)
    assert set(got) == {"pairs", "joint_friction", "anchors", "roller_teeth", "gravity"}
    assert got == sorted(got, key=ROLES.index)  # the ROLES order, pairs first
    # the views are the elements themselves
    assert strand.pairs == tuple(el for el in strand.elements if el.role == "pairs")
    assert strand.joint_friction is strand.elements[got.index("joint_friction")]
    assert strand.anchors is strand.elements[got.index("anchors")]
    teeth = strand.elements[got.index("roller_teeth")]
    assert strand.roller_teeth is teeth and strand.roller_law is teeth.law
    assert strand.friction is teeth.friction
    assert strand.gravity is strand.elements[got.index("gravity")].acceleration
    assert strand.shoes is None and strand.tensioners is None and strand.added == ()
    assert strand.force_elements == strand.elements


def test_a_named_keyword_puts_that_part_in_place(strand):
    law = jc.contact.CoulombFriction(coefficient=0.3, slip_velocity=1e-2)
    changed = dataclasses.replace(strand, friction=law, joint_friction=None, gravity=[0, -9.81])
    assert changed.friction is law and changed.roller_law is strand.roller_law
    assert changed.joint_friction is None and "joint_friction" not in roles(changed)
    np.testing.assert_array_equal(changed.gravity, [0.0, -9.81])
    assert roles(changed) == [r for r in roles(strand) if r != "joint_friction"]
    assert changed.pairs == strand.pairs and changed.anchors is strand.anchors
    # back in place: the same order as before
    again = dataclasses.replace(changed, joint_friction=strand.joint_friction)
    assert roles(again) == roles(strand)


def test_views_reach_into_the_elements_with_tree_at(strand):
    heavy = eqx.tree_at(lambda s: s.gravity, strand, jnp.asarray([0.0, -9.81]))
    np.testing.assert_array_equal(heavy.gravity, [0.0, -9.81])
    stiff = eqx.tree_at(lambda s: s.pairs[0].element.stiffness, strand, 2.0)
    assert float(stiff.pairs[0].element.stiffness) == 2.0
    assert eqx.tree_equal(stiff.anchors, strand.anchors) and roles(stiff) == roles(strand)
    # a part taken out through its view leaves no hole
    free = eqx.tree_at(lambda s: s.joint_friction, strand, None)
    assert free.joint_friction is None and None not in free.force_elements


def test_added_elements_come_after_the_built_in_parts(strand):
    push = Push(jnp.asarray([1.0, 0.0]))
    scene = strand.add_elements(push)
    assert scene.elements[-1] is push and scene.added == (push,)
    # a built-in part changed later keeps the added element last
    moved = dataclasses.replace(scene, friction=None)
    assert moved.elements[-1] is push and moved.friction is None
    i = len(scene.elements) - 1
    other = Push(jnp.asarray([0.0, 1.0]))
    assert scene.with_force_element(i, other).added == (other,)


def test_wrong_parts_are_refused(strand):
    with pytest.raises(TypeError, match="unexpected keyword"):
        dataclasses.replace(strand, rollers=None)
    with pytest.raises(TypeError, match="role is 'shoes'"):
        dataclasses.replace(strand, shoes=strand.anchors)
    with pytest.raises(TypeError, match="AbstractElement"):
        dataclasses.replace(strand, elements=(*strand.elements, "not an element"))
    gravity = strand.elements[roles(strand).index("gravity")]
    with pytest.raises(ValueError, match="2 elements play 'gravity'"):
        dataclasses.replace(strand, elements=(*strand.elements, gravity))
    no_teeth = tuple(el for el in strand.elements if el.role != "roller_teeth")
    with pytest.raises(TypeError, match="give that element in elements"):
        dataclasses.replace(strand, elements=no_teeth, friction=None)


def _runtime_imports(path: Path) -> list[str]:
    """The relative module paths ``path`` imports outside ``if TYPE_CHECKING:``."""
    tree = ast.parse(path.read_text())
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for n in ast.walk(node)}
    return [
        node.module or ""
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and node.level and id(node) not in skip
    ]


@pytest.mark.parametrize("module", ["_scene.py", "_dynamics.py", "_solve"])
def test_scene_dynamics_and_solve_import_no_concrete_element_or_law(module):
    paths = sorted((ROOT / module).glob("*.py")) if module == "_solve" else [ROOT / module]
    for path in paths:
        for name in _runtime_imports(path):
            parts = name.split(".")
            if "_elements" in parts:
                assert parts[-1] == "base", f"{path.name} imports {name}"
            if "_contact" in parts:
                assert parts[-1] in ("base", "friction_base", "film_base"), (path.name, name)


def test_the_import_check_sees_a_concrete_import(tmp_path):
    """What the check above rests on: a runtime import of a concrete element is listed,
    one under TYPE_CHECKING is not."""
    src = tmp_path / "m.py"
    src.write_text(
        "from typing import TYPE_CHECKING\nfrom ._elements.rollers import RollerTeeth\n"
        "if TYPE_CHECKING:\n    from ._elements.shoes import Shoes\n"
    )
    assert _runtime_imports(src) == ["_elements.rollers"]
