"""The CPU rasteriser (``Renderer(raster="cpu")``): culling changes no byte against testing
every triangle at every pixel centre of its box; threads change no byte; depth is the exact
ray hit (analytic planes, Open3D's ray caster); shared edges leave no crack; it agrees with
the GL raster and with its own triangles per pixel; bad options are refused."""

import numba
import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.render import Renderer
from genie_gl.render.cpu import raster
from genie_gl.sensors.pose import look_at
from genie_gl.resources import resolve
from tests.scenes import scene_of, sensor_640

from .conftest import ray_dirs


def assert_same_frames(a, b, normals=False):
    assert a.depth.tobytes() == b.depth.tobytes()
    assert np.array_equal(a.instance, b.instance) and np.array_equal(a.semantic, b.semantic)
    if a.rgb is not None or b.rgb is not None:
        assert np.array_equal(a.rgb, b.rgb)
    if normals:
        assert a.normal.tobytes() == b.normal.tobytes()


def culled_and_unculled(scene, sensor, poses, **kw):
    with Renderer(scene, raster="cpu", cull=False) as a, Renderer(scene, raster="cpu") as b:
        return [
            (a.render(sensor, p, **kw), b.render(sensor, p, **kw), b._rasteriser.counts.copy())
            for p in poses
        ]


def test_culling_changes_no_byte_on_the_benchmark_scene():
    scene, poses = scene_of("100k")
    for fa, fb, counts in culled_and_unculled(scene, sensor_640(), poses[:3]):
        assert_same_frames(fa, fb)
        assert (fa.instance > 0).mean() > 0.3
        total = sum(len(scene.meshes[i.mesh].faces) for i in scene.instances)
        assert counts[2] > 0 and counts[3] < 0.5 * total  # it does cull: hidden faces and more


def test_culling_changes_no_byte_on_a_generated_scene_with_colour_and_normals():
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=3)
    scene = gg.build_scene(layout, seed=3)
    sensor = gg.Sensor.pinhole(160, 120, 130.0)
    poses = gg.place_sensors(layout, sensor, n=4, seed=3)
    for fa, fb, _ in culled_and_unculled(scene, sensor, poses, normals=True):
        assert_same_frames(fa, fb, normals=True)
        assert (fa.instance > 0).mean() > 0.2


def test_culling_changes_no_byte_with_sub_pixel_triangles_near_and_far():
    """Thousands of triangles smaller than a pixel seen from inside their cloud with a skewed
    K, and the same scene 1e7 m away (camera-relative composition keeps it exact)."""
    rng = np.random.default_rng(11)
    sensor = gg.Sensor(97, 73, np.array([[90.0, 0.3, 48.2], [0, 93.0, 36.7], [0, 0, 1]]))
    scene = gg.Scene()
    n = 4000
    centre = rng.normal(size=(n, 3))
    centre *= 2.0 / np.linalg.norm(centre, axis=1, keepdims=True)
    size = rng.uniform(0.002, 0.05, n)
    tri = centre[:, None, :] + rng.normal(size=(n, 3, 3)) * size[:, None, None]
    scene.add(gg.Mesh(tri.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3)), np.eye(4), semantic=2)
    for _ in range(6):
        T = np.eye(4)
        T[:3, 3] = rng.uniform(-1, 1, 3)
        scene.add(trimesh.creation.icosphere(4, radius=0.3), T, semantic=3)
    shift = np.eye(4)
    shift[:3, 3] = [1e7, -1e7, 3e6]
    far = gg.Scene()
    for inst in scene.instances:
        far.add(scene.meshes[inst.mesh], shift @ inst.world_from_model, semantic=inst.semantic)
    poses = [look_at(e, e + rng.normal(size=3)) for e in rng.uniform(-0.5, 0.5, (4, 3))]
    near = culled_and_unculled(scene, sensor, poses)
    away = culled_and_unculled(far, sensor, [shift @ p for p in poses])
    for (fa, fb, _), (ga, gb, _) in zip(near, away):
        assert_same_frames(fa, fb)
        assert_same_frames(ga, gb)
        hit = fa.instance > 0
        assert hit.mean() > 0.05 and (ga.instance == fa.instance).mean() > 0.999
        same = hit & (ga.instance == fa.instance)
        np.testing.assert_allclose(ga.depth[same], fa.depth[same], rtol=1e-6)


