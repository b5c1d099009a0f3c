"""Public ray casting against analytic truths and Open3D's ray caster on the same rays."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.bench.render import bench_scene
from genie_gl.render.rays import RayCaster, Rays, RayHits, cast_rays


def test_a_plane_gives_its_analytic_distance_id_class_and_normal():
    """A ground quad z = 0 of +-50 m seen from (0.3, -0.2, 2) along 4,000 random downward rays:
    distance 2 / -dz to the last bits, the quad's ids, faces 0 or 1, the normal +z; the rays
    going up meet nothing (distance 0, instance 0, face -1)."""
    scene = gg.Scene()
    quad = gg.Mesh(
        np.array([[-50, -50, 0], [50, -50, 0], [50, 50, 0], [-50, 50, 0]], float),
        np.array([[0, 1, 2], [0, 2, 3]]),
    )
    iid = scene.add(quad, np.eye(4), semantic=7)
    rng = np.random.default_rng(1)
    d = rng.normal(size=(4000, 3))
    d[:, 2] = -np.abs(d[:, 2]) - 0.3
    d[:2000, 2] *= -1  # the first half looks up
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.array([0.3, -0.2, 2.0])
    h = cast_rays(scene, o, d)
    down = d[:, 2] < 0
    inside = down & (np.abs(o[:2] + d[:, :2] * (2 / -d[:, 2:3])) < 50).all(axis=1)
    assert inside.sum() > 1500
    np.testing.assert_allclose(h.distance[inside], 2.0 / -d[inside, 2], rtol=1e-14)
    assert (h.instance[inside] == iid).all() and (h.semantic[inside] == 7).all()
    assert set(np.unique(h.face[inside])) == {0, 1}
    np.testing.assert_array_equal(h.normal[inside], np.tile([0, 0, 1], (inside.sum(), 1)))
    assert (
        (h.distance[~down] == 0).all()
        and (h.instance[~down] == 0).all()
        and (h.face[~down] == -1).all()
    )
    assert (h.normal[~down] == 0).all() and (h.hit == (h.distance > 0)).all()


def test_rays_from_inside_a_box_meet_its_walls_and_the_normals_face_them():
    """From a point inside a turned 2 x 4 x 6 box every ray meets a wall at the slab
    method's distance; the normal faces back at the origin."""
    T = trimesh.transformations.rotation_matrix(0.4, [1, 2, 3])
    T[:3, 3] = [5, -3, 1]
    scene = gg.Scene()
    iid = scene.add(trimesh.creation.box((2, 4, 6)), T, semantic=2)
    rng = np.random.default_rng(2)
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o_box = np.array([0.3, -0.5, 1.0])
    o = T[:3, :3] @ o_box + T[:3, 3]
    h = cast_rays(scene, o, d)
    db = d @ T[:3, :3]  # the rays in the box frame
    with np.errstate(divide="ignore"):
        t = np.min(
            np.where(
                db > 0, (np.array([1, 2, 3]) - o_box) / db, (-np.array([1, 2, 3]) - o_box) / db
            ),
            axis=1,
        )
    np.testing.assert_allclose(h.distance, t, rtol=1e-12)
    assert (h.instance == iid).all()
    assert ((h.normal.astype(float) * d).sum(axis=1) < 0).all()


def test_a_ray_through_a_shared_edge_or_vertex_is_never_lost():
    """A 20 x 20 grid of unit squares cut into triangles, hit exactly at every grid vertex
    and edge midpoint (rays that run through shared edges and vertices): every ray hits, and
    a tie between the triangles of an edge goes to the lower face."""
    n = 20
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    v = np.c_[xs.ravel(), ys.ravel(), np.zeros(xs.size)]
    f = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = (
                j * (n + 1) + i,
                j * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i + 1,
                (j + 1) * (n + 1) + i,
            )
            f += [[a, b, c], [a, c, d]]
    scene = gg.Scene()
    scene.add(gg.Mesh(v, np.array(f)), np.eye(4))
    g = np.arange(0, n + 0.5, 0.5)
    targets = np.array([[x, y, 0.0] for x in g for y in g])
    # slanted rays from one point to every interior vertex and edge midpoint
    origin = np.array([7.3, 9.1, 5.0])
    inner = (targets[:, :2] > 0).all(axis=1) & (targets[:, :2] < n).all(axis=1)
    h = cast_rays(scene, origin, targets[inner] - origin)
    assert h.hit.all()
    np.testing.assert_allclose(
        h.distance, np.linalg.norm(targets[inner] - origin, axis=1), rtol=1e-14
    )
    # straight down onto every vertex and midpoint, the border's too (exact rays: on an edge is in)
    down = cast_rays(scene, targets + [0, 0, 3.0], np.tile([0, 0, -1.0], (len(targets), 1)))
    assert down.hit.all() and (down.distance == 3.0).all()
    # the grid's centre vertex is shared by six faces: the lowest of them wins
    centre = np.flatnonzero((targets == [10.0, 10.0, 0.0]).all(axis=1))[0]
    sharing = [k for k, tri in enumerate(f) if 10 * (n + 1) + 10 in tri]
    assert len(sharing) == 6 and down.face[centre] == min(sharing)
    # an edge midpoint goes to the lower of its two faces
    mid = np.flatnonzero((targets == [10.5, 10.0, 0.0]).all(axis=1))[0]
    edge = [k for k, tri in enumerate(f) if {10 * (n + 1) + 10, 10 * (n + 1) + 11} <= set(tri)]
    assert len(edge) == 2 and down.face[mid] == min(edge)


