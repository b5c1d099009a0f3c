"""The capture modes of a dataset, one module each, registered in :mod:`.base` (the plugins
register when :mod:`genie_gl.dataset` is imported; see :mod:`.base` for what a mode owns)."""

from __future__ import annotations

from .base import CAPTURE_MODES, Captured, CaptureMode, Estimate, get_mode, register_mode

__all__ = ["CAPTURE_MODES", "CaptureMode", "Captured", "Estimate", "get_mode", "register_mode"]
