"""Scenes and cameras with closed-form answers for ``genie bench stability``: planes, discs,
lenses against OpenCV's own projection (``cv2.projectPoints``, ``cv2.fisheye.projectPoints``,
``cv2.omnidir.projectPoints``)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..cloud import to_cloud
from ..render import Renderer
from ..scene.model import Mesh, Scene
from ..sensors.camera import Sensor
from ..lens.distortion import lens_views, render_through_lens


@dataclass
class Row:
    """One case: its tolerance, the worst error measured, the unit of both, and a note."""

    case: str
    tolerance: float
    worst: float
    unit: str
    note: str = ""
    seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return bool(np.isfinite(self.worst) and self.worst <= self.tolerance)


# -- small scenes with closed-form answers -------------------------------------------------------
def quad(corners) -> Mesh:
    return Mesh(np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]]))


def facing_quad(z: float, x0: float, x1: float, y0: float, y1: float) -> Mesh:
    return quad([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def plane_depth(cam: Sensor, n: np.ndarray, p0: np.ndarray) -> np.ndarray:
    """(H, W) float64 z of the plane n·(p - p0) = 0 (camera frame) along every pixel's ray
    (0 where the ray misses it, or has none)."""
    d = np.nan_to_num(cam.directions())
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (n @ p0) / (d @ n)
        z = t * d[..., 2]
    return np.where(np.isfinite(z) & (t > 0), z, 0.0)


def interior(mask: np.ndarray, k: int = 1) -> np.ndarray:
    """Pixels of ``mask`` whose (2k+1)² neighbourhood is all in the mask (away from edges)."""
    m = mask.astype(np.uint8)
    return cv2.erode(
        m, np.ones((2 * k + 1, 2 * k + 1), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0
    ).astype(bool)


def renderer(scene: Scene, context):
    return Renderer(scene, context=context)


def rel_error(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    if not mask.any():
        return float("inf")
    return float((np.abs(a[mask].astype(np.float64) - b[mask]) / np.abs(b[mask])).max())


# -- lenses ---------------------------------------------------------------------------------------
LENSES: dict[str, dict] = {
    "k1=-0.5 (barrel)": dict(dist=[-0.5, 0, 0, 0, 0]),
    "k1=+0.5 (pincushion)": dict(dist=[0.5, 0, 0, 0, 0]),
    "rational (8)": dict(dist=[3.1306, 2.3249, 8.1e-5, -5.1e-5, 0.1304, 3.4587, 3.3501, 0.6629]),
    "tilted (14)": dict(
        dist=[0.1, -0.05, 0.001, -0.002, 0.01, 0, 0, 0, 0.001, 0, -0.001, 0, 0.01, -0.02]
    ),
    "fisheye 180°": dict(dist=[0.0, 0.0, 0.0, 0.0], model="fisheye"),
    "omni ξ=0.9 (Mei)": dict(dist=[0.9, -0.2, 0.05, 0.001, -0.002], model="omni"),
}


def lens_sensor(name: str, width: int = 320, height: int = 240) -> Sensor:
    spec = LENSES[name]
    if spec.get("model") == "fisheye":  # equidistant: the image circle's rim is 90° off axis
        f = (min(width, height) / 2 - 2) / (np.pi / 2)
        K = [[f, 0, (width - 1) / 2 + 0.3], [0, f, (height - 1) / 2 - 0.2], [0, 0, 1]]
        return Sensor(width, height, K, spec["dist"], model="fisheye", name=name)
    if spec.get("model") == "omni":
        f = 0.5 * width
        K = [[f, 0, (width - 1) / 2 + 0.3], [0, f + 1, (height - 1) / 2 - 0.2], [0, 0, 1]]
        return Sensor(width, height, K, spec["dist"], model="omni", name=name)
    K = [
        [0.9 * width, 0, (width - 1) / 2 + 0.3],
        [0, 0.9 * width + 5, (height - 1) / 2 - 0.2],
        [0, 0, 1],
    ]
    return Sensor(width, height, K, spec["dist"], name=name)


def opencv_project(cam: Sensor, points: np.ndarray) -> np.ndarray:
    """(N, 2) pixels of camera-frame points by OpenCV's own projection."""
    pts = np.asarray(points, np.float64).reshape(-1, 1, 3)
    if cam.model == "fisheye":
        return cv2.fisheye.projectPoints(pts, np.zeros((3, 1)), np.zeros((3, 1)), cam.K, cam.dist)[
            0
        ].reshape(-1, 2)
    if cam.model == "omni":  # opencv-contrib's cv2.omnidir (Mei's unified model)
        return cv2.omnidir.projectPoints(
            pts, np.zeros(3), np.zeros(3), cam.K, float(cam.dist[0]), cam.dist[1:].reshape(1, 4)
        )[0].reshape(-1, 2)
    return cv2.projectPoints(pts, np.zeros(3), np.zeros(3), cam.K, cam.dist)[0].reshape(-1, 2)


