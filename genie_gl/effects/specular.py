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
from . import kernels
from .base import Decision, Effect, View, drop, drop_compiled, record
from .geometry import pixel_rays_xy

TRANSPARENT = ("drop", "behind")


@dataclass
class SpecularLoss(Effect):
    """No return on shiny surfaces at mirror angles or without a diffuse part; clear surfaces
    return nothing or what lies behind them."""

    name: ClassVar[str] = "specular_loss"
    needs_materials: ClassVar[bool] = True
    needs_render: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 4.0  # one pass, ~1.5 ms at 848 x 480 (bench planning)
    glare_deg: float = 8.0
    metal_min_roughness: float = 0.25
    transparent: str = "drop"

    def __post_init__(self) -> None:
        if self.transparent not in TRANSPARENT:
            raise ConfigError(
                f"specular_loss.transparent: expected drop or behind, got {self.transparent!r}"
            )
        if not 0 <= self.glare_deg < 90:
            raise ConfigError(
                f"specular_loss.glare_deg: expected 0 <= angle < 90, got {self.glare_deg}"
            )

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if not view.reflective.any() and not view.transparent.any():
            return Decision(False, "no shiny or clear surface in view")
        return None

    def _codes(self, materials: Any) -> np.ndarray:
        """Per instance id a code (bit 0 shiny, bit 1 shiny metal without a diffuse part, bit
        2 clear; uint8, ids beyond the table read its last entry); kept per material table."""
        memo = self.__dict__.get("_memo")
        if memo is not None and memo[0] is materials:
            return memo[1]
        m = materials
        code = (
            ((m.metallic >= 0.5) | (m.roughness <= 0.3)).astype(np.uint8)
            | (((m.metallic >= 0.5) & (m.roughness < self.metal_min_roughness)) << 1).astype(
                np.uint8
            )
            | ((m.opacity < 0.5) << 2).astype(np.uint8)
        )
        by_id = m.per_pixel(
            code, np.arange(int(m.ids[-1]) + 2 if len(m.ids) else 1, dtype=np.uint32)
        )
        by_id = np.ascontiguousarray(by_id, np.uint8)
        self.__dict__["_memo"] = (materials, by_id)
        return by_id

    def _kinds(self, frame: Frame, materials: Any) -> tuple[np.ndarray, int]:
        """Per pixel the code of :meth:`_codes` ((H, W) uint8, 0 where no return) and how
        many pixels have one."""
        return kernels.pixel_codes(frame.depth, frame.instance, self._codes(materials))

    def check(self, frame: Frame, *, materials: Any = None, **needs: Any) -> str | None:
        if materials is None or not (frame.depth > 0).any():
            return "no return in the frame" if materials is not None else None
        if not kernels.any_code(frame.depth, frame.instance, self._codes(materials)):
            return "no shiny or clear surface visible"
        return None

    def apply(
        self,
        frame: Frame,
        *,
        rng: np.random.Generator,
        materials: Any = None,
        render_frame: Any = None,
        **needs: Any,
    ) -> Frame:
        if materials is None:
            raise ConfigError(
                "specular_loss needs the scene's materials: run it through simulate()/capture()"
            )
        # one pass: each pixel's code from its instance, incidence only on the shiny ones;
        # clear ones dropped too unless the pair sees what lies behind them
        normal = frame.normal if frame.normal is not None else np.zeros((0, 0, 3), np.float32)
        behind_glass = self.transparent == "behind" and render_frame is not None
        lost, n_lost, n_clear = kernels.specular_lost(
            frame.depth,
            frame.instance,
            self._codes(materials),
            *pixel_rays_xy(frame.sensor),
            normal,
            float(np.cos(np.radians(self.glare_deg))),
            not behind_glass,
        )
        if not (behind_glass and n_clear):
            out = drop_compiled(frame, lost) if n_lost else frame
            return record(out, self.name, dropped=int(n_lost), behind=0, changed=int(n_lost))
        kind, _ = self._kinds(frame, materials)
        clear = (kind & 4).astype(bool)
        glass = np.unique(frame.instance[clear])
        seen = render_frame(frame.sensor, frame.world_from_camera, exclude=glass)
        take = clear & ~lost
        d, i, s = frame.depth.copy(), frame.instance.copy(), frame.semantic.copy()
        d[take], i[take], s[take] = seen.depth[take], seen.instance[take], seen.semantic[take]
        out = frame.replace(depth=d, instance=i, semantic=s)
        behind = int(take.sum())
        out = drop(out, lost) if lost.any() else out
        return record(out, self.name, dropped=int(lost.sum()), behind=behind)
