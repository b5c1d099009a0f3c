"""Headless rendering: GL contexts, the moderngl renderer, capture over many poses.

``genie_gl.render`` is both this package and the one-shot function of the public API
(``gg.render(scene, sensor, pose)``, DESIGN.md): Python binds a package's submodules as
attributes of the parent, so the package itself is made callable and forwards to
:func:`genie_gl.render.batch.render`.
"""
import sys
import types

from .batch import capture, limit_threads, render, silhouettes
from .context import BACKENDS, GLContext, create_context, release_shared_contexts, shared_context
from .lod import LevelOfDetail
from .renderer import Renderer

__all__ = ["BACKENDS", "GLContext", "LevelOfDetail", "Renderer", "capture", "create_context", "limit_threads", "release_shared_contexts",
           "render", "shared_context", "silhouettes"]


class _CallableModule(types.ModuleType):
    def __call__(self, *args, **kwargs):  # gg.render(scene, sensor, pose, ...)
        return render(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
