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
from .geometry import incidence_angle

TRANSPARENT = ("drop", "behind")


@dataclass
class SpecularLoss(Effect):
    """No return on shiny surfaces at mirror angles or without a diffuse part; clear surfaces
    return nothing or what lies behind them."""

    name: ClassVar[str] = "specular_loss"
    needs_normals: ClassVar[bool] = True
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

    def check(self, frame: Frame, *, materials: Any = None, **needs: Any) -> str | None:
        if materials is None or not (frame.depth > 0).any():
            return "no return in the frame" if materials is not None else None
        ids = np.unique(frame.instance)
        rows = materials.rows(ids)
        if not (materials.reflective(ids) | (materials.opacity[rows] < 0.5)).any():
            return "no shiny or clear surface visible"
        return None

    def apply(self, frame: Frame, rng: np.random.Generator, *, materials: Any = None,
              render_frame: Any = None, **needs: Any) -> Frame:
        if materials is None:
            raise ConfigError("specular_loss needs the scene's materials: run it through simulate()/capture()")
        rows = materials.rows(frame.instance)
        valid = frame.depth > 0
        shiny = valid & ((materials.metallic[rows] >= 0.5) | (materials.roughness[rows] <= 0.3))
        clear = valid & (materials.opacity[rows] < 0.5)
        lost = np.zeros_like(valid)
        if shiny.any():
            theta = incidence_angle(frame)
            lost |= shiny & (theta < np.radians(self.glare_deg))
            lost |= shiny & (materials.metallic[rows] >= 0.5) & (materials.roughness[rows] < self.metal_min_roughness)
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
