"""The library's layers: each private package imports only those below it, so an element,
a law or an observer never depends on the solve that uses it (read from the source's
relative imports; no JAX)."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "jaxchain"

#: bottom to top; a package may import itself and those before it
ORDER = (
    "_deps", "_numerics", "_checks", "_materials", "_kinematics", "_programs", "_chain", "_contact",
    "_loads", "_profiles", "_elements", "_scene", "_dynamics", "_observers", "_scenes",
    "_solve", "_statistics", "_design", "_plots",
)  # fmt: skip


def imports(path: Path) -> set[str]:
    """The top-level jaxchain modules ``path`` imports relatively."""
    package = list(path.relative_to(ROOT).parent.parts)
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[: len(package) - (node.level - 1)]
            target = base + [m for m in (node.module or "").split(".") if m]
            out |= {target[0]} if target else {a.name for a in node.names}
    return out


def _owner(path: Path) -> str:
    return path.relative_to(ROOT).with_suffix("").parts[0]


def test_every_private_module_has_a_layer():
    private = {_owner(p) for p in ROOT.rglob("*.py") if _owner(p).startswith("_")}
    assert private - {"__init__"} <= set(ORDER), private - set(ORDER)


@pytest.mark.parametrize("layer", ORDER)
def test_no_import_runs_up(layer):
    allowed = set(ORDER[: ORDER.index(layer) + 1])
    for path in ROOT.rglob("*.py"):
        if _owner(path) == layer:
            up = {m for m in imports(path) if m.startswith("_")} - allowed
            assert not up, f"{path.relative_to(ROOT)} imports {sorted(up)}, above {layer}"


#: what the studies and notebooks may import from the main job: its problem definitions
#: (the runner, optimize.run, and the command line are the job's own)
PROBLEMS = {
    "optimize", "optimize.problem", "optimize.clearance", "optimize.timing", "optimize.quiet"
}  # fmt: skip


def absolute_imports(path: Path) -> set[str]:
    """The modules ``path`` imports by absolute name (``import a.b``, ``from a.b import c``)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return out


def test_studies_use_the_main_job_s_problems_only_and_the_job_no_study():
    """benchmarks/ and the notebooks' generators import from optimize/ only its problem
    definitions, never its runner; optimize/ imports nothing from benchmarks/."""
    repo = ROOT.parent
    for path in [*repo.glob("benchmarks/*.py"), *repo.glob("notebooks/_make_*.py")]:
        used = {m for m in absolute_imports(path) if m.split(".")[0] == "optimize"}
        assert used <= PROBLEMS, f"{path.relative_to(repo)} imports {sorted(used - PROBLEMS)}"
    for path in repo.glob("optimize/*.py"):
        used = {m for m in absolute_imports(path) if m.split(".")[0] == "benchmarks"}
        assert not used, f"{path.relative_to(repo)} imports {sorted(used)}"
