"""``genie dataset``: layout → scene → placement → capture → clouds → export, for N scenes.

Scene i depends only on (seed, i): its generators come from ``SeedSequence([seed, i])``,
whatever the worker count or executor. Each scene is written into a temporary folder, its
files recorded (size, SHA-256) in its ``stats.json``, the dataset-level files it needs written
(BOP models and camera), and only then renamed into place, so a run killed at any moment
leaves no half-written scene and a re-run makes exactly the missing or damaged ones. Layout
of ``--out DIR``::

    DIR/manifest.json                 inputs and their fingerprint, seeds, versions, every run's timings
    DIR/histogram.{txt,json,png}      points per class (the paper's Table 3)
    DIR/previews/                     layout, depth/label images, top-down cloud
    DIR/scenes/NNNN/                  ply, pcd, npz: cloud_XXX.<ext> per chunk; semantickitti: the
                                      scene's scans; each with layout.json and stats.json
    DIR/sequences/NN/, genie-gl.yaml  semantickitti: the sequences (hard links to the scenes' scans)
    DIR/train_pbr/NNNNNN/             bop: the scene's RGB-D frames, masks and ground truth
    DIR/camera.json, DIR/models/      bop: the camera and the object models (mm)
"""
from __future__ import annotations

import json
import logging
import os
import platform
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..errors import ConfigError
from .config import DatasetConfig
from .manifest import OutputLock, check_resume, fingerprint, record_files, scene_complete

log = logging.getLogger(__name__)
STAGES = ("layout", "scene", "placement", "capture", "cloud", "export")


def scene_rngs(seed: int, index: int) -> dict[str, np.random.Generator]:
    """Independent generators of scene ``index`` (layout, scene, placement, capture, cloud)."""
    names = ("layout", "scene", "placement", "capture", "cloud")
    kids = np.random.SeedSequence([int(seed), int(index)]).spawn(len(names))
    return {n: np.random.default_rng(k) for n, k in zip(names, kids)}


def scene_dir(out: Path, index: int, fmt: str, n_scenes: int = 0) -> Path:
    """Where scene ``index`` of a dataset in format ``fmt`` lives."""
    from ..export import get_format

    return get_format(fmt).scene_dir(out, index)


def run_scene(cfg: DatasetConfig, index: int, *, verify: bool = False, stage=None) -> dict[str, Any]:
    """Make scene ``index`` and write it; returns its stats (also in stats.json).
    ``stage(name)`` is called as each stage starts (progress display)."""
    from ..cloud import frame_chunks, keep_cloud
    from ..export import SceneData, get_format
    from ..layout import generate_layout, load_strategy
    from ..render import capture
    from ..scene import build_scene
    from ..sensors import load_sensor, place_sensors

    stage = stage or (lambda name: None)
    out = Path(cfg.out)
    fmt = get_format(cfg.format)
    final = fmt.scene_dir(out, index)
    done = scene_complete(final, verify=verify)
    if done is not None:
        return done | {"skipped": True}
    rng = scene_rngs(cfg.seed, index)
    t = {"start": time.perf_counter()}
    stage("layout")
    layout = generate_layout(load_strategy(cfg.strategy), rng=rng["layout"])
    t["layout"] = time.perf_counter()
    stage("scene")
    scene = build_scene(layout, rng=rng["scene"])
    t["scene"] = time.perf_counter()
    stage("placement")
    sensor = load_sensor(cfg.sensor)
    poses = place_sensors(layout, sensor, n=cfg.cameras, seed=int(rng["placement"].integers(2**31)))
    t["placement"] = time.perf_counter()
    stage("capture")
    # a format that stores no colour renders none (an output not asked for costs nothing)
    frames = capture(scene, sensor, poses, seed=int(rng["capture"].integers(2**31)), workers=1,
                     depth_only=not fmt.colour)
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
                np.add.at(counts, tile.semantic, 1)
    else:
        for f in frames:
            ok = f.depth > 0
            points_total += int(ok.sum())
            np.add.at(counts, f.semantic[ok], 1)
    t["cloud"] = time.perf_counter()
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
             "class_points": {str(k): int(v) for k, v in enumerate(counts) if v}}
    stats["files"] = record_files(tmp)
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if index < cfg.previews:
        from .previews import write_previews

        write_previews(out / "previews", index, layout, frames)
    if fmt.before_rename is not None:
        fmt.before_rename(data, out)
    t["export"] = time.perf_counter()
    if final.exists():  # an incomplete scene of an earlier run
        shutil.rmtree(final)
    tmp.replace(final)  # the scene appears whole, or not at all
    keys = ("start",) + STAGES
    stats["timings_s"] = {k: t[k] - t[p] for p, k in zip(keys, keys[1:])}
    return stats


