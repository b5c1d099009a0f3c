"""The ``genie`` subcommands, one module each with ``add_arguments(parser)`` and
``run(args) -> int`` (registered in :data:`genie_gl.cli.COMMANDS`). They sit above every
stage, so a command may use any of them; the stages never import a command."""
from __future__ import annotations

import argparse
from contextlib import contextmanager

from ..checks import MAX_SEED, number_problem, whole_problem


def _number(text: str) -> int | float | str:
    """``text`` as an int, else a float, else itself (the checks then say what was expected)."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def count(lo: int = 1, hi: int = 10**6):
    """argparse type of a whole number in [lo, hi] (the words of :func:`genie_gl.checks.whole_number`)."""
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
            raise argparse.ArgumentTypeError(f"expected whole numbers separated by commas, got {text!r}")
        return [one(p) for p in parts]
    return parse


def names(known):
    """argparse type of comma-separated names out of ``known`` -> list of str (did-you-mean)."""
    from ..errors import did_you_mean

    def parse(text: str) -> list[str]:
        parts = [p.strip() for p in str(text).split(",") if p.strip()]
        for p in parts or [""]:
            if p not in known:
                raise argparse.ArgumentTypeError(f"{p!r} is unknown{did_you_mean(p, known)}; expected some of "
                                                 f"{', '.join(known)}")
        return parts
    return parse


#: argparse type of a seed: a whole number in 0..2**63-1, as :func:`genie_gl.checks.check_seed`
seed = count(0, MAX_SEED)


def positive(hi: float = 1e6):
    """argparse type of a finite number in (0, hi] (the words of :func:`genie_gl.checks.finite_number`)."""
    def parse(text: str) -> float:
        why = number_problem(_number(text), 0.0, hi, lo_open=True)
        if why:
            raise argparse.ArgumentTypeError(why)
        return float(text)
    return parse


def announce_compilation(command: str) -> None:
    """Say, if this run compiles genie-gl's kernels (numba's cache is cold: the first run), that
    it is a one-time cost (:func:`genie_gl.processes.say_when_compiling`)."""
    from ..processes import say_when_compiling

    say_when_compiling(f"genie {command}")


@contextmanager
def stages(names: list[str], *, title: str = "genie", enabled: bool = True):
    """A progress bar over a command's stages, naming the one under way: ``with stages([...]) as
    step: step("render"); ...``."""
    from tqdm import tqdm

    # shown on a terminal only (tqdm: disable=None), so a log or a pipe gets the one-line error alone
    bar = tqdm(total=len(names), unit="stage", disable=True if not enabled else None, bar_format="{desc} [{elapsed}]")
    bar.set_description(title)
    seen: list[str] = []

    def step(name: str) -> None:
        if seen:
            bar.update(1)
        seen.append(name)
        bar.set_description(f"{title}: {name} (stage {len(seen)} of {len(names)})", refresh=True)

    try:
        yield step
        bar.update(len(names) - bar.n)
    finally:
        bar.close()
