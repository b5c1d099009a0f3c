"""A lens frame with exact ids against independent truths: cv2's undistortion of every pixel
and Open3D's ray caster on the same rays, through strongly distorted lenses, to the corners.
Each oracle runs over both rasters: the GL raster's pinhole views resampled exactly
(:mod:`genie_gl.lens.ray_hits`), and the CPU raster, which draws each pixel's own ray
(:meth:`genie_gl.render.cpu.renderer.CPURenderer._lens_frame`)."""

import cv2
import numpy as np
import pytest

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.lens.distortion import render_through_lens
from tests.scenes import content_views

pytestmark = pytest.mark.gl


@pytest.fixture(params=["gl", "cpu"])
def draw(request, glctx):
    """A renderer of a scene with each raster in turn."""
    if request.param == "gl":
        return lambda scene: Renderer(scene, context=glctx, raster="gl")
    return lambda scene: Renderer(scene, raster="cpu")


# the OpenCV calibration tutorial's lens: k1 = -0.42, strong barrel
TUTORIAL = gg.Sensor(
    640,
    480,
    np.array([[535.9, 0, 342.3], [0, 535.9, 235.6], [0, 0, 1.0]]),
    [-0.42, 0.2, 0.001, -0.0003, -0.05],
)
K = TUTORIAL.K
LENSES = {
    "plumb_bob": TUTORIAL,
    "rational": gg.Sensor(640, 480, K, [0.1, -0.05, 0.001, -0.002, 0.01, 0.02, 0.0, 0.0]),
    "fisheye": gg.Sensor(
        640,
        480,
        np.array([[230.0, 0, 320], [0, 230, 240], [0, 0, 1]]),
        [0.05, -0.01, 0.002, -0.0005],
        model="fisheye",
    ),
    "omni": gg.Sensor(
        640,
        480,
        np.array([[300.0, 0, 320], [0, 300, 240], [0, 0, 1]]),
        [0.9, -0.1, 0.02, 0.001, -0.001],
        model="omni",
    ),
}


def quad(corners):
    return gg.Mesh(np.asarray(corners, float), np.array([[0, 1, 2], [0, 2, 3]]))


def cv2_rays(sensor):
    """(H, W, 2): x, y on z = 1 of every pixel centre's ray, by cv2.undistortPoints iterated
    to 1e-12 (independent of the package's inverse lens)."""
    u, v = np.meshgrid(
        np.arange(sensor.width, dtype=np.float64), np.arange(sensor.height, dtype=np.float64)
    )
    uv = np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2)
    xy = cv2.undistortPoints(
        uv,
        sensor.K,
        sensor.dist,
        None,
        None,
        None,
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14),
    )
    return xy.reshape(sensor.height, sensor.width, 2)


