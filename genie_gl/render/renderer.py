"""The moderngl renderer: one geometry pass into depth, instance, semantic, colour, normals.

Geometry is uploaded once per scene, all meshes in one vertex and one index buffer, and
reused for every camera. A frame is at most two multi-draw-indirect calls: one command per
instance that survives frustum culling (its camera_from_model row picked by the command's
base instance), with back-face culling for closed meshes unless the camera is inside their
bounding box, and only the triangles that may cover a pixel centre (``render/cull.py``).
"""

from __future__ import annotations

import contextlib
import ctypes
import threading
import time
from collections.abc import Collection, Iterable, Iterator, Sequence
from typing import Any

import moderngl
import numpy as np

from ..validation.arguments import check_pose, expect
from ..errors import ConfigError, LimitError, RenderError
from ..limits import BYTES_PER_PIXEL, MAX_SIDE, check_frame_side, check_memory, memory_limit_bytes
from ..frame import Frame
from ..scene.model import Scene
from ..sensors.camera import Sensor
from ..triangles import SceneTriangles
from .clusters import Clusters, prepare
from .fragments import Fragments, no_triangles
from .context import GL_LOWER_LEFT, GL_ZERO_TO_ONE, GLContext, create_context
from .cull import TriangleCuller
from .lod import LevelOfDetail, simplified
from .memory import _POOL, frame_buffers  # noqa: F401  (_POOL: tests reach it here)
from .projection import clip_coefficients
from .raster import Rasteriser
from .rasters import resolve_raster
from .readback import semantic_table
from .readout import Readout
from .shader import load_program
from .shading import shade, to_frame
from .visibility import Visibility

# one row per drawn instance: camera_from_model (3 rows), ids, colour
INSTANCE_DTYPE = np.dtype(
    [("rows", "<f4", (3, 4)), ("instance", "<u4"), ("semantic", "<u4"), ("color", "u1", (4,))]
)
INSTANCE_FIELDS = (
    ("4f", 16, "in_row0"),
    ("4f", 16, "in_row1"),
    ("4f", 16, "in_row2"),
    ("u4", 4, "in_instance"),
    ("u4", 4, "in_semantic"),
    ("4f1", 4, "in_color"),
)

GL_TEXTURE_2D = 0x0DE1
GL_DEPTH_COMPONENT32F = 0x8CAC
GL_DEPTH_COMPONENT = 0x1902
GL_FLOAT = 0x1406

DEPTH_PRECISIONS = ("float32", "depth24", "reversed_z")
CPU_RASTER_BYTES_PER_PIXEL = (
    16  # the CPU raster's 1 / z (float64) and slot << 32 | face (int64) per pixel
)
GL_MAX_REACH_M = (
    1e5  # farther from the camera, float32 vertices lose pixels and depth (Renderer._check_reach)
)
TARGETS = ("packed", "separate")
READBACKS = ("direct", "pbo")
COMMAND_DTYPE = np.dtype(
    [
        ("count", "<u4"),
        ("instances", "<u4"),
        ("first", "<u4"),
        ("base_vertex", "<i4"),
        ("base_instance", "<u4"),
    ]
)  # DrawElementsIndirectCommand


