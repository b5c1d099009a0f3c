"""One dataset scene, start to finish: layout, scene, placement, capture, chunks, export;
written into a temporary folder with its file record and renamed into place when whole."""

from __future__ import annotations

import json
import logging
import os
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..export import SceneData, get_format
from ..outputs import publish_folder
from . import curation
from .ahead import Ahead
from .config import DatasetConfig
from .manifest import RECORD, record_files, recorded_files, scene_complete
from .modes.base import Captured, get_mode
from .recipe import STAGES, RunInputs, load_inputs
from .streams import SceneStreams

log = logging.getLogger(__name__)


def scene_dir(out: Path, index: int, fmt: str, n_scenes: int = 0) -> Path:
    """Where scene ``index`` of a dataset in format ``fmt`` lives."""
    return get_format(fmt).scene_dir(out, index)


def needs_making(cfg: DatasetConfig, index: int) -> bool:
    """Whether scene ``index`` is still to be made, as far as a quick look tells (its files
    are not checked against their hashes: :func:`run_scene` does that with ``verify``)."""
    if scene_complete(get_format(cfg.format).scene_dir(Path(cfg.out), index)) is not None:
        return False
    return not (curation.active(cfg) and curation.cache_path(cfg, index).is_file())


def run_scene(
    cfg: DatasetConfig,
    index: int,
    *,
    inputs: RunInputs | None = None,
    verify: bool = False,
    stage=None,
    prepare=None,
    ahead: Ahead | None = None,
) -> dict[str, Any]:
    """Make scene ``index`` and write it; returns its stats (also in stats.json).
    ``inputs``: the run's strategy, sensor and settings (:func:`~.recipe.load_inputs`; loaded
    here when not given). ``stage(name)`` is called as each stage starts (progress display);
    ``prepare()`` once the scene is known to need making, before its clock starts (a
    worker's warm-up). ``ahead``: a helper process making the layout, scene and placement of
    the scenes of a mode that allows it (:mod:`.ahead`). The capture mode makes the scene's
    frames (:mod:`.modes`); the tail is every mode's: curation, export, previews, publishing."""
    stage = stage or (lambda name: None)
    out = Path(cfg.out)
    fmt = get_format(cfg.format)
    final = fmt.scene_dir(out, index)
    done = scene_complete(final, verify=verify)
    if done is not None:
        return done | {"skipped": True}
    if (
        curation.active(cfg) and curation.cache_path(cfg, index).is_file()
    ):  # made, waiting to be balanced
        return {"scene": index, "pending": True, "skipped": True}
    inputs = inputs or load_inputs(cfg)
    if prepare is not None:
        prepare()
    mode = get_mode(cfg.capture)
    cpu = time.process_time()  # the process's CPU time, its rasteriser and kernel threads included
    got = mode.capture(cfg, inputs, SceneStreams(cfg.seed, index), fmt, stage=stage, ahead=ahead)
    cpu -= got.ahead_cpu_s  # a helper's CPU time for this scene's parts counts as the scene's
    t = got.clock
    if curation.active(cfg):  # balanced once every scene is made (genie_gl/dataset/curation.py)
        if index < cfg.previews:
            got.previews(out / "previews", index)
        stats = curation.cache_scene(
            cfg,
            index,
            got.kept,
            got.layout,
            {**got.info, "cameras": got.shots, "points_total": int(got.points)},
        )
        t["export"] = time.perf_counter()
        return stats | _timings(t, got, cpu)
    stage("export")
    tmp = _scene_tmp(final)
    data = SceneData(
        index,
        got.scene,
        got.layout,
        got.frames,
        got.kept,
        cfg,
        dict(got.extra),
        rig=got.rig,
        trajectory=got.trajectory,
        recording=got.recording,
    )
    mode.write(fmt, data, tmp, got)
    got.layout.to_json(tmp / "layout.json")
    stats = {
        "scene": index,
        **got.info,
        "cameras": got.shots,
        "points_total": int(got.points),
        "chunks": len(got.kept),
        "class_points": _class_points(got.counts),
    }
    if index < cfg.previews:
        got.previews(out / "previews", index)
    _publish(stats, tmp, final, data, fmt, out, t)
    return stats | _timings(t, got, cpu)


def _scene_tmp(final: Path) -> Path:
    """A fresh temporary folder beside scene folder ``final``; what a killed run of ours left
    there (``.tmp-<name>-<pid>``) goes first."""
    for stale in final.parent.glob(f".tmp-{final.name}-*"):
        shutil.rmtree(stale, ignore_errors=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    tmp.mkdir(parents=True)
    return tmp


def _publish(
    stats: dict[str, Any],
    tmp: Path,
    final: Path,
    data: SceneData,
    fmt,
    out: Path,
    t: dict[str, float],
) -> None:
    """Record the files of ``tmp`` and ``stats`` in its ``stats.json``, let the format finish
    (``before_rename``), then rename ``tmp`` to ``final``: the scene appears whole, or not at all
    (an incomplete ``final`` of an earlier run has the files its record lists replaced; what the
    user put beside them stays)."""
    stats["files"] = record_files(tmp)
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if fmt.before_rename is not None:
        fmt.before_rename(data, out)
    t["export"] = time.perf_counter()
    publish_folder(tmp, final, previous=recorded_files(final), record=RECORD)


def _class_points(counts: np.ndarray) -> dict[str, int]:
    """{class id as text: points} for the classes with points, in id order (``counts``: (65536,)
    int64)."""
    return {str(k): int(counts[k]) for k in np.flatnonzero(counts).tolist()}


def _timings(t: dict[str, float], got: Captured, cpu: float) -> dict[str, Any]:
    """Seconds per stage, CPU seconds of the scene (all threads, a helper's included), the
    frames' cost (the manifest's "cost" block) and what each sensor effect did: not in
    stats.json. ``ahead_s``: the seconds of the stages a helper process made (:mod:`.ahead`),
    there."""
    keys = ("start",) + STAGES
    cost_ms, effects = got.costs()
    out = {
        "timings_s": {k: t[k] - t[p] for p, k in zip(keys, keys[1:])},
        "cpu_s": time.process_time() - cpu,
        "frame_cost_ms": cost_ms,
        "effects": effects,
    }
    if got.ahead_s is not None:
        out["ahead_s"] = got.ahead_s
    return out
