"""Datasets of many scenes: :func:`run_dataset` (``genie dataset``), configured by a typed
:class:`DatasetConfig`; the run, its configuration and limits, the manifest and lock, the
executors, previews and report each in their own module."""
from __future__ import annotations

from .config import DatasetConfig
from .run import run_dataset, run_scene, scene_dir, scene_rngs

__all__ = ["DatasetConfig", "run_dataset", "run_scene", "scene_dir", "scene_rngs"]
