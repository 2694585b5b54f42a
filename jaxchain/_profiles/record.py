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
(:class:`~jaxchain.Flank`) as objects tagged with their own ``"kind"``. A kind of your
own (a subclass of :class:`~jaxchain.AbstractProfile`) is read back once its class is
defined (``jaxchain._profiles.io.profile_kinds``); its constructor must take each field
as a keyword.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import equinox as eqx
import numpy as np

from .._chain import ChainSpec
from .._checks import write_text_file
from .._numerics import is_concrete

__all__ = ["FORMAT", "VERSION", "HEADER", "profile_to_dict", "save_profile"]

FORMAT = "jaxchain.profile"
VERSION = 1
UNITS = "SI: lengths in metres, angles in radians, curvatures in 1/m"
HEADER = ("format", "version", "kind", "chain", "units")


# --------------------------------------------------------------------------- encode
def profile_to_dict(profile) -> dict:
    """The JSON-ready dict of a concrete profile (see the module docstring).

    Raises:
        TypeError: ``profile`` is traced (inside ``jit``, ``grad`` or ``vmap``: its
            values are not known there).
        ValueError: a leaf is NaN or infinite (not representable in JSON).
    """
    kind = type(profile).__name__
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


def save_profile(profile, path: str | Path) -> Path:
    """Write ``profile`` to ``path`` as JSON (module docstring); returns the path.

    The file is written beside its final name and then moved there, so a reader never
    sees half a file."""
    return write_text_file(path, _dumps(profile_to_dict(profile)) + "\n", "profile")
