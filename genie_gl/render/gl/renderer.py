"""The GL raster's renderer: a frame's instances drawn by OpenGL (moderngl), read back.

:class:`GLRenderer` is what ``Renderer(scene, raster="gl")`` makes. All meshes of the scene
share one vertex and one index buffer, uploaded once; a frame is at most two
multi-draw-indirect calls: one command per instance that survives frustum culling (its
camera_from_model row picked by the command's base instance), with back-face culling for
closed meshes unless the camera is inside their bounding box, and only the triangles that
may cover a pixel centre (:mod:`genie_gl.render.cull`). A frame is a :class:`FrameJob`:
planned on the CPU (:meth:`GLRenderer._plan`), issued to the GPU (:meth:`GLRenderer._issue`,
where its winners are decided by the depth test), fetched and finished
(:mod:`genie_gl.render.gl.readout`).
"""

from __future__ import annotations

import ctypes
import threading
import time
from collections.abc import Collection, Iterable, Iterator, Sequence
from typing import Any

import moderngl
import numpy as np

from ...errors import LimitError, RenderError
from ...frame import Frame
from ...sensors.camera import Sensor
from ...validation.arguments import check_pose
from ..fragments import DrawnTriangles, no_triangles
from ..projection import clip_coefficients
from ..renderer import Renderer
from .context import GL_LOWER_LEFT, GL_ZERO_TO_ONE, create_context
from .objects import COMMAND_DTYPE, GLObjects
from .readback import semantic_table
from .readout import FrameJob, Readout

# farther from the camera, float32 vertices lose pixels and depth (GLRenderer._check_reach)
GL_MAX_REACH_M = 1e5


