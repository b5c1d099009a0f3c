"""``genie dataset``: layout → scene → placement → capture → clouds → export, for N scenes.

Scene i depends only on (seed, i): its generators come from ``SeedSequence([seed, i])``,
whatever the worker count or executor. Each scene is written into a temporary folder, its
files recorded (size, SHA-256) in its ``stats.json``, the dataset-level files it needs written
(BOP models and camera), and only then renamed into place, so a run killed at any moment
leaves no half-written scene and a re-run makes exactly the missing or damaged ones. Layout
of ``--out DIR``::

    DIR/manifest.json                 inputs and their fingerprint, seeds, versions, every run's
    timings
    DIR/histogram.{txt,json,png}      points per class (the paper's Table 3)
    DIR/previews/                     layout, depth/label images, top-down cloud
    DIR/scenes/NNNN/                  ply, pcd, npz: cloud_XXX.<ext> per chunk; semantickitti: the
                                      scene's scans; each with layout.json and stats.json
    DIR/sequences/NN/, genie-gl.yaml  semantickitti: the sequences (hard links to the scenes' scans)
    DIR/train_pbr/NNNNNN/             bop: the scene's RGB-D frames, masks and ground truth
    DIR/camera.json, DIR/models/      bop: the camera and the object models (mm)
    DIR/.balance/NNNNNN.npz           --class-balance / --points-budget: each scene's chunks
                                      before balancing (one plan needs them all; kept so a
                                      re-run resumes): see genie_gl/dataset/curation.py
"""

from __future__ import annotations

import errno
import json
import logging
import platform
import re
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .. import __version__
from ..capture import add_totals
from ..errors import ConfigError
from ..export import get_format
from ..outputs import OutputFolder, atomic_write_text, claim_folder
from ..render.rasters import default_raster
from ..scene import ASSETS
from . import curation
from .config import DatasetConfig, accuracy_used
from .executors import map_scenes
from .manifest import OutputLock, check_resume, fingerprint, recorded_raster, scene_complete
from .modes.base import get_mode
from .recipe import RunInputs, load_inputs
from .report import class_totals, dataset_cost, histogram
from .scene import run_scene, scene_dir  # noqa: F401  (the run's public names)
from .streams import SceneStreams

log = logging.getLogger(__name__)

SCENE_RECORDS = 1000  # a run's manifest record lists the timings of at most this many scenes


def _check_registered_assets(cfg: dict[str, Any] | DatasetConfig) -> None:
    get = cfg.get if isinstance(cfg, dict) else lambda k, d=None: getattr(cfg, k, d)
    if ASSETS.registered() and (get("executor", "process") == "ray" or get("workers", 1) > 1):
        raise ConfigError(
            f"assets registered with register_asset ({ASSETS.registered()}) stay in this "
            "process and worker processes would not see them; list them in the strategy's "
            "scene.assets, or use one worker"
        )


#: the temporary name of a file being written (``.<name>.<pid>.tmp``, ``.tmp.png``, ``.tmp.npz``)
TEMPORARY = re.compile(r"\..+\.\d+\.tmp(\.png|\.npz|\.las)?")

#: what a dataset writes at the top of ``--out`` besides its format's own entries
DATASET_ENTRIES = ("previews", "histogram.txt", "histogram.json", "histogram.png", ".balance")


def claim_output(cfg: DatasetConfig, fmt) -> OutputFolder:
    """``--out`` claimed for a dataset (:mod:`genie_gl.outputs`): new, or beside the user's own
    files, or a previous run's dataset (its manifest); anything else is refused in one line."""
    return claim_folder(cfg.out, "dataset", (fmt.folder, *fmt.dataset_outputs, *DATASET_ENTRIES))


def prepare(cfg: DatasetConfig) -> tuple[RunInputs, dict]:
    """Check what a run needs before any work: the strategy and sensor load (once: every
    scene gets them from here), placement can work (or the waypoints file reads), the output
    folder may be written, the estimate fits the limits; returns (the run's inputs, the
    fingerprint)."""
    inputs = load_inputs(cfg)
    strategy, sensor = inputs.strategy, inputs.sensor
    mode = get_mode(cfg.capture)
    mode.prepare(cfg, inputs)  # placement can work, a waypoints file reads
    fmt = get_format(cfg.format)
    claim_output(cfg, fmt)
    mode.check_limits(cfg, strategy, sensor, Path(cfg.out))
    for note in fmt.notes(cfg) if fmt.notes else []:
        log.warning(note)
    if cfg.executor == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ConfigError("--executor ray needs Ray: pip install 'genie-gl[ray]'") from None
    return inputs, fingerprint(cfg, strategy, sensor)


