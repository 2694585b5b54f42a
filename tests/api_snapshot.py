"""The public API of jaxchain as plain data, and its snapshot (tests/api_snapshot.json).

    python tests/api_snapshot.py            # print the current API as JSON
    python tests/api_snapshot.py --write    # record it as the snapshot (an intentional change)

For each public module: every public name, its kind (function, class, module, constant)
and, for callables, ``str(inspect.signature(obj))`` (a class: its constructor's, without
``self``). Classes add their public methods (with signatures), properties, fields (in
order; dataclass fields or NamedTuple fields) and, for an enumeration, its members.
tests/test_api_snapshot.py compares the snapshot with the current API.

Public names: ``__all__`` where a module defines it; else ``dir()`` less names with a
leading underscore, less names the module does not export under the rule for typed
packages (jaxchain ships ``py.typed``): a name is exported when the module's own code
defines it (``def``, ``class``, assignment) or re-exports it explicitly (``import X as X``,
``from m import X as X``). That leaves out a module's plain imports (``os``, ``Path``) and
submodules bound as attributes by an import elsewhere (``jaxchain.launch``).

Signatures are made stable across runs and environments: defaults print without memory
addresses, arrays by their values (not their dtype, which depends on ``jax_enable_x64``),
equinox modules as ``Name(field=value, ...)`` with every field, forward references as the
string they hold. Importing is all this does: no JAX computation is traced or compiled.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import enum
import functools
import importlib
import inspect
import json
import re
import sys
import typing
from pathlib import Path

SNAPSHOT = Path(__file__).with_name("api_snapshot.json")

# jaxchain.launch is public as the documented launcher (`python -m jaxchain.launch -n N`,
# README and jaxchain.distributed); its functions are recorded with the rest
MODULES = (
    "jaxchain",
    "jaxchain.scenes",
    "jaxchain.contact",
    "jaxchain.design",
    "jaxchain.observers",
    "jaxchain.loads",
    "jaxchain.elements",
    "jaxchain.distributed",
    "jaxchain.launch",
)
# classes whose fields are part of the contract in their order (tests/test_api_snapshot.py
# checks that the snapshot holds them)
FIELDS_OF = ("jaxchain.Solution", "jaxchain.Scene", "jaxchain.DriveState")

_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+|0x[0-9a-fA-F]{6,}")


def _strip_addresses(text: str) -> str:
    return _ADDRESS.sub("", text)


class _Repr:
    """Prints as the text given (a stable stand-in for a default value in a signature)."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


def stable_repr(value) -> str:
    """A repr of a default value that is the same in every run and environment."""
    import equinox as eqx
    import numpy as np

    if value is None or isinstance(value, bool | int | float | complex | str | bytes):
        return repr(value)
    if isinstance(value, enum.Enum):
        return f"{type(value).__qualname__}.{value.name}"
    if isinstance(value, tuple | list):
        items = ", ".join(stable_repr(v) for v in value)
        if isinstance(value, tuple) and hasattr(value, "_fields"):  # NamedTuple
            pairs = zip(value._fields, value, strict=True)
            fields = ", ".join(f"{f}={stable_repr(v)}" for f, v in pairs)
            return f"{type(value).__qualname__}({fields})"
        if isinstance(value, tuple):
            return f"({items},)" if len(value) == 1 else f"({items})"
        return f"[{items}]"
    if isinstance(value, dict):
        items = ", ".join(f"{stable_repr(k)}: {stable_repr(v)}" for k, v in value.items())
        return "{" + items + "}"
    if isinstance(value, frozenset | set):
        items = sorted(stable_repr(v) for v in value)
        return f"{type(value).__name__}({{{', '.join(items)}}})"
    if isinstance(value, np.generic):
        return repr(value.item())
    if hasattr(value, "shape") and hasattr(value, "dtype"):  # numpy or JAX array
        return f"array({np.asarray(value).tolist()!r})"
    if isinstance(value, eqx.Module) or dataclasses.is_dataclass(value):
        if isinstance(value, type):
            return _qualified(value)
        fields = ", ".join(
            f"{f.name}={stable_repr(getattr(value, f.name, '<unset>'))}"
            for f in dataclasses.fields(value)
        )
        return f"{type(value).__qualname__}({fields})"
    if isinstance(value, functools.partial):
        args = [stable_repr(value.func)] + [stable_repr(a) for a in value.args]
        args += [f"{k}={stable_repr(v)}" for k, v in value.keywords.items()]
        return f"functools.partial({', '.join(args)})"
    if inspect.isclass(value) or inspect.isroutine(value) or inspect.ismodule(value):
        return _qualified(value)
    return _strip_addresses(repr(value))


def _qualified(obj) -> str:
    if inspect.ismodule(obj):
        return f"<module {obj.__name__}>"
    module = getattr(obj, "__module__", None)
    name = getattr(obj, "__qualname__", None) or getattr(obj, "__name__", None) or repr(obj)
    return _strip_addresses(f"{module}.{name}" if module else name)


def _annotation(annotation):
    if isinstance(annotation, typing.ForwardRef):
        return annotation.__forward_arg__
    return annotation


def _format_annotation(annotation) -> str | None:
    if annotation is inspect.Parameter.empty:
        return None
    return _strip_addresses(inspect.formatannotation(_annotation(annotation)))


