"""Scanner rigs: LiDAR heads with fixed extrinsics on one moving body.

The body frame is REP 103 (x forward, y left, z up), as for camera rigs (:mod:`.rig`); a
head's own frame is REP 103 too (its spin axis its z), so a head sits on the body at
``Rz(yaw) Ry(pitch) Rx(roll)`` and ``position_m``: a level head has all three 0, a head
sweeping a vertical plane is rolled 90 degrees (its spin axis along the body's y... turned
by yaw as wanted). A head's pose at time t is ``world_from_body(t) @ body_from_scanner``.

A rig file (``rigs/<name>.lidar.yml``; a path for a user's own)::

    name: robot_vlp16
    heads:
      - name: top                      # [a-z0-9_]
        profile: velodyne_vlp16        # a scanner profile (shipped name or path beside this file)
        rate_hz: 10                    # one of the profile's rates (default: the profile's)
        returns: dual                  # one of its return modes (default: the profile's)
        position_m: [0.0, 0.0, 0.45]
        yaw_deg: 0
        pitch_deg: 0                   # + tilts the head's x axis down
        roll_deg: 0
        offset_s: 0                    # its first scan's start after the trajectory's (s)
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..errors import ConfigError
from ..resources import resolve
from .rig import MountSpec, read_spec
from ..sensors.scanner import Scanner
from ..effects.scanner_profile import load_scanner

SUFFIX = ".lidar.yml"


def body_from_head(
    position_m=(0.0, 0.0, 0.0),
    *,
    yaw_rad: float = 0.0,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
) -> np.ndarray:
    """(4, 4) float64 pose of a REP 103 head on the body: ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cy, sy, cp, sp, cr, sr = (
        np.cos(yaw_rad),
        np.sin(yaw_rad),
        np.cos(pitch_rad),
        np.sin(pitch_rad),
        np.cos(roll_rad),
        np.sin(roll_rad),
    )
    out = np.eye(4)
    out[:3, :3] = (
        np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
        @ np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    )
    out[:3, 3] = np.asarray(position_m, np.float64)
    return out


@dataclass(frozen=True, eq=False)
class Head:
    """One scanner on a rig: ``name``; ``scanner``; ``body_from_scanner`` (4, 4) float64;
    ``offset_s``: its first scan's start after the trajectory's start (s)."""

    name: str
    scanner: Scanner
    body_from_scanner: np.ndarray
    offset_s: float = 0.0

    def __post_init__(self) -> None:
        T = np.asarray(self.body_from_scanner, np.float64)
        if (
            T.shape != (4, 4)
            or not np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
            or np.linalg.det(T[:3, :3]) < 0
        ):
            raise ConfigError(
                f"scanner head {self.name!r}: body_from_scanner must be a rigid (4, 4) transform"
            )
        object.__setattr__(self, "body_from_scanner", T)


@dataclass(frozen=True, eq=False)
class ScannerRig:
    """Scanner heads on one body; ``name`` names the rig."""

    name: str
    heads: tuple[Head, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "heads", tuple(self.heads))
        if not self.heads:
            raise ConfigError(f"scanner rig {self.name!r}: needs at least one head")
        names = [h.name for h in self.heads]
        if len(set(names)) != len(names):
            raise ConfigError(f"scanner rig {self.name!r}: head names must be unique")

    @classmethod
    def single(cls, scanner: Scanner, body_from_scanner: np.ndarray | None = None) -> "ScannerRig":
        """One head at the body's origin (or at ``body_from_scanner``)."""
        T = np.eye(4) if body_from_scanner is None else body_from_scanner
        return cls(scanner.name, (Head("head", scanner, T),))


class _HeadSpec(MountSpec):
    rate_hz: float | None = Field(None, gt=0)
    returns: str | None = None


class _RigSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str | None = None
    description: str = ""
    heads: list[_HeadSpec] = Field(min_length=1)


def load_scanner_rig(name_or_path: str | os.PathLike) -> ScannerRig:
    """A scanner rig from ``rigs/<name>.lidar.yml`` or a path; a mistake is one line naming
    the file and the field."""
    path = resolve(name_or_path, "rigs", (SUFFIX,))
    spec = read_spec(path, _RigSpec, _HeadSpec, "scanner rig", "heads")
    heads = []
    for k, h in enumerate(spec.heads):
        beside = path.parent / h.profile
        try:
            scanner = load_scanner(
                beside if beside.is_file() else h.profile, rate_hz=h.rate_hz, returns=h.returns
            )
        except ConfigError as exc:
            raise ConfigError(f"{path}: heads.{k}.profile: {exc}") from None
        if h.offset_s >= scanner.scan_period_s:
            raise ConfigError(
                f"{path}: heads.{k}.offset_s {h.offset_s}: must be below one scan period "
                f"({scanner.scan_period_s:g} s)"
            )
        T = body_from_head(
            h.position_m,
            yaw_rad=np.radians(h.yaw_deg),
            pitch_rad=np.radians(h.pitch_deg),
            roll_rad=np.radians(h.roll_deg),
        )
        heads.append(Head(h.name, scanner, T, float(h.offset_s)))
    return ScannerRig(spec.name or Path(path).name.removesuffix(SUFFIX), tuple(heads))


def scanner_rig_file(name: str | None) -> Path | None:
    """The scanner-rig file ``name`` names (a ``*.lidar.yml`` path or a shipped scanner rig's
    bare name), or None when it names none (a camera rig, or no rig)."""
    if not name:
        return None
    if Path(name).is_file():
        return Path(name) if str(name).endswith(SUFFIX) else None
    try:
        return resolve(name, "rigs", (SUFFIX,))
    except ConfigError:
        return None
