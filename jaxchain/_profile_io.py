"""Saving and loading tooth profiles as human-readable JSON, so designs can be kept and shared.

``profile.save(path)`` writes any profile kind; :func:`load_profile` reads it back as an
object equal to the saved one leaf for leaf, bit for bit, static fields included. The
file is one JSON object::

    {
      "format": "jaxchain.profile",      identifies the file
      "version": 1,                      format version (a reader refuses newer ones)
      "kind": "FreeformProfile",         the profile class
      "chain": "08B",                    ISO 606 chain of this pitch and roller (or null)
      "units": "...",                    what the numbers are in
      "teeth": 18,                       then every field of the class, in its order:
      "pitch": 0.0127,                   scalars as numbers, arrays as nested lists,
      "seating_radius": [0.00431, ...],  per-gap leaves one value per gap,
      "cw": {"kind": "Flank", "seat_angle": 1.29, "curvature": [13.8, 29.1], "breaks": [0.5]},
      ...
    }

Numbers are written as Python's shortest repr of each float, which reads back to the
same float64 exactly. ``"chain"`` and ``"units"`` are for the reader and are not read
back; a file whose ``"kind"``, ``"version"`` or fields do not fit is refused with a
``ValueError`` that says what is wrong. Loading goes through the class's constructor, so
a hand-edited file is validated as a profile built in code is.

A profile kind is saved as the fields of its equinox module: array leaves as nested
lists, static fields (``teeth``, ``min_tip_width``) as numbers, nested modules
(:class:`~jaxchain.Flank`) as objects tagged with their own ``"kind"``. A new kind needs
only an entry in :data:`KINDS` (its constructor must take each field as a keyword).
"""

from __future__ import annotations

import dataclasses
import errno
import json
import math
import os
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._chain import ChainSpec
from ._freeform import Flank, FreeformProfile
from ._numerics import is_concrete
from ._profile import ToothProfile

__all__ = ["load_profile", "save_profile", "profile_to_dict", "profile_from_dict"]

FORMAT = "jaxchain.profile"
VERSION = 1
UNITS = "SI: lengths in metres, angles in radians, curvatures in 1/m"
# the top-level profile classes a file may hold, and the modules nested in them
KINDS: dict[str, type] = {"ToothProfile": ToothProfile, "FreeformProfile": FreeformProfile}
PARTS: dict[str, type] = {"Flank": Flank}
_HEADER = ("format", "version", "kind", "chain", "units")


# --------------------------------------------------------------------------- encode
def profile_to_dict(profile: ToothProfile | FreeformProfile) -> dict:
    """The JSON-ready dict of a concrete profile (see the module docstring).

    Raises:
        TypeError: ``profile`` is not a profile kind this module knows, or is traced
            (inside ``jit``, ``grad`` or ``vmap``: its values are not known there).
        ValueError: a leaf is NaN or infinite (not representable in JSON).
    """
    kind = type(profile).__name__
    if KINDS.get(kind) is not type(profile):
        raise TypeError(
            f"save: expected a jaxchain tooth profile ({', '.join(KINDS)}), got "
            f"{type(profile).__name__}"
        )
    if not is_concrete(profile):
        raise TypeError(
            f"save: the {kind} is traced (inside jit, grad or vmap), so its values are not "
            "known; save the concrete profile, outside the transformation"
        )
    header = {
        "format": FORMAT,
        "version": VERSION,
        "kind": kind,
        "chain": _chain_name(profile),
        "units": UNITS,
    }
    return header | _fields_to_dict(profile, kind)


def _fields_to_dict(module: eqx.Module, where: str) -> dict:
    out = {}
    for f in dataclasses.fields(module):
        value = getattr(module, f.name)
        name = f"{where}.{f.name}"
        if isinstance(value, eqx.Module):
            part = type(value).__name__
            if PARTS.get(part) is not type(value):
                raise TypeError(f"save: {name} is a {part}, which has no file format")
            out[f.name] = {"kind": part} | _fields_to_dict(value, name)
        elif f.metadata.get("static", False):
            if isinstance(value, bool) or not isinstance(value, (int, float, str)):
                raise TypeError(f"save: static field {name} = {value!r} is not a number")
            if isinstance(value, float) and not math.isfinite(value):
                raise ValueError(f"save: {name} is {value}; only finite numbers can be saved")
            out[f.name] = value
        else:
            arr = np.asarray(value)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"save: {name} holds NaN or inf; only finite numbers can be saved")
            out[f.name] = arr.tolist()  # Python floats: their repr reads back exactly
    return out


def _chain_name(profile) -> str | None:
    """The ISO 606 chain whose pitch and roller diameter the profile has, exactly."""
    pitch, d1 = np.asarray(profile.pitch), np.asarray(profile.roller_diameter)
    if pitch.ndim or d1.ndim:
        return None
    for name in ChainSpec.known:
        c = ChainSpec.iso606(name)
        if float(pitch) == c.pitch and float(d1) == c.roller_diameter:
            return name
    return None


def _dumps(value, indent: str = "") -> str:
    """JSON text with objects one entry per line and each innermost list on one line."""
    inner = indent + "  "
    if isinstance(value, dict):
        rows = [f"{inner}{json.dumps(k)}: {_dumps(v, inner)}" for k, v in value.items()]
        return "{\n" + ",\n".join(rows) + "\n" + indent + "}"
    if isinstance(value, list) and any(isinstance(v, list) for v in value):
        rows = [inner + _dumps(v, inner) for v in value]
        return "[\n" + ",\n".join(rows) + "\n" + indent + "]"
    return json.dumps(value, allow_nan=False)


def save_profile(profile: ToothProfile | FreeformProfile, path: str | Path) -> Path:
    """Write ``profile`` to ``path`` as JSON (module docstring); returns the path.

    The file is written beside its final name and then moved there, so a reader never
    sees half a file."""
    path = Path(path)
    text = _dumps(profile_to_dict(profile)) + "\n"
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


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
    path = Path(path)
    if not path.is_file():
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, "a jaxchain profile is a file", str(path))
        raise FileNotFoundError(errno.ENOENT, "no jaxchain profile file", str(path))
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path} is not a jaxchain profile: not JSON ({e})") from None
    try:
        return profile_from_dict(data)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def profile_from_dict(data: dict) -> ToothProfile | FreeformProfile:
    """The profile of a dict made by :func:`profile_to_dict` (or read from its JSON).

    Raises:
        ValueError: not a jaxchain profile, unknown kind, newer format version, missing or
            unknown fields, values that are not numbers, or an invalid profile.
    """
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError(
            f'not a jaxchain profile: expected a JSON object with "format": "{FORMAT}" '
            "(as profile.save writes)"
        )
    version = data.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ValueError(f'"version" must be a positive integer, got {version!r}')
    if version > VERSION:
        raise ValueError(
            f"written in profile format version {version}, newer than this jaxchain reads "
            f"(up to {VERSION}); update jaxchain to load it"
        )
    kind = data.get("kind")
    if kind not in KINDS:
        raise ValueError(f"unknown profile kind {kind!r}; known kinds: {', '.join(KINDS)}")
    fields = {k: v for k, v in data.items() if k not in _HEADER}
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
