"""The export registry: each format is one module that registers a :class:`DatasetFormat`
(as sensor effects register themselves); ``gg.export``, ``genie capture`` and ``genie dataset``
all look formats up here, so a new format is one new module imported in ``export/__init__``.

A format says where a dataset scene goes, what the scene needs (colour, chunks), how it
writes a scene's chunks or frames and a recording (which capture modes it takes follows:
:mod:`genie_gl.dataset.modes` asks), how one scene is written into its (temporary) folder, what
dataset-level files the scene needs before
its folder is renamed into place, and what is written once all scenes are there.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ConfigError, did_you_mean


@dataclass
class SceneData:
    """What a format may write for one dataset scene."""

    index: int
    scene: Any  # genie_gl.Scene
    layout: Any  # genie_gl.Layout
    frames: list  # list[Frame]
    chunks: list  # [(tile key, PointCloud)] kept by the cleaning rules
    options: Any = None  # DatasetConfig
    extra: dict = field(default_factory=dict)  # what write_scene hands to before_rename
    rig: Any = None  # trajectory capture: the genie_gl Rig ...
    trajectory: Any = None  # ... its Trajectory ...
    recording: Any = None  # ... and (Shot, Frame) pairs in time order, made as they are read


@dataclass(frozen=True)
class DatasetFormat:
    name: str
    folder: str  # scenes go to DIR/<folder>/<index>
    digits: int = 4
    colour: bool = True  # render RGB (False: depth and ids only)
    chunks: bool = True  # needs the cleaned chunks
    full_masks: bool = False  # needs each labelled instance's full silhouette
    write_scene: Callable[[SceneData, Path], None] | None = None  # the scene's files into a folder
    before_rename: Callable[[SceneData, Path], None] | None = (
        None  # dataset files the scene needs (out dir)
    )
    finish: Callable[[Path, Any, list[dict]], None] | None = (
        None  # after every scene: (out, config, stats)
    )
    write_cloud: Callable[..., Path] | None = None  # one cloud: (cloud, out_dir, name=, **kw)
    description: str = ""
    stale: tuple[str, ...] = field(default=())  # extra folders whose .tmp-* a run clears
    # what it writes is what the capture modes ask of it (genie_gl.dataset.modes): a scene's
    # chunks or frames through write_scene, a recording through write_sequence
    write_sequence: Callable[[SceneData, Path], None] | None = None  # a recording into a folder
    finish_recordings: Callable[[Path, Any, list[dict]], None] | None = (
        None  # finish, after recordings
    )
    cloud_outputs: Callable[[str], tuple[str, ...]] | None = (
        None  # top-level names write_cloud(name=) makes
    )
    dataset_outputs: tuple[str, ...] = ()  # top-level names of a dataset, beside folder
    notes: Callable[[Any], list[str]] | None = None  # (config) -> what the user must be told first
    # the disk a scene takes, for the size check before a run (a capture mode's estimate): bytes per
    # point kept, at most (xyz f4 + label u4 = 16 for SemanticKITTI; more for ply, pcd, npz),
    # and per pixel of its frames (image formats)
    bytes_per_point: float = 40.0
    bytes_per_pixel: float = 0.0

    def scene_bytes(self, points: float, pixels: float) -> float:
        """Bytes a scene of at most ``points`` points kept, from frames of ``pixels`` pixels
        in all, takes on disk (an estimate from above)."""
        return points * self.bytes_per_point + pixels * self.bytes_per_pixel

    def scene_dir(self, out: str | os.PathLike, index: int) -> Path:
        return Path(out) / self.folder / f"{index:0{self.digits}d}"


DATASET_FORMATS: dict[str, DatasetFormat] = {}


def register_format(fmt: DatasetFormat) -> DatasetFormat:
    DATASET_FORMATS[fmt.name] = fmt
    return fmt


def get_format(name: str, where: str = "--format") -> DatasetFormat:
    try:
        return DATASET_FORMATS[name]
    except KeyError:
        raise ConfigError(
            f"{where} {name!r}: unknown{did_you_mean(name, DATASET_FORMATS)}; expected one of "
            f"{', '.join(DATASET_FORMATS)}"
        ) from None


def cloud_formats() -> tuple[str, ...]:
    return tuple(n for n, f in DATASET_FORMATS.items() if f.write_cloud is not None)


def file_output(ext: str) -> Callable[[str], tuple[str, ...]]:
    """``cloud_outputs`` of a format that writes one file ``<name>.<ext>``."""
    return lambda name: (f"{name}.{ext}",)


def write_chunks(ext: str, write: Callable) -> Callable[[SceneData, Path], None]:
    """A ``write_scene`` that writes each chunk as ``cloud_NNN.<ext>``."""

    def write_scene(data: SceneData, folder: Path) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        for j, (_, tile) in enumerate(data.chunks):
            write(tile, folder / f"cloud_{j:03d}.{ext}")

    return write_scene
