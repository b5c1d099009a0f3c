"""Rendering through a lens: pinhole views rendered, then resampled into the lens's image.

A lens whose field one pinhole render can hold (up to ~150° across) is rendered as one wide
pinhole view covering the rays of every pixel (its principal point aligned to whole pixels of
the sensor's grid, so undistorted parts of the image sample pixel centres exactly). A wider
lens (a fisheye) is rendered as the faces of a cube around the camera (front and the four
sides, each cropped to the rays that fall on it). Each pixel of the lens's image then takes
its ray's sample from its view:

``resample="exact"`` (default)
    the pixel's own ray intersected (float64) with the faces, around where it crosses the
    view, of every instance the view shows (the view records which triangle each of its
    pixels shows): instance, semantic id, depth and normal of the nearest face the ray hits,
    whatever the distortion, as a ray caster finds them (:mod:`.ray_hits`, which also says
    what an instance finer than the view's pixels does); colour from a view pixel of that
    instance.
``"plane"``
    ids and colour from the nearest view pixel; depth recomputed along the pixel's own ray
    from the plane of the triangle the nearest view pixel hit (its rendered normal and
    depth): exact on planar surfaces (to float32), ids within half a view pixel.
``"bilinear"``
    depth interpolated between the four view pixels around the ray when all four hit the
    same instance (never across a silhouette), else the nearest; ids never blended.
``"nearest"``
    everything from the nearest view pixel (the depth of that pixel's ray).

``oversample`` scales the views' focal lengths (more pixels per ray of the lens: in the modes
that take a view pixel's id, ids and edges land closer to where the lens puts them, within
half a view pixel of where the lens puts the ray; in the exact mode, finer triangles are
resolved). The default, 0, is automatic: the smallest
whole factor that gives every lens pixel at least 0.8 view pixels (1 for barrel distortion
and the shipped profiles, 2 for k1 = +0.5 pincushion and a 180° fisheye's rim), so ids land
within 0.625 lens pixels. Pixels whose ray the lens does not have
(past its fold, 90° or more off the axis) get no return. The lens maps themselves are
:meth:`genie_gl.camera.Camera.unproject` / ``project``, written once.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..camera import Camera, distort_normalized
from ..errors import ConfigError
from ..frame import Frame
from ..sensors.camera import Sensor
from .ray_hits import STATS, resample_rays
from .resample import MODES, resample_view

RESAMPLE_MODES = ("nearest", "bilinear", "plane", "exact")
DEFAULT_RESAMPLE = "exact"
DEFAULT_OVERSAMPLE = 0.0  # automatic (see the module docstring)
MAX_AUTO_OVERSAMPLE = 4
AUTO_MIN_SCALE = 0.8  # automatic oversampling keeps at least this many view pixels per lens pixel
MAX_SINGLE_VIEW_TAN = math.tan(math.radians(75.0))  # wider than this: cube faces
MAX_VIEW_PX = 4096
FACES = {  # camera_from_view rotations: columns are the view's x, y, z axes in the camera frame
    "front": np.eye(3),
    "+x": np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float),
    "-x": np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]], float),
    "+y": np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float),
    "-y": np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float),
}


@dataclass(frozen=True, eq=False)
class DistortionMaps:
    """One pinhole view behind a lens image, and where each pixel it serves samples it.

    Attributes
    ----------
    render_sensor : Sensor, the view to render (a pinhole; for an effect, the frame's own camera).
    map_x, map_y : (H, W) float32, sample position in the view's pixels (-1 where not served).
    valid : (H, W) bool, the lens pixels this view serves.
    rotation : (3, 3) float64, camera_from_view (identity for a front view).
    ray_x, ray_y : (H, W) float64, each served pixel's ray in the view frame on z = 1.
    z_scale : (H, W) float64, camera-frame depth per view-frame depth along the pixel's ray.
    """

    render_sensor: Sensor
    map_x: np.ndarray
    map_y: np.ndarray
    valid: np.ndarray
    rotation: np.ndarray | None = None
    ray_x: np.ndarray | None = None
    ray_y: np.ndarray | None = None
    z_scale: np.ndarray | None = None
    scale_min: float = 1.0
    cache: dict = field(default_factory=dict, repr=False)  # resampling plans, per source camera


def check_resample(resample: str, oversample: float | None) -> float:
    """Validate the keyword arguments; returns the oversampling to use."""
    if resample not in RESAMPLE_MODES:
        raise ConfigError(
            f"resample: unknown mode {resample!r}; expected one of {', '.join(RESAMPLE_MODES)}"
        )
    os_ = DEFAULT_OVERSAMPLE if oversample is None else float(oversample)
    if not (0.25 <= os_ <= 8 or os_ == 0):
        raise ConfigError(
            f"oversample: expected 0 (automatic) or a factor in [0.25, 8], got {oversample}"
        )
    return os_


def _view(
    sensor: Camera,
    rot: np.ndarray,
    name: str,
    serve: np.ndarray,
    xv: np.ndarray,
    yv: np.ndarray,
    fx: float,
    fy: float,
    cx0: float,
    cy0: float,
    z_scale: np.ndarray | None,
) -> DistortionMaps:
    """A view with focal (fx, fy) whose principal point is (cx0, cy0) shifted by whole pixels
    so that every served ray lies at least 1 pixel inside it."""
    if serve.any():
        lo_x, hi_x = xv[serve].min(), xv[serve].max()
        lo_y, hi_y = yv[serve].min(), yv[serve].max()
    else:
        lo_x = hi_x = lo_y = hi_y = 0.0
    cx = cx0 + math.ceil(1 - fx * lo_x - cx0)
    cy = cy0 + math.ceil(1 - fy * lo_y - cy0)
    w = int(math.ceil(fx * hi_x + cx)) + 3
    h = int(math.ceil(fy * hi_y + cy)) + 3
    if max(w, h) > MAX_VIEW_PX:
        raise ConfigError(
            f"sensor {getattr(sensor, 'name', '')}: its lens needs a {w}x{h} pinhole view "
            f"(more than {MAX_VIEW_PX}); lower oversample"
        )
    K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
    # a front view's z is the camera's: it takes the sensor's range; a cube face's z is not,
    # so it renders everything and the range is applied after resampling
    front = rot is None or not np.any(rot - np.eye(3))
    near, far = (
        (sensor.near_m, sensor.far_m)
        if front
        else (sensor.clip_near_m, max(sensor.far_m * 1e3, 1.0))
    )
    view = Sensor(w, h, K, near_m=near, far_m=far, name=f"{getattr(sensor, 'name', '')}-{name}")
    mx = np.where(serve, fx * xv + cx, -1.0)
    my = np.where(serve, fy * yv + cy, -1.0)
    return DistortionMaps(
        view,
        mx.astype(np.float32),
        my.astype(np.float32),
        serve,
        rot,
        np.where(serve, xv, 0.0),
        np.where(serve, yv, 0.0),
        None if z_scale is None else np.where(serve, z_scale, 0.0),
        _scale_min(mx, my, serve),
    )


def _scale_min(mx: np.ndarray, my: np.ndarray, serve: np.ndarray) -> float:
    """The fewest view pixels per lens pixel: the smallest singular value of d(map)/d(u, v)."""
    if serve.shape[0] < 2 or serve.shape[1] < 2:
        return 1.0
    a, c = mx[:-1, 1:] - mx[:-1, :-1], my[:-1, 1:] - my[:-1, :-1]  # d/du
    b, d = mx[1:, :-1] - mx[:-1, :-1], my[1:, :-1] - my[:-1, :-1]  # d/dv
    ok = serve[:-1, :-1] & serve[:-1, 1:] & serve[1:, :-1]
    if not ok.any():
        return 1.0
    a, b, c, d = a[ok], b[ok], c[ok], d[ok]
    s1 = a * a + b * b + c * c + d * d
    det = np.abs(a * d - b * c)
    smin = np.sqrt(np.maximum(s1 / 2 - np.sqrt(np.maximum((s1 / 2) ** 2 - det**2, 0)), 0))
    return float(smin.min())


def _build_lens_views(
    key: tuple, near_m: float, far_m: float, name: str, oversample: float
) -> tuple[DistortionMaps, ...]:
    """The views behind a lens (cached as ``_lens_views``; not decorated, so that mutation
    testing reaches it)."""
    if oversample == 0:  # automatic: at least AUTO_MIN_SCALE view pixels per lens pixel everywhere
        views = _lens_views(key, near_m, far_m, name, 1.0)
        need = AUTO_MIN_SCALE / max(min(v.scale_min for v in views), 1e-6)
        factor = min(MAX_AUTO_OVERSAMPLE, max(1, int(np.ceil(need - 1e-9))))
        return views if factor == 1 else _lens_views(key, near_m, far_m, name, float(factor))
    model, W, H, K, dist = key
    cam = Sensor(
        W,
        H,
        np.frombuffer(K).reshape(3, 3),
        np.frombuffer(dist),
        near_m,
        far_m,
        model=model,
        name=name,
    )
    d = cam.directions()
    valid = np.isfinite(d).all(-1)
    fx, fy = cam.fx * oversample, cam.fy * oversample
    x, y = d[..., 0] / d[..., 2], d[..., 1] / d[..., 2]  # NaN without a ray; cos θ is never 0.0
    wide = (
        np.abs(np.where(valid, x, 0)).max(initial=0) * fx,
        np.abs(np.where(valid, y, 0)).max(initial=0) * fy,
    )
    one = (
        np.abs(np.where(valid, x, 0)).max(initial=0) <= MAX_SINGLE_VIEW_TAN
        and np.abs(np.where(valid, y, 0)).max(initial=0) <= MAX_SINGLE_VIEW_TAN
        and 2 * max(wide) + 8 <= MAX_VIEW_PX
    )
    if one:
        # principal point aligned to the sensor's pixel grid: u_view = os (u - cx) + whole pixels
        cx0, cy0 = oversample * cam.cx, oversample * cam.cy
        return (
            _view(
                cam,
                FACES["front"],
                "pinhole-margin",
                valid,
                np.where(valid, x, 0),
                np.where(valid, y, 0),
                fx,
                fy,
                cx0,
                cy0,
                None,
            ),
        )
    f = max(fx, fy)
    axes = np.stack([FACES[k][:, 2] for k in FACES])  # each face's optical axis
    face = np.argmax(np.nan_to_num(d) @ axes.T, axis=-1)
    views = []
    for i, (nm, R) in enumerate(FACES.items()):
        serve = valid & (face == i)
        if not serve.any():
            continue
        dv = np.nan_to_num(d) @ R  # view-frame rays (R^T d, row-wise)
        with np.errstate(invalid="ignore", divide="ignore"):
            xv, yv = dv[..., 0] / dv[..., 2], dv[..., 1] / dv[..., 2]
            zs = np.where(serve, d[..., 2] / dv[..., 2], 0.0)
        views.append(
            _view(
                cam,
                R,
                nm,
                serve,
                np.where(serve, xv, 0),
                np.where(serve, yv, 0),
                f,
                f,
                0.0,
                0.0,
                zs,
            )
        )
    return tuple(views)


_lens_views = lru_cache(maxsize=16)(_build_lens_views)


def lens_views(sensor: Camera, *, oversample: float | None = None) -> tuple[DistortionMaps, ...]:
    """The pinhole views behind ``sensor``'s lens image (cached per camera model)."""
    os_ = check_resample(DEFAULT_RESAMPLE, oversample)
    return _lens_views(
        sensor.lens_key, sensor.near_m, sensor.far_m, getattr(sensor, "name", ""), os_
    )


def distortion_maps(sensor: Camera, *, oversample: float | None = None) -> DistortionMaps:
    """The single wide pinhole view behind a lens that one view can hold (``oversample``
    defaults to 1 here: the view's focal lengths are the sensor's)."""
    views = lens_views(sensor, oversample=1.0 if oversample is None else oversample)
    if len(views) != 1:
        raise ConfigError(
            f"sensor {getattr(sensor, 'name', '')}: its field of view needs {len(views)} pinhole "
            "views (cube faces); use lens_views()"
        )
    return views[0]


def project(xy: np.ndarray, K: np.ndarray, D: np.ndarray) -> np.ndarray:
    """(N, 2) pixels of the normalised points ``xy`` (N, 2) through OpenCV's pinhole lens
    (:meth:`genie_gl.camera.Camera.project`, the one copy of the lens equations)."""
    D = np.asarray(D, np.float64)
    xd, yd = distort_normalized(xy[:, 0], xy[:, 1], D) if len(D) else (xy[:, 0], xy[:, 1])
    return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], 1)


