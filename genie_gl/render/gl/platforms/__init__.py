"""Headless GL platforms, one module each behind :class:`.base.Platform`; :data:`PLATFORMS`
lists them in the order ``backend=None`` tries them."""

from __future__ import annotations

from .base import Platform
from .egl import EGLPlatform
from .osmesa import OSMesaPlatform

PLATFORMS: dict[str, type[Platform]] = {p.name: p for p in (EGLPlatform, OSMesaPlatform)}

__all__ = ["PLATFORMS", "EGLPlatform", "OSMesaPlatform", "Platform"]
