"""The datasets a study trains and tests on, each made once with
:func:`genie_gl.dataset.run_dataset`
and kept in a cache folder (``out/eval-cache/datasets`` by default) for every study that needs it.

A dataset is a :class:`DataSpec`: a strategy, a sensor (a shipped profile, or a variant of one
with one effect taken out), a seed, a number of scenes of 16+ cameras and an optional class
balance. Its folder name says all of it, so two studies asking for the same data share one
folder, and ``run_dataset``'s resume makes only what is missing (a finished dataset costs a
fraction of a second). Training sets use seed 0, held-out test sets seed 1000 (target-domain
training sets 2000): no test scene is ever a training scene.
"""

from __future__ import annotations

import json
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..dataset import run_dataset
from ..errors import ConfigError
from ..resources import data_dir

log = logging.getLogger(__name__)

TRAIN_SEED = 0
TEST_SEED = 1000
TARGET_SEED = 2000
SCENES, TEST_SCENES, CAMERAS = 10, 4, 16  # a condition's default size
STRATEGIES = ("assembly_line", "storage_area", "logistics_lane")
SENSORS = ("ideal_pinhole", "realsense_d435", "azure_kinect_nfov")
PROFILE = "realsense_d435"
TARGET = ("storage_area", "azure_kinect_nfov")  # the stand-in target of the presets
SECONDS_PER_CAMERA = 0.35  # a 16-camera scene ~5.5 s on 2 loaded cores (measured, docs/eval.md)


@dataclass(frozen=True)
class DataSpec:
    """One dataset a study needs.

    Attributes
    ----------
    strategy : str
        A shipped strategy name (``assembly_line``, ``storage_area``, ``logistics_lane``) or a path.
    sensor : str
        A shipped profile name, or ``<profile>-no-<effect>``: the profile without that effect.
    seed, scenes, cameras : int
    balance : str or None
        ``paper`` for ``--class-balance paper``.
    """

    strategy: str
    sensor: str
    seed: int
    scenes: int
    cameras: int = 16
    balance: str | None = None

    @property
    def name(self) -> str:
        base = (
            f"{Path(self.strategy).stem}.{self.sensor}.s{self.seed}.n{self.scenes}.c{self.cameras}"
        )
        return base + (f".balance-{self.balance}" if self.balance else "")

    def folder(self, cache: str | os.PathLike) -> Path:
        return Path(cache) / "datasets" / self.name

    def estimate_s(self) -> float:
        return self.scenes * self.cameras * SECONDS_PER_CAMERA


def profile_effects(profile: str) -> list[str]:
    """The effect types of a shipped sensor profile, in order."""
    data = yaml.safe_load((data_dir("sensors") / f"{profile}.yaml").read_text())
    return [str(e["type"]) for e in data.get("effects") or []]


def sensor_file(sensor: str, cache: str | os.PathLike) -> str:
    """The ``--sensor`` argument for ``sensor``: a shipped name, or a variant profile written
    into ``cache/profiles`` (the shipped profile less one effect, its calibration by absolute
    path)."""
    if "-no-" not in sensor:
        return sensor
    base, effect = sensor.split("-no-", 1)
    src = data_dir("sensors") / f"{base}.yaml"
    if not src.exists():
        raise ConfigError(f"sensor variant {sensor!r}: no shipped profile {base!r}")
    data = yaml.safe_load(src.read_text())
    effects = data.get("effects") or []
    kept = [e for e in effects if str(e.get("type")) != effect]
    if len(kept) == len(effects):
        raise ConfigError(
            f"sensor variant {sensor!r}: {base} has no effect {effect!r} "
            f"(it has {', '.join(str(e.get('type')) for e in effects)})"
        )
    data.update(
        name=sensor, effects=kept, calibration=str((src.parent / data["calibration"]).resolve())
    )
    out = Path(cache) / "profiles" / f"{sensor}.yaml"
    out.parent.mkdir(parents=True, exist_ok=True)
    text = (
        f"# {base} without its {effect} effect (made by genie eval for a study)\n"
        + yaml.safe_dump(data, sort_keys=False)
    )
    if not out.exists() or out.read_text() != text:
        tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
        tmp.write_text(text)
        tmp.replace(out)
    return str(out)


def is_complete(spec: DataSpec, cache: str | os.PathLike) -> bool:
    """Whether the dataset's folder holds every scene (by its manifest)."""
    m = spec.folder(cache) / "manifest.json"
    if not m.exists():
        return False
    try:
        data = json.loads(m.read_text())
    except ValueError:
        return False
    return (spec.folder(cache) / "sequences").is_dir() and int(data.get("scenes_made", 0)) + int(
        data.get("scenes_skipped", 0)
    ) >= spec.scenes


def ensure(
    spec: DataSpec, cache: str | os.PathLike, *, workers: int = 1, progress: bool = True
) -> Path:
    """Make the dataset if it is not complete in the cache (a complete one is used as it is);
    returns its folder."""
    folder = spec.folder(cache)
    if is_complete(spec, cache):
        # made once, used as made: a profile or strategy edited since then (their fingerprint in
        # the manifest) does not remake it; remove the folder to remake it with today's inputs
        return folder
    cfg = {
        "strategy": spec.strategy,
        "scenes": spec.scenes,
        "cameras": spec.cameras,
        "sensor": sensor_file(spec.sensor, cache),
        "format": "semantickitti",
        "out": str(folder),
        "workers": workers,
        "seed": spec.seed,
        "previews": 0,
    }
    if spec.balance:
        cfg["class_balance"] = spec.balance
    log.info("dataset %s", spec.name)
    run_dataset(cfg, progress=progress)
    return folder


def test_spec(strategy: str, sensor: str, scenes: int, cameras: int = 16) -> DataSpec:
    return DataSpec(strategy, sensor, TEST_SEED, scenes, cameras)


def train_spec(
    strategy: str, sensor: str, scenes: int, cameras: int = 16, balance: str | None = None
) -> DataSpec:
    return DataSpec(strategy, sensor, TRAIN_SEED, scenes, cameras, balance)


def data_cost(spec: DataSpec, cache: str | os.PathLike) -> dict[str, Any]:
    """Per stage and per effect, ms per frame over every run that made scenes of the dataset
    (the manifest's ``runs``; its top-level ``cost`` is the last run's, which a resume that
    made nothing leaves empty)."""
    m = json.loads((spec.folder(cache) / "manifest.json").read_text())
    frames, parts = 0, {"stages": {}, "capture": {}}
    for r in m.get("runs", []):
        cost = r.get("cost") or {}
        frames += int(cost.get("frames", 0))
        for block in ("stages", "capture"):
            for k, v in (cost.get(block) or {}).items():
                parts[block][k] = parts[block].get(k, 0.0) + float(v.get("total_ms", 0.0))
    per = max(frames, 1)
    return {
        "frames": frames,
        **{
            b: {k: {"total_ms": v, "per_frame_ms": v / per} for k, v in d.items()}
            for b, d in parts.items()
        },
    }
