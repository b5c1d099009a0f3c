"""The OpenGL raster: moderngl on the machine's OpenGL driver, headless.

- :mod:`.renderer`: :class:`GLRenderer`, a frame's flow (what ``Renderer(scene,
  raster="gl")`` makes), and the depth test where a pixel's winner is decided
  (:meth:`GLRenderer._issue`);
- :mod:`.objects`: its buffers, programs, vertex arrays and render targets;
- :mod:`.readout`: a frame's read-back, and :mod:`.readback`: the packed target's decoding;
- :mod:`.shader`: the shader programs; :mod:`.context` and :mod:`.platforms`: GL contexts on
  EGL or OSMesa.
"""

from .renderer import GLRenderer

__all__ = ["GLRenderer"]
