"""OpenGL contexts: the only module that creates them, and the one place a platform is chosen.

``create_context(backend)`` returns a :class:`GLContext` holding a moderngl context started by
one of the platforms of :mod:`genie_gl.render.gl.platforms` (one module each behind a small
interface, :class:`~genie_gl.render.gl.platforms.base.Platform`):

* ``"egl"`` — surfaceless EGL (Mesa llvmpipe on a CPU box, NVIDIA's EGL on a GPU box), the
  default; or
* ``"osmesa"`` — Mesa's off-screen renderer, a fallback several times slower than llvmpipe
  through EGL.

``backend=None`` takes the process's default (:func:`set_default_backend`, which the CLI calls
with ``GENIE_GL_BACKEND``: the environment is read there, never here), else tries every
platform in order. A platform that cannot start in this process says why
(:meth:`~genie_gl.render.gl.platforms.base.Platform.unusable`: EGL in a child forked after its
parent started EGL) and the next is tried; a named one raises. When nothing starts,
:class:`BackendUnavailableError` says what was tried and which Debian packages fix it.
:func:`shared_context` never hands a forked child its parent's contexts. The package's own
worker pools spawn, and hand their workers the backend chosen here
(:func:`default_backend`).
"""

from __future__ import annotations

import ctypes
import logging
import os
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Any, Callable

import moderngl

from ...errors import BackendUnavailableError, ConfigError
from .platforms import PLATFORMS, Platform

log = logging.getLogger(__name__)

BACKENDS = tuple(PLATFORMS)
APT_HINT = "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"

_default_backend: str | None = None  # set once by the CLI from GENIE_GL_BACKEND

_LIVE: dict[int, "GLContext"] = {}  # contexts created in this process, not yet released
_CREATED = [0]  # how many this process has created

GL_LOWER_LEFT = 0x8CA1
GL_ZERO_TO_ONE = 0x935F
GL_SUBPIXEL_BITS = 0x0D50


@dataclass(eq=False)
class GLContext:
    """A moderngl context plus what genie-gl needs beside it.

    Attributes
    ----------
    ctx : moderngl.Context
    platform : Platform, the platform that started it.
    renderer : str, the GL_RENDERER string (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
    """

    ctx: moderngl.Context
    platform: Platform
    renderer: str
    programs: dict = field(default_factory=dict, repr=False)  # built shaders, shared by renderers
    _subpixel_bits: int | None = field(default=None, repr=False)

    @property
    def backend(self) -> str:
        """The platform's name: "egl" or "osmesa"."""
        return self.platform.name

    def current(self) -> AbstractContextManager:
        """A context manager making this context current around a call, where the platform
        needs it (EGL: so that other GL users of the process cannot leave theirs current)."""
        return self.platform.current(self.ctx)

    def gl_function(self, name: str, restype: Any, *argtypes: Any) -> Callable[..., Any]:
        """A ctypes binding of a GL entry point moderngl does not expose (e.g. glClipControl)."""
        address = self.platform.proc_address(name.encode())
        if not address:
            raise BackendUnavailableError(f"{self.backend}: GL function {name} is not available")
        return ctypes.CFUNCTYPE(restype, *argtypes)(address)

    def reset(self) -> None:
        """Put the state a renderer sets back to GL's defaults (no depth test or face culling,
        depth function "<", counter-clockwise front faces, the default framebuffer bound)."""
        with self.current():
            self.ctx.detect_framebuffer(0).use()
            self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
            self.ctx.depth_func = "<"
            self.ctx.front_face = "ccw"

    def error(self) -> str:
        """GL's error flag ("GL_NO_ERROR" when none), read (and so cleared) in this context."""
        with self.current():
            return self.ctx.error

    @property
    def max_side(self) -> int:
        """The largest frame side (px) this context can render: the least of its texture,
        renderbuffer and viewport limits (call with the context current)."""
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
                GL_SUBPIXEL_BITS, ctypes.byref(value)
            )
            self._subpixel_bits = max(4, value.value)
        return self._subpixel_bits

    def release(self) -> None:
        """Free the context and everything created in it."""
        _LIVE.pop(id(self), None)
        self.programs.clear()
        self.ctx.release()
        self.platform.release()


def set_default_backend(backend: str | None) -> None:
    """The backend ``create_context(None)`` uses in this process (the CLI passes
    ``GENIE_GL_BACKEND`` here; worker pools pass their parent's to their workers)."""
    global _default_backend
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(
            f"GENIE_GL_BACKEND={backend!r} is unknown; expected one of {', '.join(BACKENDS)}"
        )
    _default_backend = backend or None


def default_backend() -> str | None:
    """The backend ``create_context(None)`` uses in this process (None: the first that starts)."""
    return _default_backend


def create_context(backend: str | None = None, *, device_index: int = 0) -> GLContext:
    """Create a headless OpenGL (>= 3.3 core) context.

    Parameters
    ----------
    backend : "egl", "osmesa" or None (the process's default, else EGL, then OSMesa).
    device_index : int, the EGL device (GPU) to use on multi-GPU machines.
    """
    backend = backend or _default_backend
    if backend is not None and backend not in BACKENDS:
        raise ConfigError(
            f"GL backend {backend!r} is unknown; expected one of {', '.join(BACKENDS)}"
        )
    tried: list[str] = []
    for name in [backend] if backend else list(BACKENDS):
        platform = PLATFORMS[name]()
        why = platform.unusable()
        if why is not None:
            if backend:
                raise BackendUnavailableError(why)
            tried.append(f"{name}: {why}")
            continue
        try:
            ctx = platform.start(device_index)
        except Exception as exc:  # each platform fails in its own way; report them all
            tried.append(
                f"{name}: {type(exc).__name__}: "
                f"{str(exc).strip().splitlines()[0] if str(exc).strip() else ''}"
            )
            continue
        gl = GLContext(ctx, platform, ctx.info["GL_RENDERER"])
        _LIVE[id(gl)] = gl
        _CREATED[0] += 1
        log.debug("GL context on %s: %s", name, gl.renderer)
        return gl
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


def live_contexts() -> list[GLContext]:
    """The contexts this process created and has not released (the test suite checks them)."""
    return list(_LIVE.values())


def contexts_created() -> int:
    """How many contexts this process has created (the test suite checks that a test of a
    stage that needs no GL starts none)."""
    return _CREATED[0]


def is_shared(gl: GLContext) -> bool:
    """True for a context :func:`shared_context` holds (it outlives its renderers on purpose)."""
    return any(gl is s for s in _SHARED.values())


def release_shared_contexts() -> None:
    """Release the contexts :func:`shared_context` made in this process."""
    _forget_parents_contexts()
    while _SHARED:
        _SHARED.popitem()[1].release()
