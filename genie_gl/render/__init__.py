"""Headless rendering of pinhole views by one of two rasters, side by side.

:class:`Renderer` (:mod:`.renderer`) is the entry: ``Renderer(scene, raster=...)`` makes the
renderer of the exact CPU raster (:mod:`.cpu`) or of OpenGL (:mod:`.gl`), both standing on
the shared modules here: the scene's clusters (:mod:`.clusters`), culling (:mod:`.cull`,
:mod:`.occlusion`), the instances a frame draws (:mod:`.visibility`, :mod:`.lod`), the
per-pixel winner a raster hands over (:mod:`.fragments`) and its shading (:mod:`.shading`).
The renderer knows no lens and no sensor effect: :mod:`genie_gl.capture` composes it with
the lens, the plan, the accuracy settings and the effects.
"""

from .cpu import CPURenderer
from .gl import GLRenderer
from .gl.context import (
    BACKENDS,
    GLContext,
    create_context,
    release_shared_contexts,
    shared_context,
)
from .lod import LevelOfDetail
from .renderer import Renderer
from .threads import limit_threads

__all__ = [
    "BACKENDS",
    "CPURenderer",
    "GLContext",
    "GLRenderer",
    "LevelOfDetail",
    "Renderer",
    "create_context",
    "limit_threads",
    "release_shared_contexts",
    "shared_context",
]
