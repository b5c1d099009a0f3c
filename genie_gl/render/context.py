"""OpenGL contexts: the only module that creates them.

``create_context(backend)`` returns a :class:`GLContext` holding a moderngl context on

* ``"egl"`` — surfaceless EGL (Mesa llvmpipe on a CPU box, NVIDIA's EGL on a GPU box), the
  default; or
* ``"osmesa"`` — Mesa's off-screen renderer (Debian's libosmesa6), loaded with ctypes and
  adopted by moderngl; a fallback several times slower than llvmpipe through EGL.

``backend=None`` tries EGL, then OSMesa. The environment variable ``GENIE_GL_BACKEND`` is read
by the CLI, never here. When nothing starts, :class:`BackendUnavailableError` says what was
tried and which Debian packages fix it.

A process forked after it started EGL cannot render through EGL: the driver's threads (Mesa's
rasterizer, NVIDIA's) stay in the parent, and the child's first read-back waits for them
forever. In such a child ``backend=None`` goes straight to OSMesa (a separate driver instance,
started in the child) and ``"egl"`` raises; :func:`shared_context` never hands a child its
parent's contexts. The package's own worker pools spawn, so this concerns callers that fork.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
from dataclasses import dataclass, field
from typing import Any, Callable

import glcontext
import moderngl

from ..errors import BackendUnavailableError, ConfigError

log = logging.getLogger(__name__)

BACKENDS = ("egl", "osmesa")
APT_HINT = "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"

_default_backend: str | None = None  # set once by the CLI from GENIE_GL_BACKEND
_egl_pid: int | None = None          # the process that started EGL (its driver threads live there)

GL_LOWER_LEFT = 0x8CA1
GL_ZERO_TO_ONE = 0x935F
GL_SUBPIXEL_BITS = 0x0D50


@dataclass(eq=False)
class GLContext:
    """A moderngl context plus what genie-gl needs beside it.

    Attributes
    ----------
    ctx : moderngl.Context
    backend : str, "egl" or "osmesa".
    renderer : str, the GL_RENDERER string (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
    """

    ctx: moderngl.Context
    backend: str
    renderer: str
    _get_proc: Callable[[bytes], int] = field(repr=False)
    _keepalive: list[Any] = field(default_factory=list, repr=False)
    programs: dict = field(default_factory=dict, repr=False)  # built shaders, shared by renderers
    _subpixel_bits: int | None = field(default=None, repr=False)

    def gl_function(self, name: str, restype: Any, *argtypes: Any) -> Callable[..., Any]:
        """A ctypes binding of a GL entry point moderngl does not expose (e.g. glClipControl)."""
        address = self._get_proc(name.encode())
        if not address:
            raise BackendUnavailableError(f"{self.backend}: GL function {name} is not available")
        return ctypes.CFUNCTYPE(restype, *argtypes)(address)

    @property
    def max_side(self) -> int:
        """The largest frame side (px) this context can render: the least of its texture,
        renderbuffer and viewport limits."""
        info = self.ctx.info
        dims = info.get("GL_MAX_VIEWPORT_DIMS") or (0, 0)
        sides = [info.get("GL_MAX_TEXTURE_SIZE"), info.get("GL_MAX_RENDERBUFFER_SIZE"), *dims]
        return int(min(s for s in sides if s)) if any(sides) else 16384

    def subpixel_bits(self) -> int:
        """GL_SUBPIXEL_BITS: the rasteriser snaps vertices to 1 / 2^bits of a pixel (call with
        the context current; asked once). GL guarantees at least 4."""
        if self._subpixel_bits is None:
            value = ctypes.c_int(0)
            self.gl_function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))(
                GL_SUBPIXEL_BITS, ctypes.byref(value))
            self._subpixel_bits = max(4, value.value)
        return self._subpixel_bits

    def release(self) -> None:
        """Free the context and everything created in it."""
        self.programs.clear()
        self.ctx.release()
        self._keepalive.clear()


def set_default_backend(backend: str | None) -> None:
    """The backend ``create_context(None)`` uses in this process (the CLI passes
    ``GENIE_GL_BACKEND`` here; worker processes inherit the variable and do the same)."""
    global _default_backend
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(f"GENIE_GL_BACKEND={backend!r} is unknown; expected one of {', '.join(BACKENDS)}")
    _default_backend = backend or None


def create_context(backend: str | None = None, *, device_index: int = 0) -> GLContext:
    """Create a headless OpenGL (>= 3.3 core) context.

    Parameters
    ----------
    backend : "egl", "osmesa" or None (try EGL, then OSMesa).
    device_index : int, the EGL device (GPU) to use on multi-GPU machines.
    """
    backend = backend or _default_backend
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(f"GL backend {backend!r} is unknown; expected one of {', '.join(BACKENDS)}")
    tried: list[str] = []
    for name in [backend] if backend else list(BACKENDS):
        try:
            gl = _EGL(device_index) if name == "egl" else _osmesa()
            log.debug("GL context on %s: %s", name, gl.renderer)
            return gl
        except Exception as exc:  # each backend fails in its own way; report them all
            tried.append(f"{name}: {type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else ''}")
    raise BackendUnavailableError(
        "no OpenGL backend could start (tried " + "; ".join(tried) + "). "
        f"On Debian/Ubuntu install the Mesa libraries: `{APT_HINT}`; on an NVIDIA machine "
        "install the driver's EGL library (libnvidia-egl / libEGL_nvidia)."
    )


_SHARED: dict[str | None, GLContext] = {}
_shared_pid = os.getpid()


def _forget_parents_contexts() -> None:
    """In a forked child, drop (never release: they are the parent's) the inherited contexts."""
    global _shared_pid
    if _shared_pid != os.getpid():
        _SHARED.clear()
        _shared_pid = os.getpid()


def shared_context(backend: str | None = None) -> GLContext:
    """This process's long-lived context for ``backend``, created on first use: renderers of
    successive scenes (``genie dataset``) share it, so the context is made and each shader
    built and compiled by the driver once per process, not once per scene. Released by
    :func:`release_shared_contexts` (or when the process ends). A forked child gets its own."""
    _forget_parents_contexts()
    backend = backend or _default_backend
    gl = _SHARED.get(backend)
    if gl is None:
        gl = _SHARED[backend] = create_context(backend)
    return gl


def release_shared_contexts() -> None:
    """Release the contexts :func:`shared_context` made in this process."""
    _forget_parents_contexts()
    while _SHARED:
        _SHARED.popitem()[1].release()


def _EGL(device_index: int) -> GLContext:
    global _egl_pid
    if _egl_pid not in (None, os.getpid()):
        raise BackendUnavailableError(f"EGL was started in process {_egl_pid}, which forked this one "
                                      f"({os.getpid()}): its driver threads are not here")
    ctx = moderngl.create_context(standalone=True, backend="egl", require=330, device_index=device_index)
    _egl_pid = os.getpid()
    lib = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return GLContext(ctx, "egl", ctx.info["GL_RENDERER"], lib.eglGetProcAddress, [lib])


class _OSMesaLoader:
    """What moderngl asks of a glcontext backend, for an OSMesa context made current here."""

    def __init__(self, lib: ctypes.CDLL, handle: int) -> None:
        self.lib, self.handle = lib, handle

    def load_opengl_function(self, name: str) -> int:
        return self.lib.OSMesaGetProcAddress(name.encode()) or 0

    load = load_opengl_function

    def __enter__(self) -> "_OSMesaLoader":
        return self

    def __exit__(self, *exc: Any) -> None:
        return None

    def release(self) -> None:
        if self.handle:
            self.lib.OSMesaDestroyContext(self.handle)
            self.handle = 0


def _osmesa() -> GLContext:
    # Mesa's OSMesa through ctypes (no PyOpenGL platform switch needed, so it works in a
    # process that already imported PyOpenGL for EGL).
    path = ctypes.util.find_library("OSMesa") or "libOSMesa.so.8"
    lib = ctypes.CDLL(path)
    lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
    lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
    lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
    lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int]
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
    # OSMESA_FORMAT=RGBA, DEPTH_BITS=24, PROFILE=CORE, CONTEXT_MAJOR/MINOR_VERSION=3.3 (osmesa.h)
    attribs = (ctypes.c_int * 11)(0x22, 0x1908, 0x30, 24, 0x33, 0x34, 0x36, 3, 0x37, 3, 0)
    handle = lib.OSMesaCreateContextAttribs(attribs, None)
    if not handle:
        raise BackendUnavailableError(f"{path}: OSMesaCreateContextAttribs (core 3.3) returned NULL")
    buf = (ctypes.c_ubyte * 4)()  # OSMesa needs a colour buffer; we render into our own FBOs
    if not lib.OSMesaMakeCurrent(handle, buf, 0x1401, 1, 1):
        lib.OSMesaDestroyContext(handle)
        raise BackendUnavailableError(f"{path}: OSMesaMakeCurrent failed")
    loader = _OSMesaLoader(lib, handle)
    # moderngl adopts the current context through glcontext's default backend: point it at
    # OSMesa for the duration of this call only.
    saved = glcontext.default_backend
    glcontext.default_backend = lambda: (lambda *a, **k: loader)
    try:
        ctx = moderngl.create_context(require=330, libgl=path)
    finally:
        glcontext.default_backend = saved
    return GLContext(ctx, "osmesa", ctx.info["GL_RENDERER"], lib.OSMesaGetProcAddress, [lib, buf, loader])
