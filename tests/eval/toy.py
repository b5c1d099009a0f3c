"""Tiny labelled scenes for the evaluation tests, made in a fraction of a second without GL: a
floor (class 0) with tall racks (2), low flat pallets (1) and small boxes (9) standing on it,
their surfaces sampled at random and written with genie-gl's own exporters, so the tests read
them back through the same code as a real dataset. Each box is an instance of its own (ids 1,
2, ...); the floor, stuff, carries instance 0 as SemanticKITTI's stuff does."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from genie_gl.cloud.pointcloud import PointCloud
from genie_gl.export import npz, ply, semantickitti

# class -> (size x, y, z in metres)
BOXES = {2: (1.0, 0.4, 2.0), 1: (1.2, 0.8, 0.15), 9: (0.4, 0.3, 0.3)}


def _box_surface(
    centre: np.ndarray, size: tuple[float, float, float], n: int, rng: np.random.Generator
) -> np.ndarray:
    """n points on the five visible faces of a box standing on the floor."""
    sx, sy, sz = size
    areas = np.array([sx * sy, sx * sz, sx * sz, sy * sz, sy * sz])
    face = rng.choice(5, size=n, p=areas / areas.sum())
    u, v = rng.random(n), rng.random(n)
    p = np.zeros((n, 3))
    top = face == 0
    p[top] = np.column_stack([(u[top] - 0.5) * sx, (v[top] - 0.5) * sy, np.full(top.sum(), sz)])
    for f, sign in ((1, -1), (2, 1)):
        m = face == f
        p[m] = np.column_stack([(u[m] - 0.5) * sx, np.full(m.sum(), sign * sy / 2), v[m] * sz])
    for f, sign in ((3, -1), (4, 1)):
        m = face == f
        p[m] = np.column_stack([np.full(m.sum(), sign * sx / 2), (u[m] - 0.5) * sy, v[m] * sz])
    return p + centre


def scene_cloud(rng: np.random.Generator, *, size_m: float = 8.0, points: int = 6000) -> PointCloud:
    """One toy scene: a floor and a few boxes of each class, ~``points`` points."""
    parts, labels, ids = [], [], []
    n_floor = points // 3
    parts.append(np.column_stack([rng.random((n_floor, 2)) * size_m, np.zeros(n_floor)]))
    labels.append(np.zeros(n_floor, np.uint16))
    ids.append(np.zeros(n_floor, np.uint32))
    per_class = (points - n_floor) // len(BOXES)
    for cls, size in BOXES.items():
        k = int(rng.integers(2, 4))
        for j in range(k):
            centre = np.array([rng.uniform(1, size_m - 1), rng.uniform(1, size_m - 1), 0.0])
            pts = _box_surface(centre, size, per_class // k, rng)
            parts.append(pts)
            labels.append(np.full(len(pts), cls, np.uint16))
            ids.append(np.full(len(pts), len(ids), np.uint32))
    xyz = np.concatenate(parts)
    xyz += rng.normal(0, 0.003, xyz.shape)
    sem = np.concatenate(labels)
    return PointCloud(xyz=xyz.astype(np.float32), semantic=sem, instance=np.concatenate(ids))


def make_set(
    root: Path,
    *,
    scenes: int = 4,
    seed: int = 0,
    fmt: str = "semantickitti",
    scans_per_scene: int = 1,
    points: int = 6000,
) -> Path:
    """A toy dataset in genie-gl's layout: ``sequences/NN`` (one per scene) with ``genie-gl.yaml``,
    or ``scenes/NNNN/cloud_XXX.ply|npz``."""
    rng = np.random.default_rng(seed)
    root = Path(root)
    counts: dict[int, int] = {}
    for s in range(scenes):
        for j in range(scans_per_scene):
            cloud = scene_cloud(rng, points=points)
            for c, n in zip(*np.unique(cloud.semantic, return_counts=True)):
                counts[int(c)] = counts.get(int(c), 0) + int(n)
            if fmt == "semantickitti":
                semantickitti.write(cloud, root, sequence=s, frame=j)
            elif fmt == "ply":
                ply.write(cloud, root / "scenes" / f"{s:04d}" / f"cloud_{j:03d}.ply")
            else:
                npz.write(cloud, root / "scenes" / f"{s:04d}" / f"cloud_{j:03d}.npz")
    if fmt == "semantickitti":
        (root / "genie-gl.yaml").write_text(
            semantickitti.label_map_yaml(
                counts, {"train": list(range(scenes)), "valid": [], "test": list(range(scenes))}
            )
        )
    return root


def relabel(root: Path, lut: dict[int, int]) -> None:
    """Rewrite a SemanticKITTI set's labels in place through ``lut`` (a planted bug)."""
    for f in sorted(Path(root).glob("sequences/*/labels/*.label")):
        raw = np.fromfile(f, dtype="<u4")
        sem = raw & 0xFFFF
        new = sem.copy()
        for a, b in lut.items():
            new[sem == a] = b
        ((raw & 0xFFFF0000) | new).astype("<u4").tofile(f)