def test_one_thread_or_two_give_the_same_bytes(monkeypatch):
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    monkeypatch.setattr(raster, "PARALLEL_FACES", 0)  # two threads however small the frame
    threads = numba.get_num_threads()
    assert threads >= 2, "numba has one thread here: the case cannot compare one thread with two"
    with Renderer(scene, raster="cpu") as r:
        two = []
        for p in poses[:2]:
            two.append(r.render(sensor, p, normals=True))
            assert (
                r._rasteriser.tally[:2, 0] > 0
            ).all()  # both threads drew clusters of this frame
        numba.set_num_threads(1)
        try:
            one = [r.render(sensor, p, normals=True) for p in poses[:2]]
        finally:
            numba.set_num_threads(threads)
    for a, b in zip(one, two):
        assert_same_frames(a, b, normals=True)


def test_depth_is_the_exact_ray_hit_on_a_tilted_plane_far_away():
    """A plane z = 400 + 0.7 x - 0.2 y (two triangles) seen head on: depth is c / (n·d) per
    pixel centre ray, to float32 rounding (the GL raster interpolates float32 eye
    coordinates and is ~10x further off)."""
    sensor = gg.Sensor.pinhole(160, 120, 140.0, near_m=0.1, far_m=2000.0)
    s = 2000.0
    corners = np.array([[-s, -s, 0], [s, -s, 0], [s, s, 0], [-s, s, 0]], float)
    corners[:, 2] = 400 + 0.7 * corners[:, 0] - 0.2 * corners[:, 1]
    scene = gg.Scene()
    scene.add(gg.Mesh(corners, np.array([[0, 1, 2], [0, 2, 3]])), np.eye(4), semantic=1)
    d = ray_dirs(sensor)
    truth = 400.0 / (1 - 0.7 * d[..., 0] + 0.2 * d[..., 1])
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, np.eye(4))
    assert (f.instance > 0).all()
    err = np.abs(f.depth - truth) / truth
    assert err.max() <= 2**-24 * 1.01  # the float32 rounding of the exact value


def test_no_cracks_where_edges_and_vertices_lie_on_pixel_centre_rays():
    """A wall cut into 2 x 40 x 30 triangles whose inner vertices lie on pixel-centre rays
    (every inner edge passes through pixel centres, in both diagonal directions): every
    pixel is covered, by the wall alone."""
    sensor = gg.Sensor.pinhole(80, 60, 70.0)
    K = sensor.K
    us, vs = np.arange(0, 81, 2, dtype=float), np.arange(0, 61, 2, dtype=float)
    us[[0, -1]], vs[[0, -1]] = [-20.0, 100.0], [-20.0, 80.0]  # the outer ring well past the image
    u, v = np.meshgrid(us, vs)
    z = 5.0
    pts = np.stack(
        [(u - K[0, 2]) / K[0, 0] * z, (v - K[1, 2]) / K[1, 1] * z, np.full(u.shape, z)], -1
    )
    pts = pts.reshape(-1, 3)
    nu = len(us)
    faces = []
    for j in range(len(vs) - 1):
        for i in range(nu - 1):
            a, b, c, dd = j * nu + i, j * nu + i + 1, (j + 1) * nu + i + 1, (j + 1) * nu + i
            faces += [[a, b, c], [a, c, dd]] if (i + j) % 2 else [[a, b, dd], [b, c, dd]]
    scene = gg.Scene()
    wall = scene.add(gg.Mesh(pts, np.array(faces)), np.eye(4), semantic=1)
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, np.eye(4))
    assert (f.instance == wall).all()
    np.testing.assert_allclose(f.depth, z, rtol=2**-23)