def undistorted_rays(sensor: Camera) -> np.ndarray:
    """(H, W, 2) float64: x, y (z = 1) of every pixel's ray (NaN where none); cached."""
    return sensor.rays()


# -- resampling -------------------------------------------------------------------------------
def _plan(maps: DistortionMaps, src: Camera) -> dict:
    """What resampling from ``src`` through ``maps`` needs every time, computed once per maps:
    the served pixels, where their rays cross the view, their nearest view pixels, bilinear
    corners and weights, and for the exact and plane modes each pixel's own ray and its
    nearest view pixel's ray."""
    key = src.lens_key
    plan = maps.cache.get(key)
    if plan is not None:
        return plan
    h, w = src.height, src.width
    sel = np.flatnonzero(maps.valid.ravel())
    if maps.ray_x is not None and src.is_pinhole:  # the exact sample position, from float64 rays
        K = src.K
        rx, ry = maps.ray_x.ravel()[sel], maps.ray_y.ravel()[sel]
        mx, my = K[0, 0] * rx + K[0, 1] * ry + K[0, 2], K[1, 1] * ry + K[1, 2]
    else:
        mx = maps.map_x.ravel()[sel].astype(np.float64)
        my = maps.map_y.ravel()[sel].astype(np.float64)
    iu = np.floor(mx + 0.5).astype(np.int64)
    iv = np.floor(my + 0.5).astype(np.int64)
    inside = (iu >= 0) & (iu < w) & (iv >= 0) & (iv < h)
    sel, mx, my, iu, iv = sel[inside], mx[inside], my[inside], iu[inside], iv[inside]
    x0 = np.clip(np.floor(mx).astype(np.int64), 0, w - 2)
    y0 = np.clip(np.floor(my).astype(np.int64), 0, h - 2)
    plan = {
        "sel": sel,
        "flat": iv * w + iu,
        "f00": y0 * w + x0,
        "mx": mx,
        "my": my,
        "ax": np.clip(mx - x0, 0, 1),
        "ay": np.clip(my - y0, 0, 1),
        "zs": maps.z_scale.ravel()[sel] if maps.z_scale is not None else None,
    }
    if maps.ray_x is not None:
        rays = src.rays()
        plan["p"] = (rays[..., 0].ravel()[plan["flat"]], rays[..., 1].ravel()[plan["flat"]])
        plan["d"] = (maps.ray_x.ravel()[sel], maps.ray_y.ravel()[sel])
    maps.cache[key] = plan
    return plan


