"""The built-in case of ``genie bench accuracy``: a scene whose every pixel has a closed form.

Seen from the identity pose (camera frame = world frame, z forward, y down): a wall tilted by
0.3 rad about y through (0, 0, 3 m), a floor 0.8 m below the camera meeting it (a concave
corner, where multipath biases), a box whose front face stands at 1.4 m (straight
silhouettes, a stereo shadow on the wall) and a sphere of radius 0.3 m at 2 m (a curved
silhouette; its mesh has ``segments`` segments per circle, the tessellation knob). The sensor
has a known rational lens (Azure-Kinect-like) so the lens knobs have something to do.

:func:`truth` gives, for every pixel's ray, the depth, instance, semantic id and unit normal
of the nearest primitive: the reference of the rows whose knobs change geometry.
"""

from __future__ import annotations

import numpy as np
import trimesh

from ..scene.model import Mesh, Scene
from ..sensors.camera import Sensor
from ..effects.registry import DepthNoise
from ..effects.shadow import StereoShadow
from ..effects.surface import Multipath

WALL_ANGLE, WALL_Z = 0.3, 3.0
FLOOR_Y = 0.8
BOX_LO, BOX_HI = np.array([-0.7, -0.3, 1.4]), np.array([-0.2, 0.3, 1.8])
SPHERE_C, SPHERE_R = np.array([0.45, 0.0, 2.0]), 0.3
# instance -> semantic: wall and floor are background (0), the box 1, the sphere 2
IDS = {"wall": (1, 0), "floor": (2, 0), "box": (3, 1), "sphere": (4, 2)}
EXTENT = 6.0  # half size of the wall and floor quads
DEFAULT_SEGMENTS = 32
RATIONAL = [0.5, 0.2, 0.0, 0.0, 0.01, 0.6, 0.3, 0.05]


def _wall():
    n = np.array([np.sin(WALL_ANGLE), 0.0, -np.cos(WALL_ANGLE)])
    return n, np.array([0.0, 0.0, WALL_Z])


def sensor():
    """The built-in camera: 640 x 480, f = 525 px, rational lens, stereo shadow (75 mm),
    multipath (1 cm) and Nguyen et al.'s depth noise."""
    base = Sensor.pinhole(640, 480, 525.0)
    return Sensor(
        width=640,
        height=480,
        K=base.K,
        dist=np.array(RATIONAL),
        near_m=0.1,
        far_m=20.0,
        name="builtin-rational",
        effects=(StereoShadow(baseline_m=0.075), Multipath(bias_m=0.01), DepthNoise()),
    )


def scene(segments: int = DEFAULT_SEGMENTS):
    """The scene; the sphere is a UV sphere with ``segments`` segments per circle."""
    s = Scene()
    n, p0 = _wall()
    a = np.cross(n, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    corners = [p0 + EXTENT * (sa * a + sb * b) for sa, sb in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    s.add(Mesh(np.array(corners), quad), instance=IDS["wall"][0], semantic=IDS["wall"][1])
    floor = [
        [-EXTENT, FLOOR_Y, 0.1],
        [EXTENT, FLOOR_Y, 0.1],
        [EXTENT, FLOOR_Y, 8.0],
        [-EXTENT, FLOOR_Y, 8.0],
    ]
    s.add(Mesh(np.array(floor), quad), instance=IDS["floor"][0], semantic=IDS["floor"][1])
    box = trimesh.creation.box(BOX_HI - BOX_LO)
    s.add(box, (BOX_LO + BOX_HI) / 2, instance=IDS["box"][0], semantic=IDS["box"][1])
    sphere = trimesh.creation.uv_sphere(SPHERE_R, count=[max(3, segments // 2), max(3, segments)])
    s.add(sphere, SPHERE_C, instance=IDS["sphere"][0], semantic=IDS["sphere"][1])
    return s


def truth(sensor_, rays: np.ndarray) -> dict[str, np.ndarray]:
    """Nearest hit along each ray ``rays`` (H, W, 2): x, y of (x, y, 1), NaN where the lens
    has none. Returns depth (H, W) float64 (0: none), instance, semantic, normal (H, W, 3)."""
    H, W = rays.shape[:2]
    d = np.concatenate([rays.reshape(-1, 2), np.ones((H * W, 1))], 1)
    ok = np.isfinite(d).all(1)
    d = np.where(ok[:, None], d, 0.0)
    z = np.full(H * W, np.inf)
    idx = np.zeros(H * W, int)
    normal = np.zeros((H * W, 3))
    near = sensor_.near_m

    def take(t, which, nrm):
        nonlocal z
        better = ok & np.isfinite(t) & (t > near) & (t < z)
        z = np.where(better, t, z)
        idx[better] = which
        normal[better] = nrm[better] if nrm.ndim == 2 else nrm

    n, p0 = _wall()
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (n @ p0) / (d @ n)
        P = d * t[:, None]
        a = np.cross(n, [0.0, 1.0, 0.0]) / np.linalg.norm(np.cross(n, [0.0, 1.0, 0.0]))
        inside = (np.abs((P - p0) @ a) <= EXTENT) & (np.abs(P[:, 1]) <= EXTENT)
        take(np.where(inside, t, np.inf), 1, n)
        t = FLOOR_Y / d[:, 1]
        inside = (np.abs(d[:, 0] * t) <= EXTENT) & (t >= 0.1) & (t <= 8.0)
        take(np.where(inside & (d[:, 1] > 0), t, np.inf), 2, np.array([0.0, -1.0, 0.0]))
        t0, t1 = (BOX_LO / d), (BOX_HI / d)  # slabs (the camera sits outside the box)
        tmin = np.nanmax(np.minimum(t0, t1), 1)
        tmax = np.nanmin(np.maximum(t0, t1), 1)
        hit = tmax >= tmin
        axis = np.argmax(np.minimum(t0, t1), 1)
        nb = np.zeros((H * W, 3))
        nb[np.arange(H * W), axis] = -np.sign(d[np.arange(H * W), axis])
        take(np.where(hit, tmin, np.inf), 3, nb)
        bq = d @ SPHERE_C
        dd = (d * d).sum(1)
        disc = bq * bq - dd * (SPHERE_C @ SPHERE_C - SPHERE_R**2)
        t = (bq - np.sqrt(np.maximum(disc, 0))) / dd
        ns = (d * t[:, None] - SPHERE_C) / SPHERE_R
        take(np.where(disc >= 0, t, np.inf), 4, ns)
    names = ["", "wall", "floor", "box", "sphere"]
    inst = np.array([0] + [IDS[k][0] for k in names[1:]], np.uint32)[idx]
    sem = np.array([0] + [IDS[k][1] for k in names[1:]], np.uint16)[idx]
    depth = np.where(np.isfinite(z), z, 0.0)
    return {
        "depth": depth.reshape(H, W),
        "instance": inst.reshape(H, W),
        "semantic": sem.reshape(H, W),
        "normal": normal.reshape(H, W, 3),
    }