def _clear_leftovers(folder: OutputFolder, fmt) -> None:
    """Remove what a killed run left half-made: scene folders and files being written. Only
    inside the entries this dataset's manifest lists as its own, never the user's."""
    out = folder.path
    for parent in {out / fmt.folder, *(out / s for s in fmt.stale)}:
        for stale in parent.glob(".tmp-*") if parent.is_dir() and folder.owns(parent.name) else []:
            shutil.rmtree(stale, ignore_errors=True)
    for entry in out.iterdir():
        if entry.is_file() and entry.name.endswith(".tmp") and entry.name.startswith("."):
            base = entry.name[1:].split(".", 1)[0]
            if any(n.startswith(base) for n in (*folder.declared, "manifest")):
                entry.unlink()  # .<name>.<pid>.tmp of an atomic write of one of our files
            continue
        if not folder.owns(entry.name) or entry.is_symlink() or not entry.is_dir():
            continue
        for p in entry.rglob(
            ".*.tmp*"
        ):  # only the temporary names genie-gl's writers use: a user's
            if p.is_file() and TEMPORARY.fullmatch(p.name):  # draft.tmp, even in our folders, stays
                p.unlink()


def _abandon_unless_begun(folder: OutputFolder, fmt, cfg: DatasetConfig) -> None:
    """After a failed run: where no earlier run left a dataset and no scene was finished, there
    is nothing to resume from: what this run wrote goes (its folder too, if it made it).
    Otherwise everything stays for the same command to resume."""
    if folder.previous is not None or not folder.path.is_dir():
        return
    if any(scene_complete(fmt.scene_dir(folder.path, i)) is not None for i in range(cfg.scenes)):
        return
    try:
        folder.abandon(folder.written())
    except OSError as exc:  # the run's own error is the one to report
        log.warning("--out %s: could not remove this run's outputs: %s", folder.path, exc)


def _effects_total(results: list[dict]) -> dict:
    """Per effect over the scenes made by this run: frames run and skipped, ms, changed pixels."""
    total: dict = {}
    for r in results:
        add_totals(total, r.get("effects", {}))
    return total


def _write_manifest(folder: OutputFolder, manifest: dict) -> None:
    manifest["outputs"] = folder.outputs()
    atomic_write_text(folder.path / "manifest.json", json.dumps(manifest, indent=1))


def run_dataset(
    cfg: DatasetConfig | dict[str, Any],
    *,
    progress: bool = True,
    verify: bool = False,
    on_start: Callable[[], None] | None = None,
) -> dict[str, Any]:
    """Make every missing (or damaged) scene of the dataset described by ``cfg``; ``on_start()``
    is called once every check has passed, before the first scene."""
    _check_registered_assets(cfg)
    if isinstance(cfg, dict):
        cfg = DatasetConfig.parse(cfg)
    inputs, fp = prepare(cfg)
    if cfg.raster is None:  # settled once, recorded in the manifest: a resume keeps it
        raster = inputs.accuracy.raster or recorded_raster(Path(cfg.out)) or default_raster()
        cfg = cfg.model_copy(update={"raster": raster})
        inputs, fp = prepare(cfg)
    fmt = get_format(cfg.format)
    folder = claim_output(cfg, fmt)
    folder.path.mkdir(parents=True, exist_ok=True)
    out = folder.path
    with OutputLock(out):  # a failure is cleared up while the lock is held
        try:
            old = check_resume(out, fp, cfg.scenes)
            runs = list(old.get("runs", [])) if old else []
            manifest = {
                "genie_gl": __version__,
                "python": platform.python_version(),
                "command": "dataset",
                "fingerprint": fp,
                "inputs": {k: v for k, v in cfg.model_dump().items() if k != "out"},
                "scene_seeds": SceneStreams.describe(),
                "runs": runs,
            }
            manifest["outputs"] = sorted(set(folder.owned) | set(folder.declared))
            atomic_write_text(
                out / "manifest.json", json.dumps(manifest, indent=1)
            )  # before any scene: a later
            _clear_leftovers(folder, fmt)  # resume knows the inputs, and what is its own
            if on_start is not None:
                on_start()
            try:
                _run(cfg, inputs, folder, fmt, manifest, runs, progress=progress, verify=verify)
            except OSError as exc:
                if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
                    raise ConfigError(
                        f"--out {out}: disk full or file too large while writing "
                        f"({exc.filename or 'a scene'}: {exc.strerror}); finished scenes are kept: "
                        "free "
                        "space and run the same command again"
                    ) from None
                raise
        except BaseException:
            _abandon_unless_begun(folder, fmt, cfg)
            raise
    return manifest