class GLRenderer(GLObjects, Readout, Renderer, raster="gl"):
    """The OpenGL raster's :class:`~genie_gl.render.renderer.Renderer` (see there for the
    options). Its GL context is current in the thread that made it: use it from that thread
    (``gg.capture(..., workers=N)`` renders in processes)."""

    def _open(self, backend: str | None, context: Any) -> None:
        self._thread = threading.get_ident()  # GL contexts are current in one thread: see _current
        self._own_context = context is None
        self.gl = context or create_context(backend)
        self.ctx = self.gl.ctx
        self._programs = self.gl.programs  # one build per context
        self._fbos: dict = {}
        self._vaos: dict = {}
        self._pbos: dict = {}  # readback="pbo": (framebuffer, read) -> pixel buffer object
        self._clip_control = self.gl.gl_function(
            "glClipControl", None, ctypes.c_uint, ctypes.c_uint
        )
        self._gl_flush = None

    def _current(self) -> Any:
        # made current around every call where the platform needs it (EGL), so other GL users
        # in the process (pyrender, a second Renderer) cannot leave theirs current under us
        if threading.get_ident() != self._thread:
            raise RenderError(
                "a Renderer is used from a thread other than the one that made it; its GL context "
                "belongs to that thread: make one Renderer per thread (or use gg.capture(..., "
                "workers=N), which renders in processes)"
            )
        return self.gl.current()

    def _snap_px(self) -> float:
        return 2.0 ** -self.gl.subpixel_bits()  # twice the farthest snap

    def _uploaded(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._semantics = (
            semantic_table(self._ids, self._rows["semantic"]) if self.targets == "packed" else None
        )
        self._packed = self._semantics is not None  # an id used twice: three targets
        self._vbo = self.ctx.buffer(vertices.tobytes())
        self._ibo = self.ctx.buffer(faces.tobytes())
        self._slot_buf = None  # 0, 1, 2, ... read per instance by the triangle target's program
        self._streams: dict[int, tuple] = {}  # per-frame buffers, one set per frame in flight

    # -- rendering -----------------------------------------------------------------------------
    def _frame(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        triangles: bool,
    ) -> Frame:
        return self._read(
            self._draw(sensor, pose, color, normals, only, slot=0, triangles=triangles),
            finish=True,
        )

    def _frames(
        self,
        sensor: Sensor,
        poses: Iterable[np.ndarray],
        color: bool,
        normals: bool,
        only: Sequence[Collection[int] | None] | None,
        triangles: bool,
    ) -> Iterator[Frame]:
        fetched = None  # the frame read back last, not yet unpacked
        planned = None  # the next frame, culled and its draws written, not yet issued
        for k, pose in enumerate(poses):
            with self._current():
                job = self._plan(
                    sensor,
                    pose,
                    color,
                    normals,
                    None if only is None else only[k],
                    slot=1 + k % 2,
                    triangles=triangles,
                )
            if (
                planned is not None
            ):  # the frame before: read back once rasterised, then this one issued
                with self._current():
                    self._fetch(planned)
                fetched = planned
            with self._current():
                self._issue(job)
                self._flush()  # llvmpipe rasterises a frame's bins once they are flushed
                if self.readback == "pbo":
                    self._start_read(job)
            if (
                fetched is not None
            ):  # unpacked, and the caller's work on it done, while this frame rasterises
                yield self._finish(fetched)
                fetched = None
            planned = job
        if planned is not None:
            with self._current():
                self._fetch(planned)
            yield self._finish(planned)

    def _draw(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        slot: int,
        triangles: bool = False,
    ) -> FrameJob:
        """Cull and issue the draws of one frame into the targets of ``slot``."""
        job = self._plan(sensor, pose, color, normals, only, slot, triangles)
        self._issue(job)
        return job

    def _plan(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        slot: int,
        triangles: bool = False,
    ) -> FrameJob:
        """The CPU half of a frame's draws: its culling, its instances' rows and culled indices
        written (into the buffers of ``slot``'s parity, which no frame in flight reads), its
        program and uniforms set; :meth:`_issue` draws it. :meth:`frames` plans frame i+1
        while frame i rasterises."""
        t0 = time.perf_counter()
        W, H, K = sensor.width, sensor.height, sensor.K
        pose = check_pose(
            pose, "render pose"
        )  # a rigid world_from_camera: no scale, shear or mirror
        self.ctx  # current before the framebuffer is made
        fbo, targets, depth_tex, extra = self._framebuffer(W, H, color, normals, slot, triangles)
        linear = self.depth_precision == "float32"
        defines = (
            (("WITH_COLOR",) if color else ())
            + (("WITH_NORMAL",) if normals else ())
            + (() if linear else ("NO_LINEAR_DEPTH",))
            + (("PACKED_IDS",) if self._packed else ())
            + (("WITH_PRIMITIVE",) if triangles else ())
        )
        program = self._program(defines)
        proj_x, proj_y = clip_coefficients(K, W, H)
        program["u_proj_x"].value = tuple(proj_x.astype(np.float32))
        program["u_proj_y"].value = tuple(proj_y.astype(np.float32))
        # the GL near plane lies far below the sensor's minimum range: what is nearer than the
        # range is drawn (and masked in _read), never clipped away to show what lies behind it
        clip_near = self._clip_near(sensor)
        program["u_depth"].value = (0.0, clip_near)  # reversed, infinite far: near / z

        parity = slot % 2
        lists, culled, drawn_triangles, simplified = self._commands(
            pose, K, W, H, clip_near, only, parity, triangles
        )
        return FrameJob(
            sensor=sensor,
            pose=pose,
            color=color,
            normals=normals,
            slot=slot,
            fbo=fbo,
            extra=extra,
            program=program,
            proj=(proj_x, proj_y),
            lists=lists,
            culled=culled,
            drawn_triangles=drawn_triangles,
            triangles=int(sum(int(c["count"].sum()) for c, _ in lists) // 3),
            simplified=simplified,
            occluded=culled and self._culler.occluded,
            t0=t0,
            t1=time.perf_counter(),
        )

    def _issue(self, job: FrameJob) -> None:
        """The GL half of a frame's draws (after :meth:`_plan`): its targets cleared, its
        draws submitted (and the 24-bit depth pass, with that precision).

        Here the GL raster's winner is decided, by the GPU's depth test: targets cleared to
        reversed depth 0, a fragment is kept when its reversed depth ``near / z`` (float32)
        is greater than the pixel's (``depth_func ">"``: the nearest); coverage by the GPU's
        fixed-point rasterisation and fill rule. A tie keeps the fragment drawn first: the
        back-face-culled instances' draws before the others', each in slot order, each
        instance's triangles in index order. The 24-bit pass only gives ``depth24`` its
        depth buffer; the ids are the first pass's."""
        job.t_issue = time.perf_counter()
        ctx, sensor, fbo, lists = self.ctx, job.sensor, job.fbo, job.lists
        job.lists = None
        W, H = sensor.width, sensor.height
        parity = job.slot % 2
        fbo.use()
        ctx.viewport = (0, 0, W, H)
        self._clip_control(GL_LOWER_LEFT, GL_ZERO_TO_ONE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"
        # v grows with window y (row 0 = v = 0) mirrors the image, so outward CCW faces are CW
        ctx.front_face = "cw"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)  # 0.0f has all bits zero: ids clear to 0
        program, job.program = job.program, None
        job.drawn = self._submit(program, lists, parity, job.culled)
        if self.depth_precision == "depth24":
            n, f = float(sensor.near_m), float(sensor.far_m)
            proj_x, proj_y = job.proj
            fbo24 = job.fbo24 = job.extra[0]
            p24 = self._program(
                ("NO_LINEAR_DEPTH", "DEPTH_ONLY") + (("PACKED_IDS",) if self._packed else ())
            )
            p24["u_proj_x"].value = tuple(proj_x.astype(np.float32))
            p24["u_proj_y"].value = tuple(proj_y.astype(np.float32))
            p24["u_depth"].value = (f / (f - n), -f * n / (f - n))  # window depth = A + B / z
            fbo24.use()
            ctx.depth_func = "<"
            fbo24.clear(depth=1.0)
            self._submit(p24, lists, parity, job.culled)
        ctx.disable(moderngl.CULL_FACE)

    def _flush(self) -> None:
        if self._gl_flush is None:
            self._gl_flush = self.gl.gl_function("glFlush", None)
        self._gl_flush()

    def _clip_near(self, sensor: Sensor) -> float:
        """The GL near plane: 1/1024 of the sensor's minimum range (``Camera.clip_near_m``),
        except with a 24-bit window depth buffer, whose precision (z² / (near·2²⁴)) needs the
        near plane at the minimum range itself: there, a surface nearer than the range is
        clipped and what lies behind it shows (the float depth modes give no return)."""
        return float(sensor.near_m if self.depth_precision == "depth24" else sensor.clip_near_m)

    def _commands(
        self,
        pose: np.ndarray,
        K: np.ndarray,
        W: int,
        H: int,
        near: float,
        only: Collection[int] | None,
        parity: int = 0,
        triangles: bool = False,
    ) -> tuple[list[tuple[np.ndarray, bool]], bool, DrawnTriangles | None, int]:
        """Draw commands of a frame, nothing in Python per instance: ([(commands, back-face
        culling)], whether they draw from the culled index buffer, with ``triangles`` what
        turns a pixel's (slot, triangle) into vertices (else None), the instances drawn
        simplified)."""
        drawn = no_triangles(self._ids, self._rows["semantic"]) if triangles else None
        seen = self._visible(pose, K, W, H, near, only)
        if seen is None:
            return [], False, drawn, 0
        cfm, slots, m, backcull, eye = seen[:5]
        self._check_reach(cfm, slots, m)
        self._rows["rows"] = cfm
        inst_buf, dyn_ibo, _ = self._stream(parity)
        inst_buf.write(self._rows)
        cmd = np.zeros(len(slots), COMMAND_DTYPE)
        cmd["instances"] = 1
        cmd["base_vertex"] = self._vbase[m]
        cmd["base_instance"] = slots
        in_view = int(self._nfaces[m].sum())
        culled = self.cull and in_view >= self.cull_min_faces
        if culled:
            # not with a 24-bit depth buffer: it ties depths that are apart
            occlusion = self.depth_precision != "depth24" and in_view >= self.occlusion_min_faces
            indices, first, count = self._culler.select(
                slots,
                m,
                backcull,
                cfm,
                eye,
                self._det[slots],
                K,
                W,
                H,
                near,
                seen.planes,
                occlusion,
            )
            if indices.nbytes > dyn_ibo.size:  # same buffer name: the vertex arrays stay valid
                dyn_ibo.orphan(max(indices.nbytes, dyn_ibo.size * 3 // 2))
            dyn_ibo.write(indices)
            cmd["first"], cmd["count"] = first, count
            keep = count > 0
            cmd, backcull = cmd[keep], backcull[keep]
        else:
            cmd["first"], cmd["count"] = 3 * self._fbase[m], 3 * self._nfaces[m]
        if triangles:
            drawn.first[cmd["base_instance"]] = cmd["first"] // 3
            drawn.count[cmd["base_instance"]] = cmd["count"] // 3
            drawn.base_vertex[cmd["base_instance"]] = cmd["base_vertex"]
            drawn.backcull[cmd["base_instance"]] = backcull
            # every face of the mesh, culled or not
            drawn.mesh_first[slots], drawn.mesh_count[slots] = self._fbase[m], self._nfaces[m]
            # the culled indices are rewritten by the next frame's culling: this frame keeps a copy
            drawn = drawn._replace(
                camera_from_model=cfm,
                indices=indices.copy() if culled else self._culler.faces.reshape(-1),
            )
        lists = [
            (cmd[backcull == flag], flag) for flag in (True, False) if (backcull == flag).any()
        ]
        return lists, culled, drawn, seen.simplified

    def _check_reach(self, cfm: np.ndarray, slots: np.ndarray, m: np.ndarray) -> None:
        """Refuse a frame whose drawn instances reach farther than :data:`GL_MAX_REACH_M` from
        the camera: the GL raster holds camera-frame vertices in float32, and a triangle that
        reaches that far is drawn with pixels lost and depth off (a ground triangle of
        +-1e6 m: 0.4 % of its pixels lost, 1.6 % depth error); the CPU raster draws it exactly."""
        c = cfm[slots]
        centre = np.einsum("nij,nj->ni", c[:, :, :3], self._centre[m]) + c[:, :, 3]
        reach = np.linalg.norm(centre, axis=1) + self._radius[m] * self._scale[slots]
        far = int(np.argmax(reach)) if len(reach) else 0
        if len(reach) and reach[far] > GL_MAX_REACH_M:
            raise LimitError(
                f"Renderer: instance {int(self._ids[slots[far]])} reaches {reach[far]:.3g} m from "
                "the "
                f"camera; the GL raster draws geometry within {GL_MAX_REACH_M:g} m of it exactly "
                "enough "
                "(float32 vertices): use raster='cpu' (--raster cpu), which draws it in float64, "
                "or cut "
                "the mesh smaller"
            )

    def _submit(
        self,
        program: moderngl.Program,
        lists: list[tuple[np.ndarray, bool]],
        parity: int = 0,
        culled: bool = False,
    ) -> int:
        """Issue the frame's multi-draw calls (``culled``: from the culled index buffer);
        returns the number of instances drawn."""
        if not lists:
            return 0
        vao = self._vao(program, parity, culled)
        cmd_buf = self._stream(parity)[2]
        everything = np.concatenate([c for c, _ in lists])
        cmd_buf.write(everything)
        at = 0
        for cmd, flag in lists:
            if flag:
                self.ctx.enable(moderngl.CULL_FACE)
            else:
                self.ctx.disable(moderngl.CULL_FACE)
            vao.render_indirect(cmd_buf, moderngl.TRIANGLES, count=len(cmd), first=at)
            at += len(cmd)
        return at

    def release(self) -> None:
        """Free the GL objects (and the context, when the renderer created it)."""
        if self.gl is None:
            return
        with self._current():
            self._release_objects()
        if self._own_context:
            self.gl.release()
