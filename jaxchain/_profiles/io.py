"""Reading tooth profiles back from their JSON files (the format: :mod:`.record`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .. import _checks as checks
from .freeform import FreeformProfile
from .freeform_shape import Flank
from .iso import ToothProfile
from .record import FORMAT, HEADER, VERSION

__all__ = ["load_profile", "profile_from_dict", "KINDS", "PARTS"]

# the top-level profile classes a file may hold, and the modules nested in them
KINDS: dict[str, type] = {"ToothProfile": ToothProfile, "FreeformProfile": FreeformProfile}
PARTS: dict[str, type] = {"Flank": Flank}


# --------------------------------------------------------------------------- decode
def load_profile(path: str | Path) -> ToothProfile | FreeformProfile:
    """The tooth profile saved at ``path`` by ``profile.save(path)``: a
    :class:`~jaxchain.ToothProfile` or :class:`~jaxchain.FreeformProfile` equal to the
    saved one leaf for leaf (bit for bit in float64), validated as at construction.

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the file is not JSON, not a jaxchain profile, of an unknown kind, of a
            newer format version than this jaxchain reads, or its fields do not make a
            valid profile (the message names the file and what is wrong).
    """
    return checks.read_json_file(path, "profile", profile_from_dict)


def profile_from_dict(data: dict) -> ToothProfile | FreeformProfile:
    """The profile of a dict made by :func:`profile_to_dict` (or read from its JSON).

    Raises:
        ValueError: not a jaxchain profile, unknown kind, newer format version, missing or
            unknown fields, values that are not numbers, or an invalid profile.
    """
    checks.file_header(data, format=FORMAT, version=VERSION, what="profile", writer="profile.save")
    kind = data.get("kind")
    if kind not in KINDS:
        raise ValueError(f"unknown profile kind {kind!r}; known kinds: {', '.join(KINDS)}")
    fields = {k: v for k, v in data.items() if k not in HEADER}
    return _build(KINDS[kind], fields, kind)


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
            if part not in PARTS:
                raise ValueError(f"{name}: unknown part kind {part!r}; known: {', '.join(PARTS)}")
            fields = {k: v for k, v in raw.items() if k != "kind"}
            kwargs[f.name] = _build(PARTS[part], fields, name)
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
