"""The scenes ``genie bench render`` times: real-size scenes given as arrays in memory.

Every tool builds its own scene from the same :class:`SceneSpec` (meshes as float32 vertex and
uint32 face arrays, instances as float64 transforms), so "build" means the same for all:
meshes in memory -> first frame.

* ``100k``, ``1M``, ``10M``: a 24 m floor grid and 220 objects over 20 m x 20 m (100 boxes,
  60 icospheres, 60 cylinders), each object its own mesh with its size baked into its
  vertices (as CAD-derived assets are) and a tessellation drawn from a list that grows with
  the size: about 0.1, 1 and 10 million triangles in 221 meshes.
* ``hall``: 120 instances of one 81,920-triangle icosphere over 20 m x 20 m, plus a floor
  (~9.8 M triangles in two meshes): the case instancing should win.
* ``generated``: a layout of the shipped ``assembly_line`` strategy built into a scene
  (:func:`genie_gl.build_scene`), a scene nobody tuned for this benchmark.

Poses look from 1.2 to 7 m high across the area towards its middle; ``poses(n)`` gives ``n``
distinct ones, the same for every tool.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from ..errors import ConfigError
from ..layout import generate_layout
from ..resources import resolve
from ..scene import build_scene
from ..scene.model import Mesh, Scene
from ..sensors.pose import look_at

SIZES = ("100k", "1M", "10M", "hall", "generated")

# per size: icosphere subdivisions, cylinder sections, floor cells per side
_TESSELLATION = {
    "100k": ((2, 3), (16, 64, 256), 120),
    "1M": ((3, 4, 5), (256, 1024, 4096), 200),
    "10M": ((5, 6), (4096, 16384, 65536), 480),
}


@dataclass(frozen=True)
class SceneSpec:
    """A benchmark scene as plain arrays.

    Attributes
    ----------
    name : str, one of :data:`SIZES`.
    meshes : list of (vertices (V, 3) float32, faces (F, 3) uint32, closed bool), model frame,
    metres.
    mesh_of : (N,) int64, the mesh each instance places.
    world_from_model : (N, 4, 4) float64.
    semantic : (N,) int64, class ids.
    poses : (P, 4, 4) float64 world_from_camera (OpenCV), P >= 40.
    scene : a ready ``genie_gl.Scene`` (the generated scene only; None otherwise).
    """

    name: str
    meshes: list
    mesh_of: np.ndarray
    world_from_model: np.ndarray
    semantic: np.ndarray
    poses: np.ndarray
    scene: object = None

    @property
    def triangles(self) -> int:
        """Triangles placed in the world (instances times their mesh's faces)."""
        return int(sum(len(self.meshes[m][1]) for m in self.mesh_of))


def _floor(size_m: float, cells: int) -> tuple[np.ndarray, np.ndarray, bool]:
    """A flat grid of ``cells`` x ``cells`` squares (two triangles each), top at z = 0."""
    t = np.linspace(-size_m / 2, size_m / 2, cells + 1)
    x, y = np.meshgrid(t, t, indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1).astype(np.float32)
    i = np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]
    a, b, c, d = i, i + (cells + 1), i + (cells + 2), i + 1  # CCW seen from above
    f = np.concatenate(
        [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    )
    return v, f.astype(np.uint32), False


def _arrays(mesh, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    v = (np.asarray(mesh.vertices, np.float64) * scale).astype(np.float32)
    return v, np.asarray(mesh.faces, np.uint32), True


def _objects_scene(name: str, rng: np.random.Generator) -> tuple[list, list, list, list]:
    subdivs, sections, cells = _TESSELLATION[name]
    meshes, mesh_of, T, sem = [_floor(24.0, cells)], [0], [np.eye(4)], [0]
    spheres = {s: trimesh.creation.icosphere(s, radius=1.0) for s in subdivs}
    for i in range(220):
        kind = "box" if i % 11 < 5 else "sphere" if i % 11 < 8 else "cylinder"
        if kind == "box":
            mesh = _arrays(trimesh.creation.box((1.0, 1.0, 1.0)), rng.uniform(0.3, 1.8, 3))
        elif kind == "sphere":
            mesh = _arrays(spheres[int(rng.choice(subdivs))], np.full(3, rng.uniform(0.2, 0.9)))
        else:
            cyl = trimesh.creation.cylinder(1.0, 1.0, sections=int(rng.choice(sections)))
            r = rng.uniform(0.1, 0.6)
            mesh = _arrays(cyl, np.array([r, r, rng.uniform(0.4, 2.5)]))
        pose = np.eye(4)
        yaw = rng.uniform(0, 2 * np.pi)
        pose[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        zmin = float(mesh[0][:, 2].min())
        pose[:3, 3] = [
            *rng.uniform(-10, 10, 2),
            -zmin + rng.choice([0.0, 0.0, rng.uniform(0.2, 1.5)]),
        ]
        meshes.append(mesh)
        mesh_of.append(len(meshes) - 1)
        T.append(pose)
        sem.append(1 + i % 9)
    return meshes, mesh_of, T, sem


def _hall(rng: np.random.Generator) -> tuple[list, list, list, list]:
    ball = trimesh.creation.icosphere(6, radius=0.5)  # 81,920 triangles
    meshes = [_floor(24.0, 4), _arrays(ball, np.ones(3))]
    mesh_of, T, sem = [0], [np.eye(4)], [0]
    gx, gy = np.meshgrid(np.linspace(-9.5, 9.5, 12), np.linspace(-9.5, 9.5, 10), indexing="ij")
    for k, (x, y) in enumerate(zip(gx.ravel(), gy.ravel())):
        s = rng.uniform(0.6, 1.6)
        pose = np.diag([s, s, s, 1.0])
        pose[:3, 3] = [x + rng.uniform(-0.4, 0.4), y + rng.uniform(-0.4, 0.4), 0.5 * s]
        mesh_of.append(1)
        T.append(pose)
        sem.append(1 + k % 9)
    return meshes, mesh_of, T, sem


def poses(n: int, *, rng: np.random.Generator, half_extent_m: float = 10.0) -> np.ndarray:
    """(n, 4, 4) float64 world_from_camera: eyes on a ring at 0.6-1.3 times ``half_extent_m``
    from the middle, 1.2 to 7 m high, looking at points near the middle, 0 to 1 m high."""
    out = []
    for k in range(n):
        a = 2 * np.pi * k / n + rng.uniform(-0.3, 0.3)
        r = half_extent_m * rng.uniform(0.6, 1.3)
        h = 1.2 + (7.0 - 1.2) * ((k * 0.618034) % 1.0)
        eye = [r * np.cos(a), r * np.sin(a), h]
        target = [*rng.uniform(-0.3, 0.3, 2) * half_extent_m, rng.uniform(0.0, 1.0)]
        out.append(look_at(eye, target))
    return np.stack(out)


def _generated(seed: int) -> SceneSpec:
    layout = generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=seed)
    scene = build_scene(layout, seed=seed)
    keys = list(scene.meshes)
    index = {k: i for i, k in enumerate(keys)}
    meshes = [(m.vertices, m.faces, bool(m.closed)) for m in scene.meshes.values()]
    inst = scene.instances
    bounds = scene.bounds()
    half = float(np.max(np.abs(bounds[:, :2]))) if np.all(np.isfinite(bounds)) else 10.0
    centre = np.zeros(4)
    centre[:2] = bounds[:, :2].mean(axis=0)
    ps = poses(40, rng=np.random.default_rng(seed), half_extent_m=0.6 * half)
    ps[:, :2, 3] += centre[:2]
    return SceneSpec(
        "generated",
        meshes,
        np.array([index[i.mesh] for i in inst]),
        np.stack([i.world_from_model for i in inst]),
        np.array([i.semantic for i in inst]),
        ps,
        scene,
    )


def bench_spec(name: str, seed: int = 0) -> SceneSpec:
    """The benchmark scene ``name`` (one of :data:`SIZES`) with 40 poses."""
    if name not in SIZES:
        raise ConfigError(
            f"benchmark scene {name!r} is unknown; expected one of {', '.join(SIZES)}"
        )
    if name == "generated":
        return _generated(seed)
    rng = np.random.default_rng(seed)
    meshes, mesh_of, T, sem = _hall(rng) if name == "hall" else _objects_scene(name, rng)
    return SceneSpec(
        name,
        meshes,
        np.array(mesh_of),
        np.stack(T),
        np.array(sem),
        poses(40, rng=np.random.default_rng(seed + 1)),
    )


def to_scene(spec: SceneSpec):
    """The ``genie_gl.Scene`` of ``spec`` (each mesh stored once, instances placed)."""
    if spec.scene is not None:
        return spec.scene
    scene = Scene()
    keys = [
        scene.add_mesh(Mesh(v, f, closed=c), name=f"mesh_{k:04d}")
        for k, (v, f, c) in enumerate(spec.meshes)
    ]
    for m, T, s in zip(spec.mesh_of, spec.world_from_model, spec.semantic):
        scene.add(keys[m], T, semantic=int(s))
    return scene
