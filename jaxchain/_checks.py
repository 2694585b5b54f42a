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

__all__ = [
    "real",
    "integer",
    "choice",
    "flag",
    "instance",
    "pair",
    "fields",
    "real_leaf",
    "real_values",
    "harmonics",
    "solve_keywords",
    "element_coordinates",
]


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


def _kind(value) -> str | None:
    """What is wrong with the kind of ``value`` for a real number or an array of them (a
    JAX tracer included): None if it is real, else its kind in words."""
    if value is None or isinstance(value, (str, bytes, bool, np.bool_, complex)):
        return type(value).__name__
    if isinstance(value, numbers.Real):
        return None
    if hasattr(value, "dtype"):
        dtype = np.dtype(value.dtype)
    else:
        try:
            dtype = np.asarray(value).dtype
        except (TypeError, ValueError):  # ragged nesting
            return type(value).__name__
    if not (np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)):
        return f"{dtype} array" if dtype.kind != "O" else type(value).__name__
    return None


def real_leaf(name: str, value, unit: str = ""):
    """``value`` unchanged if it is one real number (a Python or NumPy number, an array of
    shape (), a traced scalar), else ``TypeError`` (a string, a bool, None, a complex
    number) or ``ValueError`` (an array of another shape) naming ``name``. The value is not
    read: a traced one passes, and finiteness is its owner's check where concrete."""
    unit = f" [{unit}]" if unit else ""
    kind = _kind(value)
    if kind is not None:
        raise TypeError(f"{name} must be a real number{unit}, got {kind} {value!r}")
    if np.shape(value) != ():
        raise ValueError(f"{name} must be a scalar{unit}, got shape {np.shape(value)}")
    return value


def real_values(name: str, value, what: str = "real numbers"):
    """``value`` unchanged if it is a real number or an array of them (any shape; traced
    ones pass), else ``TypeError`` naming ``name``: a string, a bool, None, complex
    numbers, or lists that do not make an array."""
    kind = _kind(value)
    if kind is not None:
        raise TypeError(f"{name} must be {what}, got {kind} {value!r}")
    return value


def harmonics(owner: str, rows, what: str = "") -> list[tuple]:
    """A sequence of ``(order, amplitude, phase)`` rows checked: each a row of 3 real
    scalars (traced ones pass); else ``TypeError``/``ValueError`` naming ``owner``'s
    ``harmonics[k]`` and its part. ``what``: added to the message of a part that is not a
    scalar (why there is one value per row)."""
    example = "e.g. harmonics=((2, 5.0, 0.0),) for one harmonic"
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence | np.ndarray):
        raise TypeError(
            f"{owner}: harmonics must be a sequence of (order, amplitude, phase) rows ({example}), "
            f"got {type(rows).__name__} {rows!r}"
        )
    out = []
    for k, h in enumerate(rows):
        if isinstance(h, (str, bytes)) or not isinstance(h, Sequence | np.ndarray):
            raise TypeError(
                f"{owner}: harmonics[{k}] must be (order, amplitude, phase), got "
                f"{type(h).__name__} {h!r} ({example}: a row per harmonic, in a sequence)"
            )
        h = tuple(h)
        if len(h) != 3:
            raise ValueError(
                f"{owner}: harmonics[{k}] must be (order, amplitude, phase), got {h!r}"
            )
        for part, v in zip(("order", "amplitude", "phase"), h, strict=True):
            kind = _kind(v)
            if kind is not None:
                raise TypeError(
                    f"{owner}: harmonics[{k}]'s {part} must be a real number, got {kind} {v!r}"
                )
            if np.shape(v) != ():
                raise ValueError(
                    f"{owner}: harmonics[{k}]'s {part} must be a scalar, got shape "
                    f"{np.shape(v)}{what}"
                )
        out.append(h)
    return out


#: the keyword options of a solve whose kind is checked before ``SolveOptions`` reads them
_SOLVE_REALS = ("rtol", "atol", "dt")


def solve_keywords(caller: str, options: dict) -> dict:
    """A solve's keyword options (``rtol=``, ``n_steps=``, ...) checked for their kind
    before they are read: tolerances and ``dt`` real scalars, ``max_steps`` and
    ``n_steps`` integers, ``dt0`` real, ``progress`` and ``allow_float32`` True or False
    (a string such as "1e-6" would be read as a number, "no" as True); returns
    ``options``."""
    for name, value in options.items():
        label = f"{caller}: {name}"
        if name in _SOLVE_REALS and value is not None:
            real_leaf(label, value)
        elif name == "dt0" and value is not None:
            real_values(label, value, "a real number [s] (or one per member)")
        elif name in ("max_steps", "n_steps") and value is not None:
            integer(label, value, lo=1)
        elif name in ("progress", "allow_float32"):
            flag(label, value)
    return options


def element_coordinates(scene, caller: str) -> None:
    """Every force element of ``scene`` with coordinates of its own checked: ``n_dofs`` an
    integer >= 0, ``dof_inertia`` (D,) finite and > 0, ``dof_start`` two (D,) arrays,
    finite (values where concrete); else ``TypeError``/``ValueError`` naming the element
    and the method to fix."""
    from ._numerics import is_concrete

    for el in scene.force_elements:
        owner = f"{caller}: {type(el).__name__}"
        d = el.n_dofs(scene)
        if isinstance(d, (bool, np.bool_)) or not isinstance(d, (int, np.integer)):
            raise TypeError(
                f"{owner}.n_dofs(scene) must return an integer >= 0 (its own coordinates), "
                f"got {type(d).__name__} {d!r}"
            )
        if d < 0:
            raise ValueError(f"{owner}.n_dofs(scene) must return an integer >= 0, got {d}")
        if not d:
            continue
        try:
            inertia = el.dof_inertia(scene)
        except NotImplementedError as e:
            raise TypeError(f"{caller}: {e}") from None
        parts = {"dof_inertia(scene)": (inertia, "finite and > 0 (kg or kg·m²)", lambda v: v > 0)}
        start = el.dof_start(scene)
        if not isinstance(start, tuple | list) or len(start) != 2:
            raise TypeError(
                f"{owner}.dof_start(scene) must return (position, rate), two arrays of shape "
                f"({d},), got {type(start).__name__}"
            )
        parts["dof_start(scene)'s position"] = (start[0], "finite", lambda v: v == v)
        parts["dof_start(scene)'s rate"] = (start[1], "finite", lambda v: v == v)
        for what, (value, rng, ok) in parts.items():
            real_values(f"{owner}.{what}", value, f"an array of shape ({d},)")
            if np.size(value) != d:
                raise ValueError(
                    f"{owner}.{what} must have shape ({d},) (n_dofs(scene) = {d}), got shape "
                    f"{np.shape(value)}"
                )
            if is_concrete(value):
                v = np.asarray(value, dtype=float)
                if not np.all(np.isfinite(v) & ok(v)):
                    raise ValueError(f"{owner}.{what} must be {rng}, got {v.tolist()}")


def _real_array(owner: str, name: str, value) -> np.ndarray:
    real_values(f"{owner}.{name}", value, "a real number")
    return np.asarray(value, dtype=float)


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
