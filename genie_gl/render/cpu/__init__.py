"""The exact CPU raster: per ray (a pixel centre, or a distorted lens's own pixel ray), the
nearest triangle along it, in float64.

- :mod:`.renderer`: :class:`CPURenderer`, a frame's flow (what ``Renderer(scene,
  raster="cpu")`` makes), a lens's frame included;
- :mod:`.raster`: a frame's kernel (which clusters may show, nearest first, which thread
  draws which columns);
- :mod:`.bounds`: may a cluster show, the pixel box it may cover, its vertices on screen;
- :mod:`.coverage`: one cluster's triangles on the frame's rays, and the depth test with its
  tie rule (:func:`.coverage._wins`: where a ray's winner is decided);
- :mod:`.bins`: rays that are not pixel centres binned on a view's grid (a lens's).
"""

from .renderer import CPURenderer

__all__ = ["CPURenderer"]
