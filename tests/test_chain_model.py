"""The chain model as one object (``jc.scenes.ChainModel``): the builders take it as
``model=``, the older keywords still build the same scene, the specs carry it, and no
function of the library takes more than 15 parameters."""

import ast
from pathlib import Path

import pytest

import jaxchain as jc

from helpers import tree_allclose

ROOT = Path(__file__).resolve().parents[1]


def test_the_model_builds_what_the_older_keywords_build():
    """Both spellings give the same scene, leaf for leaf (raw layouts: no statics)."""
    law = jc.contact.DahlFriction(0.15)
    older = dict(restitution=0.6, joint_friction=law, link_damping=0.1, settle=False)
    model = jc.scenes.ChainModel(**older)
    with pytest.warns(DeprecationWarning, match="jc.scenes.ChainModel"):
        a = jc.scenes.drive("08B", (18, 36), **older)
    b = jc.scenes.drive("08B", (18, 36), model=model)
    assert tree_allclose(a, b, rtol=0.0)
    assert float(b.roller_law.restitution) == 0.6  # the model reached the contact law
    with pytest.warns(DeprecationWarning, match="jc.scenes.ChainModel"):
        c = jc.scenes.engagement("08B", 18, form="min", elongation=0.01, settle=False)
    d = jc.scenes.engagement(
        "08B", 18, model=jc.scenes.ChainModel(form="min", elongation=0.01, settle=False)
    )
    assert tree_allclose(c, d, rtol=0.0)
    plain = jc.scenes.engagement("08B", 18, model=jc.scenes.ChainModel(settle=False))
    assert not tree_allclose(d, plain, rtol=1e-9)


def test_a_spec_carries_its_model():
    spec = jc.scenes.DriveSpec(restitution=0.5, settle=False, load_ramp=0.01)
    assert spec.model == jc.scenes.ChainModel(restitution=0.5, settle=False, load_ramp=0.01)
    assert spec.arguments()["model"] == spec.model
    built = jc.scenes.drive("08B", (18, 36), model=spec.model)
    assert tree_allclose(spec.build(), built, rtol=0.0)


def test_the_model_and_its_keywords_are_checked():
    with pytest.raises(ValueError, match="restitution must be"):
        jc.scenes.ChainModel(restitution=1.5)
    with pytest.raises(ValueError, match="elongation must be"):
        jc.scenes.ChainModel(elongation=0.1)
    with pytest.raises(TypeError, match="model must be a jc.scenes.ChainModel"):
        jc.scenes.drive(model={"restitution": 0.5})
    with pytest.raises(TypeError, match="unexpected keyword argument 'restitutoin'"):
        jc.scenes.drive(restitutoin=0.5)
    with pytest.raises(ValueError, match="restitution given both as keywords and in model="):
        jc.scenes.engagement(restitution=0.5, model=jc.scenes.ChainModel(restitution=0.6))
    with pytest.raises(ValueError, match="lubrication: an oil film acts"):
        jc.scenes.engagement(
            model=jc.scenes.ChainModel(lubrication=jc.contact.OilFilm(viscosity=0.01))
        )


def test_the_older_keywords_warn_with_the_new_spelling():
    with pytest.warns(DeprecationWarning, match=r"model=jc.scenes.ChainModel\(settle=\.\.\.\)"):
        jc.scenes.engagement(settle=False)


def test_no_library_function_takes_more_than_15_parameters():
    """The builders' options travel as objects (ChainModel, the specs, SolveOptions):
    counted over every ``def`` in jaxchain/, ``self`` and ``*args``/``**kwargs`` aside."""
    over = []
    for path in sorted((ROOT / "jaxchain").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                a = node.args
                names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
                n = len([x for x in names if x not in ("self", "cls")])
                where = (path.relative_to(ROOT).as_posix(), node.name)
                if n > 15:
                    over.append((*where, n))
    assert not over, over
    assert len(list((ROOT / "jaxchain").rglob("*.py"))) > 50  # the scan saw the library
