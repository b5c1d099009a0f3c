"""Scenes, sensors and views the tests build for themselves, from the public API only.

* :func:`objects_scene`: a 24 m floor grid and 220 objects over 20 m x 20 m (100 boxes, 60
  icospheres, 60 cylinders), each object its own mesh with its size baked into its vertices,
  at about 0.1 M (``"100k"``) or 1 M (``"1M"``) triangles in 221 meshes, with four views
  from 1.2 to 7 m high looking across it;
* :func:`hall_scene`: 120 instances of one 81,920-triangle icosphere over 20 m x 20 m on a
  floor (~9.8 M triangles in two meshes: the case instancing should win), with four views;
* :func:`sensor_640`: a 640 x 480 pinhole, fx = fy = 525 px;
* :func:`content_views`: views of a scene aimed at its labelled objects;
* :func:`strips_strategy` with :func:`register_strips`: a layout strategy of ``R`` equal strips
  per region over ``L`` levels, with an array and a per-region form of the same generator.

The recipes are the tests' own: a test's expectations change only when this module does.
"""

from __future__ import annotations

import numpy as np
import trimesh

import genie_gl as gg
from genie_gl.layout.generators import Child, Children, Generator, register
from genie_gl.scene.model import Mesh
from genie_gl.sensors.pose import look_at

# per size: icosphere subdivisions, cylinder sections, floor cells per side
_TESSELLATION = {
    "100k": ((2, 3), (16, 64, 256), 120),
    "1M": ((3, 4, 5), (256, 1024, 4096), 200),
}


def sensor_640() -> gg.Sensor:
    """A 640 x 480 ideal pinhole, fx = fy = 525 px, principal point at the centre, 0.1-100 m."""
    K = np.array([[525.0, 0, 319.5], [0, 525.0, 239.5], [0, 0, 1]])
    return gg.Sensor(640, 480, K, near_m=0.1, far_m=100.0)


def _floor(size_m: float, cells: int) -> Mesh:
    """A flat grid of ``cells`` x ``cells`` squares (two triangles each), top at z = 0."""
    t = np.linspace(-size_m / 2, size_m / 2, cells + 1)
    x, y = np.meshgrid(t, t, indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1).astype(np.float32)
    i = np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]
    a, b, c, d = i, i + (cells + 1), i + (cells + 2), i + 1  # CCW seen from above
    f = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return Mesh(v, f.astype(np.uint32), closed=False)


def _scaled(mesh: trimesh.Trimesh, scale) -> Mesh:
    v = (np.asarray(mesh.vertices, np.float64) * scale).astype(np.float32)
    return Mesh(v, np.asarray(mesh.faces, np.uint32), closed=True)


def views(n: int, *, rng: np.random.Generator, half_extent_m: float = 10.0) -> list[np.ndarray]:
    """``n`` world_from_camera poses: eyes on a ring at 0.6-1.3 times ``half_extent_m`` from
    the middle, 1.2 to 7 m high, looking at points near the middle, 0 to 1 m high."""
    out = []
    for k in range(n):
        a = 2 * np.pi * k / n + rng.uniform(-0.3, 0.3)
        r = half_extent_m * rng.uniform(0.6, 1.3)
        h = 1.2 + (7.0 - 1.2) * ((k * 0.618034) % 1.0)
        eye = [r * np.cos(a), r * np.sin(a), h]
        target = [*rng.uniform(-0.3, 0.3, 2) * half_extent_m, rng.uniform(0.0, 1.0)]
        out.append(look_at(eye, target))
    return out


def _placed(
    meshes: list[Mesh], mesh_of: list[int], T: list[np.ndarray], sem: list[int]
) -> gg.Scene:
    scene = gg.Scene()
    keys = [scene.add_mesh(m, name=f"mesh_{k:04d}") for k, m in enumerate(meshes)]
    for m, t, s in zip(mesh_of, T, sem):
        scene.add(keys[m], t, semantic=int(s))
    return scene