def _run(
    cfg: DatasetConfig,
    inputs: RunInputs,
    folder: OutputFolder,
    fmt,
    manifest: dict,
    runs: list,
    *,
    progress: bool,
    verify: bool,
) -> None:
    """Make the scenes, then the dataset-level files and the manifest (filled in place)."""
    out = folder.path
    started = time.time()
    t0 = time.perf_counter()
    results = map_scenes(cfg, inputs, progress=progress, verify=verify)
    balanced = (
        curation.finish(cfg, verify=verify) if curation.active(cfg) else None
    )  # one plan over every scene
    elapsed = time.perf_counter() - t0
    stats = [scene_complete(fmt.scene_dir(out, i)) for i in range(cfg.scenes)]
    missing = [i for i, s in enumerate(stats) if s is None]
    if missing:
        raise ConfigError(
            f"--out {out}: scenes {missing[:5]} are incomplete after the run (disk full?)"
        )
    mode = get_mode(cfg.capture)
    finish = mode.finish(fmt)
    if finish is not None:
        finish(out, cfg, stats)
    hist = histogram(
        out, stats, curation.target(cfg), curation.short(stats), reference=mode.reference()
    )
    made = [r for r in results if not r.get("skipped")]
    n_made = (
        len(made) if balanced is None else len(balanced)
    )  # balanced: the scenes written by this run
    stage_t: dict[str, float] = {}
    for r in made:
        for k, v in r.get("timings_s", {}).items():
            stage_t[k] = stage_t.get(k, 0.0) + v
    manifest["runs"] = runs + [
        {
            "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
            "scenes_made": n_made,
            "scenes_skipped": cfg.scenes - n_made,
            "workers": cfg.workers,
            "executor": cfg.executor,
            "wall_s": elapsed,
            "stage_s_total": stage_t,
            "effects": _effects_total(made),
            "cost": dataset_cost(made),
            "warmup_s": [r["warmup_s"] for r in made if "warmup_s" in r],
            "scene_s": [
                {
                    "scene": r.get("scene"),
                    "worker": r.get("worker"),
                    "nth": r.get("nth"),
                    "stages": r.get("timings_s", {}),
                    "cpu_s": r.get("cpu_s"),
                    **({"ahead_s": r["ahead_s"]} if "ahead_s" in r else {}),
                }
                for r in sorted(made, key=lambda r: r.get("scene", -1))[:SCENE_RECORDS]
            ],
        }
    ]
    manifest["cost"], manifest["accuracy"] = dataset_cost(made), accuracy_used(cfg, inputs.sensor)
    manifest["scenes_made"], manifest["scenes_skipped"] = n_made, cfg.scenes - n_made
    manifest["wall_s"], manifest["stage_s_total"], manifest["class_points"] = elapsed, stage_t, hist
    manifest["effects"] = manifest["runs"][-1]["effects"]
    if any("sequence" in s for s in stats):
        manifest["sequences"] = {f"{s['sequence']:02d}": [] for s in stats}
        for s in stats:
            manifest["sequences"][f"{s['sequence']:02d}"].append(s["scene"])
    manifest.update(curation.manifest(cfg, stats))
    manifest["notes"] = fmt.notes(cfg) if fmt.notes else []
    _write_manifest(folder, manifest)
    _check_not_empty(cfg, stats)


def _check_not_empty(cfg: DatasetConfig, stats: list[dict]) -> None:
    """A dataset without a point, or without a labelled one, is an error (its files are kept,
    recorded in the manifest, so a run with other options replaces them)."""
    totals = class_totals(stats)
    where = f"--out {cfg.out}: the {cfg.scenes} scene(s) of {cfg.strategy}"
    if not sum(totals.values()):
        raise ConfigError(
            f"{where} hold no point: every chunk has fewer than --min-points {cfg.min_points} "
            "points or "
            f"a labelled share under --min-labelled-share {cfg.min_labelled_share:g} (or no camera "
            "saw "
            "anything); lower them, or check the sensor and --mount"
        )
    if not sum(v for k, v in totals.items() if k != 0):
        raise ConfigError(
            f"{where} hold nothing labelled: every point is background (class 0); the strategy's "
            "regions may be too small for its assets (see the warnings above)"
        )
