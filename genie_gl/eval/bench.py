"""``genie eval --bench``: how long the classical model takes on ~1 M training points.

The scans of the training sets are taken in order until ``points`` (1 M by default) are
reached; their features are computed without the cache (timed), the model trained once
(seed 0, timed: wall and this process's CPU, LightGBM's threads included) and the training
points predicted. The load average is printed beside every figure: on a shared machine the
wall time says little without it.
"""

from __future__ import annotations

import os
import resource
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from .classical import BoostParams, ClassicalModel
from .data import read_set
from .features import PointTable


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (the feature workers)."""
    me, kids = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def bench_training(
    train: Sequence[str] | None,
    *,
    out: str | os.PathLike | None = None,
    workers: int = 2,
    cache: str | os.PathLike | None = None,
    points: int = 1_000_000,
    params: BoostParams | None = None,
) -> str:
    """Time features, training and prediction on ~``points`` points; returns a markdown table."""
    if not train:
        raise ConfigError(
            "--bench: give --train DIR (a dataset of ~1 M points or more, e.g. "
            "genie dataset assembly_line --scenes 10 --cameras 16)"
        )
    sets = [read_set(t) for t in train]
    scans, n = [], 0
    for s in sets:
        for scan in s.scans:
            if n >= points:
                break
            scans.append(scan)
            n += len(scan)
    if n < points * 0.9:
        raise ConfigError(
            f"--train: {n:,} points, fewer than the {points:,} the bench times; give more scenes"
        )
    table = PointTable(scans, workers=workers)
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), _cpu()
    _ = table.features
    t_feat, c_feat = time.perf_counter() - t0, _cpu() - c0
    model = ClassicalModel(max(10, int(table.labels.max()) + 1), params or BoostParams())
    t1, c1 = time.perf_counter(), _cpu()
    model.fit(table, rng=np.random.default_rng(0), threads=workers)
    t_fit, c_fit = time.perf_counter() - t1, _cpu() - c1
    t2 = time.perf_counter()
    model.predict(table, threads=workers)
    t_pred = time.perf_counter() - t2
    load1 = os.getloadavg()[0]
    text = (
        f"classical model on {n:,} points ({len(scans)} scans of {', '.join(s.spec for s in sets)}"
        "), "
        f"{workers} workers, load average {load0:.1f} -> {load1:.1f}\n\n"
        "| step | wall s | CPU s (all threads and worker processes) |\n| --- | ---: | ---: |\n"
        f"| features (pgeof, 3 scales) | {t_feat:.1f} | {c_feat:.1f} |\n"
        f"| training ({model.rounds_used} rounds, {model.params.max_points:,}-point balanced "
        "sub-sample) "
        f"| {t_fit:.1f} | {c_fit:.1f} |\n"
        f"| training incl. features | {t_feat + t_fit:.1f} | |\n"
        f"| prediction of the {n:,} points | {t_pred:.1f} | |\n"
    )
    if out is not None:
        p = Path(out) / "bench.md"
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return text


__all__ = ["bench_training"]
