"""The beams of a scan: each firing from its own pose, each channel at its own time.

A scan is one revolution of the head, ``1 / rate_hz`` s from its start. Firings come every
``firing_period_s`` on the recording's clock (so a Velodyne's 1808.4 firings per revolution at
10 Hz give scans of 1808 or 1809 firings, as a driver cuts them); a firing's channels fire at
``channel_time_s`` after it. The head's azimuth at time t (s from the recording start) is
``start_azimuth - spin 2 pi rate t`` (:mod:`.scanner`). A moving head fires each firing from
its pose at the firing's time (``world_from_scanner(t)``, interpolated on a trajectory; each
channel at its own time within the firing), so a
scan written in the scanner's frame is skewed as a real driver's is, and each point's time
lets a deskewer undo it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..jit import njit
from .scanner import Scanner

PoseAt = Callable[[np.ndarray], np.ndarray]  # (n,) times (s) -> (n, 4, 4) world_from_scanner


@dataclass(frozen=True, eq=False)
class Beams:
    """The beams of one scan, firing-major (all channels of firing 0, then firing 1, ...).

    Attributes
    ----------
    origins, directions : (B, 3) float64, world frame; directions unit length.
    sensor_origins, sensor_directions : (B, 3) float64, the same in the scanner's frame at
        the beam's own time (its firing's, plus its channel's offset).
    channel : (B,) uint16, the channel (laser id / row); ring : (B,) uint16 (the driver's ring).
    column : (B,) uint32, the firing's index within the scan (0 = first).
    firing : (B,) int64, index into ``firing_poses`` (the same as column).
    time_s : (B,) float64, the beam's firing time from the scan start (s).
    azimuth_rad : (B,) float64, the beam's azimuth in the scanner frame, in (-pi, pi].
    firing_poses : (F, 4, 4) float64, world_from_scanner at each firing's time.
    start_s : float, the scan's start on the recording clock (s); index : int, scan number.
    """

    origins: np.ndarray
    directions: np.ndarray
    sensor_origins: np.ndarray
    sensor_directions: np.ndarray
    channel: np.ndarray
    ring: np.ndarray
    column: np.ndarray
    firing: np.ndarray
    time_s: np.ndarray
    azimuth_rad: np.ndarray
    firing_poses: np.ndarray
    start_s: float
    index: int = 0

    def __len__(self) -> int:
        return len(self.origins)

    @property
    def start_pose(self) -> np.ndarray:
        """(4, 4) world_from_scanner at the first firing."""
        return self.firing_poses[0]


@njit(cache=True, nogil=True, boundscheck=False)
def _to_world(poses, which, d, o, out_d, out_o):  # pragma: no cover - compiled
    """Beam b's direction ``d[b]`` turned into the world by pose ``poses[which[b]]`` (4, 4)
    and made unit, into ``out_d[b]``, and its origin ``o[b]`` moved there, into ``out_o[b]``."""
    for b in range(len(d)):
        P = poses[which[b]]
        x, y, z = d[b, 0], d[b, 1], d[b, 2]
        wx = P[0, 0] * x + P[0, 1] * y + P[0, 2] * z
        wy = P[1, 0] * x + P[1, 1] * y + P[1, 2] * z
        wz = P[2, 0] * x + P[2, 1] * y + P[2, 2] * z
        n = math.sqrt(wx * wx + wy * wy + wz * wz)
        out_d[b, 0], out_d[b, 1], out_d[b, 2] = wx / n, wy / n, wz / n
        x, y, z = o[b, 0], o[b, 1], o[b, 2]
        out_o[b, 0] = P[0, 0] * x + P[0, 1] * y + P[0, 2] * z + P[0, 3]
        out_o[b, 1] = P[1, 0] * x + P[1, 1] * y + P[1, 2] * z + P[1, 3]
        out_o[b, 2] = P[2, 0] * x + P[2, 1] * y + P[2, 2] * z + P[2, 3]


def firing_times(scanner: Scanner, start_s: float, clock_start_s: float = 0.0) -> np.ndarray:
    """(F,) float64 times (s, recording clock) of the firings of the scan starting at
    ``start_s``: every multiple of the firing period after ``clock_start_s`` within
    [start, start + 1/rate) and within the field of view."""
    period, span = scanner.firing_period_s, scanner.scan_period_s * scanner.fov_deg / 360.0
    rel = start_s - clock_start_s
    j0 = int(np.ceil(rel / period - 1e-9))
    j1 = int(np.ceil((rel + span) / period - 1e-9))
    return clock_start_s + np.arange(j0, j1, dtype=np.float64) * period


def scan_beams(
    scanner: Scanner,
    pose_at: PoseAt | np.ndarray,
    start_s: float,
    *,
    index: int = 0,
    clock_start_s: float = 0.0,
) -> Beams:
    """The beams of the scan starting at ``start_s`` (s, recording clock); ``pose_at`` is a
    fixed (4, 4) world_from_scanner or a function of time giving one per firing."""
    t_fire = firing_times(scanner, start_s, clock_start_s)
    F, C = len(t_fire), scanner.channels
    if callable(pose_at):
        poses = np.asarray(pose_at(t_fire), np.float64)
    else:
        poses = np.broadcast_to(np.asarray(pose_at, np.float64), (F, 4, 4)).copy()
    t = t_fire[:, None] + scanner.channel_time_s[None, :]  # (F, C) absolute
    head = scanner.start_azimuth_rad - scanner.spin * 2 * np.pi * scanner.rate_hz * (
        t - clock_start_s
    )
    az = head - scanner.azimuth_offset_rad[None, :]
    el = np.broadcast_to(scanner.elevation_rad[None, :], (F, C))
    ce = np.cos(el)
    d = np.stack([ce * np.cos(az), ce * np.sin(az), np.sin(el)], -1).reshape(-1, 3)
    o = np.zeros((F * C, 3))
    if scanner.beam_origin_m:
        o[:, 0], o[:, 1] = (
            (scanner.beam_origin_m * np.cos(head)).ravel(),
            (scanner.beam_origin_m * np.sin(head)).ravel(),
        )
    firing = np.repeat(np.arange(F), C)
    if callable(pose_at) and np.any(scanner.channel_time_s):
        # each beam from the pose at its own time (a Velodyne's lasers fire 2.304 us apart), so a
        # point's time gives exactly the pose it was fired from
        beam_poses = np.ascontiguousarray(pose_at(t.ravel()), np.float64)
        which = np.arange(F * C)
    else:
        beam_poses, which = np.ascontiguousarray(poses), firing
    world_d, world_o = np.empty_like(d), np.empty_like(o)
    _to_world(beam_poses, which, d, o, world_d, world_o)
    wrapped = np.arctan2(np.sin(az), np.cos(az)).ravel()
    return Beams(
        world_o,
        world_d,
        o,
        d,
        np.tile(np.arange(C, dtype=np.uint16), F),
        np.tile(scanner.ring, F),
        firing.astype(np.uint32),
        firing,
        (t - start_s).ravel(),
        wrapped,
        poses,
        float(start_s),
        int(index),
    )


def scan_starts(
    scanner: Scanner, start_s: float, end_s: float, offset_s: float = 0.0
) -> np.ndarray:
    """(n,) float64 start times of the whole scans within [start_s, end_s] (s)."""
    T = scanner.scan_period_s
    n = int(np.floor((end_s - start_s - offset_s) / T + 1e-9))
    return start_s + offset_s + np.arange(max(n, 0), dtype=np.float64) * T