def test_depth_and_ids_agree_with_open3d_ray_casting():
    o3d = pytest.importorskip("open3d")
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    rc = o3d.t.geometry.RaycastingScene()
    ids = []
    for inst in scene.instances:
        mesh = scene.meshes[inst.mesh]
        T = inst.world_from_model
        w = np.asarray(mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3]
        rc.add_triangles(
            o3d.core.Tensor(w.astype(np.float32)),
            o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)),
        )
        ids.append(inst.instance)
    ids = np.array(ids + [0], np.uint32)
    with Renderer(scene, raster="cpu") as r:
        for pose in poses[:2]:
            f = r.render(sensor, pose, depth_only=True)
            d = ray_dirs(sensor) @ pose[:3, :3].T
            rays = np.concatenate([np.broadcast_to(pose[:3, 3], d.shape), d], -1).astype(np.float32)
            ans = rc.cast_rays(o3d.core.Tensor(rays))
            t = ans["t_hit"].numpy()
            gid = ans["geometry_ids"].numpy().astype(np.int64)
            inst = ids[np.where(gid == rc.INVALID_ID, len(ids) - 1, gid)]
            t[~np.isfinite(t)] = 0
            t[(t < sensor.near_m) | (t > sensor.far_m)] = 0
            inst[t == 0] = 0
            assert (f.instance == inst).mean() > 0.9995
            same = (f.instance == inst) & (inst > 0)
            assert same.mean() > 0.3
            # Open3D intersects in float32: a few grazing pixels differ by some 1e-6
            rel = np.abs(f.depth[same] / t[same] - 1)
            assert rel.max() < 1e-4 and (rel < 1e-6).mean() > 0.999


def test_agrees_with_the_gl_raster_in_ids_normals_and_colour(glctx):
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=5)
    scene = gg.build_scene(layout, seed=5)
    sensor = gg.Sensor.pinhole(320, 240, 260.0)
    poses = gg.place_sensors(layout, sensor, n=3, seed=5)
    with Renderer(scene, raster="cpu") as c, Renderer(scene, context=glctx) as g:
        for p in poses:
            a, b = c.render(sensor, p, normals=True), g.render(sensor, p, normals=True)
            same = (a.instance == b.instance) & (a.instance > 0)
            assert (a.instance == b.instance).mean() > 0.998 and same.mean() > 0.2
            rel = np.abs(
                a.depth[same] / b.depth[same] - 1
            )  # a crease's pixel may go to its other side
            assert (rel < 2e-4).mean() > 0.9995 and np.median(rel) < 1e-6
            assert (np.abs(a.normal[same] - b.normal[same]).max(axis=-1) < 1e-3).mean() > 0.99
            assert (np.abs(a.rgb[same].astype(int) - b.rgb[same]).max(axis=-1) <= 1).mean() > 0.99


def test_each_pixel_names_the_triangle_its_depth_comes_from():
    scene, poses = scene_of("100k")
    sensor = sensor_640()
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, poses[0], depth_only=True, triangles=True)
    d = ray_dirs(sensor)
    rng = np.random.default_rng(0)
    hits = np.argwhere(f.instance > 0)
    for v, u in hits[rng.choice(len(hits), 200, replace=False)]:
        A, B, C = f.triangles.vertices_of(v, u)
        n = np.cross(B - A, C - A)
        z = n @ A / (n @ d[v, u])
        assert abs(z - f.depth[v, u]) <= 1e-6 * z


def test_bad_options_are_refused():
    scene, _ = scene_of("100k")
    with pytest.raises(ConfigError, match="depth_precision='exakt' is unknown"):
        Renderer(scene, depth_precision="exakt")
    with pytest.raises(ConfigError, match="ask for it by name, raster='cpu'"):
        Renderer(scene, depth_precision="exact")
    with pytest.raises(
        ConfigError, match="raster 'cp' is unknown; expected cpu or gl; did you mean 'cpu'"
    ):
        Renderer(scene, raster="cp")
    from genie_gl.sensors.accuracy import AccuracySettings

    with pytest.raises(ConfigError, match="'exact' is the CPU rasteriser: write raster: cpu"):
        AccuracySettings(depth_precision="exact")
    assert (
        "raster" not in AccuracySettings().to_dict()
        and AccuracySettings(raster="gl").to_dict()["raster"] == "gl"
    )


