"""The one recipe of a dataset scene: layout → scene → placement → capture → cloud chunks
(standing cameras; a moving capture shares the layout and scene, :func:`make_scene`).

A run makes every scene with it (:func:`~genie_gl.dataset.scene.run_scene`) and each worker
warms up with it on a throw-away scene (:func:`~genie_gl.dataset.warmup.warm_up`), so the
warm-up fills exactly the caches the scenes use. What every scene of a run shares is loaded
once, where the run starts (:func:`load_inputs`: the strategy, the sensor, the accuracy
settings), and handed down frozen, to worker processes too.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..capture import capture
from ..capture.settings import settings_for
from ..cloud import FrameTally, PointCloud, frame_chunks, keep_cloud, origin_of
from ..cloud.tally import spare_core
from ..frame import Frame
from ..layout import Layout, Strategy, generate_layout, load_strategy
from ..limits import MAX_REGIONS
from ..render import shared_context
from ..scene import build_scene
from ..scene.model import Scene
from ..sensors.camera import Sensor
from ..effects.profile import load_sensor
from ..placement.genetic import place_sensors
from ..sensors.accuracy import AccuracySettings
from .config import DatasetConfig
from .streams import SceneStreams

# the stages of a scene, in order (the progress bar names them; stats time them)
STAGES = ("layout", "scene", "placement", "capture", "cloud", "export")
PARTS = STAGES[
    :3
]  # the stages before the capture (:func:`make_parts`; :mod:`.ahead` makes them ahead)


@dataclass(frozen=True, eq=False)
class RunInputs:
    """What every scene of a run shares, loaded once.

    Attributes
    ----------
    strategy : the layout strategy.
    sensor : the sensor, its accuracy knobs not yet applied (the capture applies them).
    accuracy : the settings every scene uses: ``--accuracy``, else the profile's, else the
        defaults (:func:`~genie_gl.capture.settings.settings_for`).
    max_regions : the limit on a layout's regions (``--max-nodes``).
    mount_m : the standing cameras' height above the floor in metres (``--mount``); None:
        chosen for the sensor's range.
    """

    strategy: Strategy
    sensor: Sensor
    accuracy: AccuracySettings
    max_regions: int = MAX_REGIONS
    mount_m: float | None = None


def load_inputs(cfg: DatasetConfig) -> RunInputs:
    """The strategy, sensor and accuracy settings of ``cfg``, read and checked."""
    sensor = load_sensor(cfg.sensor)
    accuracy = settings_for(sensor, None if cfg.accuracy is None else cfg.accuracy.settings)
    if cfg.raster is not None:
        accuracy = dataclasses.replace(accuracy, raster=cfg.raster)
    return RunInputs(
        load_strategy(cfg.strategy),
        sensor,
        accuracy,
        max_regions=cfg.max_nodes,
        mount_m=cfg.mount_m,
    )


@dataclass(frozen=True, eq=False)
class MadeScene:
    """A scene made by :func:`make`: its layout, scene, poses and frames, and the clock
    (``perf_counter`` at the end of each stage, keyed by stage, ``"start"`` first).
    ``ahead_s`` and ``ahead_cpu_s``: when a helper process made the layout, scene and
    placement (:mod:`.ahead`), the seconds of each there and its CPU seconds; the clock's
    layout stage is then the wait for them."""

    layout: Layout
    scene: Scene
    poses: list[np.ndarray]
    frames: list[Frame]
    clock: dict[str, float] = field(default_factory=dict)
    tally: FrameTally | None = None
    ahead_s: dict[str, float] | None = None
    ahead_cpu_s: float = 0.0


@dataclass(frozen=True, eq=False)
class Parts:
    """Scene ``index``'s layout, scene and camera poses (None: a moving capture's, placed
    later); ``stages_s``: the seconds each of :data:`PARTS` took where it was made;
    ``cpu_s``: that process's CPU seconds for them."""

    index: int
    layout: Layout
    scene: Scene
    poses: list[np.ndarray] | None
    stages_s: dict[str, float] = field(default_factory=dict)
    cpu_s: float = 0.0


class PartsAhead(Protocol):
    """What hands over scenes' parts made ahead in another process (:class:`~.ahead.Ahead`)."""

    def take(self, index: int) -> Parts | None:
        """Scene ``index``'s parts, or None when they were not made there."""


def make_parts(
    inputs: RunInputs,
    streams: SceneStreams,
    cameras: int | None,
    *,
    stage: Callable[[str], None] = lambda name: None,
) -> Parts:
    """The layout, scene and placement of ``cameras`` standing cameras (None: no placement)
    of the scene of ``streams``; ``stage(name)`` as each stage starts."""
    cpu, t = time.process_time(), [time.perf_counter()]
    stage("layout")
    layout = generate_layout(
        inputs.strategy, rng=streams.rng("layout"), max_regions=inputs.max_regions
    )
    t.append(time.perf_counter())
    stage("scene")
    scene = build_scene(layout, rng=streams.rng("scene"), segments=inputs.accuracy.tessellation)
    t.append(time.perf_counter())
    poses = None
    if cameras is not None:
        stage("placement")
        poses = place_sensors(
            layout,
            inputs.sensor,
            n=cameras,
            seed=streams.placement_seed,
            mount_height_m=inputs.mount_m,
        )
        t.append(time.perf_counter())
    return Parts(
        streams.index,
        layout,
        scene,
        poses,
        {k: b - a for k, a, b in zip(PARTS, t, t[1:])},
        time.process_time() - cpu,
    )


