"""The renderer of pinhole frames: one scene uploaded once, drawn from any number of cameras,
by one of two rasters.

:class:`Renderer` is the public entry: ``Renderer(scene, raster=...)`` makes the renderer
of the raster named (:mod:`genie_gl.render.rasters`), an instance of its own class:

- :class:`~genie_gl.render.cpu.renderer.CPURenderer` (``raster="cpu"``,
  :mod:`genie_gl.render.cpu`): the exact CPU raster, no GL;
- :class:`~genie_gl.render.gl.renderer.GLRenderer` (``raster="gl"``,
  :mod:`genie_gl.render.gl`): moderngl on the machine's OpenGL driver.

Both stand on what this module and its neighbours share: the scene's upload (its meshes
prepared into clusters, :mod:`~genie_gl.render.clusters`; one row per instance), the
instances a frame draws (:mod:`~genie_gl.render.visibility`), the per-pixel winner a raster
hands over (:mod:`~genie_gl.render.fragments`, where each raster's winner rule is written)
and the shading of it into a :class:`~genie_gl.frame.Frame`
(:mod:`~genie_gl.render.shading`).
"""

from __future__ import annotations

import contextlib
from collections.abc import Collection, Iterable, Iterator, Sequence
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from ..scene.model import Scene
from ..sensors.camera import Sensor
from ..triangles import SceneTriangles
from ..validation.arguments import expect
from .clusters import Clusters, prepare
from .cull import TriangleCuller
from .lod import LevelOfDetail, simplified
from .rasters import resolve_raster
from .visibility import Visibility

# one row per instance slot: camera_from_model (3 rows, written per frame by the GL raster),
# ids, colour
INSTANCE_DTYPE = np.dtype(
    [("rows", "<f4", (3, 4)), ("instance", "<u4"), ("semantic", "<u4"), ("color", "u1", (4,))]
)
DEPTH_PRECISIONS = ("float32", "depth24", "reversed_z")
TARGETS = ("packed", "separate")
READBACKS = ("direct", "pbo")


