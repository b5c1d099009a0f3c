"""The ``genie`` subcommands, one module each with ``add_arguments(parser)`` and
``run(args) -> int`` (registered in :data:`genie_gl.cli.COMMANDS`). They sit above every
stage, so a command may use any of them; the stages never import a command."""
from __future__ import annotations

import argparse
import math
from contextlib import contextmanager


def seed(text: str) -> int:
    """argparse type of a seed: a whole number >= 0 (numpy's SeedSequence takes no negatives)."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}") from None
    if v < 0 or v >= 2**63:
        raise argparse.ArgumentTypeError(f"expected a whole number in 0..2**63-1, got {text}")
    return v


def count(lo: int = 1, hi: int = 10**6):
    """argparse type of a whole number in [lo, hi]."""
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"expected a whole number in {lo}..{hi}, got {v}")
        return v
    return parse


def positive(hi: float = 1e6):
    """argparse type of a finite number in (0, hi]."""
    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        if not (math.isfinite(v) and 0 < v <= hi):
            raise argparse.ArgumentTypeError(f"expected a finite number in (0, {hi:g}], got {text}")
        return v
    return parse


@contextmanager
def stages(names: list[str], *, title: str = "genie", enabled: bool = True):
    """A progress bar over a command's stages, naming the one under way: ``with stages([...]) as
    step: step("render"); ...``."""
    from tqdm import tqdm

    bar = tqdm(total=len(names), unit="stage", disable=not enabled, bar_format="{desc} [{elapsed}]")
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
