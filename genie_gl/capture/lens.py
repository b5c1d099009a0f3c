"""Rendering through a lens, composed around the renderer's pinhole views.

The renderer renders pinhole views and knows no lens; a distorted sensor's image is made
from its pinhole views by :func:`genie_gl.lens.distortion.render_through_lens` (exact
resampling by default). :func:`through_lens` turns a pinhole render function into one that
takes any sensor; :func:`silhouettes` renders objects alone through the lens.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..frame import Frame
from ..render.renderer import Renderer
from ..sensors.camera import Sensor
from ..lens.distortion import draws_lenses, render_through_lens

RenderFn = Callable[..., Frame]


def through_lens(render: RenderFn) -> RenderFn:
    """``render`` (``(sensor, pose, *, depth_only, normals, only) -> Frame`` of a pinhole
    view, e.g. :meth:`Renderer.render`) made to render any sensor, a distorted one through
    its lens (its pinhole views resampled, exact by default); a pinhole sensor is rendered
    by ``render`` itself."""

    def lens_render(sensor: Sensor, pose: np.ndarray, **kw) -> Frame:
        return render_through_lens(render, sensor, pose, **kw)

    lens_render.draws_lenses = draws_lenses(render)  # type: ignore[attr-defined]
    return lens_render


def silhouettes(
    renderer: Renderer, sensor: Sensor, pose: np.ndarray, ids: Sequence[int]
) -> dict[int, np.ndarray]:
    """Full (unoccluded) silhouette of each instance in ``ids`` as ``sensor`` sees it at
    ``pose``: one render of the instance alone, through the lens for a distorted sensor.
    Returns {id: (H, W) bool}."""
    render = through_lens(renderer.render)
    out = {}
    for i in ids:
        f = render(sensor, pose, depth_only=True, only=(int(i),))
        out[int(i)] = f.instance == int(i)
    return out