def make_scene(
    inputs: RunInputs, streams: SceneStreams, *, stage: Callable[[str], None] = lambda name: None
) -> tuple[Layout, Scene, dict[str, float]]:
    """The layout and scene of ``streams`` and the clock (``"start"``, ``"layout"``,
    ``"scene"``); ``stage(name)`` as each stage starts. Standing and moving captures alike."""
    clock = {"start": time.perf_counter()}
    parts = make_parts(inputs, streams, None, stage=stage)
    t = clock["start"]
    for k, s in parts.stages_s.items():
        t += s
        clock[k] = t
    return parts.layout, parts.scene, clock


def make(
    inputs: RunInputs,
    streams: SceneStreams,
    *,
    cameras: int,
    depth_only: bool,
    stage: Callable[[str], None] = lambda name: None,
    chunk_m: float | None = None,
    ahead: PartsAhead | None = None,
) -> MadeScene:
    """The scene of ``streams`` up to its frames, taken by ``cameras`` standing cameras;
    ``stage(name)`` as each stage starts. ``depth_only``: render no colour (for formats that
    store none). ``chunk_m``: the tile size the cloud stage will cut (None: no tiles); each
    frame's points per tile are counted as the capture makes it, while the next frames
    render (the result's ``tally``, for :func:`chunk`). ``ahead``: a helper process that
    made (or is making) the layout, scene and placement of this scene (:mod:`.ahead`; made
    here when it has not)."""
    start = time.perf_counter()
    clock = {"start": start}
    parts = None
    if ahead is not None:
        stage("layout")
        parts = ahead.take(streams.index)
        if parts is not None:
            clock["layout"] = clock["scene"] = clock["placement"] = time.perf_counter()
    if parts is None:
        parts = make_parts(inputs, streams, cameras, stage=stage)
        for k in PARTS:
            start += parts.stages_s[k]
            clock[k] = start
        ahead = None
    layout, scene, poses = parts.layout, parts.scene, parts.poses
    stage("capture")
    # (a thread of its own only where this process may use another core: one of two workers
    # on two cores counts the frames in the cloud stage instead)
    tally = (
        FrameTally(chunk_m, origin_of(poses), inline=inputs.accuracy.raster == "cpu")
        if chunk_m is not None and poses and spare_core()
        else None
    )
    try:
        frames = capture(
            scene,
            inputs.sensor,
            poses,
            seed=streams.capture_seed,
            workers=1,
            depth_only=depth_only,
            accuracy=inputs.accuracy,
            context=shared_context() if inputs.accuracy.raster == "gl" else None,
            on_frame=None if tally is None else tally.add,
        )
    except BaseException:
        if tally is not None:
            tally.close()
        raise
    clock["capture"] = time.perf_counter()
    return MadeScene(
        layout,
        scene,
        poses,
        frames,
        clock,
        tally,
        None if ahead is None else dict(parts.stages_s),
        0.0 if ahead is None else parts.cpu_s,
    )


@dataclass(frozen=True, eq=False)
class Chunks:
    """The cloud stage's result: the chunks kept by the cleaning rules ([(tile key,
    PointCloud)]), the points of every frame, and the points per class id (65536,) int64."""

    kept: list[tuple[tuple[int, int], PointCloud]]
    points_total: int
    counts: np.ndarray


def chunk(
    cfg: DatasetConfig,
    frames: list[Frame],
    streams: SceneStreams,
    *,
    chunks: bool,
    tally: FrameTally | None = None,
) -> Chunks:
    """The cloud stage: the frames' points cut into ``cfg.chunk_m`` tiles of at most
    ``cfg.points`` points, those the cleaning rules keep (``chunks`` False: no tiles, for
    formats of images; the counts only). ``tally``: the frames' points per tile counted
    during the capture (:func:`make`'s), taken when it is of these frames."""
    kept, points_total, counts = [], 0, np.zeros(65536, np.int64)
    if chunks:
        # the chunks straight from the frames: the merged cloud (~12 M points at 40 cameras)
        # is built only for a preview that shows it
        try:
            tiles, points_total = frame_chunks(
                frames, cfg.chunk_m, max_points=cfg.points, rng=streams.rng("cloud"), tally=tally
            )
        finally:
            if tally is not None:
                tally.close()
        for key, tile in tiles:
            if keep_cloud(
                tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share
            )[0]:
                kept.append((key, tile))
                counts += np.bincount(tile.semantic, minlength=len(counts))
    else:
        if tally is not None:
            tally.close()
        for f in frames:
            ok = f.depth > 0
            points_total += int(ok.sum())
            counts += np.bincount(f.semantic[ok], minlength=len(counts))
    return Chunks(kept, int(points_total), counts)
