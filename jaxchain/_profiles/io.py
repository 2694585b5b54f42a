"""Reading tooth profiles back from their JSON files (the format: :mod:`.record`)."""

from __future__ import annotations

import dataclasses
import inspect
import typing
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .base import AbstractProfile
from .freeform import FreeformProfile  # noqa: F401  (the built-in kinds: defined here)
from .iso import ToothProfile  # noqa: F401
from .record import FORMAT, HEADER, VERSION

__all__ = ["load_profile", "profile_from_dict", "profile_kinds"]


def _subclasses(base: type) -> list[type]:
    """Every subclass of ``base`` defined so far, in the order they were defined."""
    out, todo = [], [base]
    while todo:
        for c in todo.pop(0).__subclasses__():
            out.append(c)
            todo.append(c)
    return out


def profile_kinds() -> dict[str, type]:
    """Every concrete profile kind defined in this process, by class name: the kinds a
    file may hold. A kind of your own is known once its class is defined (its module
    imported); of two classes of one name, the later definition (a notebook cell run
    again)."""
    kinds = {}
    for c in _subclasses(AbstractProfile):
        if not inspect.isabstract(c):
            kinds[c.__name__] = c
    return kinds


def _part(owner: type, field: str, name: str) -> type | None:
    """The module class a profile nests under ``name`` in its ``field`` (a free-form
    profile's ``Flank``, or a part of a kind of your own): the field's declared class
    when it has that name, else the latest ``eqx.Module`` of that name."""
    try:
        declared = typing.get_type_hints(owner).get(field)
    except (NameError, TypeError):  # a hint that does not resolve: read by name
        declared = None
    if isinstance(declared, type) and declared.__name__ == name:
        return declared
    found = [c for c in _subclasses(eqx.Module) if c.__name__ == name]
    return found[-1] if found else None


# --------------------------------------------------------------------------- decode
def load_profile(path: str | Path) -> AbstractProfile:
    """The tooth profile saved at ``path`` by ``profile.save(path)``: a
    :class:`~jaxchain.ToothProfile`, a :class:`~jaxchain.FreeformProfile` or a kind of your
    own (defined before the call), equal to the saved one leaf for leaf (bit for bit in
    float64), validated as at construction.

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the file is not JSON, not a jaxchain profile, of an unknown kind, of a
            newer format version than this jaxchain reads, or its fields do not make a
            valid profile (the message names the file and what is wrong).
    """
    return checks.read_json_file(path, "profile", profile_from_dict)


def profile_from_dict(data: dict) -> AbstractProfile:
    """The profile of a dict made by :func:`profile_to_dict` (or read from its JSON).

    Raises:
        ValueError: not a jaxchain profile, unknown kind, newer format version, missing or
            unknown fields, values that are not numbers, or an invalid profile.
    """
    checks.file_header(data, format=FORMAT, version=VERSION, what="profile", writer="profile.save")
    kind = data.get("kind")
    kinds = profile_kinds()
    if kind not in kinds:
        raise ValueError(
            f"unknown profile kind {kind!r}; known kinds: {', '.join(kinds)} (a kind of your "
            "own is known once its class is defined: import its module first)"
        )
    fields = {k: v for k, v in data.items() if k not in HEADER}
    return _build(kinds[kind], fields, kind)


def _build(cls: type, data: dict, where: str):
    """``cls`` from its fields in ``data``, through its constructor (which validates), with
    every array leaf exactly the array read (a constructor may normalize shapes, e.g. an
    empty ``breaks``)."""
    names = [f.name for f in dataclasses.fields(cls)]
    missing = [n for n in names if n not in data]
    unknown = [n for n in data if n not in names]
    if missing or unknown:
        raise ValueError(
            f"{where}: fields do not match a {cls.__name__}"
            + (f"; missing {missing}" if missing else "")
            + (f"; unknown {unknown}" if unknown else "")
            + f" (its fields: {names})"
        )
    kwargs, arrays = {}, {}
    for f in dataclasses.fields(cls):
        raw, name = data[f.name], f"{where}.{f.name}"
        if isinstance(raw, dict):
            part = raw.get("kind")
            cls_part = _part(cls, f.name, part) if isinstance(part, str) else None
            if cls_part is None:
                raise ValueError(
                    f"{name}: unknown part kind {part!r} (no module class of that name is defined)"
                )
            fields = {k: v for k, v in raw.items() if k != "kind"}
            kwargs[f.name] = _build(cls_part, fields, name)
        elif f.metadata.get("static", False):
            if isinstance(raw, (bool, list)) or not isinstance(raw, (int, float, str)):
                raise ValueError(f"{name} must be a number, got {raw!r}")
            kwargs[f.name] = raw
        else:
            arr = _array(raw, name)
            kwargs[f.name] = arr
            arrays[f.name] = arr
    try:
        module = cls(**kwargs)
    except TypeError as e:  # a constructor's type check: the file's values do not fit
        raise ValueError(f"{where}: {e}") from None
    if not arrays:
        return module
    exact = [jnp.asarray(a, dtype=getattr(module, n).dtype) for n, a in arrays.items()]
    return eqx.tree_at(lambda m: [getattr(m, n) for n in arrays], module, exact)


def _array(raw, name: str) -> np.ndarray:
    """A float64 array from a number or rectangular nested lists of numbers."""

    def numbers(x) -> bool:
        if isinstance(x, list):
            return all(numbers(v) for v in x)
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    if not numbers(raw):
        raise ValueError(f"{name} must be a number or nested lists of numbers, got {raw!r}")
    try:
        return np.array(raw, dtype=np.float64)
    except ValueError:
        raise ValueError(f"{name}: nested lists of unequal lengths (not an array)") from None
