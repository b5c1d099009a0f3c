"""Headless rendering: GL contexts and the moderngl renderer of pinhole views.

The renderer knows no lens and no sensor effect: :mod:`genie_gl.capture` composes it with
the lens, the plan, the accuracy settings and the effects.
"""

from .context import BACKENDS, GLContext, create_context, release_shared_contexts, shared_context
from .lod import LevelOfDetail
from .renderer import Renderer
from .threads import limit_threads

__all__ = [
    "BACKENDS",
    "GLContext",
    "LevelOfDetail",
    "Renderer",
    "create_context",
    "limit_threads",
    "release_shared_contexts",
    "shared_context",
]
