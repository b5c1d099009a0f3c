"""A mobile-scan map (``--capture mobile-map``): a rig's recording along a trajectory with a
mobile scanner's registration error (``--registration``: drift, pass misalignment) fused into
one map (``--voxel-m``), cut into ``--chunk-m`` chunks of ``--points`` points and cleaned as
standing cameras' chunks are, written in any point-cloud format. Its histogram shows the
paper's real column beside it (Table 3: a mobile scanner's data)."""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from ...capture.mobile_map import registration_rng, with_registration
from ...cloud import chunks, keep_cloud
from ...cloud.balance import PAPER_REAL
from ...cloud.fusion import fuse
from ...placement.genetic import ceiling_of
from ...motion.registration import registration_of
from .base import Captured, register_mode, stamp
from .moving import RigOnPath

log = logging.getLogger(__name__)


def voxel_bytes(width_m: float, depth_m: float, height_m: float, voxel_m: float) -> float:
    """Bytes of a mobile-scan map's bit set over a ``width_m`` x ``depth_m`` x ``height_m`` box
    (:class:`genie_gl.cloud.fusion.VoxelMap`), as a float (no overflow however small the voxel)."""
    return (
        float(np.prod([max(1.0, np.ceil(x / voxel_m)) for x in (width_m, depth_m, height_m)])) / 8.0
    )


class MobileMap(RigOnPath):
    name = "mobile-map"
    description = "a mobile-scan map fused from a rig's recording"
    rank = 2
    options = (*RigOnPath.options, "voxel_m", "registration")
    memory_fix = "use fewer --workers, a larger --voxel-m"

    def takes(self, fmt) -> bool:
        return fmt.write_scene is not None and fmt.chunks

    def reference(self) -> dict[int, float] | None:
        return PAPER_REAL

    def held_bytes(self, cfg, strategy) -> tuple[float, str]:
        """The map's bit set: the hall's box with the half metre the map keeps around it."""
        root = strategy.root
        return (
            voxel_bytes(
                root.width + 1, root.height + 1, ceiling_of(strategy.scene) + 1, cfg.voxel_m
            ),
            f" + the map's bit set at --voxel-m {cfg.voxel_m:g}",
        )

    def written_points(self, cfg, strategy, frames: float, pixels: int) -> float:
        root = strategy.root
        n = max(1.0, root.width / cfg.chunk_m + 1) * max(1.0, root.height / cfg.chunk_m + 1)
        return min(n * cfg.points, frames * pixels)

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        accuracy = (
            None if cfg.accuracy is None else cfg.accuracy.settings
        )  # each rig sensor's own otherwise
        ride = self.ride(cfg, inputs, streams, fmt, accuracy, stage=stage)
        trajectory, tally = ride.trajectory, ride.tally
        b = ride.scene.bounds()
        b[0] -= 0.5
        b[1] += 0.5
        moved = with_registration(
            ride.stream,
            trajectory,
            registration_of(cfg.registration),
            rng=registration_rng(streams.capture_seed),
        )
        times: list[float] = []

        def frames():
            for shot, frame in moved:
                times.append(shot.time_s)
                yield frame

        cloud = fuse(frames(), bounds=b, voxel_m=cfg.voxel_m)
        stamp(ride.clock, "capture")
        stage("cloud")
        kept = []
        tally.counts[:] = 0
        for key, tile in chunks(
            cloud, cfg.chunk_m, min_points=1, max_points=cfg.points, rng=streams.rng("cloud")
        ):
            if keep_cloud(
                tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share
            )[0]:
                kept.append((key, tile))
                np.add.at(tally.counts, tile.semantic, 1)
        if not kept:  # as for standing cameras: the scene is written without chunks, and said so
            log.warning(
                "a mobile-scan map of %d points gave no chunk of %d+ points with a %g labelled "
                "share "
                "(a longer --duration-s sees more)",
                len(cloud),
                cfg.min_points,
                cfg.min_labelled_share,
            )
        tally.points = len(cloud)
        stamp(ride.clock, "cloud")
        return self.captured(
            ride,
            map_cloud=cloud,
            kept=kept,
            counts=tally.counts,
            points=tally.points,
            shots=tally.shots,
            extra={"frame_times_s": np.asarray(times, np.float64) - trajectory.start_s},
        )


MOBILE_MAP = register_mode(MobileMap())