def _pixels(rgb: np.ndarray) -> np.ndarray:
    """(H·W, 3) uint8 rows of an (H, W, 3) image without a copy when it is contiguous or the
    colour part of an RGBA block (as the renderer reads it back)."""
    if rgb.flags.c_contiguous:
        return rgb.reshape(-1, 3)
    H, W, _ = rgb.shape
    if rgb.strides == (4 * W, 4, 1):
        return np.lib.stride_tricks.as_strided(rgb, (H * W, 3), (4, 1), writeable=False)
    return np.ascontiguousarray(rgb).reshape(-1, 3)


NO_F64 = np.zeros(0)
NO_RGB = np.zeros((0, 3), np.uint8)
NO_NORMAL = np.zeros((0, 3), np.float32)


def resample_views(
    frames: list[Frame],
    sensor: Camera,
    views: tuple[DistortionMaps, ...],
    pose: np.ndarray,
    *,
    resample: str = DEFAULT_RESAMPLE,
    normals: bool | None = None,
) -> Frame:
    """Resample the rendered ``frames`` of ``views`` into ``sensor``'s image at ``pose``
    (one compiled pass per view, :mod:`.resample`, or :mod:`.ray_hits` for the exact mode,
    whose frames must carry their triangles); surfaces nearer than ``sensor.near_m`` or
    farther than ``far_m`` give no return. ``normals``: give the image normals (None: when
    every view has them; the exact mode computes them from the triangles hit)."""
    H, W = sensor.height, sensor.width
    colour = all(f.rgb is not None for f in frames)
    exact = resample == "exact"
    if exact:
        missing = [
            f.sensor.name if hasattr(f.sensor, "name") else "view"
            for f in frames
            if f.triangles is None
        ]
        if missing:
            raise ConfigError(
                f"resample='exact' needs the triangles of each pinhole view ({', '.join(missing)} "
                "has "
                "none): render them with triangles=True (genie_gl.render.Renderer.render does)"
            )
    if normals is None:
        normals = all(f.normal is not None for f in frames)
    depth = np.zeros(H * W, np.float32)
    inst = np.zeros(H * W, np.uint32)
    sem = np.zeros(H * W, np.uint16)
    rgb = np.zeros((H * W, 3), np.uint8) if colour else NO_RGB
    normal = np.zeros((H * W, 3), np.float32) if normals else NO_NORMAL
    stats = np.zeros(len(STATS), np.int64)
    for f, m in zip(frames, views):
        plan = _plan(m, f.sensor)
        R = np.eye(3) if m.rotation is None else np.ascontiguousarray(m.rotation, np.float64)
        if exact:
            t = f.triangles
            resample_rays(
                plan["sel"],
                plan["mx"],
                plan["my"],
                *plan["d"],
                NO_F64 if plan["zs"] is None else plan["zs"],
                f.sensor.K,
                f.sensor.width,
                f.sensor.height,
                t.clip_near_m,
                sensor.near_m,
                sensor.far_m,
                R,
                t.pixel.reshape(-1),
                t.first,
                t.count,
                t.base_vertex,
                t.backcull,
                t.camera_from_model,
                t.indices,
                t.mesh_first,
                t.mesh_count,
                t.scene.faces,
                t.scene.vertices,
                t.instance,
                t.semantic,
                _pixels(f.rgb) if colour else NO_RGB,
                depth,
                inst,
                sem,
                rgb,
                normal,
                stats,
            )
            continue
        mode = MODES[resample]
        p, d = plan.get("p", (NO_F64, NO_F64)), plan.get("d", (NO_F64, NO_F64))
        if mode == MODES["plane"] and (f.normal is None or not len(p[0])):
            mode_v = MODES["nearest"]
        else:
            mode_v = mode
        resample_view(
            mode_v,
            plan["sel"],
            plan["flat"],
            plan["f00"],
            plan["ax"],
            plan["ay"],
            p[0],
            p[1],
            d[0],
            d[1],
            NO_F64 if plan["zs"] is None else plan["zs"],
            f.sensor.width,
            sensor.near_m,
            sensor.far_m,
            R,
            np.ascontiguousarray(f.depth).reshape(-1),
            np.ascontiguousarray(f.instance).reshape(-1),
            np.ascontiguousarray(f.semantic).reshape(-1),
            _pixels(f.rgb) if colour else NO_RGB,
            np.ascontiguousarray(f.normal).reshape(-1, 3) if f.normal is not None else NO_NORMAL,
            depth,
            inst,
            sem,
            rgb,
            normal,
        )
    meta = {
        "render_ms": sum(float((f.meta or {}).get("render_ms", 0.0)) for f in frames),
        "lens_views": len(views),
        "resample": resample,
    }
    if exact:
        meta["rays"] = dict(zip(STATS, stats.tolist()))
    return Frame(
        depth.reshape(H, W),
        inst.reshape(H, W),
        sem.reshape(H, W),
        rgb.reshape(H, W, 3) if colour else None,
        sensor,
        pose,
        normal.reshape(H, W, 3) if normals else None,
        meta,
    )


