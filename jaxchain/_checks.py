"""Argument checks of the public entry points, run before anything is traced: each names
the argument, says what is wrong and gives the valid range (``TypeError`` for a value of
the wrong kind, ``ValueError`` for one out of range)."""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["real", "integer", "choice", "flag", "instance", "pair", "fields"]


def _range(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    if lo == -math.inf and hi == math.inf:
        return ""
    if hi == math.inf:
        return f"> {lo:g}" if lo_open else f">= {lo:g}"
    if lo == -math.inf:
        return f"< {hi:g}" if hi_open else f"<= {hi:g}"
    return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def real(
    name: str,
    value,
    *,
    lo: float = -math.inf,
    hi: float = math.inf,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
) -> float:
    """``value`` as a finite float in the range, else ``TypeError``/``ValueError`` naming
    ``name``. A bool, a string, a complex number or an array of any shape but () is the
    wrong kind."""
    kind = None
    if isinstance(value, (bool, np.bool_)) or isinstance(value, (str, bytes)):
        kind = type(value).__name__
    elif isinstance(value, numbers.Real):
        pass
    elif (
        isinstance(value, (np.ndarray, np.generic))
        or hasattr(value, "__jax_array__")
        or (hasattr(value, "shape") and hasattr(value, "dtype"))
    ):
        if np.shape(value) != ():
            kind = f"array of shape {np.shape(value)}"
        elif not np.issubdtype(np.asarray(value).dtype, np.number) or np.iscomplexobj(value):
            kind = f"{np.asarray(value).dtype} array"
    else:
        kind = type(value).__name__
    rng = _range(lo, hi, lo_open, hi_open)
    unit = f" {unit}" if unit else ""
    if not rng:  # any finite number: "a real number (degrees)"
        rng, unit = unit.strip(), ""
    rng = f" {rng}" if rng else ""
    if kind is not None:
        raise TypeError(f"{name} must be a real number{rng}{unit}, got {kind} {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number{rng}{unit}, got {v}")
    below = v <= lo if lo_open else v < lo
    above = v >= hi if hi_open else v > hi
    if below or above:
        raise ValueError(f"{name} must be{rng}{unit}, got {v:g}")
    return v


def integer(name: str, value, *, lo: int, hi: int | None = None) -> int:
    """``value`` as an int in [lo, hi], else ``TypeError``/``ValueError`` naming ``name``
    (a float, even a whole one, or a bool is the wrong kind)."""
    rng = f">= {lo}" if hi is None else f"in [{lo}, {hi}]"
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer {rng}, got {type(value).__name__} {value!r}")
    if value < lo or (hi is not None and value > hi):
        raise ValueError(f"{name} must be an integer {rng}, got {value}")
    return int(value)


def choice(name: str, value, options: Sequence[str]) -> str:
    """``value`` if it is one of ``options``, else ``ValueError`` listing them."""
    if not isinstance(value, str) or value not in options:
        listed = ", ".join(repr(o) for o in options)
        raise ValueError(f"{name} must be one of {listed}, got {value!r}")
    return value


def flag(name: str, value) -> bool:
    """``value`` if it is a bool, else ``TypeError`` (a string such as 'no' is truthy)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__} {value!r}")
    return bool(value)


def instance(name: str, value, types, what: str):
    """``value`` if it is an instance of ``types``, else ``TypeError`` saying ``what`` it
    must be."""
    if not isinstance(value, types):
        raise TypeError(f"{name} must be {what}, got {type(value).__name__} {value!r}")
    return value


def pair(name: str, value, n: int = 2, what: str = "values") -> tuple:
    """``value`` as a tuple of ``n`` entries, else ``TypeError``/``ValueError`` naming
    ``name``."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence | np.ndarray):
        raise TypeError(f"{name} must be a sequence of {n} {what}, got {value!r}")
    if len(value) != n:
        raise ValueError(f"{name} must hold {n} {what}, got {len(value)}: {value!r}")
    return tuple(value)


def _real_array(owner: str, name: str, value) -> np.ndarray:
    if isinstance(value, (str, bytes, bool, np.bool_)) or value is None:
        raise TypeError(
            f"{owner}.{name} must be a real number, got {type(value).__name__} {value!r}"
        )
    v = np.asarray(value)
    if not (np.issubdtype(v.dtype, np.integer) or np.issubdtype(v.dtype, np.floating)):
        raise TypeError(f"{owner}.{name} must be a real number, got {v.dtype} {value!r}")
    return v.astype(float)


def fields(module, rules) -> None:
    """Check a module's fields: ``rules`` are (field name, predicate on a float NumPy
    array, range text). Raises ``TypeError`` for a field that is not real (a string, a
    complex number, a bool) and ``ValueError`` naming the first field with an element
    non-finite or failing its predicate."""
    owner = type(module).__name__
    for name, ok, rng in rules:
        v = _real_array(owner, name, getattr(module, name))
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{owner}.{name} must be {rng} and finite, got {v}")
        if not np.all(ok(v)):
            raise ValueError(f"{owner}.{name} must be {rng}, got {v}")


def file_header(data, *, format: str, version: int, what: str, writer: str) -> None:
    """Raise ``ValueError`` unless ``data`` (a JSON file's content) opens as a jaxchain
    ``what`` file of ``format``, in a version ≤ ``version`` (``writer``: what writes such
    files, named in the message)."""
    if not isinstance(data, dict) or data.get("format") != format:
        raise ValueError(
            f'not a jaxchain {what}: expected a JSON object with "format": "{format}" '
            f"(as {writer} writes)"
        )
    found = data.get("version")
    if isinstance(found, bool) or not isinstance(found, int) or found < 1:
        raise ValueError(f'"version" must be a positive integer, got {found!r}')
    if found > version:
        raise ValueError(
            f"written in {what} format version {found}, newer than this jaxchain reads (up "
            f"to {version}); update jaxchain to load it"
        )


def write_text_file(path, text: str, what: str) -> Path:
    """Write ``text`` to ``path`` beside its final name, then move it there (a reader never
    sees half a file); returns the path. An OS error names the path given (not the
    temporary file) and what was being written."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        message = f"cannot write the {what} file {str(path)!r}: {e.strerror or e}"
        raise (type(e)(e.errno, message) if e.errno else type(e)(message)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def read_json_file(path, what: str, parse):
    """``parse`` of the JSON in the file at ``path``, a jaxchain ``what`` file: a missing
    path or a folder raises the OS error naming it; not JSON, or what ``parse`` refuses
    (``TypeError``/``ValueError``), a ``ValueError`` that names the file."""
    import errno
    import json
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, f"a jaxchain {what} is a file", str(path))
        raise FileNotFoundError(errno.ENOENT, f"no jaxchain {what} file", str(path))
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{path} is not a jaxchain {what}: not JSON ({e})") from None
    try:
        return parse(data)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{path}: {e}") from None
