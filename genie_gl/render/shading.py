"""Shading, written once: a frame's :class:`~genie_gl.render.fragments.Fragments` into its
arrays and its :class:`~genie_gl.frame.Frame`.

Per pixel whose winner lies within the sensor's range ``[near_m, far_m]``: the depth
(float32 view z, m), the instance id and the semantic id of the winner's slot; elsewhere 0
(no return). On request, the camera-frame unit normal of the winner's face (towards the
eye), the colour (the instance's, Lambert with a head light) and the triangle under every
pixel a triangle won, in range or not, as (slot + 1, face within the slot's mesh)
(:class:`~genie_gl.triangles.PixelTriangles`, which effects use to intersect their own rays).

:func:`shade` computes all of this on the CPU from the CPU raster's winners (one compiled
pass, row by row). The GL raster's shader writes colour, normals and the triangle target
itself and packs depth and ids on the GPU: those stay there (moving them here would change
its bytes); its read-back decodes them with the same range rule
(:mod:`genie_gl.render.gl.readout`). :func:`to_frame` makes the Frame for both.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..frame import Frame
from ..jit import njit, prange, serial_copy
from ..sensors.camera import Sensor
from ..triangles import PixelTriangles, SceneTriangles
from .fragments import DrawnTriangles, Fragments
from .geometry import projection


NO_RAYS = np.zeros(1)  # _shade's rays_x, rays_y of a frame of pixel centres
NO_PIXEL = np.zeros(1, np.int64)  # _shade's pixel: pixel p shows ray p


class MeshArrays(NamedTuple):
    """The scene's meshes as uploaded: ``vertices`` (V, 3) float32 and ``faces`` (F, 3)
    uint32 joined, mesh after mesh, and per face its mesh's first vertex row ``face_vbase``
    (F,) int64."""

    vertices: np.ndarray
    faces: np.ndarray
    face_vbase: np.ndarray


class SlotShading(NamedTuple):
    """Per instance slot (N): ``camera_from_model`` (N, 3, 4) float64, ``instance`` (N,)
    uint32 and ``semantic`` (N,) ids, RGB ``color`` (N, 3) uint8, and ``face0`` (N,) int64,
    its mesh's first face in the joined faces."""

    camera_from_model: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    color: np.ndarray
    face0: np.ndarray


class FrameArrays(NamedTuple):
    """A frame's arrays, H x W flattened: ``depth`` (float32), ``instance`` (uint32),
    ``semantic`` (uint16), ``rgba`` (H W, 4) uint8, ``normal`` (H W, 3) float32,
    ``primitive`` (H W, 2) uint32 (one row each where not asked for)."""

    depth: np.ndarray
    instance: np.ndarray
    semantic: np.ndarray
    rgba: np.ndarray
    normal: np.ndarray
    primitive: np.ndarray


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def in_range(inverse_z, near_m, far_m):
    """The view z (m) of a winner of inverse depth ``inverse_z`` (1/m; 0: no hit) when it lies
    within the sensor's range [near_m, far_m], else 0.0 (no return): the CPU raster's range
    rule, for :func:`_shade` and for the frame of depth and ids its kernel fills as it draws."""
    if inverse_z > 0.0:
        z = 1.0 / inverse_z
        if z >= near_m and z <= far_m:
            return z
    return 0.0


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def in_range_f32(inverse_z, near_m, far_m):
    """:func:`in_range` as the frame's float32 depth, without a branch (a loop of it
    vectorises): the same value, 0 where out of range or no hit (1 / 0 is inf, out of
    range)."""
    z = 1.0 / inverse_z
    ok = (inverse_z > 0.0) & (z >= near_m) & (z <= far_m)
    return np.float32(z) if ok else np.float32(0.0)


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _vertex(vertices, vi, m, r):
    """Row r of camera_from_model ``m`` applied to vertex ``vi`` (float64)."""
    return (
        m[r, 0] * np.float64(vertices[vi, 0])
        + m[r, 1] * np.float64(vertices[vi, 1])
        + m[r, 2] * np.float64(vertices[vi, 2])
        + m[r, 3]
    )


