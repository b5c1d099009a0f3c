"""Standing cameras (``--capture static``, the default): ``--cameras`` sensors placed on the
scene's free floor for coverage (``--mount``), each frame captured once; the frames' points
cut into chunks (or, for a format of images, the frames themselves) go to the format's
``write_scene``. The recipe is :mod:`genie_gl.dataset.recipe`'s, so a worker's warm-up and a
helper process making scenes ahead (:mod:`genie_gl.dataset.ahead`) make the same scenes."""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ...capture import effect_totals, frame_costs, silhouettes
from ...export import get_format
from ...layout.estimate import layout_estimate
from ...limits import BYTES_PER_CLOUD_POINT, BYTES_PER_NODE, BYTES_PER_PIXEL
from ...placement.genetic import ceiling_of, mount_for
from ...render import Renderer
from ..previews import write_previews
from ..recipe import chunk, make
from .base import Captured, CaptureMode, Estimate, register_mode, stamp

log = logging.getLogger(__name__)


class StandingCameras(CaptureMode):
    name = "static"
    description = "standing cameras, placed for coverage"
    rank = 0
    options = ("cameras", "mount_m")
    fingerprints_mode = False  # a standing run's fingerprint is as it was before other modes
    made_ahead = True

    def prepare(self, cfg, inputs) -> None:
        mount_for(
            inputs.sensor, ceiling_m=ceiling_of(inputs.strategy.scene), mount_height_m=cfg.mount_m
        )

    def takes(self, fmt) -> bool:
        return fmt.write_scene is not None

    def estimate(self, cfg, strategy, sensor) -> Estimate:
        """Per worker: the frames of one scene (cameras x pixels x BYTES_PER_PIXEL) plus the
        layout, a preview scene's merged cloud, and one layout more for one worker's helper
        process; disk: the points (or images) the format writes."""
        nodes, work = layout_estimate(strategy)
        pixels = int(sensor.width) * int(sensor.height)
        per_worker = cfg.cameras * pixels * BYTES_PER_PIXEL + nodes * BYTES_PER_NODE
        if cfg.previews:  # a preview scene's frames are merged into one cloud as well
            per_worker += cfg.cameras * pixels * BYTES_PER_CLOUD_POINT
        workers = min(cfg.workers, cfg.scenes)
        helper = nodes * BYTES_PER_NODE if workers == 1 and cfg.scenes > 1 else 0
        chunks = max(1.0, strategy.root.width / cfg.chunk_m + 1) * max(
            1.0, strategy.root.height / cfg.chunk_m + 1
        )
        points = min(
            chunks * cfg.points, cfg.cameras * pixels
        )  # a scene keeps at most its chunks' points
        disk = int(cfg.scenes * get_format(cfg.format).scene_bytes(points, cfg.cameras * pixels))
        what = (
            f"{workers} workers x {cfg.cameras} cameras x {sensor.width}x{sensor.height} px x "
            f"{BYTES_PER_PIXEL} B + {nodes:.3g} regions"
        )
        return Estimate(
            nodes,
            work,
            pixels,
            int(per_worker * workers + helper),
            int(disk),
            what,
            "use fewer --workers or --cameras, a smaller sensor",
        )

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        # a format that stores no colour renders none (an output not asked for costs nothing)
        made = make(
            inputs,
            streams,
            cameras=cfg.cameras,
            depth_only=not fmt.colour,
            stage=stage,
            chunk_m=cfg.chunk_m if fmt.chunks else None,
            ahead=ahead,
        )
        layout, scene, frames, clock = made.layout, made.scene, made.frames, dict(made.clock)
        extra = {"full_masks": full_masks(scene, frames, cfg.raster)} if fmt.full_masks else {}
        stage("cloud")
        cut = chunk(cfg, frames, streams, chunks=fmt.chunks, tally=made.tally)
        stamp(clock, "cloud")
        index = streams.index
        if fmt.chunks and not cut.kept:
            log.warning(
                "scene %d: no chunk kept: every chunk of its %d points has fewer than --min-points "
                "%d points "
                "or a labelled share under --min-labelled-share %g",
                index,
                cut.points_total,
                cfg.min_points,
                cfg.min_labelled_share,
            )
        elif not cut.counts[1:].any():
            log.warning(
                "scene %d: nothing labelled: its %d points are all background (class 0)",
                index,
                cut.points_total,
            )
        return Captured(
            layout,
            scene,
            clock,
            frames=frames,
            kept=cut.kept,
            counts=cut.counts,
            points=cut.points_total,
            shots=len(frames),
            info={"instances": len(scene.instances)},
            costs=lambda: (frame_costs(frames), effect_totals(frames)),
            previews=lambda folder, i: write_previews(folder, i, layout, frames, scene, cfg.raster),
            extra=extra,
            ahead_s=made.ahead_s,
            ahead_cpu_s=made.ahead_cpu_s,
        )


def full_masks(scene, frames, raster: str | None) -> list[dict[int, np.ndarray]]:
    """Per frame, {instance id: (H, W) bool} the full silhouette of each labelled instance the
    frame sees (each drawn alone, through the lens), for formats that write amodal masks."""
    with Renderer(scene, raster=raster) as r:
        return [
            silhouettes(
                r,
                f.sensor,
                f.world_from_camera,
                np.unique(f.instance[(f.semantic != 0) & (f.depth > 0)]).tolist(),
            )
            for f in frames
        ]


STANDING = register_mode(StandingCameras())
