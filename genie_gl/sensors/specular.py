"""Active stereo and structured light on shiny and clear surfaces: returns lost where the
projected pattern does not come back.

A D400 or a Zivid matches a projected pattern; a Lambertian surface scatters it back to the
imager, a mirror-like one sends it away (bare metal, whose reflection is all specular, keeps
no pattern below ``metal_min_roughness``), and at near-mirror angles (incidence under
``glare_deg``) a reflective surface sends the projector's light straight into the imager and
saturates it. A clear surface (opacity < 0.5: safety glass, polycarbonate guards) shows no
pattern of its own: a structured-light camera gets nothing there (``transparent: drop``), an
active stereo pair matches what lies behind it (``transparent: behind``).

Figures are engineering ones [U: no datasheet gives them; vendors' application notes on
shiny and transparent objects describe the behaviour, not thresholds].
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from .effect import Decision, Effect, View, drop, record
from .geometry import pixel_rays, view_directions

TRANSPARENT = ("drop", "behind")


def _cos_incidence(frame: Frame, idx: np.ndarray) -> np.ndarray:
    """cos θ at flat pixel indices ``idx``: the rendered normal when the frame has one, else
    the normal of the depth image (central differences; 0 beside a hole or the border)."""
    d = view_directions(frame.sensor).reshape(-1, 3)[idx]
    if frame.normal is not None:
        n = frame.normal.reshape(-1, 3)[idx].astype(np.float64)
        return -(n * d).sum(1)
    H, W = frame.depth.shape
    v, u = np.divmod(idx, W)
    xy = pixel_rays(frame.sensor)
    z = frame.depth

    def point(vv, uu):
        zz = z[vv, uu].astype(np.float64)
        return np.stack([xy[vv, uu, 0] * zz, xy[vv, uu, 1] * zz, zz], 1), zz > 0

    ul, ur = np.maximum(u - 1, 0), np.minimum(u + 1, W - 1)
    vu, vd = np.maximum(v - 1, 0), np.minimum(v + 1, H - 1)
    (a, va), (b, vb), (c, vc), (e, ve) = point(v, ur), point(v, ul), point(vd, u), point(vu, u)
    n = np.cross(a - b, c - e)
    length = np.linalg.norm(n, axis=1)
    ok = va & vb & vc & ve & (ur > ul) & (vd > vu) & (length > 0)
    n = n / np.where(ok, length, 1.0)[:, None]
    return np.where(ok, np.abs((n * d).sum(1)), 0.0)


@dataclass
class SpecularLoss(Effect):
    """No return on shiny surfaces at mirror angles or without a diffuse part; clear surfaces
    return nothing or what lies behind them."""

    name: ClassVar[str] = "specular_loss"
    needs_materials: ClassVar[bool] = True
    needs_render: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 30.0
    glare_deg: float = 8.0
    metal_min_roughness: float = 0.25
    transparent: str = "drop"

    def __post_init__(self) -> None:
        if self.transparent not in TRANSPARENT:
            raise ConfigError(f"specular_loss.transparent: expected drop or behind, got {self.transparent!r}")
        if not 0 <= self.glare_deg < 90:
            raise ConfigError(f"specular_loss.glare_deg: expected 0 <= angle < 90, got {self.glare_deg}")

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if not view.reflective.any() and not view.transparent.any():
            return Decision(False, "no shiny or clear surface in view")
        return None

    def _kinds(self, frame: Frame, materials: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per pixel: shiny, shiny metal without a diffuse part, clear (bool, (H, W)); the last
        frame's are kept, so check() and apply() of one frame look them up once."""
        memo = self.__dict__.get("_memo")
        if memo is not None and memo[0] is frame.instance and memo[1] is frame.depth and memo[2] is materials:
            return memo[3]
        kinds = self._lookup(frame, materials)
        self.__dict__["_memo"] = (frame.instance, frame.depth, materials, kinds)
        return kinds

    def _lookup(self, frame: Frame, materials: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m = materials
        code = (((m.metallic >= 0.5) | (m.roughness <= 0.3)).astype(np.uint8)
                | (((m.metallic >= 0.5) & (m.roughness < self.metal_min_roughness)) << 1).astype(np.uint8)
                | ((m.opacity < 0.5) << 2).astype(np.uint8))
        kind = m.per_pixel(code, frame.instance)   # id 0 (no return) reads the default: 0
        kind = np.where(frame.depth > 0, kind, np.uint8(0))
        return (kind & 1).astype(bool), (kind & 2).astype(bool), (kind & 4).astype(bool)

    def check(self, frame: Frame, *, materials: Any = None, **needs: Any) -> str | None:
        if materials is None or not (frame.depth > 0).any():
            return "no return in the frame" if materials is not None else None
        shiny, _, clear = self._kinds(frame, materials)
        if not (shiny.any() or clear.any()):
            self.__dict__.pop("_memo", None)
            return "no shiny or clear surface visible"
        return None

    def apply(self, frame: Frame, rng: np.random.Generator, *, materials: Any = None,
              render_frame: Any = None, **needs: Any) -> Frame:
        if materials is None:
            raise ConfigError("specular_loss needs the scene's materials: run it through simulate()/capture()")
        shiny, bare, clear = self._kinds(frame, materials)
        self.__dict__.pop("_memo", None)   # the frame's buffers are not kept past its run
        lost = bare.copy()
        idx = np.flatnonzero(shiny & ~bare)
        if idx.size:   # incidence only where it matters: the shiny pixels
            cos = _cos_incidence(frame, idx)
            lost.ravel()[idx[cos > np.cos(np.radians(self.glare_deg))]] = True
        behind = 0
        out = frame
        if clear.any() and self.transparent == "behind" and render_frame is not None:
            glass = np.unique(frame.instance[clear])
            seen = render_frame(frame.sensor, frame.world_from_camera, exclude=glass)
            take = clear & ~lost
            d, i, s = frame.depth.copy(), frame.instance.copy(), frame.semantic.copy()
            d[take], i[take], s[take] = seen.depth[take], seen.instance[take], seen.semantic[take]
            out = frame.replace(depth=d, instance=i, semantic=s)
            behind = int(take.sum())
        else:
            lost |= clear
        out = drop(out, lost) if lost.any() else out
        return record(out, self.name, dropped=int(lost.sum()), behind=behind)