def objects_scene(size: str = "100k", seed: int = 0) -> tuple[gg.Scene, list[np.ndarray]]:
    """The floor and 220 objects at ``size`` (``"100k"`` or ``"1M"`` triangles), and four views."""
    rng = np.random.default_rng(seed)
    subdivs, sections, cells = _TESSELLATION[size]
    meshes, mesh_of, T, sem = [_floor(24.0, cells)], [0], [np.eye(4)], [0]
    spheres = {s: trimesh.creation.icosphere(s, radius=1.0) for s in subdivs}
    for i in range(220):
        kind = "box" if i % 11 < 5 else "sphere" if i % 11 < 8 else "cylinder"
        if kind == "box":
            mesh = _scaled(trimesh.creation.box((1.0, 1.0, 1.0)), rng.uniform(0.3, 1.8, 3))
        elif kind == "sphere":
            mesh = _scaled(spheres[int(rng.choice(subdivs))], np.full(3, rng.uniform(0.2, 0.9)))
        else:
            cyl = trimesh.creation.cylinder(1.0, 1.0, sections=int(rng.choice(sections)))
            r = rng.uniform(0.1, 0.6)
            mesh = _scaled(cyl, np.array([r, r, rng.uniform(0.4, 2.5)]))
        pose = np.eye(4)
        yaw = rng.uniform(0, 2 * np.pi)
        pose[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        zmin = float(mesh.vertices[:, 2].min())
        pose[:3, 3] = [
            *rng.uniform(-10, 10, 2),
            -zmin + rng.choice([0.0, 0.0, rng.uniform(0.2, 1.5)]),
        ]
        meshes.append(mesh)
        mesh_of.append(len(meshes) - 1)
        T.append(pose)
        sem.append(1 + i % 9)
    return _placed(meshes, mesh_of, T, sem), views(40, rng=np.random.default_rng(seed + 1))[:4]


def hall_scene(seed: int = 0) -> tuple[gg.Scene, list[np.ndarray]]:
    """120 instances of one 81,920-triangle ball on a floor, and four views."""
    rng = np.random.default_rng(seed)
    meshes = [_floor(24.0, 4), _scaled(trimesh.creation.icosphere(6, radius=0.5), np.ones(3))]
    mesh_of, T, sem = [0], [np.eye(4)], [0]
    gx, gy = np.meshgrid(np.linspace(-9.5, 9.5, 12), np.linspace(-9.5, 9.5, 10), indexing="ij")
    for k, (x, y) in enumerate(zip(gx.ravel(), gy.ravel())):
        s = rng.uniform(0.6, 1.6)
        pose = np.diag([s, s, s, 1.0])
        pose[:3, 3] = [x + rng.uniform(-0.4, 0.4), y + rng.uniform(-0.4, 0.4), 0.5 * s]
        mesh_of.append(1)
        T.append(pose)
        sem.append(1 + k % 9)
    return _placed(meshes, mesh_of, T, sem), views(40, rng=np.random.default_rng(seed + 1))[:4]


def scene_of(size: str, seed: int = 0) -> tuple[gg.Scene, list[np.ndarray]]:
    """:func:`objects_scene` for ``"100k"`` and ``"1M"``, :func:`hall_scene` for ``"hall"``."""
    return hall_scene(seed) if size == "hall" else objects_scene(size, seed)


def content_views(
    scene: gg.Scene, n: int, *, distance_m: float = 4.0, height_m: float = 3.0
) -> list[np.ndarray]:
    """``n`` views aimed at the scene's labelled objects: their centres spread by farthest-point
    sampling from the one nearest the middle, each seen from ``distance_m`` further out and
    ``height_m`` above it."""
    inst = [i for i in scene.instances if i.semantic > 0] or list(scene.instances)
    centres = []
    for i in inst:
        b = scene.meshes[i.mesh].bounds
        c = (b[0] + b[1]) / 2 if np.all(np.isfinite(b)) else np.zeros(3)
        centres.append(i.world_from_model[:3, :3] @ c + i.world_from_model[:3, 3])
    centres = np.array(centres)
    lo, hi = scene.bounds()
    mid = (lo + hi) / 2
    chosen = [int(np.argmin(np.linalg.norm(centres[:, :2] - mid[:2], axis=1)))]
    dist = np.linalg.norm(centres - centres[chosen[0]], axis=1)
    while len(chosen) < min(n, len(centres)):
        chosen.append(int(np.argmax(dist)))
        dist = np.minimum(dist, np.linalg.norm(centres - centres[chosen[-1]], axis=1))
    out = []
    for k in range(n):
        t = centres[chosen[k % len(chosen)]]
        away = t[:2] - mid[:2]
        angle = np.arctan2(away[1], away[0]) if np.linalg.norm(away) > 1e-6 else 0.0
        angle += 2 * np.pi * (k // len(chosen)) / max(1, -(-n // len(chosen)))
        eye = [
            t[0] + distance_m * np.cos(angle),
            t[1] + distance_m * np.sin(angle),
            t[2] + height_m,
        ]
        out.append(look_at(eye, t))
    return out


def strips_strategy(regions: int, levels: int, generator: str = "test_strips") -> dict:
    """A strategy of ``levels`` levels, each region cut into ``regions`` equal strips by
    ``generator`` (``"test_strips"``, array code, or ``"test_strips_per_region"``)."""
    return {
        "name": f"strips_R{regions}_L{levels}",
        "root": {"width": 1000.0, "height": 1000.0, "type": "n"},
        "region_types": {"n": {}, "leaf": {"final": True}},
        "levels": [
            {
                "n": {
                    "generator": generator,
                    "args": {"n": regions},
                    "children": {"strip": "n" if lvl < levels - 1 else "leaf"},
                }
            }
            for lvl in range(levels)
        ],
    }


def register_strips() -> None:
    """Register ``test_strips`` (with array code) and ``test_strips_per_region`` (without)."""

    @register("test_strips")
    class Strips(Generator):
        """n equal strips across the parent."""

        slots = ("strip",)

        def generate(self, parent, *, rng):
            n = int(self.args["n"])
            w = parent.w / n
            return [Child(parent.x + i * w, parent.y, w, parent.h, "strip") for i in range(n)]

        def max_children(self, w, h, parents, area):
            return parents * int(self.args["n"])

        def generate_batch(self, parents, *, rng):
            n, m = int(self.args["n"]), len(parents)
            w = np.repeat(parents.w / n, n)
            x = np.repeat(parents.x, n) + np.tile(np.arange(n), m) * w
            return Children(
                np.repeat(np.arange(m), n),
                x,
                np.repeat(parents.y, n),
                w,
                np.repeat(parents.h, n),
                np.zeros(n * m, np.int32),
                np.full(n * m, -1, np.int8),
                [],
            )

    @register("test_strips_per_region")
    class StripsPerRegion(Strips):
        """The same generator without array code: the engine calls ``generate`` per region."""

        generate_batch = Generator.generate_batch