def open3d_caster(scene):
    import open3d as o3d  # installed by the test extra: a missing reader fails, never skips

    rc = o3d.t.geometry.RaycastingScene()
    ids = {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        v = (
            np.asarray(m.vertices, np.float64) @ inst.world_from_model[:3, :3].T
            + inst.world_from_model[:3, 3]
        )
        g = rc.add_triangles(
            o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(np.asarray(m.faces, np.uint32))
        )
        ids[g] = inst.instance
    return rc, ids


def cast(caster, sensor, pose):
    """Open3D's instance and depth (camera z) along every pixel's ray of ``sensor``."""
    import open3d as o3d

    rc, ids = caster
    d = sensor.directions().reshape(-1, 3)
    ok = np.isfinite(d[:, 0])
    dw = np.where(ok[:, None], d, 0.0) @ pose[:3, :3].T
    rays = np.c_[np.broadcast_to(pose[:3, 3], dw.shape), dw].astype(np.float32)
    hit = rc.cast_rays(o3d.core.Tensor(rays))
    t = hit["t_hit"].numpy().astype(np.float64)
    inst = np.array([ids.get(int(g), 0) for g in hit["geometry_ids"].numpy()], np.uint32)
    z = t * d[:, 2]
    seen = ok & np.isfinite(t) & (z >= sensor.near_m) & (z <= sensor.far_m)
    return (
        np.where(seen, inst, 0).reshape(sensor.height, sensor.width),
        np.where(seen, z, 0.0).reshape(sensor.height, sensor.width),
    )


def test_markers_through_the_tutorial_lens_land_where_cv2_puts_each_pixel_ray(draw):
    """Small square markers (10-11 px at the centre) all over the image, corners included, in front
    of a wall:
    each pixel shows the marker its own ray (cv2's undistortion of the pixel centre) meets,
    at every pixel; the markers' centroids therefore agree with cv2's to far below 0.1 px.
    The nearest view pixel's id (the old way) is measurably off."""
    sensor = TUTORIAL
    rays = cv2_rays(sensor)
    z, half = 2.0, 0.02
    targets = np.array(
        [
            [8, 8],
            [631, 9],
            [9, 470],
            [630, 471],
            [320, 240],
            [320, 10],
            [10, 240],
            [629, 240],
            [160, 120],
            [480, 360],
            [200, 400],
            [500, 90],
        ],
        np.float64,
    )
    centres = (
        cv2.undistortPoints(
            targets.reshape(-1, 1, 2),
            sensor.K,
            sensor.dist,
            None,
            None,
            None,
            (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14),
        ).reshape(-1, 2)
        * z
    )
    scene = gg.Scene()
    scene.add(quad([[-30, -30, 3], [30, -30, 3], [30, 30, 3], [-30, 30, 3]]), instance=1)
    truth = np.ones(rays.shape[:2], np.uint32)
    edge = np.zeros(rays.shape[:2], bool)
    for k, (cx, cy) in enumerate(centres):
        scene.add(
            quad(
                [
                    [cx - half, cy - half, z],
                    [cx + half, cy - half, z],
                    [cx + half, cy + half, z],
                    [cx - half, cy + half, z],
                ]
            ),
            instance=10 + k,
        )
        dx, dy = np.abs(rays[..., 0] * z - cx) - half, np.abs(rays[..., 1] * z - cy) - half
        truth[(dx < 0) & (dy < 0)] = 10 + k
        edge |= (np.abs(dx) < 1e-9) & (dy < 1e-9) | (np.abs(dy) < 1e-9) & (
            dx < 1e-9
        )  # a ray on an edge: either
    with draw(scene) as r:
        exact = render_through_lens(r.render, sensor, np.eye(4), resample="exact")
        nearest = render_through_lens(r.render, sensor, np.eye(4), resample="nearest")
    assert (exact.instance == 0).sum() == 0  # the wall fills the view to the corners
    assert not (exact.instance != truth)[~edge].any()  # no pixel wrong
    wrong_nearest = 0
    for k, (u, v) in enumerate(targets):
        ours, want = np.nonzero(exact.instance == 10 + k), np.nonzero(truth == 10 + k)
        assert len(want[0]) >= 25
        assert (
            abs(ours[1].mean() - want[1].mean()) < 0.1
            and abs(ours[0].mean() - want[0].mean()) < 0.1
        )
        np.testing.assert_allclose(exact.depth[want], z, rtol=1e-6)
        wrong_nearest += ((nearest.instance == 10 + k) != (truth == 10 + k)).sum()
    assert wrong_nearest > 20  # what the exact mode improves on


@pytest.fixture(scope="module")
def storage_area():
    layout = gg.generate_layout("storage_area", seed=0)
    scene = gg.build_scene(layout, seed=0)
    return scene, open3d_caster(scene), content_views(scene, 2)


@pytest.mark.parametrize("lens", sorted(LENSES))
def test_ids_and_depth_equal_open3d_ray_casting_on_a_benchmark_scene(draw, storage_area, lens):
    """Through plumb-bob, rational, fisheye and omnidirectional lenses on the storage-area
    scene (pallets whose slats are seen edge-on, slivers the frame's culling drops for
    covering no pixel centre): ids equal Open3D's ray caster at >= 99.99 % of pixels (the
    CPU raster, which draws each pixel's own ray: >= 99.999 %) and depth agrees to float32
    where both hit the same instance (relative p99 <= 1e-6: Open3D's float32 rounding)."""
    scene, caster, poses = storage_area
    sensor = LENSES[lens]
    with draw(scene) as r:
        cpu = r.raster == "cpu"
        for pose in poses:
            f = render_through_lens(r.render, sensor, pose, resample="exact")
            inst, depth = cast(caster, sensor, pose)
            same = f.instance == inst
            assert same.mean() >= (0.99999 if cpu else 0.9999), f"{lens}: {(~same).sum()} differ"
            both = same & (depth > 0)
            rel = np.abs(f.depth[both] - depth[both]) / depth[both]
            assert np.quantile(rel, 0.99) <= 1e-6 and np.quantile(rel, 0.999) < 1e-5
            # the GL raster resampled its pinhole views; the CPU raster drew the lens's rays
            assert ("rays" in f.meta) != cpu


def test_exact_mode_is_deterministic_and_a_pinhole_frame_asks_for_nothing(glctx, storage_area):
    scene, _, poses = storage_area
    with Renderer(scene, context=glctx) as r:
        a = render_through_lens(r.render, TUTORIAL, poses[0], resample="exact")
        b = render_through_lens(r.render, TUTORIAL, poses[0], resample="exact")
        plain = r.render(TUTORIAL.ideal(), poses[0])
        assert plain.triangles is None  # no primitive target unless asked
        pinhole = render_through_lens(r.render, TUTORIAL.ideal(), poses[0], resample="exact")
    for x, y in [
        (a.depth, b.depth),
        (a.instance, b.instance),
        (a.semantic, b.semantic),
        (a.rgb, b.rgb),
    ]:
        assert x.tobytes() == y.tobytes()
    assert (
        pinhole.depth.tobytes() == plain.depth.tobytes()
        and pinhole.instance.tobytes() == plain.instance.tobytes()
    )


def test_thin_bars_and_silhouettes_against_nothing_equal_open3d(draw):
    """Bars 0.6-0.9 view pixels thick at grazing angles and a sphere, with nothing behind:
    a ray that hits none of the view's candidates has no return, one that meets a bar between
    pixel centres has the bar, as Open3D's ray caster says, through the fisheye to its rim."""
    import trimesh

    rng = np.random.default_rng(3)
    scene = gg.Scene()
    scene.add(trimesh.creation.icosphere(subdivisions=3, radius=0.6), [0.3, -0.2, 3.0], instance=1)
    for k in range(12):
        bar = trimesh.creation.box((4.0, 0.004 + 0.002 * rng.random(), 0.004))
        T = trimesh.transformations.rotation_matrix(rng.uniform(0, np.pi), [0, 0, 1])
        T = T @ trimesh.transformations.rotation_matrix(rng.uniform(-1.2, 1.2), [1, 0, 0])
        T[:3, 3] = [rng.uniform(-1.5, 1.5), rng.uniform(-1.2, 1.2), rng.uniform(2.0, 3.5)]
        scene.add(bar, T, instance=10 + k)
    caster = open3d_caster(scene)
    sensor = LENSES["fisheye"]
    with draw(scene) as r:
        f = render_through_lens(r.render, sensor, np.eye(4), resample="exact")
        nearest = render_through_lens(r.render, sensor, np.eye(4), resample="nearest")
    inst, depth = cast(caster, sensor, np.eye(4))
    bars = inst >= 10
    assert bars.sum() > 500 and (inst == 0).mean() > 0.5
    assert (f.instance != inst).sum() <= 2  # float32 ties in Open3D at most
    assert ((nearest.instance != inst) & bars).sum() > 50  # the view pixels alone miss them
    np.testing.assert_allclose(f.depth[f.instance == inst], depth[f.instance == inst], rtol=2e-5)


def test_supersampling_through_the_lens_takes_each_pixels_own_sub_rays(draw):
    """Edge supersampling with the exact lens mode renders the lens's image at 2x (2 x 2 exact
    rays per pixel, symmetric about its centre ray) and keeps one of each pixel's own
    samples' ids: the id all four agree on where they do, one of the four elsewhere."""
    import trimesh

    from genie_gl.capture.lens import through_lens
    from genie_gl.capture.supersample import supersample_sensor, supersampled

    scene = gg.Scene()
    scene.add(quad([[-30, -30, 4], [30, -30, 4], [30, 30, 4], [-30, 30, 4]]), instance=1)
    scene.add(trimesh.creation.icosphere(subdivisions=3, radius=0.7), [0.4, -0.3, 2.5], instance=2)
    scene.add(trimesh.creation.box((0.3, 2.0, 0.3)), [-0.8, 0.2, 3.0], instance=3)
    sensor = gg.Sensor(
        320, 240, np.array([[268.0, 0, 171.1], [0, 268.0, 117.8], [0, 0, 1]]), TUTORIAL.dist
    )
    pose = np.eye(4)
    with draw(scene) as r:
        f = render_through_lens(
            supersampled(through_lens(r.render), 2), sensor, pose, resample="exact"
        )
        hi = render_through_lens(r.render, supersample_sensor(sensor, 2), pose, resample="exact")
    assert f.meta["supersample"] == 2 and f.instance.shape == (240, 320)
    if r.raster == "cpu":  # the lens's own rays at 2x, drawn (no pinhole view resampled)
        assert "rays" not in hi.meta and hi.meta["lens_views"] == 1
    blocks = hi.instance.reshape(240, 2, 320, 2).swapaxes(1, 2).reshape(240, 320, 4)
    own = (blocks == f.instance[..., None]).any(-1)
    assert own.all()
    agree = (blocks == blocks[..., :1]).all(-1)
    assert (f.instance[agree] == blocks[..., 0][agree]).all() and (~agree).sum() > 50