@njit(cache=True, nogil=True, boundscheck=False, error_model="numpy", inline="always")
def _depth_ids(iz, hit, ids, sems, near_m, far_m, arrays, p):
    """Pixel ``p`` of a frame's (depth, instance, semantic) ``arrays`` from a winner of inverse
    depth ``iz`` and ``hit`` (slot << 32 | face): its z by :func:`in_range`'s rule and its
    slot's ids, or nothing."""
    z = in_range(iz, near_m, far_m)
    if z != 0.0:
        sl = hit >> np.int64(32)
        arrays[0][p] = np.float32(z)
        arrays[1][p] = ids[sl]
        arrays[2][p] = sems[sl]
    else:
        arrays[0][p] = 0.0
        arrays[1][p] = 0
        arrays[2][p] = 0


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy")
def _shade(
    depth,
    hit,
    mesh,
    slots,
    proj,
    rays_x,
    rays_y,
    pixel,
    near_m,
    far_m,
    width,
    out,
    want_rgb,
    want_normal,
    want_tri,
):
    """The frame's arrays ``out`` (:class:`FrameArrays`) from the drawn buffers (``depth``:
    (H W,) float64 1 / z, 0 where nothing; ``hit``: slot << 32 | face), row by row in
    parallel: z in [near_m, far_m] (else no return), instance and semantic ids, and on
    request the face normal (camera frame, towards the eye), the colour (the instance's,
    Lambert with a head light, as the GL shader) and the (slot + 1, face within the slot's
    mesh) of every pixel a triangle won, in range or not; ``mesh``: the scene's
    :class:`MeshArrays`, ``slots``: the :class:`SlotShading`. Pixel p's ray is
    ``K^-1 (u, v, 1)`` from ``proj`` or, when ``rays_x`` has more than one element, ``(rays_x[p],
    rays_y[p], 1)`` (a frame whose rays are not pixel centres: a lens's); when ``pixel`` has
    more than one element, pixel p shows the winner of ray ``pixel[p]`` of ``depth`` and
    ``hit`` (the raster holds a lens's rays in the order of their bins; -1: pixel p is left
    as it is). A face's unit normal is computed once per run of pixels that show it."""
    vertices, faces, fvbase = mesh.vertices, mesh.faces, mesh.face_vbase
    cfm, ids, sems, color, slot_face0 = (
        slots.camera_from_model,
        slots.instance,
        slots.semantic,
        slots.color,
        slots.face0,
    )
    out_depth, out_instance, out_semantic = out.depth, out.instance, out.semantic
    out_rgb, out_normal, out_tri = out.rgba, out.normal, out.primitive
    fx, s, cx, fy, cy = proj[0], proj[1], proj[2], proj[3], proj[4]
    W = int(width)
    n = len(out_depth)
    rays = len(rays_x) > 1
    mapped = len(pixel) > 1
    rows = n // W
    ids_only = not (want_rgb or want_normal or want_tri)
    arrays = (out_depth, out_instance, out_semantic)
    for v in prange(rows):
        if ids_only:  # depth and ids alone: the range rule and the slot's ids, no more
            for p in range(v * W, (v + 1) * W):
                j = pixel[p] if mapped else p
                if j >= 0:
                    _depth_ids(depth[j], hit[j], ids, sems, near_m, far_m, arrays, p)
            continue
        last = np.int64(-1)
        ux = uy = uz = 0.0
        for p in range(v * W, (v + 1) * W):
            j = pixel[p] if mapped else p  # the ray pixel p shows (-1: none, left as it is)
            if j < 0:
                continue
            iz = depth[j]
            h = hit[j] if iz > 0.0 else np.int64(-1)
            z = in_range(iz, near_m, far_m)
            if want_tri:
                if h < 0:
                    out_tri[p, 0] = 0
                    out_tri[p, 1] = 0
                else:
                    out_tri[p, 0] = np.uint32((h >> np.int64(32)) + 1)
                    out_tri[p, 1] = np.uint32(
                        (h & np.int64(0xFFFFFFFF)) - slot_face0[h >> np.int64(32)]
                    )
            if z == 0.0:  # no hit, or out of range
                out_depth[p] = 0.0
                out_instance[p] = 0
                out_semantic[p] = 0
                if want_rgb:
                    for k in range(4):
                        out_rgb[p, k] = 0
                if want_normal:
                    for k in range(3):
                        out_normal[p, k] = 0.0
                continue
            sl = h >> np.int64(32)
            out_depth[p] = np.float32(z)
            out_instance[p] = ids[sl]
            out_semantic[p] = sems[sl]
            if not (want_rgb or want_normal):
                continue
            if h != last:
                f = h & np.int64(0xFFFFFFFF)
                m = cfm[sl]
                va, vb, vc = (
                    fvbase[f] + faces[f, 0],
                    fvbase[f] + faces[f, 1],
                    fvbase[f] + faces[f, 2],
                )
                ax, ay, az = (
                    _vertex(vertices, va, m, 0),
                    _vertex(vertices, va, m, 1),
                    _vertex(vertices, va, m, 2),
                )
                bx, by, bz = (
                    _vertex(vertices, vb, m, 0) - ax,
                    _vertex(vertices, vb, m, 1) - ay,
                    _vertex(vertices, vb, m, 2) - az,
                )
                wx, wy, wz = (
                    _vertex(vertices, vc, m, 0) - ax,
                    _vertex(vertices, vc, m, 1) - ay,
                    _vertex(vertices, vc, m, 2) - az,
                )
                ux, uy, uz = by * wz - bz * wy, bz * wx - bx * wz, bx * wy - by * wx
                nl = math.sqrt(ux * ux + uy * uy + uz * uz)
                if nl > 0.0:
                    ux, uy, uz = ux / nl, uy / nl, uz / nl
                last = h
            if rays:
                xn, yn = rays_x[p], rays_y[p]
            else:
                u = p - v * W
                yn = (v - cy) / fy
                xn = (u - cx - s * yn) / fx
            dl = math.sqrt(xn * xn + yn * yn + 1.0)
            vx, vy, vz = xn / dl, yn / dl, 1.0 / dl
            nx, ny, nz = ux, uy, uz
            if nx == 0.0 and ny == 0.0 and nz == 0.0:
                nx, ny, nz = -vx, -vy, -vz
            if nx * vx + ny * vy + nz * vz > 0.0:
                nx, ny, nz = -nx, -ny, -nz
            if want_normal:
                out_normal[p, 0] = nx
                out_normal[p, 1] = ny
                out_normal[p, 2] = nz
            if want_rgb:
                lam = max(-(nx * vx + ny * vy + nz * vz), 0.0)
                for k in range(3):
                    out_rgb[p, k] = np.uint8(
                        min(255.0, np.floor(color[sl, k] * (0.2 + 0.8 * lam) + 0.5))
                    )
                out_rgb[p, 3] = 255


