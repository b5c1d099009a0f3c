"""The moderngl renderer: one geometry pass into depth, instance, semantic, colour, normals.

Geometry is uploaded once per scene and reused for every camera; each mesh is drawn once
per camera, instanced, for the instances that survive frustum culling. Closed meshes are
drawn with back-face culling unless the camera is inside their bounding box.
"""
from __future__ import annotations

import ctypes
import logging
import time
from collections.abc import Collection
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any

import moderngl
import numpy as np

from ..checks import check_pose
from ..errors import RenderError
from ..frame import Frame
from ..scene.model import Mesh, Scene
from ..sensors.camera import Sensor
from .context import GL_LOWER_LEFT, GL_ZERO_TO_ONE, GLContext, create_context
from .projection import clip_coefficients, frustum_planes, rigid_inverse
from .shader import load_program

log = logging.getLogger(__name__)

# one row per drawn instance: camera_from_model (3 rows), ids, colour
INSTANCE_DTYPE = np.dtype([("rows", "<f4", (3, 4)), ("instance", "<u4"), ("semantic", "<u4"),
                           ("color", "u1", (4,))])
INSTANCE_FIELDS = (("4f", 16, "in_row0"), ("4f", 16, "in_row1"), ("4f", 16, "in_row2"),
                   ("u4", 4, "in_instance"), ("u4", 4, "in_semantic"), ("4f1", 4, "in_color"))

GL_TEXTURE_2D = 0x0DE1
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_DEPTH_COMPONENT = 0x1902
GL_FLOAT = 0x1406


def sanitize(mesh: Mesh, name: str) -> np.ndarray:
    """Faces of ``mesh`` safe to rasterise: drops faces with non-finite or coincident vertices.

    Returns (F', 3) uint32. Dropped faces are reported once, as a warning naming the mesh.
    """
    faces = mesh.faces
    if len(faces) == 0:
        return faces
    v = mesh.vertices.astype(np.float64)
    tri = v[faces]
    finite = np.isfinite(tri).all(axis=(1, 2))
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    keep = finite & (area2 > 0)
    if not keep.all():
        log.warning("mesh %r: skipped %d of %d faces (%d with NaN/Inf vertices, %d degenerate)",
                    name, int((~keep).sum()), len(faces), int((~finite).sum()),
                    int((finite & ~(area2 > 0)).sum()))
    return np.ascontiguousarray(faces[keep])


@dataclass(eq=False)
class _GpuMesh:
    vbo: moderngl.Buffer
    ibo: moderngl.Buffer
    closed: bool
    centre: np.ndarray        # (3,) bounding-sphere centre, model frame
    radius: float
    lo: np.ndarray            # (3,) model AABB
    hi: np.ndarray
    first: int                # this mesh's instances are rows [first, last) of the sorted table
    last: int
    inst_buf: moderngl.Buffer | None = None
    vaos: dict | None = None


class _Pool:
    """Recycled memory for frame buffers.

    A fresh array is page-faulted in on its first write, 4 KiB at a time: for a 640 x 480
    frame that costs several times the read-back itself. A frame's buffers are views into one
    block lent from this pool; when the last view dies (the frame is dropped), the block comes
    back and the next frame of that size writes into memory that is already mapped.
    """

    def __init__(self, max_bytes: int = 512 << 20) -> None:
        self.free: dict[int, list[np.ndarray]] = {}
        self.max_bytes, self.bytes = max_bytes, 0
        self.types: dict[int, type] = {}

    def lend(self, size: int) -> np.ndarray:
        """A writable uint8 array of ``size`` bytes, returned to the pool when it dies."""
        blocks = self.free.get(size)
        if blocks:
            raw = blocks.pop()
            self.bytes -= size
        else:
            raw = np.empty(size, np.uint8)
        lease_type = self.types.get(size)
        if lease_type is None:
            pool = self

            class Lease(ctypes.c_ubyte * size):  # type: ignore[misc, valid-type]
                def __del__(self) -> None:  # the last view of the block is gone
                    pool.give_back(self._raw)

            lease_type = self.types[size] = Lease
        lease = lease_type.from_address(raw.ctypes.data)
        lease._raw = raw  # keeps the memory alive as long as any view of the lease
        return np.frombuffer(lease, np.uint8)

    def give_back(self, raw: np.ndarray) -> None:
        if self.bytes + raw.nbytes <= self.max_bytes:
            self.free.setdefault(raw.nbytes, []).append(raw)
            self.bytes += raw.nbytes


_POOL = _Pool()


