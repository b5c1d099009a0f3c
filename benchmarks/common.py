"""What every benchmark prints first and the arguments they share."""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from genie_gl.bench.scenes import SIZES, bench_spec, to_scene
from genie_gl.sensors.camera import Sensor


def header() -> str:
    """The date, time (UTC) and load averages a figure is read with."""
    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
    return (
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load {load}, {os.cpu_count()} cores"
    )


def parser(name: str, doc: str | None) -> argparse.ArgumentParser:
    return argparse.ArgumentParser(
        prog=f"python -m benchmarks {name}",
        description=(doc or "").split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )


def scene_argument(p: argparse.ArgumentParser, default: str) -> None:
    p.add_argument(
        "scene",
        nargs="?",
        default=default,
        choices=SIZES,
        help=f"benchmark scene (default {default})",
    )


def sensor_640() -> Sensor:
    """The benchmarks' camera: 640 x 480, fx = fy = 525 px, 0.1-100 m."""
    return Sensor(
        640,
        480,
        np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]]),
        near_m=0.1,
        far_m=100.0,
    )


def benchmark_scene(name: str):
    """(spec, scene) of the benchmark scene ``name``: its arrays with 40 poses, and its Scene."""
    spec = bench_spec(name)
    return spec, to_scene(spec)