def _check_registered_assets(cfg: dict[str, Any] | DatasetConfig) -> None:
    from ..scene import ASSETS

    get = cfg.get if isinstance(cfg, dict) else lambda k, d=None: getattr(cfg, k, d)
    if ASSETS.registered() and (get("executor", "process") == "ray" or get("workers", 1) > 1):
        raise ConfigError(f"assets registered with register_asset ({ASSETS.registered()}) stay in this "
                          "process and worker processes would not see them; list them in the strategy's "
                          "scene.assets, or use one worker")


def prepare(cfg: DatasetConfig) -> tuple[Any, Any, dict]:
    """Check what a run needs before any work: the strategy and sensor load, the output folder
    is writable, the estimate fits the limits; returns (strategy, sensor, fingerprint)."""
    from ..layout import load_strategy
    from ..sensors import load_sensor
    from .limits import check_limits

    strategy = load_strategy(cfg.strategy)
    sensor = load_sensor(cfg.sensor)
    out = Path(cfg.out)
    check_limits(cfg, strategy, sensor, out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise ConfigError(f"--out {out}: not writable ({exc.strerror})") from None
    if cfg.executor == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ConfigError("--executor ray needs Ray: pip install 'genie-gl[ray]'") from None
    return strategy, sensor, fingerprint(cfg, strategy, sensor)


def _clear_leftovers(out: Path, fmt) -> None:
    """Remove what a killed run left half-made: scene folders and files being written."""
    for parent in {out / fmt.folder, *(out / s for s in fmt.stale)}:
        for stale in parent.glob(".tmp-*") if parent.is_dir() else []:
            shutil.rmtree(stale, ignore_errors=True)
    for p in out.rglob("*.tmp*"):
        if p.is_file() and (p.name.endswith(".tmp") or p.name.endswith(".tmp.png")):
            p.unlink()


def _write_manifest(out: Path, manifest: dict) -> None:
    tmp = out / "manifest.json.tmp"
    tmp.write_text(json.dumps(manifest, indent=1))
    tmp.replace(out / "manifest.json")


def run_dataset(cfg: DatasetConfig | dict[str, Any], *, progress: bool = True, verify: bool = False) -> dict[str, Any]:
    """Make every missing (or damaged) scene of the dataset described by ``cfg``."""
    from ..export import get_format
    from .executors import map_scenes
    from .report import histogram

    _check_registered_assets(cfg)
    if isinstance(cfg, dict):
        cfg = DatasetConfig.parse(cfg)
    strategy, sensor, fp = prepare(cfg)
    out = Path(cfg.out)
    fmt = get_format(cfg.format)
    with OutputLock(out):
        old = check_resume(out, fp)
        runs = list(old.get("runs", [])) if old else []
        manifest = {
            "genie_gl": __version__, "python": platform.python_version(), "command": "dataset",
            "fingerprint": fp,
            "inputs": {k: v for k, v in cfg.model_dump().items() if k != "out"},
            "scene_seeds": "numpy SeedSequence([seed, scene index]).spawn(5): layout, scene, placement, capture, cloud",
            "runs": runs,
        }
        _write_manifest(out, manifest)  # before any scene: a later resume knows the inputs
        _clear_leftovers(out, fmt)
        started = time.time()
        t0 = time.perf_counter()
        results = map_scenes(cfg, progress=progress, verify=verify)
        elapsed = time.perf_counter() - t0
        stats = [scene_complete(fmt.scene_dir(out, i)) for i in range(cfg.scenes)]
        missing = [i for i, s in enumerate(stats) if s is None]
        if missing:
            raise ConfigError(f"--out {out}: scenes {missing[:5]} are incomplete after the run (disk full?)")
        if fmt.finish is not None:
            fmt.finish(out, cfg, stats)
        hist = histogram(out, stats)
        made = [r for r in results if not r.get("skipped")]
        stage_t: dict[str, float] = {}
        for r in made:
            for k, v in r.get("timings_s", {}).items():
                stage_t[k] = stage_t.get(k, 0.0) + v
        manifest["runs"] = runs + [{
            "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
            "scenes_made": len(made), "scenes_skipped": cfg.scenes - len(made), "workers": cfg.workers,
            "executor": cfg.executor, "wall_s": elapsed, "stage_s_total": stage_t}]
        manifest["scenes_made"], manifest["scenes_skipped"] = len(made), cfg.scenes - len(made)
        manifest["wall_s"], manifest["stage_s_total"], manifest["class_points"] = elapsed, stage_t, hist
        if any("sequence" in s for s in stats):
            manifest["sequences"] = {f"{s['sequence']:02d}": [] for s in stats}
            for s in stats:
                manifest["sequences"][f"{s['sequence']:02d}"].append(s["scene"])
        _write_manifest(out, manifest)
    return manifest
