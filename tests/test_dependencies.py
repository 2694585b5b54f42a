"""The JAX stack in use is inside the bounds ``pyproject.toml`` declares (the releases
jaxchain is tested on), and no module of jaxchain but its wrapper reads a dependency's
private API."""

import ast
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
BOUNDED = ("jax", "jaxlib", "equinox", "diffrax", "optimistix")


def _requirements() -> dict[str, Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    reqs = (Requirement(r) for r in project["dependencies"])
    return {r.name: r for r in reqs}


@pytest.mark.parametrize("name", BOUNDED)
def test_the_version_in_use_is_inside_its_bounds(name):
    req = _requirements()[name]
    assert any(s.operator == "<" for s in req.specifier), f"{name} has no upper bound"
    version = metadata.version(name)
    assert req.specifier.contains(version, prereleases=True), f"{name} {version} not in {req}"


def test_private_apis_of_dependencies_only_in_the_wrapper():
    """``from equinox._errors import ...`` and the like: only in ``jaxchain/_deps.py``."""
    found = []
    for path in (ROOT / "jaxchain").rglob("*.py"):
        if path.name == "_deps.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module + "." + a.name for a in node.names]
            for n in names:
                top, *rest = n.split(".")
                if top != "jaxchain" and any(p.startswith("_") for p in rest[:1]):
                    found.append(f"{path.relative_to(ROOT)}: {n}")
    assert not found, found
