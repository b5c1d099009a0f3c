"""Headless rendering: GL contexts, the moderngl renderer, capture over many poses."""
from .capture import capture, render
from .context import BACKENDS, GLContext, create_context
from .renderer import Renderer

__all__ = ["BACKENDS", "GLContext", "Renderer", "capture", "create_context", "render"]
