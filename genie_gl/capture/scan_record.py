"""The ``Scan`` record: the points of one revolution of one head, with the scanner's fields
(what :mod:`.scan` makes and the cloud and export stages read)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..sensors.scanner import Scanner


@dataclass(frozen=True, eq=False)
class Scan:
    """The points of one revolution of one head.

    Attributes
    ----------
    head : str, the head's name on its rig; head_index : int, its place on the rig.
    scanner : Scanner; index : int, the scan's number; start_s : float, its start (s,
        recording clock).
    world_xyz : (N, 3) float64, the points in the world (exact: each from its own firing).
    sensor_xyz : (N, 3) float64, each point in the scanner's frame at its own firing (raw:
        what a driver reports, skewed by the motion during the revolution).
    range_m : (N,) float64; intensity : (N,) float32 in [0, 1]; ring, channel : (N,) uint16;
    column : (N,) uint32, the firing within the scan; time_s : (N,) float64, from the scan
        start; azimuth_rad : (N,) float64, in the scanner frame;
    return_number, returns : (N,) uint8; semantic : (N,) uint16; instance : (N,) uint32.
    firing_poses : (F, 4, 4) float64, world_from_scanner at each firing (the point's pose is
        ``firing_poses[column]``).
    beams : int, beams fired; plan : dict, effect name -> (runs, why).
    """

    head: str
    head_index: int
    scanner: Scanner
    index: int
    start_s: float
    world_xyz: np.ndarray
    sensor_xyz: np.ndarray
    range_m: np.ndarray
    intensity: np.ndarray
    ring: np.ndarray
    channel: np.ndarray
    column: np.ndarray
    time_s: np.ndarray
    azimuth_rad: np.ndarray
    return_number: np.ndarray
    returns: np.ndarray
    semantic: np.ndarray
    instance: np.ndarray
    firing_poses: np.ndarray
    beams: int = 0
    plan: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.world_xyz)

    @property
    def start_pose(self) -> np.ndarray:
        """(4, 4) world_from_scanner at the scan's first firing."""
        return self.firing_poses[0]

    def deskewed_xyz(self) -> np.ndarray:
        """(N, 3) float64 the points in the scanner's frame at the scan start (motion undone
        with the true poses: what a KITTI odometry scan holds)."""
        inv = np.linalg.inv(self.start_pose)
        return self.world_xyz @ inv[:3, :3].T + inv[:3, 3]
