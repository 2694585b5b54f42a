"""Every private API of a dependency that jaxchain uses, in one place.

* ``equinox._errors.EQX_ON_ERROR`` (equinox 0.13): the mode ``eqx.error_if`` reads when
  a program is traced. The solve sets it to ``"nan"`` while it is traced, so diffrax's
  checks of traced inputs are no host callbacks (a program with one is never written to
  JAX's persistent compilation cache), and the program store keys programs by it. If
  equinox renames or moves it, :func:`on_error_mode` and :func:`errors_as_nan` fail at
  import or at the first solve (``tests/test_compile_cache.py`` fails): follow equinox's
  new spelling here. The versions jaxchain is tested on are bounded in ``pyproject.toml``.
"""

from __future__ import annotations

import contextlib

import equinox._errors as _eqx_errors

__all__ = ["on_error_mode", "errors_as_nan"]


def on_error_mode() -> str:
    """equinox's current on-error mode (``"raise"``, ``"nan"``, ``"breakpoint"``)."""
    return _eqx_errors.EQX_ON_ERROR


@contextlib.contextmanager
def errors_as_nan():
    """While inside, equinox's ``error_if`` answers a failed check with NaN instead of a
    host callback; the mode before is restored on the way out."""
    old = _eqx_errors.EQX_ON_ERROR
    _eqx_errors.EQX_ON_ERROR = "nan"
    try:
        yield
    finally:
        _eqx_errors.EQX_ON_ERROR = old
