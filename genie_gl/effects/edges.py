"""Effects at depth discontinuities: flying (mixed) pixels and ToF edge dropout.

* ``flying_pixels`` — a pixel whose footprint straddles a depth edge integrates light from
  both surfaces, and ToF and stereo sensors report a depth between the two: points float in
  the gap between an object and what lies behind it.
* ``edge_dropout`` — the Azure Kinect depth engine invalidates such pixels instead: a pixel
  is dropped when the valid depths of its 3x3 neighbourhood span more than ``span_m``
  (0.8 m by default; the figure used for the Azure Kinect here, a parameter to tune).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import cv2
import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from . import kernels
from .base import Effect, drop, record


def has_step(depth: np.ndarray, jump_m: float) -> bool:
    """True when two valid 4-neighbours differ in depth by more than ``jump_m``."""
    return bool(kernels.has_step(depth, float(jump_m)))


def largest_step(depth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every pixel, the 4-neighbour (both valid) with the largest |depth difference|.

    Returns (step (H, W) float64, that neighbour's depth minus the pixel's; 0 where none;
    other (H, W) float64, that neighbour's depth).
    """
    z = depth.astype(np.float64)
    valid = z > 0
    step = np.zeros_like(z)
    other = np.zeros_like(z)
    zp = np.pad(z, 1)
    vp = np.pad(valid, 1)
    H, W = z.shape
    for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        zn = zp[1 + dy : 1 + dy + H, 1 + dx : 1 + dx + W]
        ok = valid & vp[1 + dy : 1 + dy + H, 1 + dx : 1 + dx + W]
        d = np.where(ok, zn - z, 0.0)
        larger = np.abs(d) > np.abs(step)
        step = np.where(larger, d, step)
        other = np.where(larger, zn, other)
    return step, other


@dataclass
class FlyingPixels(Effect):
    """Pixels on a depth edge report, with probability ``probability``, a blend
    z + α·(z_other − z), α ~ U(0, 1), of their depth and their neighbour's across the edge.

    A pixel is on an edge when a valid 4-neighbour differs from it by more than ``jump_m``
    (the neighbour with the largest difference is the other side); both sides of an edge are
    candidates, each drawn independently. Ids stay those of the pixel (the label of the
    surface the pixel mostly saw), so the floating points carry realistic label noise.
    """

    name: ClassVar[str] = "flying_pixels"
    draws: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 60.0
    probability: float = 0.5
    jump_m: float = 0.05

    def __post_init__(self) -> None:
        if not 0 <= self.probability <= 1:
            raise ConfigError(f"flying_pixels.probability: expected 0..1, got {self.probability}")
        if not self.jump_m > 0:
            raise ConfigError(f"flying_pixels.jump_m: expected > 0, got {self.jump_m}")

    def check(self, frame: Frame, **needs: Any) -> str | None:
        # no edge: the draws below have size 0 and the depth is unchanged
        return None if has_step(frame.depth, self.jump_m) else f"no depth step over {self.jump_m} m"

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        # the edge pixels alone (one compiled pass), in the order largest_step() gives them
        edge, nb = kernels.edge_pixels(frame.depth, float(self.jump_m))
        pick = rng.random(edge.size) < self.probability
        alpha = rng.random(edge.size)
        z = frame.depth.astype(np.float64).ravel()
        idx = edge[pick]
        z[idx] += alpha[pick] * (z[nb[pick]] - z[idx])
        out = frame.replace(depth=z.reshape(frame.depth.shape).astype(np.float32))
        return record(out, self.name, edge_pixels=int(edge.size), mixed=int(idx.size))


@dataclass
class EdgeDropout(Effect):
    """No return where the valid depths of the 3x3 neighbourhood span more than ``span_m``."""

    name: ClassVar[str] = "edge_dropout"
    cost_ms_per_mpx: ClassVar[float] = 25.0
    span_m: float = 0.8

    def __post_init__(self) -> None:
        if not self.span_m > 0:
            raise ConfigError(f"edge_dropout.span_m: expected > 0, got {self.span_m}")

    def check(self, frame: Frame, **needs: Any) -> str | None:
        lo, hi = kernels.valid_span(frame.depth)
        if hi == 0:
            return "no return in the frame"
        if hi - lo <= self.span_m:
            return f"no 3x3 neighbourhood spans over {self.span_m} m"
        return None

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        z = frame.depth
        valid = z > 0
        kernel = np.ones((3, 3), np.uint8)
        hi = cv2.dilate(z, kernel, borderType=cv2.BORDER_REPLICATE)  # 0 = no return
        lo = cv2.erode(
            np.where(valid, z, np.float32(np.inf)), kernel, borderType=cv2.BORDER_REPLICATE
        )
        gone = valid & (hi.astype(np.float64) - lo > self.span_m)
        out = drop(frame, gone) if gone.any() else frame
        return record(out, self.name, dropped=int(gone.sum()))
