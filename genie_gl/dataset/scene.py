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

from ..capture import capture, effect_totals, frame_costs, segments_option
from ..cloud import frame_chunks, keep_cloud
from ..export import SceneData, get_format
from ..layout import generate_layout, load_strategy
from ..render import shared_context
from ..scene import build_scene
from ..sensors import load_sensor, place_sensors
from . import curation
from .config import DatasetConfig, settings_of
from .manifest import record_files, scene_complete
from .previews import write_previews, write_recording_previews
from .recording import capture_moving, stats_of, write_trajectory

log = logging.getLogger(__name__)

STAGES = ("layout", "scene", "placement", "capture", "cloud", "export")


def scene_rngs(seed: int, index: int) -> dict[str, np.random.Generator]:
    """Independent generators of scene ``index`` (layout, scene, placement, capture, cloud,
    trajectory)."""
    names = ("layout", "scene", "placement", "capture", "cloud", "trajectory")   # appended: earlier ones unchanged
    kids = np.random.SeedSequence([int(seed), int(index)]).spawn(len(names))
    return {n: np.random.default_rng(k) for n, k in zip(names, kids)}


def scene_dir(out: Path, index: int, fmt: str, n_scenes: int = 0) -> Path:
    """Where scene ``index`` of a dataset in format ``fmt`` lives."""
    return get_format(fmt).scene_dir(out, index)


