"""The ``Trajectory``: timestamps and body poses (DESIGN.md ``Rig`` and ``Trajectory``).

A trajectory is a list of samples (times strictly increasing, float64 seconds from its
start) with the ``world_from_body`` pose (4x4 float64, REP 103 body frame) at each; between
samples the pose is interpolated, the position linearly and the rotation by slerp, so a
sensor firing at any rate finds its pose. The makers on the layout's free floor are in
:mod:`.paths`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ConfigError
from ..jit import njit


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Body poses over time.

    Attributes
    ----------
    times_s : (N,) float64, strictly increasing, seconds (the first is the start, usually 0).
    world_from_body : (N, 4, 4) float64 rigid transforms, REP 103 body frame (x forward,
        y left, z up) in the world (Z up, metres).
    meta : dict, how it was made (maker, speed, height, turning rate, length).
    """

    times_s: np.ndarray
    world_from_body: np.ndarray
    meta: dict | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.times_s, np.float64)
        T = np.asarray(self.world_from_body, np.float64)
        if t.ndim != 1 or len(t) < 2:
            raise ConfigError(
                f"trajectory: needs at least two samples, got times of shape {t.shape}"
            )
        if T.shape != (len(t), 4, 4):
            raise ConfigError(
                f"trajectory: world_from_body must be ({len(t)}, 4, 4), got {T.shape}"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)):
            raise ConfigError("trajectory: times must be finite and strictly increasing")
        R = T[:, :3, :3]
        if not np.allclose(R @ np.transpose(R, (0, 2, 1)), np.eye(3), atol=1e-6) or not np.all(
            np.isfinite(T)
        ):
            raise ConfigError("trajectory: every world_from_body must be a rigid transform")
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "world_from_body", T)
        object.__setattr__(self, "meta", dict(self.meta or {}))

    def __len__(self) -> int:
        return len(self.times_s)

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def end_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) float64 body origins in the world."""
        return self.world_from_body[:, :3, 3]

    @property
    def length_m(self) -> float:
        """Path length along the samples (m)."""
        return float(np.linalg.norm(np.diff(self.positions, axis=0), axis=1).sum())

    def distance_at(self, times_s: np.ndarray) -> np.ndarray:
        """(n,) float64 distance travelled (m) from the start to each of ``times_s``."""
        cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(self.positions, axis=0), axis=1))]
        return np.interp(np.asarray(times_s, np.float64), self.times_s, cum)

    def at(self, times_s: np.ndarray, then: np.ndarray | None = None) -> np.ndarray:
        """(n, 4, 4) float64 world_from_body at ``times_s`` (within [start, end]): positions
        linear, rotations slerped between the samples either side; times ``then`` (4, 4)
        (a sensor's body_from_sensor: world_from_sensor) when given."""
        t = np.atleast_1d(np.asarray(times_s, np.float64))
        lo, hi = self.start_s, self.end_s
        if t.size and (t.min() < lo - 1e-9 or t.max() > hi + 1e-9):
            raise ConfigError(
                f"trajectory: times {t.min():g}..{t.max():g} s lie outside its span {lo:g}..{hi:g} "
                "s"
            )
        t = np.clip(t, lo, hi)
        out = np.zeros((len(t), 4, 4))
        out[:, 3, 3] = 1.0
        for k in range(3):
            out[:, k, 3] = np.interp(t, self.times_s, self.positions[:, k])
        self._slerp(t, out)
        exact = np.searchsorted(self.times_s, t)
        hit = (exact < len(self.times_s)) & (self.times_s[np.minimum(exact, len(self) - 1)] == t)
        out[hit] = self.world_from_body[exact[hit]]  # a sample's own pose, bit for bit
        if then is not None:
            then = np.ascontiguousarray(then, np.float64)
            if (
                then.shape != (4, 4)
                or not np.isfinite(then).all()
                or not np.array_equal(then[3], [0.0, 0.0, 0.0, 1.0])
            ):
                raise ConfigError(
                    "trajectory: then must be a finite (4, 4) rigid transform (last row 0 0 0 1), "
                    f"got shape {then.shape}"
                )
            composed = np.empty_like(out)
            _rigid_times(out, then, composed)
            return composed
        return out

    def _slerp(self, t: np.ndarray, out: np.ndarray) -> None:
        """The rotations at times ``t`` (n,) into ``out`` (n, 4, 4)[:, :3, :3]: slerp between
        the samples either side (each segment's relative rotation as a rotation vector,
        scaled by the fraction of the segment passed)."""
        if "_quats" not in self.__dict__:  # the samples' quaternions, the segments' rotations
            rot = Rotation.from_matrix(self.world_from_body[:, :3, :3])
            object.__setattr__(self, "_quats", np.ascontiguousarray(rot.as_quat()))
            steps = (rot[:-1].inv() * rot[1:]).as_rotvec()
            object.__setattr__(self, "_steps", np.ascontiguousarray(steps))
        _slerped(self.times_s, self._quats, self._steps, np.ascontiguousarray(t), out)

    def yaw_rates(self) -> np.ndarray:
        """(N-1,) float64 turning rate about the world's z between samples (rad/s)."""
        yaw = np.unwrap(np.arctan2(self.world_from_body[:, 1, 0], self.world_from_body[:, 0, 0]))
        return np.diff(yaw) / np.diff(self.times_s)

    def speeds(self) -> np.ndarray:
        """(N-1,) float64 speed between samples (m/s)."""
        return np.linalg.norm(np.diff(self.positions, axis=0), axis=1) / np.diff(self.times_s)

    def crop(self, duration_s: float) -> "Trajectory":
        """The first ``duration_s`` seconds (ending on an interpolated sample)."""
        end = self.start_s + float(duration_s)
        if end >= self.end_s:
            return self
        keep = self.times_s < end
        times = np.r_[self.times_s[keep], end]
        poses = np.concatenate([self.world_from_body[keep], self.at([end])])
        return Trajectory(times, poses, {**self.meta, "cropped_s": float(duration_s)})


@njit(cache=True, nogil=True, boundscheck=False)
def _rigid_times(poses, then, out):  # pragma: no cover - compiled
    """``poses`` (n, 4, 4) rigid times ``then`` (4, 4) into ``out``."""
    for r in range(len(poses)):
        for i in range(3):
            p0, p1, p2 = poses[r, i, 0], poses[r, i, 1], poses[r, i, 2]
            for j in range(4):
                out[r, i, j] = p0 * then[0, j] + p1 * then[1, j] + p2 * then[2, j]
            out[r, i, 3] += poses[r, i, 3]
        out[r, 3, 0], out[r, 3, 1], out[r, 3, 2], out[r, 3, 3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True, nogil=True, boundscheck=False)
def _slerped(times, quats, steps, t, out):  # pragma: no cover - compiled
    """Rotation matrices at times ``t`` (n,) into ``out`` (n, 4, 4)[:, :3, :3]: in the segment
    of the samples ``times`` (N,) holding each, the sample's quaternion ``quats`` (N, 4)
    (x, y, z, w) turned by the fraction of the segment's rotation vector ``steps`` (N-1, 3)."""
    for r in range(len(t)):
        i = min(max(np.searchsorted(times, t[r], side="right") - 1, 0), len(times) - 2)
        f = (t[r] - times[i]) / (times[i + 1] - times[i])
        vx, vy, vz = steps[i, 0] * f, steps[i, 1] * f, steps[i, 2] * f
        angle = math.sqrt(vx * vx + vy * vy + vz * vz)
        if angle <= 1e-3:  # sin(a / 2) / a by its series
            a2 = angle * angle
            scale = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
        else:
            scale = math.sin(0.5 * angle) / angle
        qx, qy, qz, qw = vx * scale, vy * scale, vz * scale, math.cos(0.5 * angle)
        px, py, pz, pw = quats[i, 0], quats[i, 1], quats[i, 2], quats[i, 3]
        x = pw * qx + qw * px + (py * qz - pz * qy)
        y = pw * qy + qw * py + (pz * qx - px * qz)
        z = pw * qz + qw * pz + (px * qy - py * qx)
        w = pw * qw - (px * qx + py * qy + pz * qz)
        n = math.sqrt(x * x + y * y + z * z + w * w)
        x, y, z, w = x / n, y / n, z / n, w / n
        out[r, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
        out[r, 0, 1] = 2.0 * (x * y - z * w)
        out[r, 0, 2] = 2.0 * (x * z + y * w)
        out[r, 1, 0] = 2.0 * (x * y + z * w)
        out[r, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
        out[r, 1, 2] = 2.0 * (y * z - x * w)
        out[r, 2, 0] = 2.0 * (x * z - y * w)
        out[r, 2, 1] = 2.0 * (y * z + x * w)
        out[r, 2, 2] = 1.0 - 2.0 * (x * x + y * y)


def quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """(4,) float64 unit quaternion (x, y, z, w) of a rotation matrix, w >= 0."""
    q = Rotation.from_matrix(R).as_quat()
    return q if q[3] >= 0 else -q


def planar_poses(xy: np.ndarray, yaw: np.ndarray, height_m: float) -> np.ndarray:
    """(n, 4, 4) world_from_body of a level body at ``xy`` (n, 2) facing ``yaw`` (n,) rad
    (0: +x, pi/2: +y), its origin ``height_m`` above the floor."""
    xy, yaw = np.asarray(xy, np.float64), np.asarray(yaw, np.float64)
    out = np.zeros((len(xy), 4, 4))
    c, s = np.cos(yaw), np.sin(yaw)
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = c, -s, s, c
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    out[:, :2, 3] = xy
    out[:, 2, 3] = float(height_m)
    return out
