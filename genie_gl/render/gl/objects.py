"""The GL raster's objects: per-frame buffers, programs, vertex arrays and render targets,
made on first use and kept for the renderer's life (:class:`GLObjects`, a base of
:class:`~genie_gl.render.gl.renderer.GLRenderer`)."""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np

from ...errors import LimitError
from ...limits import check_frame_side
from ..renderer import INSTANCE_DTYPE
from .shader import load_program

# the instance rows' layout as vertex attributes (one row per drawn instance)
INSTANCE_FIELDS = (
    ("4f", 16, "in_row0"),
    ("4f", 16, "in_row1"),
    ("4f", 16, "in_row2"),
    ("u4", 4, "in_instance"),
    ("u4", 4, "in_semantic"),
    ("4f1", 4, "in_color"),
)
COMMAND_DTYPE = np.dtype(
    [
        ("count", "<u4"),
        ("instances", "<u4"),
        ("first", "<u4"),
        ("base_vertex", "<i4"),
        ("base_instance", "<u4"),
    ]
)  # DrawElementsIndirectCommand
GL_TEXTURE_2D = 0x0DE1
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_DEPTH_COMPONENT = 0x1902
GL_FLOAT = 0x1406


class GLObjects:
    """The GL renderer's objects (its context ``ctx``, its uploaded buffers ``_vbo``,
    ``_ibo``, and the caches ``_streams``, ``_programs``, ``_vaos``, ``_fbos``, ``_pbos``)."""

    def _stream(self, parity: int) -> tuple:
        """(instance rows, culled indices, draw commands): the buffers a frame writes."""
        if parity not in self._streams:
            ctx, n = self.ctx, max(1, len(self._mesh))
            # the culled index buffer starts small and grows with what a frame draws
            self._streams[parity] = (
                ctx.buffer(reserve=n * INSTANCE_DTYPE.itemsize),
                ctx.buffer(reserve=1 << 16) if self.cull else None,
                ctx.buffer(reserve=n * COMMAND_DTYPE.itemsize),
            )
        return self._streams[parity]

    def _program(self, defines: tuple[str, ...]) -> moderngl.Program:
        return load_program(self.ctx, "geometry", defines, cache=self._programs)

    def _vao(self, program: moderngl.Program, parity: int, culled: bool) -> moderngl.VertexArray:
        key = (id(program), parity, culled)
        vao = self._vaos.get(key)
        if vao is None:
            # attributes a program does not use (colour in depth-only mode) become padding
            fmt = " ".join(f if a in program else f"{n}x" for f, n, a in INSTANCE_FIELDS) + "/i"
            attrs = [a for _, _, a in INSTANCE_FIELDS if a in program]
            content = [(self._vbo, "3f", "in_position"), (self._stream(parity)[0], fmt, *attrs)]
            if "in_slot" in program:
                if self._slot_buf is None:
                    self._slot_buf = self.ctx.buffer(
                        np.arange(max(1, len(self._mesh)), dtype="<u4").tobytes()
                    )
                content.append((self._slot_buf, "u4/i", "in_slot"))
            vao = self.ctx.vertex_array(
                program,
                content,
                index_buffer=self._stream(parity)[1] if culled else self._ibo,
                index_element_size=4,
            )
            self._vaos[key] = vao
        return vao

    def _framebuffer(
        self,
        width: int,
        height: int,
        color: bool,
        normals: bool,
        slot: int = 0,
        triangles: bool = False,
    ) -> tuple:
        key = (width, height, color, normals, slot, triangles)
        if key in self._fbos:
            return self._fbos[key]
        check_frame_side(width, height, "Renderer", self.gl.max_side)
        try:
            self._fbos[key] = self._make_framebuffer(width, height, color, normals, triangles)
        except moderngl.Error as exc:  # the driver could not allocate the targets
            raise LimitError(
                f"Renderer: the GL driver ({self.gl.renderer}) could not allocate {width}x{height} "
                "px "
                f"render targets ({str(exc).strip()}); use a smaller sensor"
            ) from None
        return self._fbos[key]

    def _make_framebuffer(
        self, width: int, height: int, color: bool, normals: bool, triangles: bool = False
    ) -> tuple:
        ctx, size = self.ctx, (width, height)
        if self._packed:  # (depth bits, instance): see render/readback.py
            targets = [ctx.texture(size, 2, dtype="u4")]
        else:
            targets = [
                ctx.texture(size, 1, dtype="f4"),
                ctx.texture(size, 1, dtype="u4"),
                ctx.texture(size, 1, dtype="u2"),
            ]
        if color or normals:
            targets.append(
                ctx.texture(size, 4, dtype="f1")
            )  # location 3 or 1 (unused without colour)
        if normals:
            targets.append(ctx.texture(size, 4, dtype="f4"))
        if triangles:  # (slot + 1, triangle within its draw): see genie_gl/triangles.py
            targets.append(ctx.texture(size, 2, dtype="u4"))
        depth = ctx.depth_texture(size)
        # moderngl allocates 24-bit fixed-point depth; reversed Z needs a float depth buffer.
        bind = self.gl.gl_function("glBindTexture", None, ctypes.c_uint, ctypes.c_uint)
        teximage = self.gl.gl_function(
            "glTexImage2D",
            None,
            ctypes.c_uint,
            ctypes.c_int,
            ctypes.c_int,
            ctypes.c_int,
            ctypes.c_int,
            ctypes.c_int,
            ctypes.c_uint,
            ctypes.c_uint,
            ctypes.c_void_p,
        )
        bind(GL_TEXTURE_2D, depth.glo)
        teximage(
            GL_TEXTURE_2D,
            0,
            GL_DEPTH_COMPONENT32F,
            width,
            height,
            0,
            GL_DEPTH_COMPONENT,
            GL_FLOAT,
            None,
        )
        bind(GL_TEXTURE_2D, 0)
        fbo = ctx.framebuffer(color_attachments=targets, depth_attachment=depth)
        extra = []
        if self.depth_precision == "depth24":  # a second, depth-only target of 24 bits
            d24 = ctx.depth_texture(size)
            extra = [ctx.framebuffer(depth_attachment=d24), d24]
        return fbo, targets, depth, extra

    def _release_objects(self) -> None:
        # moderngl re-binds the last framebuffer used when it creates another: leave the
        # default one bound, never a deleted name.
        self.ctx.detect_framebuffer(0).use()
        for vao in self._vaos.values():
            vao.release()
        for buf in (
            self._vbo,
            self._ibo,
            self._slot_buf,
            *(b for bufs in self._streams.values() for b in bufs),
            *self._pbos.values(),
        ):
            if buf is not None:
                buf.release()
        for fbo, targets, depth, extra in self._fbos.values():
            fbo.release()
            for t in (*targets, depth, *extra):
                t.release()
        self._vaos, self._fbos, self._pbos = {}, {}, {}
        self._vbo = self._ibo = self._slot_buf = None
        self._streams = {}
