"""Effects that depend on the surface's orientation: lateral noise, incidence-angle dropout and
a simple multipath bias in concave corners. They read the normals ``simulate`` renders for
them (``needs_normals``); a frame without normals gets normals estimated from its depth.

* ``lateral_noise`` — Nguyen, Izadi & Lovell 2012 (3DIMPVT), lateral noise of the Kinect:
  σ_L(θ) = 0.8 + 0.035·θ/(π/2 − θ) pixels (θ the incidence angle), i.e. σ_L·z/f metres.
* ``incidence_dropout`` — no return beyond a maximum incidence angle (too little light comes
  back from grazing surfaces, and structured-light patterns smear there).
* ``multipath`` — off unless listed: ToF light that bounces off a second surface before
  returning lengthens the measured path, so concave corners read too far.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from .base import Decision, Effect, View, drop, record
from .geometry import camera_points, incidence_angle, surface_normals, view_directions


def nguyen_lateral_px(theta: np.ndarray) -> np.ndarray:
    """Nguyen et al. 2012 lateral σ in pixels at incidence ``theta`` (radians, < π/2)."""
    return 0.8 + 0.035 * theta / (np.pi / 2 - theta)


@dataclass
class LateralNoise(Effect):
    """Each pixel reports the depth of a point displaced across the image by N(0, σ_L²) in u
    and in v (a jittered sampling position; depth, ids and normal move together, colour does
    not).

    The depth at the displaced position is interpolated bilinearly when its four neighbours
    are one surface (all valid, one instance, depth span under ``continuity_rel``·z) and taken
    from the nearest pixel otherwise, so silhouettes jitter and never blend (blending is
    ``flying_pixels``' job). Pixels without a return move with σ_L(0) and may pick one up:
    edges jitter both ways.

    Parameters
    ----------
    model : "nguyen2012" (σ_L(θ) above, θ clamped to ``max_angle_deg``) or "constant".
    sigma_px : σ_L of the constant model, pixels.
    max_angle_deg : clamp of θ for the Nguyen model (it diverges at 90°).
    continuity_rel : relative depth span below which four neighbours count as one surface.
    """

    name: ClassVar[str] = "lateral_noise"
    draws: ClassVar[bool] = True
    needs_normals: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 250.0
    model: str = "nguyen2012"
    sigma_px: float = 0.8
    max_angle_deg: float = 80.0
    continuity_rel: float = 0.1

    def __post_init__(self) -> None:
        if self.model not in ("nguyen2012", "constant"):
            raise ConfigError(
                f"lateral_noise.model: unknown model {self.model!r}; "
                "expected nguyen2012 or constant"
            )
        if not 0 <= self.max_angle_deg < 90:
            raise ConfigError(
                f"lateral_noise.max_angle_deg: expected 0 <= angle < 90, got {self.max_angle_deg}"
            )

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if self.model == "constant" and self.sigma_px == 0:
            return Decision(False, "sigma_px = 0: no pixel moves")
        return Decision(True, "σ_L >= 0.8 px at every angle (Nguyen 2012): every pixel moves")

    def check(self, frame: Frame, **needs: Any) -> str | None:
        return None  # draws per pixel whatever the frame holds: decided in plan()

    def skip(self, frame: Frame, rng: np.random.Generator) -> None:
        H, W = frame.depth.shape
        rng.standard_normal((H, W))
        rng.standard_normal((H, W))

    def sigma(self, theta: np.ndarray) -> np.ndarray:
        """σ_L in pixels at incidence angles ``theta`` (radians)."""
        if self.model == "constant":
            return np.full(np.shape(theta), float(self.sigma_px))
        return nguyen_lateral_px(np.minimum(theta, np.radians(self.max_angle_deg)))

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        H, W = frame.depth.shape
        s = self.sigma(incidence_angle(frame))  # 0 rad (σ_L(0)) where no return
        su = np.arange(W, dtype=np.float64)[None, :] + rng.standard_normal((H, W)) * s
        sv = np.arange(H, dtype=np.float64)[:, None] + rng.standard_normal((H, W)) * s
        np.clip(su, 0, W - 1, out=su)
        np.clip(sv, 0, H - 1, out=sv)
        # flat indices: 1-D gathers are several times faster than 2-D fancy indexing
        near = np.rint(sv).astype(np.intp) * W + np.rint(su).astype(np.intp)
        z, ids = frame.depth.ravel(), frame.instance.ravel()
        depth = z[near].astype(np.float64)
        if W > 1 and H > 1:  # bilinear where the four neighbours are one surface
            u0 = np.minimum(su.astype(np.intp), W - 2)  # su >= 0: truncation is floor
            v0 = np.minimum(sv.astype(np.intp), H - 2)
            fu, fv = su - u0, sv - v0
            base = v0 * W + u0
            corners = (base, base + 1, base + W, base + W + 1)
            z00, z01, z10, z11 = (z[c] for c in corners)
            i00, i01, i10, i11 = (ids[c] for c in corners)
            lo = np.minimum(np.minimum(z00, z01), np.minimum(z10, z11)).astype(np.float64)
            hi = np.maximum(np.maximum(z00, z01), np.maximum(z10, z11))
            one = (
                (lo > 0)
                & (i00 == i01)
                & (i00 == i10)
                & (i00 == i11)
                & (hi - lo <= self.continuity_rel * lo)
            )
            bil = (
                z00 * (1 - fu) * (1 - fv)
                + z01 * fu * (1 - fv)
                + z10 * (1 - fu) * fv
                + z11 * fu * fv
            )
            depth = np.where(one, bil, depth)
        normal = (
            None if frame.normal is None else frame.normal.reshape(-1, 3)[near].reshape(H, W, 3)
        )
        return frame.replace(
            depth=depth.astype(np.float32),
            instance=ids[near].reshape(H, W),
            semantic=frame.semantic.ravel()[near].reshape(H, W),
            normal=normal,
        )


@dataclass
class IncidenceDropout(Effect):
    """No return where the incidence angle exceeds ``max_angle_deg``."""

    name: ClassVar[str] = "incidence_dropout"
    needs_normals: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 50.0
    max_angle_deg: float = 75.0

    def __post_init__(self) -> None:
        if not 0 < self.max_angle_deg <= 90:
            raise ConfigError(
                f"incidence_dropout.max_angle_deg: expected 0 < angle <= 90, "
                f"got {self.max_angle_deg}"
            )

    def check(self, frame: Frame, **needs: Any) -> str | None:
        if not (frame.depth > 0).any():
            return "no return in the frame"
        if frame.normal is not None:
            # cos θ = −n·d: steeper than the threshold only where |n·d| < cos(max)
            d = view_directions(frame.sensor)
            n = frame.normal
            cos = -(n[..., 0] * d[..., 0] + n[..., 1] * d[..., 1] + n[..., 2] * d[..., 2])
            if not (
                (frame.depth > 0) & (cos < np.cos(np.radians(self.max_angle_deg)) + 1e-6)
            ).any():
                return f"no surface beyond {self.max_angle_deg}° incidence"
        return None

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        steep = (frame.depth > 0) & (incidence_angle(frame) > np.radians(self.max_angle_deg))
        out = drop(frame, steep) if steep.any() else frame
        return record(out, self.name, dropped=int(steep.sum()))


# offsets of the multipath neighbourhood: 8 directions at the full and at half the radius
_DIRECTIONS = np.array([(np.cos(a), np.sin(a)) for a in np.arange(8) * np.pi / 4])


@dataclass
class Multipath(Effect):
    """A small positive range bias in concave corners (ToF multipath), deterministic.

    The model, simple on purpose: sample 16 neighbours of each pixel (8 directions at
    ``radius_px`` and at half of it); a neighbour "faces" the pixel when it lies in front of
    the pixel's tangent plane (on the side its normal points to) by more than
    ``min_offset_m`` — in a concave corner the other wall does, on a plane or a convex edge
    nothing does. The range grows by ``bias_m`` times the share of facing neighbours (so at
    most ``bias_m``, about half of it right in a corner, nothing beyond ``radius_px`` from
    one); the depth grows by the same factor along the ray. Real multipath depends on
    reflectances and on the whole scene; this captures its sign and where it appears.
    """

    name: ClassVar[str] = "multipath"
    needs_normals: ClassVar[bool] = True
    needs_convexity: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 300.0
    bias_m: float = 0.01
    systematic_error: ClassVar[bool] = True
    radius_px: int = 8
    min_offset_m: float = 0.01

    def __post_init__(self) -> None:
        if int(self.radius_px) < 1:
            raise ConfigError(f"multipath.radius_px: expected >= 1, got {self.radius_px}")

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if len(view.ids) == 1 and bool(view.convex[0]):
            return Decision(False, "one convex object in view: no concave corner")
        return Decision(
            True, f"{len(view.ids)} objects in view, or one not convex: concave corners possible"
        )

    def share(self, frame: Frame) -> np.ndarray:
        """(H, W) float64: share of the 16 neighbours that face each pixel (0 where no return)."""
        P = camera_points(frame)
        n = surface_normals(frame)
        valid = frame.depth > 0
        H, W = valid.shape
        r = int(self.radius_px)
        # component planes: (Q − P)·n = Q·n − P·n, three multiply-adds per neighbour
        Xp, Yp, Zp = (np.pad(P[..., k], r) for k in range(3))
        nx, ny, nz = (np.ascontiguousarray(n[..., k]) for k in range(3))
        pn = (P * n).sum(-1) + self.min_offset_m
        Vp = np.pad(valid, r)
        count = np.zeros((H, W))
        offsets = np.rint(np.concatenate([_DIRECTIONS * r, _DIRECTIONS * (r / 2)])).astype(int)
        for dx, dy in offsets:
            sl = (slice(r + dy, r + dy + H), slice(r + dx, r + dx + W))
            facing = Xp[sl] * nx + Yp[sl] * ny + Zp[sl] * nz > pn
            count += Vp[sl] & facing
        return np.where(valid, count / len(offsets), 0.0)

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        c = self.share(frame)
        z = frame.depth.astype(np.float64)
        rng_len = np.linalg.norm(camera_points(frame), axis=-1)
        grow = np.where(c > 0, 1.0 + self.bias_m * c / np.maximum(rng_len, 1e-9), 1.0)
        return frame.replace(depth=(z * grow).astype(np.float32))