def distort(
    wide: Frame, sensor: Camera, maps: DistortionMaps, *, resample: str = "nearest"
) -> Frame:
    """Resample the single pinhole view ``wide`` into ``sensor``'s image (see the module)."""
    check_resample(resample, None)
    return resample_views(
        [wide], sensor, (maps,), wide.world_from_camera, resample=resample
    ).replace(meta=wide.meta)


RenderFn = Callable[..., Frame]


def draws_lenses(render: RenderFn) -> bool:
    """Whether ``render`` draws a distorted sensor's own pixel rays (its ``draws_lenses``, or
    that of the renderer it is a method of: the CPU raster's
    :class:`~genie_gl.render.cpu.renderer.CPURenderer`), so that no pinhole view is resampled."""
    while isinstance(render, functools.partial):  # (a render with some keywords bound)
        render = render.func
    flag = getattr(render, "draws_lenses", None)
    if flag is None:
        flag = getattr(getattr(render, "__self__", None), "draws_lenses", False)
    return bool(flag)


def render_through_lens(
    render: RenderFn,
    sensor: Camera,
    pose: np.ndarray,
    *,
    resample: str = DEFAULT_RESAMPLE,
    oversample: float | None = None,
    normals: bool = False,
    **kw,
) -> Frame:
    """``sensor``'s image at ``pose`` (world_from_camera) through its lens: its pinhole views
    rendered with ``render(view, view_pose, triangles=True, **kw)`` (the exact mode; the plane
    mode ``normals=True``) and resampled (see the module). An ideal pinhole sensor is rendered
    as it is, and so is a lens in the exact mode when ``render`` draws a lens's own pixel rays
    itself (:func:`draws_lenses`: the CPU raster); a ``render`` with a ``lens`` attribute (a
    supersampled one, :func:`genie_gl.capture.supersample.supersampled`) renders the exact mode
    itself."""
    os_ = check_resample(resample, oversample)
    pose = np.asarray(pose, np.float64)
    if sensor.is_pinhole or (resample == "exact" and draws_lenses(render)):
        return render(sensor, pose, normals=normals, **kw)
    lens = getattr(render, "lens", None)
    if lens is not None and resample == "exact":  # a render supersampled through the lens
        return lens(sensor, pose, resample=resample, oversample=oversample, normals=normals, **kw)
    views = _lens_views(
        sensor.lens_key, sensor.near_m, sensor.far_m, getattr(sensor, "name", ""), os_
    )
    frames = []
    exact = resample == "exact"
    # the exact mode asks the views for their triangles (normals come from the triangles hit);
    # the plane mode for their normals
    view_kw = (
        {**kw, "triangles": True} if exact else {**kw, "normals": normals or resample == "plane"}
    )
    for m in views:
        view_pose = pose.copy()
        view_pose[:3, :3] = pose[:3, :3] @ m.rotation
        frames.append(render(m.render_sensor, view_pose, **view_kw))
    out = resample_views(
        frames, sensor, views, pose, resample=resample, normals=normals if exact else None
    )
    return out if normals else out.replace(normal=None)
