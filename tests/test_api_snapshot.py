"""The public API against its snapshot (tests/api_snapshot.json, from tests/api_snapshot.py).

Every recorded public name of jaxchain, jaxchain.scenes, .contact, .design, .observers,
.distributed and .launch must still exist with the same kind and signature; a class keeps
its recorded methods (same signatures), properties, attributes, enumeration members and
fields, the fields in their recorded order. What is new passes and is reported (a
warning): public names, methods, properties, fields, members, and parameters added to a
signature in a way no existing call notices (each new one has a default or is ``*args`` /
``**kwargs``, and every recorded one keeps its text and, if positional, its position).
Anything else, a changed annotation or default included, fails.

Import only: nothing is traced or compiled.

After an intentional API change, record it: ``python tests/api_snapshot.py --write``.
"""

from __future__ import annotations

import json
import warnings

import pytest
from api_snapshot import FIELDS_OF, MODULES, SNAPSHOT, current_api

UPDATE = "If the change is intended, record it: python tests/api_snapshot.py --write"

POSITIONAL = ("POSITIONAL_ONLY", "POSITIONAL_OR_KEYWORD")
VARIADIC = ("VAR_POSITIONAL", "VAR_KEYWORD")


class APIAdditionsWarning(UserWarning):
    """Public API added since the snapshot (allowed; recorded by the next --write)."""


