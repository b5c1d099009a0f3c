"""The ``Frame``: what one camera sees at one pose. Renderers make them; effects map them."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .camera import Camera
from .triangles import PixelTriangles


@dataclass(frozen=True, eq=False)
class Frame:
    """The buffers of one camera at one pose.

    Attributes
    ----------
    depth : (H, W) float32, z along the optical axis in metres; 0 means no return.
    instance : (H, W) uint32, instance id, 0 = none.
    semantic : (H, W) uint16, class id (0 where nothing was hit, and for background).
    rgb : (H, W, 3) uint8 or None (None in depth-only mode).
    sensor : Camera, the camera that made the frame (a ``Sensor`` when it came from one).
    world_from_camera : (4, 4) float64, the pose (OpenCV camera frame).
    normal : (H, W, 3) float32 or None, unit normals in the camera frame (0 where no hit).
    meta : dict, free-form (timings, effect records).
    triangles : PixelTriangles or None, the triangle each pixel shows (a pinhole view rendered
        for a lens that intersects each of its pixels' own rays: :mod:`genie_gl.triangles`).
    Row 0 of every buffer is the top of the image (v = 0), column 0 its left (u = 0).
    """

    depth: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    rgb: np.ndarray | None
    sensor: Camera
    world_from_camera: np.ndarray
    normal: np.ndarray | None = None
    meta: dict[str, Any] | None = None
    triangles: PixelTriangles | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.sensor, Camera):
            raise ValueError(
                "Frame.sensor: expected a genie_gl Camera or Sensor, got "
                f"{type(self.sensor).__name__}"
            )
        H, W = self.sensor.height, self.sensor.width
        checks = [
            ("depth", self.depth, (H, W), np.float32),
            ("instance", self.instance, (H, W), np.uint32),
            ("semantic", self.semantic, (H, W), np.uint16),
        ]
        if self.rgb is not None:
            checks.append(("rgb", self.rgb, (H, W, 3), np.uint8))
        if self.normal is not None:
            checks.append(("normal", self.normal, (H, W, 3), np.float32))
        if self.triangles is not None:
            checks.append(("triangles.pixel", self.triangles.pixel, (H, W, 2), np.uint32))
        for name, arr, shape, dtype in checks:
            if arr.shape != shape or arr.dtype != dtype:
                raise ValueError(
                    f"Frame.{name}: expected {shape} {np.dtype(dtype).name}, got {arr.shape} "
                    f"{arr.dtype}"
                )
        pose = np.asarray(self.world_from_camera, dtype=np.float64)
        if pose.shape != (4, 4):
            raise ValueError(f"Frame.world_from_camera: expected (4, 4), got {pose.shape}")
        object.__setattr__(self, "world_from_camera", pose)

    @property
    def pose(self) -> np.ndarray:
        """Alias of ``world_from_camera``."""
        return self.world_from_camera

    @property
    def valid(self) -> np.ndarray:
        """(H, W) bool: pixels with a return (0 < depth < inf)."""
        return (self.depth > 0) & (self.depth < np.inf)

    def replace(self, **changes: Any) -> "Frame":
        """A copy with some fields replaced (effects use this)."""
        return replace(self, **changes)
