"""The CPU raster draws a distorted lens's own pixel rays (rays binned on a grid of the view's
frame, :class:`genie_gl.render.cpu.coverage.Samples`), with the kernel, the winner rule and
the culling of the pixel-centre frame: analytic depths and normals through a lens one view
holds and through a fisheye past 180 degrees (cube faces), the culled frame equal to the
unculled reference byte for byte, the tie rule, and ``gg.capture`` taking the same path."""

import dataclasses

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.lens.distortion import lens_views
from genie_gl.render.cpu import bins
from genie_gl.render.cpu.bins import lens_samples

TUTORIAL = gg.Sensor(
    640,
    480,
    np.array([[535.9, 0, 342.3], [0, 535.9, 235.6], [0, 0, 1.0]]),
    [-0.42, 0.2, 0.001, -0.0003, -0.05],
    near_m=0.1,
    far_m=100.0,
)
# a Kannala-Brandt fisheye past 180 degrees across (its rays need the cube's side faces)
FISHEYE = gg.Sensor(
    320,
    240,
    np.array([[80.0, 0, 160], [0, 80, 120], [0, 0, 1]]),
    [0.0, 0.0, 0.0, 0.0],
    near_m=0.1,
    far_m=1000.0,
    model="fisheye",
)


def quad(corners):
    return gg.Mesh(np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]]))


def wall(z, half=60.0):
    """A wall facing the camera at depth z (its front face towards -z)."""
    return quad([[-half, -half, z], [-half, half, z], [half, half, z], [half, -half, z]])


# a strong pincushion (rays densest at the rim) and a lens that folds inside the image (the
# pixels past the fold have no ray; the rays before it crowd together)
PINCUSHION = dataclasses.replace(TUTORIAL, dist=np.array([0.5, 0.0, 0.0, 0.0, 0.0]))
FOLDING = dataclasses.replace(TUTORIAL, dist=np.array([-0.8, 0.0, 0.0, 0.0, 0.0]))


@pytest.mark.parametrize(
    "sensor",
    [TUTORIAL, FISHEYE, PINCUSHION, FOLDING],
    ids=["tutorial", "fisheye-190", "pincushion", "folding"],
)
def test_a_wall_through_the_lens_is_at_its_analytic_depth_with_its_normal(sensor):
    """Every pixel whose ray meets the wall at z = 4 m holds depth 4 (camera z, float32) and the
    normal (0, 0, -1) in the camera frame, whichever view's bins hold its ray; the pixels
    whose ray misses it (past 90 degrees, or past the lens's fold) hold nothing, as the lens's
    rays say. The bins are never more than the view's pixels, however the rays crowd."""
    scene = gg.Scene()
    scene.add(wall(4.0), instance=7)
    d = sensor.directions()
    hits = np.isfinite(d).all(-1) & (np.nan_to_num(d[..., 2]) > 0)
    on_wall = np.nan_to_num(d[..., :2]) / np.where(hits, d[..., 2], 1)[..., None] * 4.0
    hits &= np.all(np.abs(on_wall) < 60, -1)
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, np.eye(4), normals=True)
    assert (f.instance == 7).sum() == hits.sum() > 0.4 * hits.size
    assert np.array_equal(f.instance == 7, hits)
    np.testing.assert_allclose(f.depth[hits], 4.0, rtol=1e-6)
    want = np.broadcast_to([0.0, 0.0, -1.0], f.normal[hits].shape)
    np.testing.assert_allclose(f.normal[hits], want, atol=1e-6)
    assert not f.depth[~hits].any() and not f.normal[~hits].any()
    if sensor is FISHEYE:
        assert len(lens_views(sensor, oversample=1.0)) == 5  # the side faces drew rays too
    for m in lens_views(sensor, oversample=1.0):
        _, Wg, Hg = lens_samples(m).grid
        assert Wg <= m.render_sensor.width and Hg <= m.render_sensor.height


def boxes_before_a_wall(rng, n, size, subdivisions, radius, centre):
    """A wall at 9 m (instance 1), ``n`` boxes up to ``size`` m a side turned at random between
    1.5 and 8.5 m (instances 10, 11, ...) and a sphere of many small faces (instance 99)."""
    scene = gg.Scene()
    scene.add(wall(9.0), instance=1)
    for k in range(n):
        box = trimesh.creation.box(rng.uniform(0.05, size, 3))
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        T[:3, 3] = [rng.uniform(-4, 4), rng.uniform(-3, 3), rng.uniform(1.5, 8.5)]
        scene.add(box, T, instance=10 + k)
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    scene.add(sphere, centre, instance=99)
    return scene


def test_the_culled_lens_frame_equals_the_unculled_reference_byte_for_byte():
    """Occlusion tiles, cluster bounds and the spans of rows of bins skip work, never a ray:
    the lens frame equals the one whose every face is tested against every ray of its box."""
    scene = boxes_before_a_wall(np.random.default_rng(5), 40, 1.5, 5, 1.0, [0.5, 0.2, 4.0])
    for sensor in (TUTORIAL, FISHEYE):
        with Renderer(scene, raster="cpu") as r:
            a = r.render(sensor, np.eye(4), normals=True)
        with Renderer(scene, raster="cpu", cull=False) as ref:
            b = ref.render(sensor, np.eye(4), normals=True)
        assert (a.instance > 0).mean() > 0.3 and len(np.unique(a.instance)) > 20
        for name in ("depth", "instance", "rgb", "normal"):
            assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name


