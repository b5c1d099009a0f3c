"""What a number must be, in the words every check of one says: a whole number in its bounds
(a seed: 0..2**63-1), a finite number in its bounds. Each function returns why a value is not
what was expected, or None; :mod:`genie_gl.validation.arguments` raises them as
:class:`~genie_gl.errors.ConfigError` for the API and :mod:`genie_gl.validation.options` as argparse
errors for the command line, so both say the same thing. The standard library only: the
command line's option types import no numpy, so ``genie COMMAND --help`` stays quick.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

MAX_SEED = 2**63 - 1


def whole_problem(value: Any, lo: int | None = None, hi: int | None = None) -> str | None:
    """Why ``value`` is not a whole number in ``lo..hi`` (None when it is). A float is taken
    only when it is whole (``3.0``); ``3.5``, True, NaN and text are refused."""
    span = (
        f" in {lo}..{hi}"
        if lo is not None and hi is not None
        else f" >= {lo}"
        if lo is not None
        else ""
    )
    span = span.replace(f"..{MAX_SEED}", "..2**63-1")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return f"expected a whole number{span}, got {value!r:.60}"
    if isinstance(value, numbers.Integral):
        v = int(value)
    elif math.isfinite(float(value)) and float(value).is_integer():
        v = int(value)
    else:
        return f"expected a whole number{span}, got {value!r}"
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        return f"expected a whole number{span}, got {v}"
    return None


def number_problem(
    value: Any, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False
) -> str | None:
    """Why ``value`` is not a finite number in [lo, hi] (``lo_open``: (lo, hi]); None when it is."""
    left = "(" if lo_open else "["
    span = (
        f" in {left}{lo:g}, {hi:g}]"
        if lo is not None and hi is not None
        else (f" {'>' if lo_open else '>='} {lo:g}" if lo is not None else "")
    )
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return f"expected a finite number{span}, got {value!r:.60}"
    v = float(value)
    if (
        not math.isfinite(v)
        or (lo is not None and (v < lo or (lo_open and v == lo)))
        or (hi is not None and v > hi)
    ):
        return f"expected a finite number{span}, got {value!r}"
    return None