def test_the_record_and_its_checks():
    r = Rays.azimuth_elevation(
        [0, 0, 1.0], np.linspace(-np.pi, np.pi, 8, endpoint=False), [-0.1, 0.0, 0.1]
    )
    assert r.shape == (3, 8) and r.grid == "azimuth_elevation"
    np.testing.assert_allclose(np.linalg.norm(r.directions, axis=1), 1.0)
    np.testing.assert_allclose(
        r.directions[8], [-1.0, 0.0, 0.0], atol=1e-15
    )  # row 1 (elevation 0), azimuth -pi
    with pytest.raises(gg.ConfigError, match="direction 0 is zero or not finite"):
        cast_rays(gg.Scene(), np.zeros(3), [[0, 0, 0.0]])
    with pytest.raises(gg.ConfigError, match="direction 2 is zero or not finite"):  # the first
        cast_rays(gg.Scene(), np.zeros(3), [[1, 0, 0], [0, 1, 0], [np.nan, 0, 0], [0, 0, 0]])
    with pytest.raises(gg.ConfigError, match="origins must have shape"):
        cast_rays(gg.Scene(), np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(gg.ConfigError, match="rows \\* cols"):
        Rays(np.zeros(3), np.ones((6, 3)), "pinhole", (2, 2))
    empty = cast_rays(gg.Scene(), np.zeros(3), np.ones((4, 3)))
    assert isinstance(empty, RayHits) and not empty.hit.any() and (empty.face == -1).all()
    assert gg.cast_rays is cast_rays


def world_scene(scene):
    """The scene with every instance's triangles in float32 world coordinates (the triangles
    Open3D is given), so both casters meet the same triangles."""
    out = gg.Scene()
    for inst in scene.instances:
        m, T = scene.meshes[inst.mesh], inst.world_from_model
        w = (m.vertices.astype(np.float64) @ T[:3, :3].T + T[:3, 3]).astype(np.float32)
        out.add(
            gg.Mesh(w, m.faces, origin=np.zeros(3)),
            np.eye(4),
            semantic=inst.semantic,
            instance=inst.instance,
        )
    return out


def test_random_rays_agree_with_open3d_ray_casting():
    """100,000 random rays (origins anywhere in the 100 k scene's box, float32-exact, as
    Open3D takes them) against Open3D's RaycastingScene on the same float32 triangles: the
    same instance at >= 99.999 % of rays where the two distances differ (a ray meeting two
    coincident faces of different instances, a box on the floor, is a tie either may
    take), the same face where the instance is the same and the distance too, relative
    distance error p99 <= 1e-6."""
    import open3d as o3d  # installed by the test extra: a missing reader fails, never skips

    scene = world_scene(bench_scene("100k")[0])
    rng = np.random.default_rng(3)
    lo, hi = scene.bounds()
    n = 100_000
    o = (lo + rng.random((n, 3)) * (hi - lo)).astype(np.float32).astype(np.float64)
    d = rng.normal(size=(n, 3)).astype(np.float32).astype(np.float64)
    h = cast_rays(scene, o, d)
    rc = o3d.t.geometry.RaycastingScene()
    ids = [inst.instance for inst in scene.instances]
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        rc.add_triangles(o3d.core.Tensor(m.vertices), o3d.core.Tensor(m.faces.astype(np.uint32)))
    a = rc.cast_rays(o3d.core.Tensor(np.c_[o, d].astype(np.float32)))
    g = a["geometry_ids"].numpy().astype(np.int64)
    inst = np.array(ids + [0], np.uint32)[np.where(g == rc.INVALID_ID, len(ids), g)]
    t = a["t_hit"].numpy().astype(np.float64) * np.linalg.norm(
        d, axis=1
    )  # Open3D's t is in units of |d|
    t[~np.isfinite(t)] = 0.0
    assert 0.3 < h.hit.mean() < 0.9
    tie = np.abs(h.distance - t) <= 1e-5 * np.maximum(t, 1e-3)
    assert ((h.instance == inst) | tie).mean() >= 0.99999
    same = (h.instance == inst) & h.hit
    assert same.mean() > 0.3
    rel = np.abs(h.distance[same] / t[same] - 1)
    assert np.percentile(rel, 99) <= 1e-6
    assert (h.face[same & tie] == a["primitive_ids"].numpy()[same & tie]).mean() > 0.999


def test_the_caster_is_rebuilt_when_the_scene_changes():
    scene = gg.Scene()
    scene.add(trimesh.creation.box((1, 1, 1)), np.eye(4))
    down = cast_rays(scene, [0, 0, 5.0], [[0, 0, -1.0]])
    np.testing.assert_allclose(down.distance, [4.5])
    T = np.eye(4)
    T[2, 3] = 2.0
    top = scene.add(trimesh.creation.box((1, 1, 1)), T)
    again = cast_rays(scene, [0, 0, 5.0], [[0, 0, -1.0]])
    np.testing.assert_allclose(again.distance, [2.5])
    assert again.instance[0] == top and RayCaster(scene).triangles == 24
