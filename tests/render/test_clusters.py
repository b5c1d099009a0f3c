"""Scene upload: a mesh's clusters hold exactly its drawable faces, and their bounds and cones
hold what they claim; the culler's memory follows what is drawn, not the instances."""

import importlib

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.render.clusters import CLUSTER, prepare
from genie_gl.sensors.pose import look_at

pytestmark = pytest.mark.gl


def triangle_set(v, f):
    """Sorted rows of each face's three vertices (float32 coordinates, in face order)."""
    t = np.asarray(v, np.float32)[np.asarray(f)].reshape(len(f), 9)
    return t[np.lexsort(t.T[::-1])]


def noisy_mesh(rng):
    """A subdivided sphere (20,480 faces: many clusters), shuffled, with some NaN vertices and
    degenerate faces."""
    m = trimesh.creation.icosphere(5, radius=1.3)
    v = np.asarray(m.vertices, np.float32) + rng.normal(0, 0.01, (len(m.vertices), 3)).astype(
        np.float32
    )
    f = np.asarray(m.faces, np.uint32)[rng.permutation(len(m.faces))]
    v = np.concatenate([v, [[np.nan, 0, 0]]]).astype(np.float32)
    bad_nan = np.array([[0, 1, len(v) - 1]] * 3, np.uint32)
    bad_flat = np.array([[5, 5, 6], [7, 8, 7]], np.uint32)
    return v, np.concatenate([f, bad_nan, bad_flat]), len(f)


def test_clusters_hold_exactly_the_drawable_faces_with_true_bounds_and_cones():
    v, f, good = noisy_mesh(np.random.default_rng(0))
    c = prepare(gg.Mesh(v, f, closed=True), "noisy")
    assert (c.dropped_nonfinite, c.dropped_degenerate) == (3, 2)
    assert len(c.faces) == good and c.count == -(-good // CLUSTER)
    # the same triangles, coordinates bit for bit (only their order and vertex sharing change)
    assert np.array_equal(triangle_set(c.vertices, c.faces), triangle_set(v, f[:good]))
    p = c.vertices.astype(np.float64)
    for k in range(c.count):
        fk = c.faces[k * CLUSTER : (k + 1) * CLUSTER].astype(np.int64)
        lo, hi = c.vrange[k]
        assert fk.min() >= lo and fk.max() < hi  # a cluster's vertices are its own range
        assert set(np.unique(fk)) == set(range(lo, hi))
        d = np.linalg.norm(p[lo:hi] - c.centre[k], axis=1)
        assert d.max() <= c.radius[k] * (1 + 1e-12)
        tri = p[fk]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(n, axis=1)
        per = sum(
            np.linalg.norm(tri[:, i] - tri[:, j], axis=1) for i, j in ((0, 1), (0, 2), (1, 2))
        )
        assert c.thickness[k] <= (area2 / per).min() * (1 + 1e-9)
        assert c.perimeter[k] <= per.min() * (1 + 1e-9)
        if c.cos_a[k] > 0:  # every face normal within the cone
            assert ((n / area2[:, None]) @ c.axis[k] >= c.cos_a[k] - 1e-9).all()
    assert np.allclose(c.lo, p.min(axis=0)) and np.allclose(c.hi, p.max(axis=0))
    # faces in a cluster are near each other: clusters much smaller than the mesh
    assert np.median(c.radius) < 0.25 * np.linalg.norm(c.hi - c.lo)


def test_a_mesh_shared_by_many_instances_is_prepared_once(monkeypatch):
    renderer_module = importlib.import_module("genie_gl.render.renderer")

    calls = []
    real = renderer_module.prepare
    monkeypatch.setattr(
        renderer_module, "prepare", lambda mesh, name: calls.append(name) or real(mesh, name)
    )
    scene = gg.Scene()
    ball, box = trimesh.creation.icosphere(3), trimesh.creation.box((1, 1, 1))
    for k in range(50):
        scene.add(ball if k % 2 else box, [k, 0, 0])
    with Renderer(scene) as r:
        assert len(calls) == 2 and r.triangles == 25 * (1280 + 12)


def test_culling_memory_follows_what_is_drawn_not_the_instances():
    """400 instances of a 5,120-face sphere (2 M triangles), a camera that sees a few: the
    index buffer and the culler's arrays hold what is drawn (grown by half again at most)."""
    scene = gg.Scene()
    ball = trimesh.creation.icosphere(4, radius=0.4)
    for i in range(20):
        for j in range(20):
            scene.add(ball, [2.0 * i, 2.0 * j, 0.4])
    sensor = gg.Sensor.pinhole(320, 240, 260.0)
    pose = look_at([-3.0, -3.0, 1.5], [0.0, 0.0, 0.4])
    with Renderer(scene) as r:
        assert r.triangles == 400 * 5120
        frame = r.render(sensor, pose, depth_only=True)
        drawn = r.stats["triangles_drawn"]
        assert (frame.instance > 0).any() and 0 < drawn < 0.05 * r.triangles
        index_buffer = r._streams[0][1]
        assert index_buffer.size <= max(1 << 16, 1.5 * 12 * drawn)
        assert len(r._culler._out) <= 1.5 * 3 * drawn
        big = [
            k
            for k, a in vars(r._culler).items()
            if isinstance(a, np.ndarray) and a.size >= r.triangles
        ]
        assert big == []
