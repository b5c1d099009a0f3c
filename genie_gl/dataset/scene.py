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

from ..capture import effect_totals, frame_costs
from ..export import SceneData, get_format
from . import curation
from .ahead import Ahead
from .config import DatasetConfig
from .manifest import record_files, scene_complete
from .previews import write_previews, write_recording_previews
from .recipe import STAGES, RunInputs, chunk, load_inputs, make, make_scene
from .recording import capture_moving, stats_of, write_trajectory
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


def run_scene(cfg: DatasetConfig, index: int, *, inputs: RunInputs | None = None, verify: bool = False, stage=None,
              prepare=None, ahead: Ahead | None = None) -> dict[str, Any]:
    """Make scene ``index`` and write it; returns its stats (also in stats.json).
    ``inputs``: the run's strategy, sensor and settings (:func:`~.recipe.load_inputs`; loaded
    here when not given). ``stage(name)`` is called as each stage starts (progress display);
    ``prepare()`` once the scene is known to need making, before its clock starts (a
    worker's warm-up). ``ahead``: a helper process making the layout, scene and placement of
    standing cameras' scenes (:mod:`.ahead`)."""
    stage = stage or (lambda name: None)
    out = Path(cfg.out)
    fmt = get_format(cfg.format)
    final = fmt.scene_dir(out, index)
    done = scene_complete(final, verify=verify)
    if done is not None:
        return done | {"skipped": True}
    if curation.active(cfg) and curation.cache_path(cfg, index).is_file():  # made, waiting to be balanced
        return {"scene": index, "pending": True, "skipped": True}
    inputs = inputs or load_inputs(cfg)
    if prepare is not None:
        prepare()
    streams = SceneStreams(cfg.seed, index)
    cpu = time.process_time()  # the process's CPU time, its rasteriser and kernel threads included
    if cfg.capture != "static":   # a rig along a trajectory (genie_gl/dataset/recording.py)
        layout, scene, t = make_scene(inputs, streams, stage=stage)
        return _run_moving(cfg, index, layout, scene, streams, fmt, stage, t, cpu, out, final)
    # a format that stores no colour renders none (an output not asked for costs nothing)
    made = make(inputs, streams, cameras=cfg.cameras, depth_only=not fmt.colour, stage=stage,
                chunk_m=cfg.chunk_m if fmt.chunks else None, ahead=ahead)
    layout, scene, frames, t = made.layout, made.scene, made.frames, dict(made.clock)
    cpu -= made.ahead_cpu_s   # the helper's CPU time for this scene's parts counts as the scene's
    stage("cloud")
    cut = chunk(cfg, frames, streams, chunks=fmt.chunks, tally=made.tally)
    kept, points_total, counts = cut.kept, cut.points_total, cut.counts
    t["cloud"] = time.perf_counter()
    if fmt.chunks and not kept:
        log.warning("scene %d: no chunk kept: every chunk of its %d points has fewer than --min-points %d points or "
                    "a labelled share under --min-labelled-share %g", index, points_total, cfg.min_points,
                    cfg.min_labelled_share)
    elif not counts[1:].any():
        log.warning("scene %d: nothing labelled: its %d points are all background (class 0)", index, points_total)
    if curation.active(cfg):  # balanced once every scene is made (genie_gl/dataset/curation.py)
        if index < cfg.previews:
            write_previews(out / "previews", index, layout, frames, scene, cfg.raster)
        stats = curation.cache_scene(cfg, index, kept, layout, {"instances": len(scene.instances),
                                                                "cameras": len(frames), "points_total": int(points_total)})
        t["export"] = time.perf_counter()
        return stats | _timings(t, frames, cpu, ahead_s=made.ahead_s)
    stage("export")
    tmp = _scene_tmp(final)
    data = SceneData(index, scene, layout, frames, kept, cfg)
    fmt.write_scene(data, tmp)
    layout.to_json(tmp / "layout.json")
    stats = {"scene": index, "instances": len(scene.instances), "cameras": len(frames),
             "points_total": int(points_total), "chunks": len(kept),
             "class_points": _class_points(counts)}
    if index < cfg.previews:
        write_previews(out / "previews", index, layout, frames, scene, cfg.raster)
    _publish(stats, tmp, final, data, fmt, out, t)
    return stats | _timings(t, frames, cpu, ahead_s=made.ahead_s)


