"""Datasets of many scenes: :func:`run_dataset` (``genie dataset``), configured by a typed
:class:`DatasetConfig`; each scene captured by its capture mode (:mod:`.modes`: standing
cameras, a recording along a trajectory, a mobile-scan map, each registered) from its own
random streams (:class:`SceneStreams`); the run, its configuration, the manifest and lock,
the executors, previews and report each in their own module."""

from __future__ import annotations

from .config import DatasetConfig
from .modes import mobile_map, recording, scanning, standing  # noqa: F401  (the capture modes register)
from .recipe import RunInputs, load_inputs
from .run import run_dataset, run_scene, scene_dir
from .streams import SceneStreams

__all__ = [
    "DatasetConfig",
    "RunInputs",
    "SceneStreams",
    "load_inputs",
    "run_dataset",
    "run_scene",
    "scene_dir",
]