def lens_map_error(cam: Sensor) -> tuple[float, int]:
    """Worst pixel distance between every pixel and OpenCV's projection of its ray, and how
    many pixels have a ray (corners included when the lens has them)."""
    d = cam.directions()
    ok = np.isfinite(d).all(-1)
    v, u = np.nonzero(ok)
    uv = opencv_project(cam, d[ok])
    return float(np.hypot(uv[:, 0] - u, uv[:, 1] - v).max()), int(ok.sum())


def marker_scene(cam: Sensor, dist_m: float = 2.0, radius_px: float = 7.0, grid=(5, 4)):
    """Flat discs facing the camera, centred on the rays of pixels spread over the image
    (corners included); returns the scene and, per marker, (id, centre, e1, e2, radius)."""
    W, H = cam.size
    margin = radius_px * 2.2
    us = np.linspace(margin, W - 1 - margin, grid[0])
    vs = np.linspace(margin, H - 1 - margin, grid[1])
    if cam.model == "fisheye":  # keep inside the image circle
        uu, vv = np.meshgrid(us, vs)
        r = np.hypot(uu - cam.cx, vv - cam.cy)
        pix = np.stack([uu[r < min(W, H) / 2 - margin], vv[r < min(W, H) / 2 - margin]], 1)
    else:
        pix = np.stack(np.meshgrid(us, vs), -1).reshape(-1, 2)
    dirs = cam.unproject(pix)
    scene, markers = Scene(), []
    seg = 96
    ang = np.linspace(0, 2 * np.pi, seg, endpoint=False)
    for k, d in enumerate(dirs):
        if not np.all(np.isfinite(d)):
            continue
        c = d * dist_m
        e1 = np.cross(d, [0, 1.0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        # the disc's radius: radius_px at the local scale of the lens
        step = cam.project(np.stack([c, c + e1 * 1e-3]))
        rad = radius_px * 1e-3 / np.linalg.norm(step[1] - step[0])
        ring = c + rad * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2)
        verts = np.vstack([c, ring])
        faces = np.array([[0, 1 + i, 1 + (i + 1) % seg] for i in range(seg)])
        iid = scene.add(Mesh(verts, faces), instance=k + 1)
        markers.append((iid, c, e1, e2, rad))
    return scene, markers


def marker_raycast(cam: Sensor, c, e1, e2, rad) -> np.ndarray:
    """(H, W) bool: the pixels whose ray (the lens's inverse, held to OpenCV's projection by
    :func:`lens_map_error`) hits the disc: the mask an exact ray caster draws."""
    d = cam.directions()
    n = np.cross(e1, e2)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (c @ n) / (d @ n)
        p = t[..., None] * d - c
        return np.nan_to_num(np.hypot(p @ e1, p @ e2), nan=np.inf) <= rad


def marker_truth(cam: Sensor, c, e1, e2, rad, n: int = 161) -> np.ndarray:
    """The image-area centroid of a disc by OpenCV's projection: a fine grid on the disc,
    each point weighted by the image area of its cell."""
    s = np.linspace(-rad, rad, n)
    S, T = np.meshgrid(s, s)
    P = c + S[..., None] * e1 + T[..., None] * e2
    uv = opencv_project(cam, P.reshape(-1, 3)).reshape(n, n, 2)
    du, dv = np.gradient(uv, axis=1), np.gradient(uv, axis=0)
    area = np.abs(du[..., 0] * dv[..., 1] - du[..., 1] * dv[..., 0])
    inside = S**2 + T**2 <= rad**2
    w = area * inside
    return (uv * w[..., None]).sum((0, 1)) / w.sum()


def lens_rows(
    name: str, context=None, resample: str = "exact", oversample: float | None = None
) -> list[Row]:
    cam = lens_sensor(name)
    rows = []
    err, n = lens_map_error(cam)
    rows.append(
        Row(f"{name}: every pixel's ray vs OpenCV", 0.1, err, "px", f"{n} pixels with a ray")
    )
    if name.startswith("tilted"):
        return rows
    scene, markers = marker_scene(cam)
    with renderer(scene, context) as r:
        f = render_through_lens(r.render, cam, np.eye(4), resample=resample, oversample=oversample)
    worst = quant = 0.0
    for iid, c, e1, e2, rad in markers:
        v, u = np.nonzero(f.instance == iid)
        mask = marker_raycast(cam, c, e1, e2, rad)
        if len(u) == 0 or not mask.any():
            worst = float("inf")
            continue
        vv, uu = np.nonzero(mask)
        worst = max(worst, float(np.hypot(u.mean() - uu.mean(), v.mean() - vv.mean())))
        quant = max(
            quant,
            float(
                np.hypot(*(np.array([uu.mean(), vv.mean()]) - marker_truth(cam, c, e1, e2, rad)))
            ),
        )
    # an id is its nearest view pixel's: within half a view pixel, 0.5 / scale lens pixels
    scale = min(m.scale_min for m in lens_views(cam, oversample=oversample))
    rows.append(
        Row(
            f"{name}: marker centroids vs a ray caster through the lens",
            0.5 / scale,
            worst,
            "px",
            f"{len(markers)} discs, corners included; {scale:.2f} view px per lens px at least; "
            f"the pixel grid alone moves a centroid {quant:.2f} px from OpenCV's",
        )
    )
    # a tilted plane through the lens: depth along every ray, and the cloud on the plane
    n_cam = np.array([0.3, -0.4, -1.0])
    n_cam /= np.linalg.norm(n_cam)
    p0 = np.array([0.0, 0.0, 2.5])
    e1 = np.cross(n_cam, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n_cam, e1)
    big = 40.0
    corners = [p0 + big * (a * e1 + b * e2) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    plane = Scene()
    plane.add(quad(corners), instance=5)
    with renderer(plane, context) as r:
        f = render_through_lens(r.render, cam, np.eye(4), resample=resample, oversample=oversample)
    want = plane_depth(cam, n_cam, p0)
    valid = f.depth > 0
    missing = int(((want > 0) & np.isfinite(cam.directions()).all(-1) & ~valid).sum())
    rows.append(
        Row(
            f"{name}: planar depth through the lens",
            1e-5,
            rel_error(f.depth, want, valid),
            "rel depth",
            f"{int(valid.sum())} pixels, {missing} without a return",
        )
    )
    cloud = to_cloud([f])
    dist = np.abs((cloud.world_xyz - p0) @ n_cam) / np.linalg.norm(cloud.world_xyz, axis=1)
    rows.append(
        Row(
            f"{name}: cloud of the plane on the plane",
            1e-5,
            float(dist.max()),
            "rel distance",
            "unprojected through the inverse lens",
        )
    )
    return rows
