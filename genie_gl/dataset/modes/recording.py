"""A rig's recording along a trajectory (``--capture trajectory``): every frame, in time order,
handed to the format's sequence writer (SemanticKITTI sequences, TUM RGB-D, a ROS 2 bag, E57).

The recording is rendered by the capture as the writer reads it, a window of frames at a time
(:func:`genie_gl.capture.trajectory.record`), so it is never held whole in memory; the time
spent rendering is the capture's, the rest the export's (:class:`~.moving.Tally`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from .base import Captured, register_mode
from .moving import RigOnPath


class Recording(RigOnPath):
    name = "trajectory"
    description = "a rig's recording along a trajectory"
    rank = 1
    options = (*RigOnPath.options, "cloud_stride")
    disk_fix = "make fewer --scenes, a shorter --duration-s"

    def takes(self, fmt) -> bool:
        return fmt.write_sequence is not None

    def curates(self, fmt) -> bool:
        return False  # a recording is written frame by frame: nothing to sub-sample

    def finish(self, fmt) -> Callable | None:
        return fmt.finish_recordings

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        accuracy = (
            None if cfg.accuracy is None else cfg.accuracy.settings
        )  # each rig sensor's own otherwise
        ride = self.ride(cfg, inputs, streams, fmt, accuracy, stage=stage)
        return self.captured(ride, recording=ride.stream)

    def write_recording(self, fmt, data, folder: Path, got: Captured) -> None:
        tally = got.tally
        fmt.write_sequence(data, folder)
        # the frames were rendered as the writer read them: those seconds are the capture's
        got.clock["capture"] = got.clock["cloud"] = got.clock["capture"] + tally.seconds
        got.counts, got.points, got.shots = tally.counts, tally.points, tally.shots
        got.info["trajectory"]["shots"] = tally.shots  # counted once the writer has read them all


RECORDING = register_mode(Recording())