def run_scene(cfg: DatasetConfig, index: int, *, verify: bool = False, stage=None, prepare=None) -> dict[str, Any]:
    """Make scene ``index`` and write it; returns its stats (also in stats.json).
    ``stage(name)`` is called as each stage starts (progress display); ``prepare()`` once the
    scene is known to need making, before its clock starts (a worker's warm-up)."""
    stage = stage or (lambda name: None)
    out = Path(cfg.out)
    fmt = get_format(cfg.format)
    final = fmt.scene_dir(out, index)
    done = scene_complete(final, verify=verify)
    if done is not None:
        return done | {"skipped": True}
    if curation.active(cfg) and curation.cache_path(cfg, index).is_file():  # made, waiting to be balanced
        return {"scene": index, "pending": True, "skipped": True}
    if prepare is not None:
        prepare()
    rng = scene_rngs(cfg.seed, index)
    t = {"start": time.perf_counter()}
    cpu = time.process_time()  # the process's CPU time, its rasteriser and kernel threads included
    stage("layout")
    layout = generate_layout(load_strategy(cfg.strategy), rng=rng["layout"], max_regions=cfg.max_nodes)
    t["layout"] = time.perf_counter()
    stage("scene")
    accuracy = settings_of(cfg.accuracy)
    scene = build_scene(layout, rng=rng["scene"], **segments_option(accuracy))
    t["scene"] = time.perf_counter()
    if cfg.capture != "static":   # a rig along a trajectory (genie_gl/dataset/recording.py)
        return _run_moving(cfg, index, layout, scene, rng, fmt, accuracy, stage, t, cpu, out, final)
    stage("placement")
    sensor = load_sensor(cfg.sensor)
    poses = place_sensors(layout, sensor, n=cfg.cameras, seed=int(rng["placement"].integers(2**31)),
                          mount_height_m=cfg.mount_m)
    t["placement"] = time.perf_counter()
    stage("capture")
    # a format that stores no colour renders none (an output not asked for costs nothing)
    frames = capture(scene, sensor, poses, seed=int(rng["capture"].integers(2**31)), workers=1,
                     depth_only=not fmt.colour, accuracy=accuracy, context=shared_context())
    t["capture"] = time.perf_counter()
    stage("cloud")
    kept, points_total, counts = [], 0, np.zeros(65536, np.int64)
    if fmt.chunks:
        # the chunks straight from the frames: the merged cloud (~12 M points at 40 cameras)
        # is built only for a preview that shows it
        tiles, points_total = frame_chunks(frames, cfg.chunk_m, max_points=cfg.points, rng=rng["cloud"])
        for key, tile in tiles:
            if keep_cloud(tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share)[0]:
                kept.append((key, tile))
                counts += np.bincount(tile.semantic, minlength=len(counts))
    else:
        for f in frames:
            ok = f.depth > 0
            points_total += int(ok.sum())
            counts += np.bincount(f.semantic[ok], minlength=len(counts))
    t["cloud"] = time.perf_counter()
    if fmt.chunks and not kept:
        log.warning("scene %d: no chunk kept: every chunk of its %d points has fewer than --min-points %d points or "
                    "a labelled share under --min-labelled-share %g", index, points_total, cfg.min_points,
                    cfg.min_labelled_share)
    elif not counts[1:].any():
        log.warning("scene %d: nothing labelled: its %d points are all background (class 0)", index, points_total)
    if curation.active(cfg):  # balanced once every scene is made (genie_gl/dataset/curation.py)
        if index < cfg.previews:
            write_previews(out / "previews", index, layout, frames, scene)
        stats = curation.cache_scene(cfg, index, kept, layout, {"instances": len(scene.instances),
                                                                "cameras": len(frames), "points_total": int(points_total)})
        t["export"] = time.perf_counter()
        return stats | _timings(t, frames, cpu)
    stage("export")
    for stale in final.parent.glob(f".tmp-{final.name}-*"):  # what a killed run left
        shutil.rmtree(stale, ignore_errors=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    tmp.mkdir(parents=True)
    data = SceneData(index, scene, layout, frames, kept, cfg)
    fmt.write_scene(data, tmp)
    layout.to_json(tmp / "layout.json")
    stats = {"scene": index, "instances": len(scene.instances), "cameras": len(frames),
             "points_total": int(points_total), "chunks": len(kept),
             "class_points": _class_points(counts)}
    stats["files"] = record_files(tmp)
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if index < cfg.previews:
        write_previews(out / "previews", index, layout, frames, scene)
    if fmt.before_rename is not None:
        fmt.before_rename(data, out)
    t["export"] = time.perf_counter()
    if final.exists():  # an incomplete scene of an earlier run
        shutil.rmtree(final)
    tmp.replace(final)  # the scene appears whole, or not at all
    return stats | _timings(t, frames, cpu)


def _run_moving(cfg, index, layout, scene, rng, fmt, accuracy, stage, t, cpu, out: Path, final: Path) -> dict[str, Any]:
    """Scene ``index`` captured along a trajectory: a recording or a mobile-scan map."""
    moving = capture_moving(cfg, layout, scene, rng, fmt, accuracy, stage, t)
    info = {"instances": len(scene.instances), **stats_of(moving)}
    if curation.active(cfg):   # a mobile-scan map's chunks, balanced once every scene is made
        if index < cfg.previews:
            write_recording_previews(out / "previews", index, layout, moving.tally.preview, moving.trajectory,
                                     moving.map_cloud, scene)
        stats = curation.cache_scene(cfg, index, moving.kept, layout, {
            **info, "cameras": moving.tally.shots, "points_total": int(moving.tally.points)})
        t["export"] = time.perf_counter()
        return stats | _timings(t, None, cpu, moving.tally)
    stage("export")
    for stale in final.parent.glob(f".tmp-{final.name}-*"):  # what a killed run left
        shutil.rmtree(stale, ignore_errors=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    tmp.mkdir(parents=True)
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
    stats["files"] = record_files(tmp)
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if index < cfg.previews:
        write_recording_previews(out / "previews", index, layout, moving.tally.preview, moving.trajectory,
                                 moving.map_cloud, scene)
    if fmt.before_rename is not None:
        fmt.before_rename(data, out)
    t["export"] = time.perf_counter()
    if final.exists():  # an incomplete scene of an earlier run
        shutil.rmtree(final)
    tmp.replace(final)  # the scene appears whole, or not at all
    return stats | _timings(t, None, cpu, moving.tally)


def _class_points(counts: np.ndarray) -> dict[str, int]:
    """{class id as text: points} for the classes with points, in id order (``counts``: (65536,) int64)."""
    return {str(k): int(counts[k]) for k in np.flatnonzero(counts).tolist()}


def _timings(t: dict[str, float], frames: list | None, cpu: float, tally=None) -> dict[str, Any]:
    """Seconds per stage, CPU seconds of the scene (all threads), the frames' cost (the
    manifest's "cost" block) and what each sensor effect did: not in stats.json. A moving
    capture's ``tally`` (:class:`~genie_gl.dataset.recording.Tally`) summed them over every
    frame as the recording streamed past."""
    keys = ("start",) + STAGES
    return {"timings_s": {k: t[k] - t[p] for p, k in zip(keys, keys[1:])}, "cpu_s": time.process_time() - cpu,
            "frame_cost_ms": frame_costs(frames) if tally is None else dict(tally.cost_ms),
            "effects": effect_totals(frames) if tally is None else tally.effects}
