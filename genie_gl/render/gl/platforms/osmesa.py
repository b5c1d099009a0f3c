"""Mesa's off-screen renderer (Debian's libosmesa6), loaded with ctypes and adopted by
moderngl: the fallback where EGL cannot start, several times slower than llvmpipe through
EGL. It needs no PyOpenGL platform switch, so it works in a process that already imported
PyOpenGL for EGL, and in a child forked after its parent started EGL."""

from __future__ import annotations

import ctypes
import ctypes.util
from typing import Any, ClassVar

import glcontext
import moderngl

from ....errors import BackendUnavailableError
from .base import Platform


class _Loader:
    """What moderngl asks of a glcontext backend, for an OSMesa context made current here."""

    def __init__(self, lib: ctypes.CDLL, handle: int) -> None:
        self.lib, self.handle = lib, handle

    def load_opengl_function(self, name: str) -> int:
        return self.lib.OSMesaGetProcAddress(name.encode()) or 0

    load = load_opengl_function

    def __enter__(self) -> "_Loader":
        return self

    def __exit__(self, *exc: Any) -> None:
        return None

    def release(self) -> None:
        if self.handle:
            self.lib.OSMesaDestroyContext(self.handle)
            self.handle = 0


class OSMesaPlatform(Platform):
    """An OSMesa core 3.3 context, current in the thread that made it."""

    name: ClassVar[str] = "osmesa"

    def __init__(self) -> None:
        self._lib: ctypes.CDLL | None = None
        self._keep: list[Any] = []

    def start(self, device_index: int) -> moderngl.Context:
        path = ctypes.util.find_library("OSMesa") or "libOSMesa.so.8"
        lib = ctypes.CDLL(path)
        lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
        lib.OSMesaMakeCurrent.argtypes = [
            ctypes.c_void_p,
            ctypes.c_void_p,
            ctypes.c_uint,
            ctypes.c_int,
            ctypes.c_int,
        ]
        lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
        # OSMESA_FORMAT=RGBA, DEPTH_BITS=24, PROFILE=CORE, CONTEXT_MAJOR/MINOR_VERSION=3.3
        # (osmesa.h)
        attribs = (ctypes.c_int * 11)(0x22, 0x1908, 0x30, 24, 0x33, 0x34, 0x36, 3, 0x37, 3, 0)
        handle = lib.OSMesaCreateContextAttribs(attribs, None)
        if not handle:
            raise BackendUnavailableError(
                f"{path}: OSMesaCreateContextAttribs (core 3.3) returned NULL"
            )
        buf = (ctypes.c_ubyte * 4)()  # OSMesa needs a colour buffer; we render into our own FBOs
        if not lib.OSMesaMakeCurrent(handle, buf, 0x1401, 1, 1):
            lib.OSMesaDestroyContext(handle)
            raise BackendUnavailableError(f"{path}: OSMesaMakeCurrent failed")
        loader = _Loader(lib, handle)
        # moderngl adopts the current context through glcontext's default backend: point it at
        # OSMesa for the duration of this call only.
        saved = glcontext.default_backend
        glcontext.default_backend = lambda: (lambda *a, **k: loader)
        try:
            ctx = moderngl.create_context(require=330, libgl=path)
        finally:
            glcontext.default_backend = saved
        self._lib, self._keep = lib, [buf, loader]
        return ctx

    def proc_address(self, name: bytes) -> int:
        return self._lib.OSMesaGetProcAddress(name) or 0 if self._lib is not None else 0

    def release(self) -> None:
        self._keep.clear()
        self._lib = None