def test_a_lens_frame_is_the_same_whatever_the_height_of_its_bins(monkeypatch):
    """A bin is about BIN_RAD of the view tall (8 rows of the tutorial lens's view, 4 of a
    short focal length's): the height only decides which rays a face is tested against and how
    tall an occlusion tile is in bins, never a ray's winner: the frames drawn with bins of 2, 4
    and 8 rows are the same bytes."""
    assert bins.bin_rows(535.9) == 8 and bins.bin_rows(230.0) == 4 and bins.bin_rows(80.0) == 4
    scene = boxes_before_a_wall(np.random.default_rng(11), 30, 1.2, 4, 0.8, [0.3, 0.1, 3.5])
    frames = {}
    for rows in (2, 4, 8):
        monkeypatch.setattr(bins, "BIN_ROWS", (rows, rows))
        for sensor in (TUTORIAL, FISHEYE):
            for m in lens_views(sensor, oversample=1.0):  # (binned afresh)
                m.cache.pop("lens_samples", None)
                assert lens_samples(m).samples.tiles.shape[0] == -(-m.render_sensor.height // 8)
            with Renderer(scene, raster="cpu") as r:
                f = r.render(sensor, np.eye(4), normals=True)
            frames[rows, sensor.model] = [f.depth, f.instance, f.normal]
    for sensor in (TUTORIAL, FISHEYE):  # (no bins of this test's heights left in the cache)
        for m in lens_views(sensor, oversample=1.0):
            m.cache.pop("lens_samples", None)
    for model in (TUTORIAL.model, FISHEYE.model):
        assert (frames[8, model][1] > 0).mean() > 0.3
        for rows in (2, 4):
            for a, b in zip(frames[rows, model], frames[8, model]):
                assert a.tobytes() == b.tobytes(), (rows, model)


def test_ties_through_the_lens_go_to_the_lower_slot():
    """Two coincident walls: every pixel of the lens shows the one of the lower instance slot
    (the raster's one winner rule, for a lens's rays as for pixel centres)."""
    scene = gg.Scene()
    scene.add(wall(3.0), instance=5)  # slot 0
    scene.add(wall(3.0), instance=4)  # slot 1, the same triangles
    with Renderer(scene, raster="cpu") as r:
        f = r.render(TUTORIAL, np.eye(4))
    assert (f.instance == 5).all()


# a radial lens whose principal point is a pixel centre: the rays of its middle column have
# x = 0 exactly, those of its middle row y = 0
CENTRED = gg.Sensor(
    320,
    240,
    np.array([[200.0, 0, 160], [0, 200.0, 120], [0, 0, 1]]),
    [-0.3, 0.05, 0.0, 0.0, 0.0],
    near_m=0.1,
    far_m=100.0,
)


@pytest.mark.parametrize("lens", [True, False], ids=["lens", "pinhole"])
@pytest.mark.parametrize("turn", [0, 1, 2])
def test_rays_on_an_edge_two_faces_share_hit_one_of_them(lens, turn):
    """Two faces sharing the edge x = 0: the rays of the middle column lie on it exactly
    (their edge functions are exactly 0 for both faces) and each still hits one of them. An
    edge test that left out its zeros would leave a crack there.
    The shared edge is the first, third or second edge of both faces (their corners turned
    by ``turn``), so that a change to any one of the three tests is seen."""
    sensor = CENTRED if lens else dataclasses.replace(CENTRED, dist=np.zeros(5))
    h, z = 8.0, 4.0
    corners = np.array([[0.0, -h, z], [0.0, h, z], [-h, 0.0, z], [h, 0.0, z]])
    faces = np.roll(np.array([[0, 1, 2], [1, 0, 3]]), turn, axis=1)  # the shared edge first
    scene = gg.Scene()
    scene.add(gg.Mesh(corners, faces), np.eye(4), instance=3)
    with Renderer(scene, raster="cpu") as r:
        f = r.render(sensor, np.eye(4))
    d = sensor.directions()
    hits = np.abs(d[..., 0] / d[..., 2] * z) + np.abs(d[..., 1] / d[..., 2] * z) < h
    assert hits[:, 160].all()
    assert np.array_equal(f.instance == 3, hits)
    np.testing.assert_allclose(f.depth[hits], z, rtol=1e-6)


def test_capture_draws_the_lens_rays_and_equals_the_renderer():
    """``gg.capture`` of a distorted sensor with the CPU raster draws the lens's rays (no
    pinhole view is resampled): its frame equals the renderer's, byte for byte."""
    scene = gg.Scene()
    scene.add(wall(6.0), instance=1)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), [0.3, -0.2, 3.0], instance=2)
    sensor = TUTORIAL
    (f,) = gg.capture(scene, sensor, [np.eye(4)], seed=0, raster="cpu")
    with Renderer(scene, raster="cpu") as r:
        g = r.render(sensor, np.eye(4))
    assert "rays" not in f.meta and f.meta["lens_views"] == 1
    assert f.depth.tobytes() == g.depth.tobytes() and f.instance.tobytes() == g.instance.tobytes()
    assert (f.instance == 2).sum() > 1000
