"""The option types of the ``genie`` command line (argparse ``type=``): whole numbers, seeds,
positive numbers, lists of them, names out of a set. They say what was expected in the words
of :mod:`genie_gl.validation.arguments`, so ``genie capture --seed -1`` and ``gg.capture(...,
seed=-1)`` say
the same thing."""

from __future__ import annotations

import argparse

from .bounds import MAX_SEED, number_problem, whole_problem
from ..errors import did_you_mean


def _number(text: str) -> int | float | str:
    """``text`` as an int, else a float, else itself (the checks then say what was expected)."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def count(lo: int = 1, hi: int = 10**6):
    """argparse type of a whole number in [lo, hi] (the words of
    :func:`genie_gl.validation.arguments.whole_number`)."""

    def parse(text: str) -> int:
        why = whole_problem(_number(text), lo, hi)
        if why:
            raise argparse.ArgumentTypeError(why)
        return int(text)

    return parse


def counts(lo: int = 1, hi: int = 10**6):
    """argparse type of comma-separated whole numbers in [lo, hi] (``1,2,4``) -> list of int."""
    one = count(lo, hi)

    def parse(text: str) -> list[int]:
        parts = [p.strip() for p in str(text).split(",") if p.strip()]
        if not parts:
            raise argparse.ArgumentTypeError(
                f"expected whole numbers separated by commas, got {text!r}"
            )
        return [one(p) for p in parts]

    return parse


def names(known):
    """argparse type of comma-separated names out of ``known`` -> list of str (did-you-mean)."""

    def parse(text: str) -> list[str]:
        parts = [p.strip() for p in str(text).split(",") if p.strip()]
        for p in parts or [""]:
            if p not in known:
                raise argparse.ArgumentTypeError(
                    f"{p!r} is unknown{did_you_mean(p, known)}; expected some of {', '.join(known)}"
                )
        return parts

    return parse


# : argparse type of a seed: a whole number in 0..2**63-1, as
# :func:`genie_gl.validation.arguments.check_seed`
seed = count(0, MAX_SEED)
# : argparse type of comma-separated seeds (``0,1,2``) -> list of int
seeds = counts(0, MAX_SEED)


def positive(hi: float = 1e6, *, zero: bool = False):
    """argparse type of a finite number in (0, hi] (with ``zero``: [0, hi]; the words of
    :func:`genie_gl.validation.arguments.finite_number`)."""

    def parse(text: str) -> float:
        why = number_problem(_number(text), 0.0, hi, lo_open=not zero)
        if why:
            raise argparse.ArgumentTypeError(why)
        return float(text)

    return parse
