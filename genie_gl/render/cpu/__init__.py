"""The exact CPU raster: per pixel centre, the nearest triangle along its ray, in float64.

- :mod:`.renderer`: :class:`CPURenderer`, a frame's flow (what ``Renderer(scene,
  raster="cpu")`` makes);
- :mod:`.raster`: a frame's kernel (which clusters may show, nearest first, which thread
  draws which columns);
- :mod:`.coverage`: one cluster's triangles on the pixel centres, and the depth test with its
  tie rule (:func:`.coverage._write`: where a pixel's winner is decided).
"""

from .renderer import CPURenderer

__all__ = ["CPURenderer"]
