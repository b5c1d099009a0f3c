"""``genie bench cli``: how long ``genie --help`` and every subcommand's ``--help`` take.

Each command line runs ``--repeats`` times in a fresh interpreter (``python -m genie_gl.cli``,
what the ``genie`` script runs), and the median wall time is reported, beside the
interpreter's own start (``python -c pass``). ``--against DIR`` times the package of another
checkout (``DIR/genie_gl``, put first on ``PYTHONPATH``) in turns with this one, so a change
is measured side by side under the same load. Goal: every line within 0.3 s.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from ..cli import COMMANDS
from ..commands.bench import BENCHMARKS
from ..outputs import atomic_write_text

GOAL_S = 0.3


def command_lines() -> list[list[str]]:
    """``--help`` of genie, of every command and of every benchmark."""
    return [[], *[[c] for c in COMMANDS], *[["bench", b] for b in BENCHMARKS]]


def _time(args: list[str], env: dict[str, str]) -> float:
    t = time.perf_counter()
    subprocess.run(
        [sys.executable, *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=False,
    )
    return time.perf_counter() - t


def measure(repeats: int, against: str | None = None) -> dict:
    """Median seconds per command line, for this package and (``against``) another checkout's."""
    envs = {"this": dict(os.environ)}
    if against is not None:
        envs["against"] = dict(os.environ, PYTHONPATH=str(Path(against).resolve()))
    times: dict[str, dict[str, list[float]]] = {k: {} for k in envs}
    start: dict[str, list[float]] = {k: [] for k in envs}
    for _ in range(repeats):
        for key, env in envs.items():  # in turns: a busy spell falls on both alike
            start[key].append(_time(["-c", "pass"], env))
            for line in command_lines():
                times[key].setdefault(" ".join(["genie", *line, "--help"]), []).append(
                    _time(["-m", "genie_gl.cli", *line, "--help"], env)
                )
    out = {"repeats": repeats, "goal_s": GOAL_S, "against": against}
    for key in envs:
        out[key] = {
            "python_start_s": statistics.median(start[key]),
            "median_s": {k: statistics.median(v) for k, v in times[key].items()},
        }
    return out


def run(args: argparse.Namespace) -> int:
    result = measure(args.repeats, getattr(args, "against", None))
    lines = list(result["this"]["median_s"])
    head = f"{'command line':<40}{'this s':>9}" + (
        f"{'against s':>11}{'ratio':>8}" if result["against"] else ""
    )
    print(head)
    for line in lines:
        t = result["this"]["median_s"][line]
        row = f"{line:<40}{t:>9.3f}"
        if result["against"]:
            a = result["against"]["median_s"][line]
            row += f"{a:>11.3f}{a / t:>8.1f}"
        print(row + ("" if t <= GOAL_S else "  over the goal"))
    print(
        f"{'python -c pass':<40}{result['this']['python_start_s']:>9.3f}"
        + (f"{result['against']['python_start_s']:>11.3f}" if result["against"] else "")
    )
    worst = max(result["this"]["median_s"].values())
    print(
        f"slowest: {worst:.3f} s (goal {GOAL_S} s), median of {args.repeats} fresh processes each"
    )
    out = Path(args.out)
    atomic_write_text(out / "cli.json", json.dumps(result, indent=1))
    return 0 if worst <= GOAL_S else 1