def signature(obj) -> dict:
    """``{"signature": str, "parameters": [[name, kind, text], ...], "returns": str}`` of a
    callable (``None`` each where Python cannot give its signature)."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return {"signature": None, "parameters": None, "returns": None}
    params = [
        p.replace(
            annotation=_annotation(p.annotation),
            default=p.default if p.default is p.empty else _Repr(stable_repr(p.default)),
        )
        for p in sig.parameters.values()
    ]
    sig = sig.replace(parameters=params, return_annotation=_annotation(sig.return_annotation))
    return {
        "signature": _strip_addresses(str(sig)),
        "parameters": [[p.name, p.kind.name, _strip_addresses(str(p))] for p in params],
        "returns": _format_annotation(sig.return_annotation),
    }


def _exported(module) -> set[str] | None:
    """Names the module's own code binds at top level as public: definitions, assignments
    and explicit re-exports (``X as X``); ``None`` where its source cannot be read."""
    try:
        tree = ast.parse(inspect.getsource(module))
    except (OSError, TypeError):
        return None
    names: set[str] = set()

    def targets(node):
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.Tuple | ast.List):
            for elt in node.elts:
                targets(elt)
        elif isinstance(node, ast.Starred):
            targets(node.value)

    def visit(body):
        for node in body:
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(node.name)
            elif isinstance(node, ast.Assign):
                for target in node.targets:
                    targets(target)
            elif isinstance(node, ast.AnnAssign | ast.AugAssign):
                targets(node.target)
            elif isinstance(node, ast.Import | ast.ImportFrom):
                names.update(a.asname for a in node.names if a.asname and a.asname == a.name)
            elif isinstance(node, ast.If):
                visit(node.body)
                visit(node.orelse)
            elif isinstance(node, ast.Try):
                visit(node.body)
                visit(node.orelse)
                visit(node.finalbody)
                for handler in node.handlers:
                    visit(handler.body)
            elif isinstance(node, ast.With):
                visit(node.body)

    visit(tree.body)
    return names


def public_names(module) -> list[str]:
    """The module's public names: ``__all__`` where it defines it, else ``dir()`` less
    private names and names it does not export (see the module docstring)."""
    if hasattr(module, "__all__"):
        return sorted(module.__all__)
    names = [n for n in dir(module) if not n.startswith("_")]
    exported = _exported(module)
    if exported is not None:
        names = [n for n in names if n in exported]
    return sorted(names)


def _owner(cls: type, name: str):
    for klass in cls.__mro__:
        if name in vars(klass):
            return klass, vars(klass)[name]
    return None, None


def _fields(cls: type) -> list[str] | None:
    if dataclasses.is_dataclass(cls):
        return [f.name for f in dataclasses.fields(cls)]
    if issubclass(cls, tuple) and hasattr(cls, "_fields"):
        return list(cls._fields)
    return None


def describe_class(cls: type) -> dict:
    import equinox as eqx

    entry = {"kind": "class", **signature(cls)}
    fields = _fields(cls)
    methods, properties, attributes = {}, [], []
    for name in dir(cls):
        if name.startswith("_") or (fields and name in fields):
            continue
        owner, raw = _owner(cls, name)
        # members inherited from outside jaxchain (tuple.count, Exception.args, ...) are
        # theirs, not jaxchain's
        if owner is None or not owner.__module__.startswith("jaxchain"):
            continue
        if isinstance(raw, property | functools.cached_property):
            properties.append(name)
        elif isinstance(raw, classmethod | staticmethod):
            methods[name] = signature(getattr(cls, name))
        elif inspect.isroutine(raw) or (callable(raw) and not inspect.isclass(raw)):
            methods[name] = signature(raw)
        else:
            attributes.append(name)
    entry["methods"] = methods
    entry["properties"] = properties
    entry["attributes"] = attributes
    if fields is not None:
        entry["fields"] = fields
    if issubclass(cls, eqx.Enumeration):
        entry["members"] = list(vars(cls).get("_name_to_item", {}))
    return entry


def describe(obj) -> dict:
    if inspect.ismodule(obj):
        return {"kind": "module", "module": obj.__name__}
    if inspect.isclass(obj):
        return describe_class(obj)
    if inspect.isroutine(obj) or (callable(obj) and hasattr(obj, "__wrapped__")):
        return {"kind": "function", **signature(obj)}
    return {"kind": "constant", "type": _qualified(type(obj))}


def current_api() -> dict:
    """The public API of the modules in :data:`MODULES`, as JSON-ready data."""
    modules = {}
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        modules[module_name] = {
            name: describe(getattr(module, name)) for name in public_names(module)
        }
    return {"modules": modules, "fields_of": list(FIELDS_OF)}


def dumps(api: dict) -> str:
    """JSON, one entry a line where it is flat (a scalar, or a list of scalars)."""

    def flat(value) -> bool:
        if isinstance(value, dict):
            return not value
        return not isinstance(value, list) or all(not isinstance(v, dict | list) for v in value)

    def render(value, indent: str) -> str:
        if flat(value):
            return json.dumps(value, ensure_ascii=False)
        inner = indent + " "
        if isinstance(value, dict):
            items = [f"{inner}{json.dumps(k)}: {render(v, inner)}" for k, v in value.items()]
            return "{\n" + ",\n".join(items) + f"\n{indent}}}" if items else "{}"
        items = [f"{inner}{render(v, inner)}" for v in value]
        return "[\n" + ",\n".join(items) + f"\n{indent}]"

    return render(api, "") + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write the snapshot ({SNAPSHOT})")
    parser.add_argument("--out", type=Path, default=SNAPSHOT, help="where --write writes")
    args = parser.parse_args(argv)
    # as in the tests (tests/conftest.py): float64, on the CPU
    import jax

    jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_platforms", "cpu")
    import jaxchain

    text = dumps(current_api())
    if args.write:
        args.out.write_text(text, encoding="utf-8")
        count = sum(len(v) for v in json.loads(text)["modules"].values())
        print(
            f"wrote {args.out}: {count} public names of {len(MODULES)} modules "
            f"(jaxchain from {Path(jaxchain.__file__).parent})",
            file=sys.stderr,
        )
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
