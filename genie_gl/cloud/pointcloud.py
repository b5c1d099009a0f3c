"""The ``PointCloud``: labelled points as a structure of arrays (DESIGN.md)."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

OPTIONAL = ("rgb", "normal", "camera", "intensity", "ring", "time", "return_number", "returns")


@dataclass(frozen=True, eq=False)
class PointCloud:
    """N labelled points.

    Attributes
    ----------
    xyz : (N, 3) float32 (float64 when asked for, ``to_cloud(precision="float64")``), world
        frame relative to ``origin``, metres.
    origin : (3,) float64, world position of xyz = 0 (the cameras' mean snapped to 100 m).
    semantic : (N,) uint16; instance : (N,) uint32.
    rgb : (N, 3) uint8 or None; normal : (N, 3) float32 or None (world frame);
    camera : (N,) uint16 or None, index of the frame that saw the point.

    A scanner's points also carry (each None for a camera's cloud, LIDAR.md §9.5 gives what
    each format calls them):
    intensity : (N,) float32 or None, reflectivity as the head reports it: the surface's
        albedo x cos(incidence) for a diffuse surface, in [0, 1];
    ring : (N,) uint16 or None, the beam's ring (the driver's: Velodyne 0 = lowest beam,
        Ouster 0 = top row);
    time : (N,) float64 or None, the beam's firing time in seconds from its scan's start;
    return_number : (N,) uint8 or None, 1-based, nearest echo first;
    returns : (N,) uint8 or None, the number of echoes its beam reported.
    """

    xyz: np.ndarray
    semantic: np.ndarray
    instance: np.ndarray
    origin: np.ndarray = None  # type: ignore[assignment]
    rgb: np.ndarray | None = None
    normal: np.ndarray | None = None
    camera: np.ndarray | None = None
    intensity: np.ndarray | None = None
    ring: np.ndarray | None = None
    time: np.ndarray | None = None
    return_number: np.ndarray | None = None
    returns: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.xyz)
        object.__setattr__(
            self,
            "origin",
            np.zeros(3) if self.origin is None else np.asarray(self.origin, np.float64),
        )
        checks = {
            "xyz": ((n, 3), np.float32),
            "semantic": ((n,), np.uint16),
            "instance": ((n,), np.uint32),
            "rgb": ((n, 3), np.uint8),
            "normal": ((n, 3), np.float32),
            "camera": ((n,), np.uint16),
            "intensity": ((n,), np.float32),
            "ring": ((n,), np.uint16),
            "time": ((n,), np.float64),
            "return_number": ((n,), np.uint8),
            "returns": ((n,), np.uint8),
        }
        for name, (shape, dtype) in checks.items():
            a = getattr(self, name)
            if a is None:
                continue
            if name == "xyz" and a.dtype == np.float64:
                dtype = np.float64
            if a.shape != shape or a.dtype != dtype:
                raise ValueError(
                    f"PointCloud.{name}: expected {shape} {np.dtype(dtype).name}, got {a.shape} "
                    f"{a.dtype}"
                )

    def __len__(self) -> int:
        return len(self.xyz)

    @property
    def world_xyz(self) -> np.ndarray:
        """(N, 3) float64 absolute world coordinates."""
        return self.xyz.astype(np.float64) + self.origin

    def finite(self) -> np.ndarray:
        """(N,) bool: the points whose coordinates (and origin) are finite."""
        if not np.isfinite(self.origin).all():
            return np.zeros(len(self), bool)
        return np.isfinite(self.xyz).all(axis=1)

    def non_finite(self) -> int:
        """How many points have a NaN or infinite coordinate (0 for a cloud fit to write)."""
        if not np.isfinite(self.origin).all():
            return len(self)
        return 0 if np.isfinite(self.xyz).all() else int(len(self) - self.finite().sum())

    def select(self, index: Any) -> "PointCloud":
        """The points at ``index`` (boolean mask or integer indices)."""
        kw = {
            f.name: (getattr(self, f.name)[index] if getattr(self, f.name) is not None else None)
            for f in fields(self)
            if f.name != "origin"
        }
        return PointCloud(origin=self.origin, **kw)

    def with_origin(self, origin: np.ndarray) -> "PointCloud":
        origin = np.asarray(origin, np.float64)
        xyz = (self.xyz.astype(np.float64) + (self.origin - origin)).astype(self.xyz.dtype)
        return replace(self, xyz=xyz, origin=origin)

    @staticmethod
    def concatenate(clouds: list["PointCloud"]) -> "PointCloud":
        if not clouds:
            raise ValueError("PointCloud.concatenate: no clouds")
        origin = clouds[0].origin
        clouds = [c if np.array_equal(c.origin, origin) else c.with_origin(origin) for c in clouds]
        kw = {}
        for f in fields(PointCloud):
            if f.name == "origin":
                continue
            parts = [getattr(c, f.name) for c in clouds]
            kw[f.name] = None if any(p is None for p in parts) else np.concatenate(parts)
        return PointCloud(origin=origin, **kw)