@pytest.mark.gl
def test_a_capture_through_a_distorted_lens_with_effects_takes_the_exact_raster(monkeypatch):
    """``accuracy: {raster: cpu}`` reaches the renderer through ``capture``: the
    Azure Kinect's fisheye-like lens (its ids from each lens pixel's own ray) and its
    effects run on the CPU raster's frames and agree with the GL raster's."""
    from genie_gl.sensors.accuracy import AccuracySettings

    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=1)
    scene = gg.build_scene(layout, seed=1)
    sensor = gg.load_sensor(resolve("azure_kinect_nfov", "sensors", (".yaml",)))
    poses = gg.place_sensors(layout, sensor, n=2, seed=1)
    drawn = []  # the CPU rasteriser's frames, counted (it still draws them)
    draw = raster.Rasteriser.draw
    monkeypatch.setattr(
        raster.Rasteriser, "draw", lambda self, *a, **k: drawn.append(1) or draw(self, *a, **k)
    )
    exact = gg.capture(scene, sensor, poses, seed=0, accuracy=AccuracySettings(raster="cpu"))
    assert len(drawn) >= len(
        poses
    )  # (the lens resamples each pixel's ray: depth alone cannot tell)
    monkeypatch.undo()
    gl = gg.capture(scene, sensor, poses, seed=0, accuracy=AccuracySettings(raster="gl"))
    for a, b in zip(exact, gl):
        assert (a.instance > 0).mean() > 0.2
        assert (a.instance == b.instance).mean() > 0.999
        same = (a.instance == b.instance) & (a.depth > 0) & (b.depth > 0)
        assert (
            np.median(np.abs(a.depth[same] - b.depth[same])) < 1e-4
        )  # the same noise, the same surfaces


@pytest.mark.parametrize("lens", [False, True], ids=["pinhole", "lens"])
def test_a_frame_of_depth_and_ids_alone_equals_those_of_a_full_frame(monkeypatch, lens):
    """Depth and ids alone are filled strip by strip as they are drawn (through a lens, by
    the shading pass's depth-and-ids loop); with colour and normals the full shading pass
    fills them: the same values, with the sensor's range applied (a far limit inside the
    scene empties pixels), on one thread and on two."""
    import dataclasses

    scene, poses = scene_of("100k")
    sensor = dataclasses.replace(sensor_640(), far_m=6.0)
    if lens:  # the OpenCV tutorial lens on the same K
        sensor = dataclasses.replace(sensor, dist=np.array([-0.42, 0.2, 0.001, -0.0003, -0.05]))
    monkeypatch.setattr(raster, "PARALLEL_FACES", 0)
    threads = numba.get_num_threads()
    with Renderer(scene, raster="cpu") as r:
        for t in sorted({1, threads}):
            numba.set_num_threads(t)
            try:
                for p in poses[:3]:
                    alone = r.render(sensor, p, depth_only=True)
                    full = r.render(sensor, p, normals=True)
                    assert alone.rgb is None and full.rgb is not None
                    assert alone.depth.tobytes() == full.depth.tobytes()
                    assert np.array_equal(alone.instance, full.instance)
                    assert np.array_equal(alone.semantic, full.semantic)
                    cut = (full.depth == 0) & (alone.instance == 0)
                    assert 0.01 < cut.mean() < 0.99 and alone.depth.max() <= 6.0
            finally:
                numba.set_num_threads(threads)


