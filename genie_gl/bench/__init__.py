"""``genie bench NAME``: benchmarks that put error beside milliseconds.

Each benchmark is a module ``genie_gl.bench.<name>`` with ``add_arguments(parser)`` and
``run(args) -> int``. They print a table and write figures (PNG, JSON) under ``--out``.
"""
from __future__ import annotations

import argparse
import importlib

from ..outputs import claim_folder
from ..processes import say_when_compiling

BENCHMARKS: dict[str, str] = {
    "render": "renderer against pyrender and Open3D (ms/frame, frames/s, ratios)",
    "layout": "layout engine throughput, the paper's Table 7 (nodes/s)",
    "accuracy": "what accuracy costs on your scene and sensor: every knob's error vs ms, Pareto plot, --budget-mm",
    "pipeline": "seconds per scene end to end, share of each stage, scaling with workers",
    "stability": "hard cases against analytic truth: tolerance and worst error per case (exit 1 on a failure)",
    "planning": "a full D435 and Azure frame before and after planning, as multiples of the ideal render",
    "sequence": "frames/s along a trajectory against the same number of standing frames",
    "odometry": "KISS-ICP on a SemanticKITTI sequence of a rig's recording; evo's ATE against its ground truth",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="bench", metavar="NAME", required=True)
    for name, help_text in BENCHMARKS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument("--out", default="out/bench", help="folder for the figures (default out/bench)")
        try:
            mod = importlib.import_module(f"genie_gl.bench.{name}")
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.startswith("genie_gl"):
                continue
            raise
        mod.add_arguments(p)


# the files each benchmark writes under --out (claimed before it runs: a user's file of the same
# name is never replaced; anything else a benchmark makes there is recorded as it appears)
OUTPUTS: dict[str, tuple[str, ...]] = {
    "render": ("render.json",), "layout": ("layout.json", "layout.png"),
    "accuracy": ("accuracy.json", "accuracy.md", "accuracy.png", "accuracy.yaml", "cache"),
    "pipeline": ("pipeline.json",), "stability": ("stability.json",), "planning": ("planning.json",),
    "sequence": ("sequence.json",), "odometry": ("odometry.json", "odometry"),
}


def run(args: argparse.Namespace) -> int:
    try:
        mod = importlib.import_module(f"genie_gl.bench.{args.bench}")
    except ModuleNotFoundError as exc:
        if exc.name == f"genie_gl.bench.{args.bench}":
            print(f"genie bench {args.bench}: not available in this build")
            return 2
        raise
    check = getattr(mod, "check_arguments", None)
    if check is not None:   # a benchmark's own option checks, before its folder is claimed
        check(args)
    folder = claim_folder(args.out, "bench", OUTPUTS.get(args.bench, ()), reserve=True)
    say_when_compiling(f"genie bench {args.bench}")
    code = int(mod.run(args) or 0)
    folder.finish({"last": args.bench})
    return code