@pytest.fixture(scope="module")
def snapshot() -> dict:
    if not SNAPSHOT.exists():
        pytest.fail(f"{SNAPSHOT} is missing. Generate it: python tests/api_snapshot.py --write")
    return json.loads(SNAPSHOT.read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def current() -> dict:
    return current_api()


def _extension(old: dict, new: dict) -> list[str] | None:
    """The parameters ``new`` adds to ``old`` where no call valid for ``old`` notices them;
    ``None`` where the change is anything else."""
    if old["parameters"] is None or new["parameters"] is None:
        return None
    if old["returns"] != new["returns"]:
        return None
    new_params = {name: (kind, text) for name, kind, text in new["parameters"]}
    for name, kind, text in old["parameters"]:
        if new_params.get(name) != (kind, text):
            return None
    old_positional = [p[0] for p in old["parameters"] if p[1] in POSITIONAL]
    new_positional = [p[0] for p in new["parameters"] if p[1] in POSITIONAL]
    if new_positional[: len(old_positional)] != old_positional:
        return None
    # with *args, a new positional parameter would take what *args took
    takes_rest = any(p[1] == "VAR_POSITIONAL" for p in old["parameters"])
    if takes_rest and len(new_positional) > len(old_positional):
        return None
    old_names = {p[0] for p in old["parameters"]}
    added = [p for p in new["parameters"] if p[0] not in old_names]
    if not all(_has_default(kind, text) for _, kind, text in added):
        return None
    return [text for _, _, text in added]


def _has_default(kind: str, text: str) -> bool:
    """Whether a parameter, as ``str(inspect.Parameter)`` writes it, can be left out."""
    if kind in VARIADIC:
        return True
    # "name=default" without an annotation, "name: 'annotation' = default" with one
    return " = " in text if ":" in text else "=" in text


def _compare_signature(where: str, old: dict, new: dict, problems: list, added: list) -> None:
    if old["signature"] == new["signature"]:
        return
    extension = _extension(old, new)
    if extension is not None:
        added.append(f"{where}: new parameters {', '.join(extension)}")
        return
    problems.append(
        f"{where}: signature changed\n      old: {old['signature']}\n      new: {new['signature']}"
    )


def _compare_names(where: str, what: str, old: list, new: list, problems, added) -> None:
    gone = [n for n in old if n not in new]
    if gone:
        problems.append(f"{where}: {what} removed: {', '.join(gone)}")
    extra = [n for n in new if n not in old]
    if extra:
        added.append(f"{where}: new {what}: {', '.join(extra)}")


def _compare_class(where: str, old: dict, new: dict, problems: list, added: list) -> None:
    _compare_signature(where, old, new, problems, added)
    for name, old_method in old["methods"].items():
        new_method = new["methods"].get(name)
        if new_method is None:
            now = "now a property" if name in new["properties"] else "gone"
            problems.append(f"{where}.{name}: method removed ({now})")
        else:
            _compare_signature(f"{where}.{name}", old_method, new_method, problems, added)
    extra = [n for n in new["methods"] if n not in old["methods"]]
    if extra:
        added.append(f"{where}: new methods: {', '.join(extra)}")
    for key in ("properties", "attributes", "members"):
        if key in old or key in new:
            _compare_names(where, key, old.get(key, []), new.get(key, []), problems, added)
    if "fields" in old or "fields" in new:
        old_fields, new_fields = old.get("fields", []), new.get("fields", [])
        _compare_names(where, "fields", old_fields, new_fields, problems, added)
        kept = [f for f in new_fields if f in old_fields]
        if kept != [f for f in old_fields if f in new_fields]:
            problems.append(
                f"{where}: fields reordered\n      old: {old_fields}\n      new: {new_fields}"
            )


def compare(old_api: dict, new_api: dict) -> tuple[list[str], list[str]]:
    """(problems, additions) between the snapshot ``old_api`` and ``new_api``."""
    problems: list[str] = []
    added: list[str] = []
    for module, old_names in old_api["modules"].items():
        new_names = new_api["modules"].get(module)
        if new_names is None:
            problems.append(f"{module}: module no longer recorded (tests/api_snapshot.py)")
            continue
        for name, old in old_names.items():
            where = f"{module}.{name}"
            new = new_names.get(name)
            if new is None:
                problems.append(f"{where}: removed (was a {old['kind']})")
            elif new["kind"] != old["kind"]:
                problems.append(f"{where}: was a {old['kind']}, is a {new['kind']}")
            elif old["kind"] == "function":
                _compare_signature(where, old, new, problems, added)
            elif old["kind"] == "class":
                _compare_class(where, old, new, problems, added)
            elif old["kind"] == "constant" and old["type"] != new["type"]:
                problems.append(f"{where}: constant of type {old['type']}, now {new['type']}")
            elif old["kind"] == "module" and old["module"] != new["module"]:
                problems.append(f"{where}: was module {old['module']}, is {new['module']}")
        extra = sorted(set(new_names) - set(old_names))
        if extra:
            added.append(f"{module}: new public names: {', '.join(extra)}")
    return problems, added


def test_public_api_matches_snapshot(snapshot, current):
    assert sorted(snapshot["modules"]) == sorted(MODULES), (
        f"the snapshot records {sorted(snapshot['modules'])}, tests/api_snapshot.py "
        f"{sorted(MODULES)}. {UPDATE}"
    )
    problems, added = compare(snapshot, current)
    if added:
        message = "public API added since the snapshot (allowed):\n  " + "\n  ".join(added)
        print(message)
        warnings.warn(message, APIAdditionsWarning, stacklevel=1)
    assert not problems, (
        f"{len(problems)} recorded public API entries were removed or changed:\n  "
        + "\n  ".join(problems)
        + f"\n{UPDATE}"
    )


@pytest.mark.parametrize("qualified", FIELDS_OF)
def test_fields_kept_in_order(snapshot, current, qualified):
    """The snapshot holds the fields of Solution, Scene and DriveState; they are all still
    fields, in their recorded order (new ones may come anywhere)."""
    module, _, name = qualified.rpartition(".")
    recorded = snapshot["modules"][module][name].get("fields")
    assert recorded, f"the snapshot holds no fields of {qualified}. {UPDATE}"
    fields = current["modules"][module][name].get("fields") or []
    missing = [f for f in recorded if f not in fields]
    assert not missing, f"{qualified}: fields removed: {missing}. {UPDATE}"
    kept = [f for f in fields if f in recorded]
    assert kept == recorded, (
        f"{qualified}: fields reordered\n  recorded: {recorded}\n  now: {fields}\n{UPDATE}"
    )


def test_snapshot_is_stable(current):
    """The recorded form does not change between two readings (no memory addresses or
    other per-run text in signatures)."""
    assert current_api() == current


def test_comparison_reports_changes():
    """compare() itself: a removed name, a changed signature and a removed field fail; a
    new name and a new keyword with a default are only reported."""

    def function(signature, parameters):
        return {
            "kind": "function",
            "signature": signature,
            "parameters": parameters,
            "returns": None,
        }

    a = ["a", "POSITIONAL_OR_KEYWORD", "a"]
    old = {
        "modules": {
            "m": {
                "f": function("(a)", [a]),
                "g": function("(a)", [a]),
                "h": function("(a)", [a]),
                "C": {
                    "kind": "class",
                    "signature": "()",
                    "parameters": [],
                    "returns": None,
                    "methods": {},
                    "properties": ["p"],
                    "attributes": [],
                    "fields": ["x", "y"],
                },
            }
        }
    }
    new = {
        "modules": {
            "m": {
                "f": function("(a, *, b=1)", [a, ["b", "KEYWORD_ONLY", "b=1"]]),
                "g": function("(a, b)", [a, ["b", "POSITIONAL_OR_KEYWORD", "b"]]),
                "C": {
                    "kind": "class",
                    "signature": "()",
                    "parameters": [],
                    "returns": None,
                    "methods": {},
                    "properties": ["p", "q"],
                    "attributes": [],
                    "fields": ["y"],
                },
                "k": {"kind": "constant", "type": "builtins.int"},
            }
        }
    }
    problems, added = compare(old, new)
    text = "\n".join(problems)
    assert "m.g: signature changed" in text and "old: (a)" in text and "new: (a, b)" in text
    assert "m.h: removed" in text
    assert "m.C: fields removed: x" in text
    assert "m.f" not in text
    assert any("m.f: new parameters b=1" in line for line in added)
    assert any("new public names: k" in line for line in added)
    assert any("new properties: q" in line for line in added)
