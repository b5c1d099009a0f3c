"""OpenGL contexts: the only module that creates them.

``create_context(backend)`` returns a :class:`GLContext` holding a moderngl context on

* ``"egl"`` — surfaceless EGL (Mesa llvmpipe on a CPU box, NVIDIA's EGL on a GPU box), the
  default; or
* ``"osmesa"`` — Mesa's off-screen renderer through PyOpenGL (>= 3.1.7; 3.1.0's OSMesa
  binding is broken), a fallback 8–12x slower than llvmpipe through EGL.

``backend=None`` tries EGL, then OSMesa. The environment variable ``GENIE_GL_BACKEND`` is read
by the CLI, never here. When nothing starts, :class:`BackendUnavailableError` says what was
tried and which Debian packages fix it.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import sys
from dataclasses import dataclass, field
from typing import Any, Callable

import moderngl

from ..errors import BackendUnavailableError, ConfigError

log = logging.getLogger(__name__)

BACKENDS = ("egl", "osmesa")
APT_HINT = "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"

GL_LOWER_LEFT = 0x8CA1
GL_ZERO_TO_ONE = 0x935F


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

    def gl_function(self, name: str, restype: Any, *argtypes: Any) -> Callable[..., Any]:
        """A ctypes binding of a GL entry point moderngl does not expose (e.g. glClipControl)."""
        address = self._get_proc(name.encode())
        if not address:
            raise BackendUnavailableError(f"{self.backend}: GL function {name} is not available")
        return ctypes.CFUNCTYPE(restype, *argtypes)(address)

    def release(self) -> None:
        """Free the context and everything created in it."""
        self.ctx.release()
        self._keepalive.clear()


def create_context(backend: str | None = None, *, device_index: int = 0) -> GLContext:
    """Create a headless OpenGL (>= 3.3 core) context.

    Parameters
    ----------
    backend : "egl", "osmesa" or None (try EGL, then OSMesa).
    device_index : int, the EGL device (GPU) to use on multi-GPU machines.
    """
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


def _EGL(device_index: int) -> GLContext:
    ctx = moderngl.create_context(standalone=True, backend="egl", require=330, device_index=device_index)
    lib = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    lib.eglGetProcAddress.restype = ctypes.c_void_p
    lib.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return GLContext(ctx, "egl", ctx.info["GL_RENDERER"], lib.eglGetProcAddress, [lib])


def _osmesa() -> GLContext:
    if "OpenGL" in sys.modules and os.environ.get("PYOPENGL_PLATFORM") != "osmesa":
        raise BackendUnavailableError(
            "PyOpenGL was already imported for another platform in this process; "
            "start a fresh process with GENIE_GL_BACKEND=osmesa"
        )
    # PyOpenGL picks its platform once, at import: this is the only way to ask for OSMesa.
    os.environ["PYOPENGL_PLATFORM"] = "osmesa"
    from OpenGL import GL, arrays, osmesa  # noqa: PLC0415  (import only when asked for)

    attribs = [
        osmesa.OSMESA_FORMAT, osmesa.OSMESA_RGBA,
        osmesa.OSMESA_DEPTH_BITS, 24,
        osmesa.OSMESA_PROFILE, osmesa.OSMESA_CORE_PROFILE,
        osmesa.OSMESA_CONTEXT_MAJOR_VERSION, 3,
        osmesa.OSMESA_CONTEXT_MINOR_VERSION, 3,
        0,
    ]
    handle = osmesa.OSMesaCreateContextAttribs(attribs, None)
    if not handle:
        raise BackendUnavailableError("OSMesaCreateContextAttribs returned NULL (core 3.3 profile)")
    # OSMesa needs a colour buffer to be current; we render into our own framebuffers.
    buf = arrays.GLubyteArray.zeros((1, 1, 4))
    if not osmesa.OSMesaMakeCurrent(handle, buf, GL.GL_UNSIGNED_BYTE, 1, 1):
        raise BackendUnavailableError("OSMesaMakeCurrent failed")
    ctx = moderngl.create_context(require=330)  # adopt the current OSMesa context
    lib = ctypes.CDLL(ctypes.util.find_library("OSMesa") or "libOSMesa.so.8")
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    return GLContext(ctx, "osmesa", ctx.info["GL_RENDERER"], lib.OSMesaGetProcAddress, [lib, buf, handle])
