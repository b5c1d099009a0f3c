"""``genie dataset``: layout → scene → placement → capture → clouds → export, for N scenes.

Scene i depends only on (seed, i): its generators come from ``SeedSequence([seed, i])``,
whatever the worker count or executor. Each scene is written into a temporary folder and
renamed into place when complete, so an interrupted run leaves no half-written scene and a
re-run skips finished scenes. Layout of ``--out DIR``::

    DIR/manifest.json                 inputs, seeds, versions, timings
    DIR/histogram.{txt,json,png}      points per class (the paper's Table 3)
    DIR/previews/                     layout, depth/label images, top-down cloud
    DIR/sequences/NN/                 semantickitti: one sequence per scene, one scan per chunk
    DIR/scenes/NNNN/                  ply, pcd, npz: cloud_XXX.<ext> per chunk
    DIR/train_pbr/NNNNNN/             bop: the scene's RGB-D frames, masks and ground truth
    DIR/camera.json, DIR/models/      bop: the camera and the object models (mm)
    (each scene folder also holds layout.json and stats.json)
    DIR/.balance/NNNNNN.npz           --class-balance / --points-budget: each scene's chunks
                                      before balancing (one plan needs them all; kept so a
                                      re-run resumes)
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from . import curation
from .errors import ConfigError

log = logging.getLogger(__name__)
FORMATS = ("semantickitti", "ply", "pcd", "npz", "bop")
EXT = {"ply": "ply", "pcd": "pcd", "npz": "npz"}


def scene_rngs(seed: int, index: int) -> dict[str, np.random.Generator]:
    """Independent generators of scene ``index`` (layout, scene, placement, capture, cloud)."""
    names = ("layout", "scene", "placement", "capture", "cloud")
    kids = np.random.SeedSequence([int(seed), int(index)]).spawn(len(names))
    return {n: np.random.default_rng(k) for n, k in zip(names, kids)}


def scene_dir(out: Path, index: int, fmt: str, n_scenes: int) -> Path:
    if fmt == "bop":
        return out / "train_pbr" / f"{index:06d}"
    if fmt == "semantickitti":
        return out / "sequences" / f"{index:0{max(2, len(str(n_scenes - 1)))}d}"
    return out / "scenes" / f"{index:04d}"


def run_scene(cfg: dict[str, Any], index: int) -> dict[str, Any]:
    """Make scene ``index`` and write it; returns its stats (also in stats.json)."""
    from .cloud import frame_chunks, keep_cloud, to_cloud
    from .export import bop
    from .layout import generate_layout, load_strategy
    from .render import capture
    from .scene import build_scene
    from .sensors import load_sensor, place_sensors

    out = Path(cfg["out"])
    final = scene_dir(out, index, cfg["format"], cfg["scenes"])
    if final.exists():
        return json.loads((final / "stats.json").read_text()) | {"skipped": True}
    rng = scene_rngs(cfg["seed"], index)
    t = {"start": time.perf_counter()}
    strategy = load_strategy(cfg["strategy"])
    layout = generate_layout(strategy, rng=rng["layout"])
    t["layout"] = time.perf_counter()
    scene = build_scene(layout, rng=rng["scene"])
    t["scene"] = time.perf_counter()
    sensor = load_sensor(cfg["sensor"])
    poses = place_sensors(layout, sensor, n=cfg["cameras"], seed=int(rng["placement"].integers(2**31)))
    t["placement"] = time.perf_counter()
    # SemanticKITTI scans carry no colour: render none (an output not asked for costs nothing)
    frames = capture(scene, sensor, poses, seed=int(rng["capture"].integers(2**31)), workers=1,
                     depth_only=cfg["format"] == "semantickitti")
    t["capture"] = time.perf_counter()
    # the chunks straight from the frames: the merged cloud (~12 M points at 40 cameras) is
    # built only for a preview that shows it
    tiles, points_total = frame_chunks(frames, cfg["chunk_m"], max_points=cfg["points"], rng=rng["cloud"])
    kept = []
    for key, tile in tiles:
        ok, why = keep_cloud(tile, min_points=cfg["min_points"], min_labelled_share=cfg["min_labelled_share"])
        if ok:
            kept.append((key, tile))
    t["cloud"] = time.perf_counter()
    if curation.active(cfg):  # balanced once every scene is made (curation.py)
        if index < cfg["previews"]:
            write_previews(out / "previews", index, layout, frames, to_cloud(frames))
        return curation.cache_scene(cfg, index, kept, layout, {"instances": len(scene.instances),
                                                               "cameras": len(frames), "points_total": points_total})
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    counts = write_chunks(cfg, tmp, kept)
    meshes: list[str] = []
    if cfg["format"] == "bop":
        meshes = write_bop_scene(scene, frames, tmp)
    layout.to_json(tmp / "layout.json")
    stats = {"scene": index, "instances": len(scene.instances), "cameras": len(frames),
             "points_total": points_total, "chunks": len(kept),
             "class_points": {str(k): int(v) for k, v in enumerate(counts) if v}}
    (tmp / "stats.json").write_text(json.dumps(stats, indent=1, sort_keys=True))
    if index < cfg["previews"]:
        write_previews(out / "previews", index, layout, frames, to_cloud(frames))
    t["export"] = time.perf_counter()
    tmp.replace(final)  # the scene appears whole, or not at all
    if meshes:
        bop.write_dataset_files(scene, frames[0], out, meshes)
    keys = ["start", "layout", "scene", "placement", "capture", "cloud", "export"]
    stats["timings_s"] = {k: t[k] - t[p] for p, k in zip(keys, keys[1:])}
    from .plan import effect_totals  # what each sensor effect did (issue 12); timings: not in stats.json

    stats["effects"] = effect_totals(frames)
    return stats


def write_chunks(cfg: dict[str, Any], tmp: Path, kept: list) -> np.ndarray:
    """Write a scene's chunks into ``tmp`` in the dataset's format; returns points per class."""
    from .export import npz, pcd, ply, semantickitti

    counts = np.zeros(65536, np.int64)
    for j, (key, tile) in enumerate(kept):
        np.add.at(counts, tile.semantic, 1)
        if cfg["format"] == "bop":
            continue
        if cfg["format"] == "semantickitti":
            # the scan files are written inside the scene's own folder: a sequence folder
            semantickitti.write(tile, tmp / "_root", sequence=0, frame=j)
        else:
            {"ply": ply.write, "pcd": pcd.write, "npz": npz.write}[cfg["format"]](
                tile, tmp / f"cloud_{j:03d}.{EXT[cfg['format']]}")
    if cfg["format"] == "semantickitti" and kept:
        for p in (tmp / "_root" / "sequences" / "00").iterdir():
            p.replace(tmp / p.name)
        shutil.rmtree(tmp / "_root")
    return counts


def write_bop_scene(scene, frames, folder: Path) -> list[str]:
    """BOP files of one scene, with full silhouettes rendered object by object."""
    from .export import bop
    from .render import Renderer, silhouettes

    with Renderer(scene) as r:
        full = [silhouettes(r, f.sensor, f.world_from_camera,
                            np.unique(f.instance[(f.semantic != 0) & (f.depth > 0)]).tolist()) for f in frames]
    return bop.write_scene_files(scene, frames, folder, full_masks=full)


def write_previews(folder: Path, index: int, layout, frames, cloud) -> None:
    from PIL import Image

    from .export.semantickitti import COLORS_RGB
    from .layout import save_layout_png

    folder.mkdir(parents=True, exist_ok=True)
    save_layout_png(layout, folder / f"scene_{index:04d}_layout.png")
    palette = np.zeros((65536, 3), np.uint8)
    palette[:] = (255, 255, 255)
    for k, c in COLORS_RGB.items():
        palette[k] = c
    for c, f in enumerate(frames[:2]):
        d = f.depth
        v = d[d > 0]
        lo, hi = (np.percentile(v, 1), np.percentile(v, 99)) if v.size else (0, 1)
        g = np.where(d > 0, 255 * (1 - np.clip((d - lo) / max(hi - lo, 1e-6), 0, 1)), 0).astype(np.uint8)
        depth_img = np.stack([g, g, g], -1)
        label = np.where((f.depth > 0)[..., None], palette[f.semantic], 0).astype(np.uint8)
        parts = [depth_img, label] + ([f.rgb] if f.rgb is not None else [])
        _save(Image.fromarray(np.concatenate(parts, 1)), folder / f"scene_{index:04d}_cam{c:02d}.png")
    # top-down view of the merged cloud, coloured by class (highest point wins)
    x0, y0, w, h = layout.bounds
    s = 900 / max(w, h)
    W, H = int(w * s) + 1, int(h * s) + 1
    img = np.full((H, W, 3), 255, np.uint8)
    xyz = cloud.world_xyz
    order = np.argsort(xyz[:, 2])
    c = np.clip(((xyz[order, 0] - x0) * s).astype(int), 0, W - 1)
    r = np.clip(((y0 + h - xyz[order, 1]) * s).astype(int), 0, H - 1)
    img[r, c] = palette[cloud.semantic[order]]
    _save(Image.fromarray(img), folder / f"scene_{index:04d}_cloud_top.png")


def _save(img, path: Path) -> None:
    tmp = path.with_name(path.stem + ".tmp.png")
    img.save(tmp)
    tmp.replace(path)


def histogram(out: Path, stats: list[dict], target: dict[int, float] | None = None,
              short: dict[str, str] | None = None) -> dict[str, int]:
    from .export.semantickitti import CLASSES, COLORS_RGB

    total: dict[int, int] = {}
    for s in stats:
        for k, v in s["class_points"].items():
            total[int(k)] = total.get(int(k), 0) + v
    n = sum(total.values()) or 1
    lines = [f"{'id':>3}  {'class':<20}{'points':>14}{'share':>9}" + (f"{'target':>9}" if target else "")]
    for k in sorted(set(total) | set(target or {})):
        lines.append(f"{k:>3}  {CLASSES.get(k, f'class_{k}'):<20}{total.get(k, 0):>14,}{100 * total.get(k, 0) / n:>8.2f}%"
                     + (f"{100 * target.get(k, 0.0):>8.2f}%" if target else ""))
    for k, why in sorted((short or {}).items(), key=lambda kv: int(kv[0])):
        lines.append(f"short of its target: {CLASSES.get(int(k), f'class_{k}')}: {why}")
    (out / "histogram.txt").write_text("\n".join(lines) + "\n")
    (out / "histogram.json").write_text(json.dumps({CLASSES.get(k, str(k)): v for k, v in sorted(total.items())}, indent=1))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.5))
    keys = sorted(total)
    ax.bar([CLASSES.get(k, str(k)) for k in keys], [total[k] for k in keys],
           color=[np.array(COLORS_RGB.get(k, (128, 128, 128))) / 255 for k in keys])
    ax.set_yscale("log")
    ax.set_ylabel("points")
    ax.set_title("points per class")
    plt.setp(ax.get_xticklabels(), rotation=30, ha="right")
    fig.tight_layout()
    fig.savefig(out / "histogram.png", dpi=100)
    plt.close(fig)
    return {CLASSES.get(k, str(k)): v for k, v in total.items()}


def _worker(job: tuple[dict, int]) -> dict:
    if os.environ.get("GENIE_GL_BACKEND"):  # a spawned worker: the CLI's choice, inherited
        from .render.context import set_default_backend

        set_default_backend(os.environ["GENIE_GL_BACKEND"])
    from .render import limit_threads  # workers share the cores: llvmpipe and numba threads

    limit_threads((os.cpu_count() or 1) // max(1, int(job[0]["workers"])))
    return run_scene(*job)


def _effects_total(results: list[dict]) -> dict:
    """Per effect over the scenes made by this run: frames run and skipped, ms, changed pixels."""
    from .plan import add_totals

    total: dict = {}
    for r in results:
        add_totals(total, r.get("effects", {}))
    return total


def run_dataset(cfg: dict[str, Any], *, progress: bool = True) -> dict[str, Any]:
    """Make every missing scene of the dataset described by ``cfg`` (see ``add_arguments``)."""
    from tqdm import tqdm

    from .scene import ASSETS

    if ASSETS.registered() and (cfg["executor"] == "ray" or cfg["workers"] > 1):
        raise ConfigError(f"assets registered with register_asset ({ASSETS.registered()}) stay in this "
                          "process and worker processes would not see them; list them in the strategy's "
                          "scene.assets, or use one worker")
    out = Path(cfg["out"])
    for parent in (out / "sequences", out / "scenes"):  # what an interrupted run left half-made
        for stale in parent.glob(".tmp-*") if parent.is_dir() else []:
            shutil.rmtree(stale, ignore_errors=True)
    there = sum(scene_dir(out, i, cfg["format"], cfg["scenes"]).exists() for i in range(cfg["scenes"]))
    todo = [i for i in range(cfg["scenes"]) if not scene_dir(out, i, cfg["format"], cfg["scenes"]).exists()
            and not (curation.active(cfg) and curation.cache_path(cfg, i).exists())]
    results: list[dict] = []
    t0 = time.perf_counter()
    bar = tqdm(total=cfg["scenes"], initial=cfg["scenes"] - len(todo), unit="scene", disable=not progress,
               desc="scenes")
    if cfg["executor"] == "ray":
        import ray

        ray.init(address=cfg.get("address"), ignore_reinit_error=True, log_to_driver=False)
        remote = ray.remote(run_scene)
        pending = [remote.remote(cfg, i) for i in todo]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            results.append(ray.get(done[0]))
            bar.update(1)
    elif cfg["workers"] <= 1 or len(todo) <= 1:
        for i in todo:
            results.append(run_scene(cfg, i))
            bar.update(1)
    else:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(min(cfg["workers"], len(todo))) as pool:
            for r in pool.imap_unordered(_worker, [(cfg, i) for i in todo]):
                results.append(r)
                bar.update(1)
    bar.close()
    if curation.active(cfg):
        curation.finish(cfg, lambda i: scene_dir(out, i, cfg["format"], cfg["scenes"]), write_chunks)
    elapsed = time.perf_counter() - t0
    stats = [json.loads((scene_dir(out, i, cfg["format"], cfg["scenes"]) / "stats.json").read_text())
             for i in range(cfg["scenes"])]
    hist = histogram(out, stats, curation.target(cfg), curation.short(stats))
    stage_t: dict[str, float] = {}
    for r in results:
        for k, v in r.get("timings_s", {}).items():
            stage_t[k] = stage_t.get(k, 0.0) + v
    manifest = {
        "genie_gl": __version__, "python": platform.python_version(), "command": "dataset",
        "inputs": {k: v for k, v in cfg.items() if k != "out"},
        "scene_seeds": "numpy SeedSequence([seed, scene index]).spawn(5): layout, scene, placement, capture, cloud",
        "scenes_made": cfg["scenes"] - there, "scenes_skipped": there,
        "wall_s": elapsed, "stage_s_total": stage_t, "class_points": hist,
        "effects": _effects_total(results),
    }
    from .export.semantickitti import CLASSES

    manifest.update(curation.manifest(cfg, stats, CLASSES))
    tmp = out / "manifest.json.tmp"
    tmp.write_text(json.dumps(manifest, indent=1))
    tmp.replace(out / "manifest.json")
    return manifest


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("strategy", help="strategy JSON file or shipped name")
    p.add_argument("--scenes", type=int, default=3)
    p.add_argument("--cameras", type=int, default=8)
    p.add_argument("--sensor", default="realsense_d435", help="sensor profile name or path")
    p.add_argument("--format", default="semantickitti", help=f"one of {', '.join(FORMATS)}")
    p.add_argument("--out", required=True)
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--points", type=int, default=25000, help="points per chunk (the paper: 25 000)")
    p.add_argument("--chunk-m", type=float, default=12.0, help="chunk size in metres")
    p.add_argument("--min-points", type=int, default=2000)
    p.add_argument("--min-labelled-share", type=float, default=0.05)
    p.add_argument("--previews", type=int, default=3, help="scenes that get preview pictures")
    p.add_argument("--executor", choices=("process", "ray"), default="process")
    p.add_argument("--address", default=None, help="Ray cluster address (with --executor ray)")
    curation.add_arguments(p)
    p.add_argument("--no-progress", action="store_true")


def config_from_args(args: argparse.Namespace) -> dict[str, Any]:
    from .layout import load_strategy
    from .sensors import load_sensor

    if args.format not in FORMATS:
        raise ConfigError(f"--format {args.format!r}: unknown; expected one of {', '.join(FORMATS)}")
    if args.scenes < 1 or args.cameras < 1 or args.workers < 1:
        raise ConfigError("--scenes, --cameras and --workers must be >= 1")
    from .export.semantickitti import CLASSES

    curated = curation.config(args, CLASSES)
    strategy = load_strategy(args.strategy)      # fails fast on a missing or bad strategy
    load_sensor(args.sensor)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise ConfigError(f"--out {out}: not writable ({exc.strerror})") from None
    if args.executor == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ConfigError("--executor ray needs Ray: pip install 'genie-gl[ray]'") from None
    return {"strategy": strategy.source, "scenes": args.scenes, "cameras": args.cameras, "sensor": args.sensor,
            "format": args.format, "out": str(out), "workers": args.workers, "seed": args.seed,
            "points": args.points, "chunk_m": args.chunk_m, "min_points": args.min_points,
            "min_labelled_share": args.min_labelled_share, "previews": args.previews,
            "executor": args.executor, "address": args.address,
            **curated}


def run(args: argparse.Namespace) -> int:
    cfg = config_from_args(args)
    m = run_dataset(cfg, progress=not args.no_progress)
    print(f"dataset: {m['scenes_made']} scenes made, {m['scenes_skipped']} already there, "
          f"{m['wall_s']:.1f} s -> {cfg['out']} (previews in {Path(cfg['out']) / 'previews'})")
    return 0