def frame_buffers(H: int, W: int, color: bool, normals: bool) -> dict[str, np.ndarray]:
    """A frame's output arrays as views into one block of recycled memory (see :class:`_Pool`)."""
    parts = [("depth", np.float32, (H, W)), ("instance", np.uint32, (H, W))]
    if normals:
        parts.append(("normal", np.float32, (H, W, 3)))
    if color:
        parts.append(("rgba", np.uint8, (H, W, 4)))
    parts.append(("semantic", np.uint16, (H, W)))
    sizes = [-(-int(np.prod(shape)) * np.dtype(dt).itemsize // 64) * 64 for _, dt, shape in parts]
    block = _POOL.lend(sum(sizes))
    out, at = {}, 0
    for (name, dt, shape), b in zip(parts, sizes):
        n = int(np.prod(shape)) * np.dtype(dt).itemsize
        out[name] = block[at:at + n].view(dt).reshape(shape)
        at += b
    return out


class Renderer:
    """Renders ideal pinhole frames of one scene from any number of cameras.

    Use as a context manager (or call :meth:`release`)::

        with gg.Renderer(scene) as r:
            frames = [r.render(sensor, pose) for pose in poses]

    Parameters
    ----------
    scene : Scene
    backend : "egl", "osmesa" or None (EGL, falling back to OSMesa).
    context : GLContext, an existing context to share (then ``backend`` is ignored and the
        context is not released with the renderer).
    """

    def __init__(self, scene: Scene, *, backend: str | None = None, context: GLContext | None = None):
        self._own_context = context is None
        self.gl = context or create_context(backend)
        self.ctx = self.gl.ctx
        self._programs: dict = {}
        self._fbos: dict = {}
        self._clip_control = self.gl.gl_function("glClipControl", None, ctypes.c_uint, ctypes.c_uint)
        with self._current():
            self._upload(scene)
        self.stats: dict[str, float] = {}

    def _current(self) -> Any:
        # EGL contexts are made current around every call, so other GL users in the process
        # (pyrender, a second Renderer) cannot leave theirs current under us.
        return self.ctx if self.gl.backend == "egl" else nullcontext()

    # -- scene upload ------------------------------------------------------------------------
    def _upload(self, scene: Scene) -> None:
        ctx = self.ctx
        keys = list(scene.meshes)
        index = {k: i for i, k in enumerate(keys)}
        inst = scene.instances
        mesh_of = np.array([index[i.mesh] for i in inst], dtype=np.int64)
        order = np.argsort(mesh_of, kind="stable")
        self._mesh_of = mesh_of[order]
        self._world_from_model = (np.stack([inst[i].world_from_model for i in order])
                                  if len(inst) else np.zeros((0, 4, 4)))
        self._ids = np.array([inst[i].instance for i in order], dtype=np.uint32)
        self._sem = np.array([inst[i].semantic for i in order], dtype=np.uint32)
        colors = np.full((len(inst), 4), 255, dtype=np.uint8)
        if len(inst):
            colors[:, :3] = np.array([inst[i].color for i in order], dtype=np.uint8)
        self._colors = colors
        # scale of each instance (for bounding spheres): largest column norm
        self._scale = (np.linalg.norm(self._world_from_model[:, :3, :3], axis=1).max(axis=1)
                       if len(inst) else np.zeros(0))
        self._meshes: list[_GpuMesh | None] = []
        bounds = np.searchsorted(self._mesh_of, np.arange(len(keys) + 1))
        self.triangles = 0
        for i, key in enumerate(keys):
            mesh = scene.meshes[key]
            faces = sanitize(mesh, key)
            first, last = int(bounds[i]), int(bounds[i + 1])
            if len(faces) == 0 or last == first:
                self._meshes.append(None)
                continue
            used = mesh.vertices[np.unique(faces)].astype(np.float64)
            lo, hi = used.min(axis=0), used.max(axis=0)
            centre = (lo + hi) / 2
            radius = float(np.linalg.norm(used - centre, axis=1).max())
            self._meshes.append(_GpuMesh(
                vbo=ctx.buffer(np.ascontiguousarray(mesh.vertices, dtype="<f4").tobytes()),
                ibo=ctx.buffer(np.ascontiguousarray(faces, dtype="<u4").tobytes()),
                closed=bool(mesh.closed), centre=centre, radius=radius, lo=lo, hi=hi,
                first=first, last=last,
                inst_buf=ctx.buffer(reserve=max(1, last - first) * INSTANCE_DTYPE.itemsize),
                vaos={},
            ))
            self.triangles += len(faces) * (last - first)
        self._centres = np.array([m.centre if m else np.zeros(3) for m in self._meshes]).reshape(-1, 3)
        self._radii = np.array([m.radius if m else 0.0 for m in self._meshes])

    # -- GL objects ---------------------------------------------------------------------------
    def _program(self, color: bool, normals: bool) -> moderngl.Program:
        defines = (["WITH_COLOR"] if color else []) + (["WITH_NORMAL"] if normals else [])
        return load_program(self.ctx, "geometry", defines, cache=self._programs)

    def _vao(self, mesh: _GpuMesh, program: moderngl.Program) -> moderngl.VertexArray:
        vao = mesh.vaos.get(id(program))
        if vao is None:
            # attributes a program does not use (colour in depth-only mode) become padding
            fmt = " ".join(f if a in program else f"{n}x" for f, n, a in INSTANCE_FIELDS) + "/i"
            attrs = [a for _, _, a in INSTANCE_FIELDS if a in program]
            vao = self.ctx.vertex_array(
                program,
                [(mesh.vbo, "3f", "in_position"), (mesh.inst_buf, fmt, *attrs)],
                index_buffer=mesh.ibo, index_element_size=4,
            )
            mesh.vaos[id(program)] = vao
        return vao

    def _framebuffer(self, width: int, height: int, color: bool, normals: bool) -> tuple:
        key = (width, height, color, normals)
        if key in self._fbos:
            return self._fbos[key]
        ctx, size = self.ctx, (width, height)
        targets = [ctx.texture(size, 1, dtype="f4"), ctx.texture(size, 1, dtype="u4"),
                   ctx.texture(size, 1, dtype="u2")]
        if color or normals:
            targets.append(ctx.texture(size, 4, dtype="f1"))  # location 3 (unused without colour)
        if normals:
            targets.append(ctx.texture(size, 4, dtype="f4"))
        depth = ctx.depth_texture(size)
        # moderngl allocates 24-bit fixed-point depth; reversed Z needs a float depth buffer.
        bind = self.gl.gl_function("glBindTexture", None, ctypes.c_uint, ctypes.c_uint)
        teximage = self.gl.gl_function(
            "glTexImage2D", None, ctypes.c_uint, ctypes.c_int, ctypes.c_int, ctypes.c_int,
            ctypes.c_int, ctypes.c_int, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)
        bind(GL_TEXTURE_2D, depth.glo)
        teximage(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, width, height, 0, GL_DEPTH_COMPONENT, GL_FLOAT, None)
        bind(GL_TEXTURE_2D, 0)
        fbo = ctx.framebuffer(color_attachments=targets, depth_attachment=depth)
        self._fbos[key] = (fbo, targets, depth)
        return self._fbos[key]

    # -- rendering -----------------------------------------------------------------------------
    def render(self, sensor: Sensor, pose: np.ndarray, *, depth_only: bool = False,
               normals: bool = False, only: Collection[int] | None = None) -> Frame:
        """Render the ideal pinhole frame of ``sensor`` (its distortion ignored) at ``pose``.

        Parameters
        ----------
        sensor : Sensor, image size and K.
        pose : (4, 4) float64 world_from_camera (OpenCV camera frame).
        depth_only : skip the colour buffer (``Frame.rgb`` is None).
        normals : also render camera-frame unit normals (``Frame.normal``).
        only : draw just the instances with these ids (e.g. an object's full silhouette).
        """
        pose = check_pose(pose, "Renderer.render pose")
        with self._current():
            return self._render(sensor, pose, depth_only, normals, only)

    def _render(self, sensor: Sensor, pose: np.ndarray, depth_only: bool, normals: bool,
                only: Collection[int] | None = None) -> Frame:
        t0 = time.perf_counter()
        W, H, K = sensor.width, sensor.height, sensor.K
        pose = np.asarray(pose, dtype=np.float64)
        if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
            raise RenderError(f"pose must be a finite (4, 4) matrix, got shape {pose.shape}")
        color = not depth_only
        ctx = self.ctx
        fbo, targets, _ = self._framebuffer(W, H, color, normals)
        program = self._program(color, normals)
        proj_x, proj_y = clip_coefficients(K, W, H)
        program["u_proj_x"].value = tuple(proj_x.astype(np.float32))
        program["u_proj_y"].value = tuple(proj_y.astype(np.float32))
        program["u_near"].value = float(sensor.near_m)

        fbo.use()
        ctx.viewport = (0, 0, W, H)
        self._clip_control(GL_LOWER_LEFT, GL_ZERO_TO_ONE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"
        # v grows with window y (row 0 = v = 0) mirrors the image, so outward CCW faces are CW
        ctx.front_face = "cw"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)  # 0.0f has all bits zero: ids clear to 0

        drawn = self._draw(program, rigid_inverse(pose), K, W, H, sensor.near_m, only)
        ctx.disable(moderngl.CULL_FACE)
        ctx.finish()  # so that the read-back time below is the copy alone
        t1 = time.perf_counter()

        out = frame_buffers(H, W, color, normals)
        depth, instance, semantic = out["depth"], out["instance"], out["semantic"]
        fbo.read_into(depth, components=1, attachment=0, dtype="f4")
        fbo.read_into(instance, components=1, attachment=1, dtype="u4")
        fbo.read_into(semantic, components=1, attachment=2, dtype="u2")
        rgb = normal = None
        if color:  # RGBA is read as stored (a 3-component read converts: 7x slower)
            fbo.read_into(out["rgba"], components=4, attachment=3, dtype="f1")
            rgb = out["rgba"][..., :3]
        if normals:
            normal = out["normal"]
            fbo.read_into(normal, components=3, attachment=4, dtype="f4")
        err = ctx.error
        if err != "GL_NO_ERROR":
            raise RenderError(f"OpenGL error after rendering: {err}")
        t2 = time.perf_counter()
        if drawn and float(depth.max()) > sensor.far_m:  # infinite-far projection: clip here
            beyond = depth > sensor.far_m
            depth[beyond] = 0
            instance[beyond] = 0
            semantic[beyond] = 0
            if rgb is not None:
                rgb[beyond] = 0
            if normal is not None:
                normal[beyond] = 0
        self.stats = {"draw_s": t1 - t0, "readback_s": t2 - t1, "instances_drawn": drawn}
        return Frame(depth, instance, semantic, rgb, sensor, pose, normal,
                     {"render_ms": 1e3 * (time.perf_counter() - t0)})

    def _draw(self, program: moderngl.Program, camera_from_world: np.ndarray, K: np.ndarray,
              W: int, H: int, near: float, only: Collection[int] | None = None) -> int:
        n = len(self._mesh_of)
        if n == 0:
            return 0
        cfm = np.matmul(camera_from_world, self._world_from_model)  # float64, camera-relative
        centres = np.einsum("nij,nj->ni", cfm[:, :3, :3], self._centres[self._mesh_of]) + cfm[:, :3, 3]
        radii = self._radii[self._mesh_of] * self._scale
        planes = frustum_planes(K, W, H, near)
        visible = ((centres @ planes[:, :3].T + planes[:, 3]) >= -radii[:, None]).all(axis=1)
        if only is not None:
            visible &= np.isin(self._ids, np.fromiter(only, np.int64))
        if not visible.any():
            return 0
        rows = np.empty(n, INSTANCE_DTYPE)
        rows["rows"] = cfm[:, :3, :4]
        rows["instance"] = self._ids
        rows["semantic"] = self._sem
        rows["color"] = self._colors
        drawn = 0
        ctx = self.ctx
        for mesh in self._meshes:
            if mesh is None:
                continue
            sl = slice(mesh.first, mesh.last)
            vis = visible[sl]
            if not vis.any():
                continue
            cull = np.zeros(len(vis), bool)
            if mesh.closed:
                # camera inside the (slightly grown) box: draw both faces to see the inside
                m = cfm[sl]
                eye = np.linalg.solve(m, np.broadcast_to([0.0, 0.0, 0.0, 1.0], (len(m), 4))[..., None])[:, :3, 0]
                pad = 1e-6 * (1 + np.abs(mesh.hi - mesh.lo))
                inside = ((eye >= mesh.lo - pad) & (eye <= mesh.hi + pad)).all(axis=1)
                cull = ~inside
            vao = self._vao(mesh, program)
            for flag in (True, False):
                sel = vis & (cull == flag)
                k = int(sel.sum())
                if k == 0:
                    continue
                mesh.inst_buf.write(rows[sl][sel].tobytes())
                if flag:
                    ctx.enable(moderngl.CULL_FACE)
                else:
                    ctx.disable(moderngl.CULL_FACE)
                vao.render(moderngl.TRIANGLES, instances=k)
                drawn += k
        return drawn

    # -- lifetime ---------------------------------------------------------------------------
    def release(self) -> None:
        """Free the GL objects (and the context, when the renderer created it)."""
        with self._current():
            self._release_objects()
        if self._own_context:
            self.gl.release()

    def _release_objects(self) -> None:
        # moderngl re-binds the last framebuffer used when it creates another: leave the
        # default one bound, never a deleted name.
        self.ctx.detect_framebuffer(0).use()
        for mesh in self._meshes:
            if mesh is not None:
                for vao in mesh.vaos.values():
                    vao.release()
                mesh.vbo.release()
                mesh.ibo.release()
                mesh.inst_buf.release()
        for fbo, targets, depth in self._fbos.values():
            fbo.release()
            for t in (*targets, depth):
                t.release()
        self._meshes, self._fbos = [], {}

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()
