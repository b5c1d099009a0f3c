"""Pictures of layouts: leaves coloured by region type, orientation ticks and a legend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from ..outputs import save_png
from .model import DIRECTION, Layout


def layout_image(layout: Layout, px_per_m: float | None = None, legend: bool = True) -> Image.Image:
    """An RGB picture of ``layout`` (y up, as on a floor plan)."""
    x0, y0, w, h = layout.bounds
    s = px_per_m or max(4.0, min(20.0, 900.0 / max(w, h)))
    W, H = int(np.ceil(w * s)) + 1, int(np.ceil(h * s)) + 1
    used = sorted({r.type for r in layout.leaves()})
    legend_w = (16 + 8 * max((len(t) for t in used), default=0) + 24) if legend else 0
    img = Image.new("RGB", (W + legend_w, max(H, 20 * len(used) + 10)), (255, 255, 255))
    d = ImageDraw.Draw(img)

    def box(r):
        return [(r.x - x0) * s, (y0 + h - r.y - r.h) * s, (r.x - x0 + r.w) * s, (y0 + h - r.y) * s]

    for reg, depth, _ in layout.regions():  # parents first: leaf colours composed over them
        t = layout.region_types[reg.type]
        d.rectangle(box(reg), fill=tuple(t.color), outline=(60, 60, 60) if depth else (0, 0, 0))
    for reg in layout.leaves():
        b = box(reg)
        cx, cy = (b[0] + b[2]) / 2, (b[1] + b[3]) / 2
        dx, dy = DIRECTION[reg.orientation]
        L = 0.3 * min(b[2] - b[0], b[3] - b[1])
        if L >= 3:
            d.line([cx, cy, cx + dx * L, cy - dy * L], fill=(30, 30, 30), width=1)
    if legend:
        for i, t in enumerate(used):
            y = 8 + 20 * i
            d.rectangle(
                [W + 8, y, W + 22, y + 14],
                fill=tuple(layout.region_types[t].color),
                outline=(0, 0, 0),
            )
            d.text((W + 28, y + 1), t, fill=(0, 0, 0))
    return img


def save_layout_png(layout: Layout, path: str | Path, **kw) -> Path:
    """Write the picture of ``layout`` to ``path`` (temporary file, then rename); an existing
    file is replaced only when it is a picture genie-gl wrote (:mod:`genie_gl.outputs`)."""
    return save_png(layout_image(layout, **kw), path)