class Renderer(Visibility):
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
        None: the machine's default, "cpu" without a hardware GPU); the renderer made is an
        instance of that raster's class (a :class:`Renderer` either way). "cpu"
        (:class:`~genie_gl.render.cpu.renderer.CPURenderer`): no GL at all; the exact CPU
        rasteriser (:mod:`genie_gl.render.cpu.raster`) finds the nearest triangle along
        each pixel centre's ray in float64 and its exact depth (ids, colour and normals from
        that triangle; ties: :mod:`genie_gl.render.fragments`). Faster than llvmpipe on
        scenes of a hundred thousand triangles and more (docs/real-size-scenes.md); against
        GL's "float32" the depth differs in the last bits and, at edges, a pixel centre may
        go to the neighbouring triangle.
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
        looked up per instance on read-back (:mod:`genie_gl.render.gl.readback`); "separate":
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
    raster: str  # the raster's name, set by each raster's class
    # whether :meth:`render` and :meth:`frames` draw a distorted sensor's own pixel rays (the
    # CPU raster); else they draw pinhole views only (a lens is resampled from them)
    draws_lenses: ClassVar[bool] = False
    _rasters: ClassVar[dict[str, type[Renderer]]] = {}  # name -> class, filled as they are defined

    def __init_subclass__(cls, raster: str | None = None, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        if raster is not None:
            cls.raster = raster
            Renderer._rasters[raster] = cls

    def __new__(cls, *args: Any, raster: str | None = "gl", **kw: Any) -> Renderer:
        """``Renderer(...)`` makes the renderer of the raster named by ``raster`` (None: the
        machine's default); a raster's own class makes its own."""
        if cls is Renderer:
            cls = Renderer._rasters[resolve_raster(raster, "Renderer")]
        return super().__new__(cls)

    def __init__(
        self,
        scene: Scene,
        *,
        backend: str | None = None,
        context: Any = None,
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
        self.depth_precision, self.cull, self.lod = depth_precision, bool(cull), lod
        self.targets, self.readback = targets, readback
        self._open(backend, context)
        with self._current():
            self._upload(scene)
        self.stats: dict[str, float] = {}

    # -- what each raster provides -------------------------------------------------------------
    def _open(self, backend: str | None, context: Any) -> None:
        """Start what the raster draws with (the GL raster: its context)."""

    def _current(self) -> Any:
        """A context manager around every call that draws (the GL raster: its context made
        current)."""
        return contextlib.nullcontext()

    def _snap_px(self) -> float:
        """The culler's error bound for the raster's sub-pixel snapping, pixels (see
        :mod:`genie_gl.render.cull`): twice 1/16, GL's least snapping step."""
        return 2.0**-4

    def _uploaded(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        """Take what the raster needs of the upload (the joined ``vertices`` (V, 3) float32
        and ``faces`` (F, 3) uint32)."""

    def _frame(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        triangles: bool,
    ) -> Frame:
        """One frame (:meth:`render`'s, inside :meth:`_current`)."""
        raise NotImplementedError

    def _frames(
        self,
        sensor: Sensor,
        poses: Iterable[np.ndarray],
        color: bool,
        normals: bool,
        only: Sequence[Collection[int] | None] | None,
        triangles: bool,
    ) -> Iterator[Frame]:
        """The frames of :meth:`frames`."""
        raise NotImplementedError

    def release(self) -> None:
        """Free what the raster holds (GL objects; the context, when the renderer made it)."""

    # -- scene upload ------------------------------------------------------------------------
    def _upload(self, scene: Scene) -> None:
        """The scene's meshes prepared once each (:func:`~genie_gl.render.clusters.prepare`),
        joined into one vertex and one index array; per instance slot its transform, ids and
        colour (instances of one mesh in adjacent slots, in scene order); the culler over the
        joined clusters. The raster then takes what it needs (:meth:`_uploaded`)."""
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
        # (contiguous copies for the kernels: a field of the rows is strided except in a scene
        # of one instance, and numba compiles or loads a kernel once per layout)
        self._semantic = np.ascontiguousarray(self._rows["semantic"])
        self._colour = np.ascontiguousarray(self._rows["color"][:, :3])
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
            snap_px=self._snap_px(),
        )
        self._uploaded(vertices, all_faces)

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
        if not (sensor.is_pinhole or self.draws_lenses):
            raise ConfigError(
                f"Renderer.render: sensor {getattr(sensor, 'name', '')!r} has lens distortion and "
                "the "
                "renderer draws pinhole views; render it through its lens with "
                "genie_gl.capture.through_lens(renderer.render), gg.render or gg.capture"
            )
        with self._current():
            return self._frame(sensor, pose, not depth_only, normals, only, triangles)

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
        The GL raster overlaps them: frame i is copied out of its targets once it has
        rasterised, and unpacked into its Frame, and handed to the caller, only after frame
        i+1 is submitted (into a second set of targets): its unpacking and the caller's work
        on it run while frame i+1 rasterises. (A read waits for every frame submitted before
        it, so frame i is copied before frame i+1 is submitted; see docs/pipeline.md.) The
        CPU raster draws frames of depth and ids alone (a pinhole's or a lens's) side by
        side, one per thread, ahead of the caller
        (:meth:`genie_gl.render.cpu.renderer.CPURenderer._frames`), any other frame when
        it is asked for.
        ``only``: per pose, the ids to draw (None: all), as ``render(..., only=)``; ``triangles``
        as ``render(..., triangles=)``."""
        if not (sensor.is_pinhole or self.draws_lenses):
            raise ConfigError(
                f"Renderer.frames: sensor {getattr(sensor, 'name', '')!r} has lens distortion and "
                "the "
                "renderer draws pinhole views (gg.capture renders it through its lens)"
            )
        yield from self._frames(sensor, poses, not depth_only, normals, only, triangles)

    def _triangle_scene(self) -> SceneTriangles:
        """The scene's meshes for :class:`PixelTriangles`, made the first time a frame asks
        for triangles."""
        if self._scene_triangles is None:
            self._scene_triangles = SceneTriangles.build(self._culler.vertices, self._culler.faces)
        return self._scene_triangles

    # -- lifetime ---------------------------------------------------------------------------
    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()
