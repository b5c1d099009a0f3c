"""Surfaceless EGL: Mesa llvmpipe on a CPU machine, NVIDIA's EGL on a GPU one (the default).

A process forked after it started EGL cannot render through EGL: the driver's threads
(Mesa's rasteriser, NVIDIA's) stay in the parent, and the child's first read-back waits for
them forever. :data:`started_in` records the process that started it, so a child refuses.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from contextlib import AbstractContextManager
from typing import ClassVar

import moderngl

from .base import Platform

started_in: int | None = None  # the process that started EGL (its driver threads live there)


class EGLPlatform(Platform):
    """moderngl's standalone EGL context; made current around every call, so other GL users
    of the process (pyrender, a second renderer) cannot leave theirs current under it."""

    name: ClassVar[str] = "egl"

    def __init__(self) -> None:
        self._lib: ctypes.CDLL | None = None

    def unusable(self) -> str | None:
        if started_in not in (None, os.getpid()):
            return (
                f"EGL was started in process {started_in}, which forked this one ({os.getpid()}): "
                "its driver threads are not here"
            )
        return None

    def start(self, device_index: int) -> moderngl.Context:
        global started_in
        ctx = moderngl.create_context(
            standalone=True, backend="egl", require=330, device_index=device_index
        )
        started_in = os.getpid()
        lib = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
        lib.eglGetProcAddress.restype = ctypes.c_void_p
        lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        self._lib = lib
        return ctx

    def proc_address(self, name: bytes) -> int:
        return self._lib.eglGetProcAddress(name) or 0 if self._lib is not None else 0

    def current(self, ctx: moderngl.Context) -> AbstractContextManager:
        return ctx

    def release(self) -> None:
        self._lib = None