def _run_moving(cfg, index, layout, scene, streams: SceneStreams, fmt, stage, t, cpu, out: Path,
                final: Path) -> dict[str, Any]:
    """Scene ``index`` captured along a trajectory: a recording or a mobile-scan map."""
    accuracy = None if cfg.accuracy is None else cfg.accuracy.settings   # each rig sensor's own otherwise
    moving = capture_moving(cfg, layout, scene, streams, fmt, accuracy, stage, t)
    info = {"instances": len(scene.instances), **stats_of(moving)}
    if curation.active(cfg):   # a mobile-scan map's chunks, balanced once every scene is made
        if index < cfg.previews:
            write_recording_previews(out / "previews", index, layout, moving.tally.preview, moving.trajectory,
                                     moving.map_cloud, scene, cfg.raster)
        stats = curation.cache_scene(cfg, index, moving.kept, layout, {
            **info, "cameras": moving.tally.shots, "points_total": int(moving.tally.points)})
        t["export"] = time.perf_counter()
        return stats | _timings(t, None, cpu, moving.tally)
    stage("export")
    tmp = _scene_tmp(final)
    data = SceneData(index, scene, layout, [], moving.kept, cfg, dict(moving.extra), rig=moving.rig,
                     trajectory=moving.trajectory, recording=moving.recording)
    if cfg.capture == "trajectory":
        fmt.write_sequence(data, tmp)     # renders the recording as it writes it
        t["capture"] = t["cloud"] = time.perf_counter()
    else:
        fmt.write_scene(data, tmp)
    write_trajectory(moving.trajectory, tmp / "trajectory.txt")
    layout.to_json(tmp / "layout.json")
    counts = moving.tally.counts
    stats = {"scene": index, **info, "cameras": moving.tally.shots, "points_total": int(moving.tally.points),
             "chunks": len(moving.kept), "class_points": _class_points(counts)}
    if index < cfg.previews:
        write_recording_previews(out / "previews", index, layout, moving.tally.preview, moving.trajectory,
                                 moving.map_cloud, scene, cfg.raster)
    _publish(stats, tmp, final, data, fmt, out, t)
    return stats | _timings(t, None, cpu, moving.tally)


def _scene_tmp(final: Path) -> Path:
    """A fresh temporary folder beside scene folder ``final``; what a killed run of ours left
    there (``.tmp-<name>-<pid>``) goes first."""
    for stale in final.parent.glob(f".tmp-{final.name}-*"):
        shutil.rmtree(stale, ignore_errors=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    tmp.mkdir(parents=True)
    return tmp


def _publish(stats: dict[str, Any], tmp: Path, final: Path, data: SceneData, fmt, out: Path,
             t: dict[str, float]) -> None:
    """Record the files of ``tmp`` and ``stats`` in its ``stats.json``, let the format finish
    (``before_rename``), then rename ``tmp`` to ``final``: the scene appears whole, or not at all
    (an incomplete ``final`` of an earlier run is replaced)."""
    stats["files"] = record_files(tmp)
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if fmt.before_rename is not None:
        fmt.before_rename(data, out)
    t["export"] = time.perf_counter()
    if final.exists():
        shutil.rmtree(final)
    tmp.replace(final)


def _class_points(counts: np.ndarray) -> dict[str, int]:
    """{class id as text: points} for the classes with points, in id order (``counts``: (65536,) int64)."""
    return {str(k): int(counts[k]) for k in np.flatnonzero(counts).tolist()}


def _timings(t: dict[str, float], frames: list | None, cpu: float, tally=None,
             ahead_s: dict[str, float] | None = None) -> dict[str, Any]:
    """Seconds per stage, CPU seconds of the scene (all threads, a helper's included), the
    frames' cost (the manifest's "cost" block) and what each sensor effect did: not in
    stats.json. A moving capture's ``tally`` (:class:`~genie_gl.dataset.recording.Tally`)
    summed them over every frame as the recording streamed past. ``ahead_s``: the seconds of
    the stages a helper process made (:mod:`.ahead`), there."""
    keys = ("start",) + STAGES
    out = {"timings_s": {k: t[k] - t[p] for p, k in zip(keys, keys[1:])}, "cpu_s": time.process_time() - cpu,
           "frame_cost_ms": frame_costs(frames) if tally is None else dict(tally.cost_ms),
           "effects": effect_totals(frames) if tally is None else tally.effects}
    if ahead_s is not None:
        out["ahead_s"] = ahead_s
    return out