class Renderer(Visibility, Readout):
    """Renders ideal pinhole frames of one scene from any number of cameras.

    Use as a context manager (or call :meth:`release`)::

        with gg.Renderer(scene) as r:
            frames = [r.render(sensor, pose) for pose in poses]
            frames = list(r.frames(sensor, poses))   # the same frames, CPU and GL overlapped

    All meshes of the scene share one vertex and one index buffer, uploaded once; a frame is
    at most two multi-draw calls (instances drawn with and without back-face culling), one
    command per instance, whatever the number of instances. Per frame, camera_from_model of
    every instance is composed in float64 by one vectorised product and cast to float32, so
    depth does not depend on where in the world the scene sits. With ``cull=True`` (the
    default) only the triangles that may cover a pixel centre are drawn
    (:mod:`genie_gl.render.cull`); the frames are the same bit for bit.

    Parameters
    ----------
    scene : Scene
    backend : "egl", "osmesa" or None (EGL, falling back to OSMesa).
    context : GLContext, an existing context to share (then ``backend`` is ignored and the
        context is not released with the renderer; unused with raster="cpu").
    raster : "gl" (default) or "cpu": which rasteriser draws (:mod:`genie_gl.render.rasters`;
        None: the machine's default, "cpu" without a hardware GPU). "cpu": no GL at all; the
        exact CPU rasteriser (:mod:`genie_gl.render.raster`) finds the nearest triangle along
        each pixel centre's ray in float64 and its exact depth (ids, colour and normals from
        that triangle). Faster than llvmpipe on scenes of a hundred thousand triangles and
        more (docs/real-size-scenes.md); against GL's "float32" the depth differs in the last
        bits and, at edges, a pixel centre may go to the neighbouring triangle.
        ``depth_precision``, ``targets`` and ``readback`` do not apply to it; ``cull=False``
        tests every triangle at every pixel centre of its box (the reference the culled
        frame equals byte for byte; slow).
    depth_precision : how the GL raster obtains ``Frame.depth`` (ids do not depend on it).
        "float32" (default): view z interpolated per fragment into a float32 target.
        "depth24": a 24-bit fixed-point window depth buffer of a conventional projection
        (near and far planes of the sensor), read back and linearised; its error grows as
        z² (as on most real-time renderers). "reversed_z": the float32 reversed, infinite-far
        depth buffer (near / z) read back and linearised.
    cull : drop triangles that cannot cover a pixel centre (exact; False draws everything). A
        frame with fewer than ``cull_min_faces`` faces in view is drawn whole either way.
    targets : "packed" (default): depth and instance id in one RG32UI target, the semantic id
        looked up per instance on read-back (:mod:`genie_gl.render.readback`); "separate":
        three targets (depth, instance, semantic). The frames are the same bit for bit.
    lod : a :class:`~genie_gl.render.lod.LevelOfDetail` to draw instances that look small
        with simplified copies of their meshes (changes pixels; None, the default: exact).
    readback : "direct" (default): :meth:`frames` reads each frame's targets into the frame's
        arrays once the next frame is submitted; "pbo": each frame is read into pixel buffer
        objects as soon as it is submitted and copied out a frame later (on llvmpipe this
        costs a second copy and is slower: see ``genie bench pipeline``).
    """

    cull_min_faces = 20_000  # fewer faces in view: drawing them all costs less than culling
    # fewer faces in view: no occlusion culling (a frame this small is cheap either way); with
    # more, it runs while it pays (:meth:`TriangleCuller.select`)
    occlusion_min_faces = 50_000

    def __init__(
        self,
        scene: Scene,
        *,
        backend: str | None = None,
        context: GLContext | None = None,
        depth_precision: str = "float32",
        cull: bool = True,
        targets: str = "packed",
        readback: str = "direct",
        lod: LevelOfDetail | None = None,
        raster: str | None = "gl",
    ):
        if depth_precision == "exact":
            raise ConfigError(
                "Renderer depth_precision='exact' is the CPU rasteriser: ask for it by name, "
                "raster='cpu' (depth_precision names the GL raster's depth buffers)"
            )
        for name, value, known in (
            ("depth_precision", depth_precision, DEPTH_PRECISIONS),
            ("targets", targets, TARGETS),
            ("readback", readback, READBACKS),
        ):
            if value not in known:
                raise ConfigError(
                    f"Renderer {name}={value!r} is unknown; expected one of {', '.join(known)}"
                )
        expect(scene, Scene, "Renderer: scene")
        if lod is not None and not isinstance(lod, LevelOfDetail):
            raise ConfigError(
                "Renderer lod: expected a genie_gl.render.LevelOfDetail or None, got "
                f"{type(lod).__name__}"
            )
        self._thread = threading.get_ident()  # GL contexts are current in one thread: see _current
        self.depth_precision, self.cull, self.lod = depth_precision, bool(cull), lod
        raster = resolve_raster(raster, "Renderer")
        self.targets, self.readback, self.raster = targets, readback, raster
        self._own_context = context is None and raster == "gl"
        self.gl = (
            None if raster == "cpu" else (context or create_context(backend))
        )  # the CPU raster: no GL
        self.ctx = self.gl.ctx if self.gl is not None else None
        self._programs = self.gl.programs if self.gl is not None else {}  # one build per context
        self._fbos: dict = {}
        self._vaos: dict = {}
        self._pbos: dict = {}  # readback="pbo": (framebuffer, read) -> pixel buffer object
        self._clip_control = (
            self.gl.gl_function("glClipControl", None, ctypes.c_uint, ctypes.c_uint)
            if self.gl is not None
            else None
        )
        self._gl_flush = None
        self._sizes_checked: set[tuple[int, int]] = (
            set()
        )  # frame sizes the CPU raster found room for
        self._culled = False
        self._lod_drawn = 0
        with self._current():
            self._upload(scene)
        self.stats: dict[str, float] = {}

    def _current(self) -> Any:
        if self.gl is None:  # the CPU raster: no context, any thread
            return contextlib.nullcontext()
        # made current around every call where the platform needs it (EGL), so other GL users
        # in the process (pyrender, a second Renderer) cannot leave theirs current under us
        if threading.get_ident() != self._thread:
            raise RenderError(
                "a Renderer is used from a thread other than the one that made it; its GL context "
                "belongs to that thread: make one Renderer per thread (or use gg.capture(..., "
                "workers=N), which renders in processes)"
            )
        return self.gl.current()

    # -- scene upload ------------------------------------------------------------------------
    def _upload(self, scene: Scene) -> None:
        ctx = self.ctx
        keys = list(scene.meshes)
        index = {k: i for i, k in enumerate(keys)}
        inst = scene.instances
        mesh_of = np.fromiter((index[i.mesh] for i in inst), dtype=np.int64, count=len(inst))
        n = len(keys)
        # each mesh placed by an instance is prepared once, however many instances place it;
        # with level of detail, its simplified copy goes in a slot of its own after the meshes
        prepared: dict[int, Clusters] = {}
        copies: list[tuple[int, Clusters, bool]] = []
        for i in np.unique(mesh_of):
            c = prepare(scene.meshes[keys[i]], keys[i])
            if len(c.faces):
                prepared[int(i)] = c
                small = (
                    simplified(scene.meshes[keys[i]], self.lod) if self.lod is not None else None
                )
                if small is not None:
                    copies.append((int(i), prepare(small, keys[i] + " (simplified)"), small.closed))
        self._copy_of = np.full(n, -1, np.int64)
        for k, (i, c, _) in enumerate(copies):
            self._copy_of[i] = n + k
            prepared[n + k] = c
        n += len(copies)
        vbase, fbase, nfaces, cbase = (np.zeros(n, np.int64) for _ in range(4))
        closed, lo, hi = np.zeros(n, bool), np.zeros((n, 3)), np.zeros((n, 3))
        centre, radius = np.zeros((n, 3)), np.zeros(n)
        v_at = f_at = c_at = 0
        for i, c in prepared.items():
            lo[i], hi[i] = c.lo, c.hi
            centre[i] = (lo[i] + hi[i]) / 2
            radius[i] = c.bound
            closed[i] = (
                bool(scene.meshes[keys[i]].closed) if i < len(keys) else copies[i - len(keys)][2]
            )
            vbase[i], fbase[i], nfaces[i], cbase[i] = v_at, f_at, len(c.faces), c_at
            v_at, f_at, c_at = v_at + len(c.vertices), f_at + len(c.faces), c_at + c.count
        drawable = np.zeros(len(keys), bool)
        drawable[[i for i in prepared if i < len(keys)]] = True
        keep = np.flatnonzero(drawable[mesh_of])
        order = keep[np.argsort(mesh_of[keep], kind="stable")]  # same mesh, scene order
        self._mesh = mesh_of[order]
        N = len(order)
        self._world_from_model = (
            np.stack([inst[k].world_from_model for k in order]).astype(np.float64)
            if N
            else np.zeros((0, 4, 4))
        )
        self._model_from_world = np.linalg.inv(self._world_from_model) if N else np.zeros((0, 4, 4))
        self._det = np.linalg.det(self._world_from_model[:, :3, :3]) if N else np.zeros(0)
        self._ids = np.array([inst[k].instance for k in order], dtype=np.uint32)
        self._id_order = np.argsort(self._ids, kind="stable")  # None below when an id is used twice
        if len(self._ids) > 1 and (np.diff(self._ids[self._id_order].astype(np.int64)) == 0).any():
            self._id_order = None
        self._scale = (
            np.linalg.norm(self._world_from_model[:, :3, :3], axis=1).max(axis=1)
            if N
            else np.zeros(0)
        )
        self._rows = np.zeros(N, INSTANCE_DTYPE)
        self._rows["instance"] = self._ids
        self._rows["semantic"] = [inst[k].semantic for k in order]
        self._rows["color"][:, 3] = 255
        if N:
            self._rows["color"][:, :3] = np.array([inst[k].color for k in order], dtype=np.uint8)
        self._semantics = (
            semantic_table(self._ids, self._rows["semantic"]) if self.targets == "packed" else None
        )
        self._packed = self._semantics is not None  # an id used twice: three targets
        self._vbase, self._fbase, self._nfaces = vbase, fbase, nfaces
        self._closed, self._lo, self._hi, self._centre, self._radius = (
            closed,
            lo,
            hi,
            centre,
            radius,
        )
        self.triangles = int(nfaces[self._mesh].sum()) if N else 0
        parts = list(prepared.values())

        def joined(name: str, empty: np.ndarray) -> np.ndarray:
            return np.concatenate([getattr(c, name) for c in parts]) if parts else empty

        vertices = joined("vertices", np.zeros((1, 3), "<f4"))
        all_faces = joined("faces", np.zeros((1, 3), "<u4"))
        self._scene_triangles: SceneTriangles | None = (
            None  # made when a frame first asks for triangles
        )
        self._culler = TriangleCuller(
            vertices,
            all_faces,
            vbase,
            fbase,
            nfaces,
            cbase,
            joined("centre", np.zeros((1, 3))),
            joined("radius", np.zeros(1)),
            joined("vrange", np.zeros((1, 2), np.int64)),
            joined("axis", np.zeros((1, 3))),
            joined("cos_a", np.zeros(1)),
            joined("sin_a", np.zeros(1)),
            joined("thickness", np.zeros(1)),
            joined("perimeter", np.ones(1)),
            snap_px=2.0 ** -(self.gl.subpixel_bits() if self.gl is not None else 4),
        )  # twice the farthest snap
        self._rasteriser = Rasteriser(self._culler) if self.raster == "cpu" else None
        self._vbo = ctx.buffer(vertices.tobytes()) if ctx is not None else None
        self._ibo = ctx.buffer(all_faces.tobytes()) if ctx is not None else None
        self._slot_buf = None  # 0, 1, 2, ... read per instance by the triangle target's program
        self._streams: dict[int, tuple] = {}  # per-frame buffers, one set per frame in flight

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

    # -- GL objects ---------------------------------------------------------------------------
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

    # -- rendering -----------------------------------------------------------------------------
    def render(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        *,
        depth_only: bool = False,
        normals: bool = False,
        only: Collection[int] | None = None,
        triangles: bool = False,
    ) -> Frame:
        """Render the pinhole frame of ``sensor`` at ``pose``, without its effects.

        The renderer draws pinhole views only: a distorted sensor is rendered through its lens
        by the capture stage (:func:`genie_gl.capture.through_lens` wraps this method;
        ``gg.render`` and ``gg.capture`` do it). Surfaces nearer than the sensor's minimum
        range ``near_m`` give no return (depth 0, ids 0).

        Parameters
        ----------
        sensor : Sensor (or Camera) of a pinhole lens: image size, K and range.
        pose : (4, 4) float64 world_from_camera (OpenCV camera frame).
        depth_only : skip the colour buffer (``Frame.rgb`` is None).
        normals : also render camera-frame unit normals (``Frame.normal``).
        only : draw just the instances with these ids (e.g. an object's full silhouette).
        triangles : also record the triangle each pixel shows (``Frame.triangles``, a
            :class:`~genie_gl.triangles.PixelTriangles`: one more target), for a lens that
            intersects its own pixels' rays with them.
        """
        if not sensor.is_pinhole:
            raise ConfigError(
                f"Renderer.render: sensor {getattr(sensor, 'name', '')!r} has lens distortion and "
                "the "
                "renderer draws pinhole views; render it through its lens with "
                "genie_gl.capture.through_lens(renderer.render), gg.render or gg.capture"
            )
        with self._current():
            if self.raster == "cpu":
                return self._render_cpu(sensor, pose, not depth_only, normals, only, triangles)
            return self._render(sensor, pose, depth_only, normals, only, triangles)

    def frames(
        self,
        sensor: Sensor,
        poses: Iterable[np.ndarray],
        *,
        depth_only: bool = False,
        normals: bool = False,
        only: Sequence[Collection[int] | None] | None = None,
        triangles: bool = False,
    ) -> Iterator[Frame]:
        """The frames of ``sensor`` at ``poses``, in order, equal to ``render`` pose by pose.
        Frame i is copied out of its targets once it has rasterised, and unpacked into its
        Frame, and handed to the caller, only after frame i+1 is submitted (into a second set
        of targets): its unpacking and the caller's work on it run while frame i+1
        rasterises. (A read waits for every frame submitted before it, so frame i is copied
        before frame i+1 is submitted; see docs/pipeline.md.)
        ``only``: per pose, the ids to draw (None: all), as ``render(..., only=)``; ``triangles``
        as ``render(..., triangles=)``."""
        if not sensor.is_pinhole:
            raise ConfigError(
                f"Renderer.frames: sensor {getattr(sensor, 'name', '')!r} has lens distortion and "
                "the "
                "renderer draws pinhole views (gg.capture renders it through its lens)"
            )
        if self.raster == "cpu":  # nothing to overlap: each frame is drawn when it is asked for
            for k, pose in enumerate(poses):
                yield self._render_cpu(
                    sensor,
                    pose,
                    not depth_only,
                    normals,
                    None if only is None else only[k],
                    triangles,
                )
            return
        fetched = None  # the frame read back last, not yet unpacked
        planned = None  # the next frame, culled and its draws written, not yet issued
        for k, pose in enumerate(poses):
            with self._current():
                job = self._plan(
                    sensor,
                    pose,
                    not depth_only,
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

    def _render(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        depth_only: bool,
        normals: bool,
        only: Collection[int] | None = None,
        triangles: bool = False,
    ) -> Frame:
        return self._read(
            self._draw(sensor, pose, not depth_only, normals, only, slot=0, triangles=triangles),
            finish=True,
        )

    def _draw(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        slot: int,
        triangles: bool = False,
    ) -> dict:
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
    ) -> dict:
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
        lists = self._commands(pose, K, W, H, clip_near, only, parity, triangles)
        return {
            "sensor": sensor,
            "pose": pose,
            "color": color,
            "normals": normals,
            "slot": slot,
            "fbo": fbo,
            "fbo24": None,
            "extra": extra,
            "program": program,
            "proj": (proj_x, proj_y),
            "lists": lists,
            "culled": self._culled,
            "pixel_triangles": self._frame_triangles if triangles else None,
            "drawn": 0,
            "triangles": int(sum(int(c["count"].sum()) for c, _ in lists) // 3),
            "simplified": self._lod_drawn,
            "occluded": self._culled and self._culler.occluded,
            "t0": t0,
            "t1": time.perf_counter(),
        }

    def _issue(self, job: dict) -> None:
        """The GL half of a frame's draws (after :meth:`_plan`): its targets cleared, its
        draws submitted (and the 24-bit depth pass, with that precision)."""
        job["t_issue"] = time.perf_counter()
        ctx, sensor, fbo, lists = self.ctx, job["sensor"], job["fbo"], job.pop("lists")
        W, H = sensor.width, sensor.height
        parity = job["slot"] % 2
        fbo.use()
        ctx.viewport = (0, 0, W, H)
        self._clip_control(GL_LOWER_LEFT, GL_ZERO_TO_ONE)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = ">"
        # v grows with window y (row 0 = v = 0) mirrors the image, so outward CCW faces are CW
        ctx.front_face = "cw"
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=0.0)  # 0.0f has all bits zero: ids clear to 0
        job["drawn"] = self._submit(job.pop("program"), lists, parity, job["culled"])
        if self.depth_precision == "depth24":
            n, f = float(sensor.near_m), float(sensor.far_m)
            proj_x, proj_y = job["proj"]
            fbo24 = job["fbo24"] = job["extra"][0]
            p24 = self._program(
                ("NO_LINEAR_DEPTH", "DEPTH_ONLY") + (("PACKED_IDS",) if self._packed else ())
            )
            p24["u_proj_x"].value = tuple(proj_x.astype(np.float32))
            p24["u_proj_y"].value = tuple(proj_y.astype(np.float32))
            p24["u_depth"].value = (f / (f - n), -f * n / (f - n))  # window depth = A + B / z
            fbo24.use()
            ctx.depth_func = "<"
            fbo24.clear(depth=1.0)
            self._submit(p24, lists, parity, job["culled"])
        ctx.disable(moderngl.CULL_FACE)

    def _render_cpu(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        triangles: bool,
    ) -> Frame:
        """A frame drawn by the CPU rasteriser (:mod:`genie_gl.render.raster`)."""
        t0 = time.perf_counter()
        W, H, K = sensor.width, sensor.height, sensor.K
        pose = check_pose(pose, "render pose")
        if (W, H) not in self._sizes_checked:
            check_frame_side(W, H, "Renderer", MAX_SIDE, "the largest frame genie-gl draws")
            # the raster's buffers (1 / z float64, slot and face int64) and the frame's arrays
            check_memory(
                W * H * (CPU_RASTER_BYTES_PER_PIXEL + BYTES_PER_PIXEL),
                memory_limit_bytes(),
                f"a {W}x{H} px frame x {CPU_RASTER_BYTES_PER_PIXEL + BYTES_PER_PIXEL} B",
                "Renderer: use a smaller sensor",
                option=None,
            )
            self._sizes_checked.add((W, H))
        near = float(sensor.clip_near_m)
        out = frame_buffers(H, W, color, normals, triangles)
        seen = self._visible(pose, K, W, H, near, only)
        drawn_triangles = no_triangles(self._ids, self._rows["semantic"]) if triangles else None
        fragments = Fragments(H, W, None, None, out)
        drawn = faces = simplified = 0
        face0 = np.zeros(len(self._mesh), np.int64)
        cfm = np.zeros((max(1, len(self._mesh)), 3, 4))
        if seen is not None:
            cfm, slots, m = seen.camera_from_model, seen.slots, seen.mesh
            r = self._rasteriser
            r.face_vbase(self._vbase, self._fbase, self._nfaces)
            ids_only = not (color or normals or triangles) and H * W > 1
            inverse_z, winner = r.draw(
                slots,
                m,
                seen.backcull,
                cfm,
                seen.eye,
                self._det[slots],
                K,
                W,
                H,
                near,
                seen.planes,
                self.cull,
                (self._ids, self._rows["semantic"], sensor.near_m, sensor.far_m, out)
                if ids_only
                else None,
            )
            fragments = Fragments(H, W, inverse_z, winner, out, shaded=ids_only)
            face0[slots] = self._fbase[m]
            drawn, faces, simplified = len(slots), int(self._nfaces[m].sum()), seen.simplified
            if triangles:
                d = drawn_triangles
                d.first[slots], d.count[slots], d.base_vertex[slots], d.backcull[slots] = (
                    self._fbase[m],
                    self._nfaces[m],
                    self._vbase[m],
                    seen.backcull,
                )
                d.mesh_first[slots], d.mesh_count[slots] = self._fbase[m], self._nfaces[m]
                drawn_triangles = d._replace(
                    camera_from_model=cfm, indices=self._culler.faces.reshape(-1)
                )
        t1 = time.perf_counter()
        rgb = self._rows["color"][:, :3] if len(self._mesh) else np.zeros((1, 3), np.uint8)
        if not fragments.shaded:  # (a frame of depth and ids alone was filled as it was drawn)
            shade(
                fragments,
                self._culler.vertices,
                self._culler.faces,
                self._rasteriser.face_vbase(self._vbase, self._fbase, self._nfaces),
                cfm,
                self._ids,
                self._rows["semantic"],
                rgb,
                face0,
                K,
                sensor.near_m,
                sensor.far_m,
            )
        t2 = time.perf_counter()
        self.stats = {
            "cull_s": 0.0,
            "draw_s": t1 - t0,
            "readback_s": t2 - t1,
            "instances_drawn": drawn,
            "triangles_drawn": faces,
            "instances_simplified": simplified,
            "occlusion_culled": False,
        }
        return to_frame(
            out,
            sensor,
            pose,
            color,
            normals,
            drawn_triangles,
            self._triangle_scene() if triangles else None,
            near,
            1e3 * (t2 - t0),
        )

    def _flush(self) -> None:
        if self._gl_flush is None:
            self._gl_flush = self.gl.gl_function("glFlush", None)
        self._gl_flush()

    def _triangle_scene(self) -> SceneTriangles:
        """The scene's meshes for :class:`PixelTriangles`, made the first time a frame asks
        for triangles."""
        if self._scene_triangles is None:
            self._scene_triangles = SceneTriangles.build(self._culler.vertices, self._culler.faces)
        return self._scene_triangles

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
    ) -> list[tuple[np.ndarray, bool]]:
        """Draw commands of a frame: [(commands, back-face culling)], nothing in Python per
        instance. With ``triangles``, ``self._frame_triangles`` is set to what turns a pixel's
        (slot, triangle) into vertices (the fields of :class:`PixelTriangles` after ``pixel``)."""
        if triangles:
            self._frame_triangles = no_triangles(self._ids, self._rows["semantic"])
        seen = self._visible(pose, K, W, H, near, only)
        self._lod_drawn = 0 if seen is None else seen.simplified
        if seen is None:
            return []
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
        self._culled = culled
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
            first, count, base, cull = self._frame_triangles[:4]
            first[cmd["base_instance"]] = cmd["first"] // 3
            count[cmd["base_instance"]] = cmd["count"] // 3
            base[cmd["base_instance"]] = cmd["base_vertex"]
            cull[cmd["base_instance"]] = backcull
            # the culled indices are rewritten by the next frame's culling: this frame keeps a copy
            drawn_indices = indices.copy() if culled else self._culler.faces.reshape(-1)
            ids, sem, mesh_first, mesh_count = self._frame_triangles[6:]
            mesh_first[slots], mesh_count[slots] = (
                self._fbase[m],
                self._nfaces[m],
            )  # every face, culled or not
            self._frame_triangles = (
                first,
                count,
                base,
                cull,
                cfm,
                drawn_indices,
                ids,
                sem,
                mesh_first,
                mesh_count,
            )
        return [(cmd[backcull == flag], flag) for flag in (True, False) if (backcull == flag).any()]

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

    # -- lifetime ---------------------------------------------------------------------------
    def release(self) -> None:
        """Free the GL objects (and the context, when the renderer created it)."""
        if self.gl is None:
            return
        with self._current():
            self._release_objects()
        if self._own_context:
            self.gl.release()

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

    def __enter__(self) -> "Renderer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()