def test_culling_changes_no_byte_where_edges_graze_pixel_centres():
    """Triangles of a few to tens of pixels whose vertices lie on pixel-centre rays or within
    1e-12..1e-6 px of them, with edges nearly parallel to the rows or the columns: a line's
    span ends land on or next to centres, where only the exact test may decide (the spans
    skip the test only for centres more than their rounding inside)."""
    rng = np.random.default_rng(5)
    sensor = gg.Sensor(64, 48, np.array([[50.0, 0.0, 31.5], [0, 50.0, 23.5], [0, 0, 1]]))
    n = 400
    uv = rng.integers(0, 64, (n, 3, 2)).astype(float)
    uv[..., 1] %= 48
    nudge = rng.choice([0.0, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6, 0.5], (n, 3, 2))
    uv += nudge
    flat = rng.random(n) < 0.5  # an edge nearly along a row (or a column)
    axis = rng.integers(0, 2, n)
    uv[flat, 1, axis[flat]] = uv[flat, 0, axis[flat]] + rng.choice([0.0, 1e-11, -1e-11], flat.sum())
    z = rng.uniform(1.5, 3.0, (n, 3))
    xyz = np.stack([(uv[..., 0] - 31.5) * z / 50.0, (uv[..., 1] - 23.5) * z / 50.0, z], axis=-1)
    scene = gg.Scene()
    scene.add(gg.Mesh(xyz.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3)), np.eye(4), semantic=2)
    ((fa, fb, counts),) = culled_and_unculled(scene, sensor, [np.eye(4)])
    assert_same_frames(fa, fb)
    assert (fa.instance > 0).mean() > 0.5
    with Renderer(scene, raster="cpu", cull=False) as r:
        r.render(sensor, np.eye(4))
        every = r._rasteriser.counts[4]
    assert (
        counts[4] < every
    )  # the spans did narrow the lines (the culled frame tested fewer centres)


def test_culling_changes_no_byte_where_a_row_runs_along_an_edge_parallel_to_it():
    """An edge exactly parallel to the pixel rows (its two vertices at one height and depth in
    the camera frame), the camera level with it to within 1e-13..2e-10 relative of a row of
    centres: the span cannot tell that row's inside from its outside, so each of its centres
    gets the exact test (it was taken whole, 36 centres the exact test leaves out)."""
    sensor = gg.Sensor(64, 48, np.array([[64.0, 0.0, 31.5], [0, 64.0, 23.5], [0, 0, 1]]))
    for delta in (1e-13, -1e-13, 1e-11, -1e-11, 2e-10, -2e-10):
        for row in (10, 30):
            y = np.float32(0.3)
            pose = np.eye(4)
            pose[1, 3] = float(y) - (row - 23.5) / 64.0 * 2.0 * (
                1 + delta
            )  # camera-frame y of the edge
            for off in (0.5, -0.5):
                tri = np.array([[-0.6, y, 2.0], [0.6, y, 2.0], [0.0, y + off, 2.0]])
                for order in ([0, 1, 2], [1, 0, 2]):
                    scene = gg.Scene()
                    scene.add(gg.Mesh(tri, np.array([order])), np.eye(4), semantic=2)
                    ((fa, fb, _),) = culled_and_unculled(scene, sensor, [pose])
                    assert_same_frames(fa, fb)
                    assert (fa.instance > 0).sum() > 100


def test_ties_go_to_the_lower_slot_then_the_lower_face():
    """The CPU raster's one tie rule (:func:`genie_gl.render.cpu.coverage._write`): a pixel
    centre that two triangles meet at the same float64 depth goes to the lower (slot, face).
    Two coincident copies of a square wall at z = 2: every pixel shows the first copy; on
    the square's diagonal, where the pixel centres' rays cross the edge both its faces share
    (edge functions exactly 0), the pixel shows face 0; off it, the face that covers it."""
    sensor = gg.Sensor(64, 64, np.array([[32.0, 0, 32], [0, 32.0, 32], [0, 0, 1]]))
    wall = gg.Mesh(
        np.array([[-2, -2, 2], [2, -2, 2], [2, 2, 2], [-2, 2, 2]], float),
        np.array([[0, 1, 2], [0, 2, 3]]),
    )
    scene = gg.Scene()
    first = scene.add(wall, np.eye(4), semantic=1)
    scene.add(wall, np.eye(4), semantic=2)
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, np.eye(4), triangles=True)
    assert (f.instance == first).all() and (f.semantic == 1).all()
    np.testing.assert_array_equal(f.depth, 2.0)
    slot, face = f.triangles.pixel[..., 0], f.triangles.pixel[..., 1]
    assert (slot == 1).all()
    u, v = np.meshgrid(np.arange(64), np.arange(64))
    assert (face[u == v] == 0).all()
    assert (face[u > v] == 0).all() and (
        face[u < v] == 1
    ).all()  # x > y: below the diagonal, face 0 (0-1-2)