# the same kernel on the calling thread alone (a lens's frames drawn side by side)
_shade_serial = serial_copy(_shade, "_shade_serial")


@njit(cache=True, nogil=True, parallel=True, boundscheck=False, error_model="numpy")
def _ray_depth_ids(depth, hit, pixel_of, ids, sems, near_m, far_m, out):
    """A frame of depth and ids alone whose rays are not pixel centres (a lens's), in the
    rays' order: ray j (``depth``: 1 / z, ``hit``: slot << 32 | face) fills pixel
    ``pixel_of[j]`` of ``out`` (:class:`FrameArrays`) by :func:`in_range`'s rule, as
    :func:`_shade` would along the same ray. Read in order and written scattered: each pixel
    has one ray, and a lens's rays lie in the order of their bins, not of the pixels."""
    # (taken from the named tuple outside the parallel loop: its fields read by the inlined
    # helper inside the loop gave wrong frames)
    arrays = (out.depth, out.instance, out.semantic)
    n = len(pixel_of)
    chunk = 4096
    for c in prange(-(-n // chunk)):
        for j in range(c * chunk, min((c + 1) * chunk, n)):
            _depth_ids(depth[j], hit[j], ids, sems, near_m, far_m, arrays, pixel_of[j])


_ray_depth_ids_serial = serial_copy(_ray_depth_ids, "_ray_depth_ids_serial")


def shade(
    fragments: Fragments,
    vertices: np.ndarray,
    faces: np.ndarray,
    face_vbase: np.ndarray,
    cfm: np.ndarray,
    ids: np.ndarray,
    semantic: np.ndarray,
    color: np.ndarray,
    slot_face0: np.ndarray,
    K: np.ndarray,
    near_m: float,
    far_m: float,
) -> None:
    """Fill ``fragments.arrays`` (:func:`genie_gl.render.memory.frame_buffers`) from the CPU
    raster's winners (``inverse_z`` None: nothing drawn, all 0). The scene's joined
    ``vertices`` (V, 3) float32 and ``faces`` (F, 3), per face its mesh's first vertex row
    ``face_vbase`` (F,); per slot its camera_from_model ``cfm`` (N, 3, 4), ids, RGB colour
    (N, 3) uint8 and first face in the joined arrays ``slot_face0`` (N,)."""
    out = fragments.arrays
    if fragments.inverse_z is None:
        for a in out.values():
            a.fill(0)
        return
    want_rgb, want_normal, want_tri = "rgba" in out, "normal" in out, "primitive" in out
    _shade(
        fragments.inverse_z,
        fragments.winner,
        MeshArrays(vertices, faces, face_vbase),
        SlotShading(cfm, ids, semantic, color, slot_face0),
        projection(K),
        NO_RAYS,
        NO_RAYS,
        NO_PIXEL,
        float(near_m),
        float(far_m),
        fragments.width,
        FrameArrays(
            out["depth"].reshape(-1),
            out["instance"].reshape(-1),
            out["semantic"].reshape(-1),
            out["rgba"].reshape(-1, 4) if want_rgb else np.zeros((1, 4), np.uint8),
            out["normal"].reshape(-1, 3) if want_normal else np.zeros((1, 3), np.float32),
            out["primitive"].reshape(-1, 2) if want_tri else np.zeros((1, 2), np.uint32),
        ),
        want_rgb,
        want_normal,
        want_tri,
    )


def shade_rays(
    inverse_z: np.ndarray,
    winner: np.ndarray,
    mesh: MeshArrays,
    slots: SlotShading,
    rays: tuple[np.ndarray, np.ndarray],
    ray_of: np.ndarray,
    pixel_of: np.ndarray,
    width: int,
    near_m: float,
    far_m: float,
    out: FrameArrays,
    color: bool,
    normals: bool,
    serial: bool = False,
) -> None:
    """Shade a frame whose rays are not pixel centres (a lens's): pixel p (row-major, rows of
    ``width``) shows the winner the CPU raster found for ray ``ray_of[p]`` of ``inverse_z``
    and ``winner`` (-1: the pixel is left as it is), along its ray ``(x[p], y[p], 1)`` of ``rays``
    (the frame of ``slots``' camera_from_model); as :func:`shade` does for pixel centres;
    ``pixel_of``: the pixel of each ray (its inverse, -1 nowhere). A frame of depth and ids
    alone is filled in the rays' order (:func:`_ray_depth_ids`: the same values, the rays'
    arrays read in order). ``serial``: on the calling thread alone."""
    if not (color or normals):
        (_ray_depth_ids_serial if serial else _ray_depth_ids)(
            inverse_z,
            winner,
            pixel_of,
            slots.instance,
            slots.semantic,
            float(near_m),
            float(far_m),
            out,
        )
        return
    (_shade_serial if serial else _shade)(
        inverse_z,
        winner,
        mesh,
        slots,
        np.zeros(5),
        rays[0],
        rays[1],
        ray_of,
        float(near_m),
        float(far_m),
        int(width),
        out,
        bool(color),
        bool(normals),
        False,
    )


def to_frame(
    arrays: dict[str, np.ndarray],
    sensor: Sensor,
    pose: np.ndarray,
    color: bool,
    normals: bool,
    drawn: DrawnTriangles | None,
    scene: SceneTriangles | None,
    clip_near_m: float,
    render_ms: float,
) -> Frame:
    """The :class:`~genie_gl.frame.Frame` of a shaded frame's ``arrays``; ``drawn`` (with the
    meshes ``scene`` and the near plane the raster drew with): its
    :class:`~genie_gl.triangles.PixelTriangles` (None: none asked for)."""
    tri = (
        PixelTriangles(arrays["primitive"], *drawn, scene, clip_near_m)
        if drawn is not None
        else None
    )
    return Frame(
        arrays["depth"],
        arrays["instance"],
        arrays["semantic"],
        arrays["rgba"][..., :3] if color else None,
        sensor,
        pose,
        arrays["normal"] if normals else None,
        {"render_ms": render_ms},
        tri,
    )
