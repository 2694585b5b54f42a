"""Reading a number the text writes and comparing it with its source, at the precision the
text gives it: shared by tests/test_figures.py (README and docs/figures.md) and
tests/test_notebook_numbers.py (the notebooks' text). Imports nothing but the standard
library."""

import re

NUMBER = r"([−+-]?\d+(?:\.\d+)?)"  # a number as the text writes it (− or - for minus)


def quoted(text: str, pattern: str) -> tuple[str, ...]:
    """The numbers ``pattern`` (``{}`` for each) finds in ``text``, as written."""
    regex = re.escape(pattern).replace(r"\{\}", NUMBER)
    found = re.search(regex, text)
    assert found, f"{pattern!r} is not in {text!r}"
    return found.groups()


def same(value: float, written: str, step: float | None = None) -> bool:
    """``value`` rounds to ``written`` (to as many decimals as it has, or to the nearest
    multiple of ``step`` where the text rounds further: "about 430" with ``step=10``)."""
    w = written.replace("−", "-")
    if step is None:
        step = 10.0 ** -(len(w.split(".")[1]) if "." in w else 0)
    return abs(value - float(w)) <= 0.5 * step * (1 + 1e-9)


def check(text: str, pattern: str, *values: float, step: float | None = None) -> None:
    """The numbers ``pattern`` finds in ``text`` are ``values``, rounded as written."""
    numbers = quoted(text, pattern)
    assert len(numbers) == len(values)
    for n, v in zip(numbers, values, strict=True):
        assert same(v, n, step), f"{pattern!r}: the text says {n}, the source {v:.6g}"
