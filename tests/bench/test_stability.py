"""The hard cases of ``genie bench stability``, each against its analytic truth, and the lens
contract of every entry point."""

import subprocess
import sys
from dataclasses import replace

import cv2
import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.bench import stability as st
from genie_gl.capture import through_lens
from genie_gl.render import Renderer
from genie_gl.lens.distortion import lens_views, render_through_lens

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def glctx():
    """A context of this module's own: pyrender's reference renderer (test_reference.py)
    terminates the EGL display when it is deleted, which kills a session-wide context."""
    from genie_gl.render import create_context

    context = create_context("egl")
    yield context
    with context.ctx:
        assert context.ctx.error == "GL_NO_ERROR"
    context.release()


@pytest.mark.parametrize("name", sorted(set(st.CASES) - {"translation"}))
def test_hard_case_holds_its_tolerance(glctx, name):
    rows = st.CASES[name](context=glctx)
    assert rows
    bad = [(r.case, r.worst, r.tolerance, r.note) for r in rows if not r.ok]
    assert not bad


def test_generated_scene_translated_by_1e7_m_640x480(glctx):
    """The must-show: depth equal within 1e-6 relative (grazing pixels weighed by cos), ids
    identical, the cloud made absolute within 0.1 mm; 1e3 and 1e5 m bit-identical."""
    rows = st.translation_rows(context=glctx)
    assert all(r.ok for r in rows), [(r.case, r.worst) for r in rows if not r.ok]
    assert all(
        "0 ids/returns differ" in r.note
        for r in rows
        if r.case.endswith("< 85°") and "depth" in r.case
    )
    assert rows[0].worst == 0 and rows[3].worst == 0  # 1e3 and 1e5 m: the same bits


def test_old_near_plane_would_fail_the_near_range_case(glctx):
    """The check can fail: a renderer that clips at the minimum range shows the wall behind."""
    s = gg.Sensor.pinhole(64, 48, 50.0, near_m=0.05)
    scene = gg.Scene()
    scene.add(st.facing_quad(2.0, -5, 5, -5, 5), instance=1)
    scene.add(st.facing_quad(0.02, -0.1, 0.1, -0.1, 0.1), instance=2)
    with Renderer(scene, context=glctx) as r:
        f = r.render(s, np.eye(4))
        g = r.render(gg.Sensor.pinhole(64, 48, 50.0, near_m=0.01), np.eye(4))
    assert (f.depth == 0).all() and (f.instance == 0).all()  # nothing behind the plate
    assert (g.instance == 2).all() and np.allclose(g.depth, 0.02)  # in range: the plate itself


# -- lens maps against OpenCV, property-based ----------------------------------------------------
# hypothesis is in the test extra: a missing one fails here, never skips (no importorskip)
from hypothesis import given, settings, strategies as hs  # noqa: E402

coef = hs.floats(-0.3, 0.3, allow_nan=False)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(k=hs.lists(coef, min_size=14, max_size=14), n=hs.sampled_from([4, 5, 8, 12, 14]))
def test_pinhole_lens_project_equals_cv2_and_unproject_inverts_it(k, n):
    d = np.array(k[:n]) * ([1, 1, 0.05, 0.05] + [1] * 10)[:n]
    if n == 14:
        d[12:] *= 0.2
    cam = gg.Sensor(160, 120, [[150.0, 0, 80.3], [0, 152.0, 59.6], [0, 0, 1]], d)
    pts = np.random.default_rng(0).uniform([-0.5, -0.4, 1.0], [0.5, 0.4, 3.0], (400, 3))
    ours = cam.project(pts)
    ok = np.isfinite(ours).all(1)
    ref = st.opencv_project(cam, pts)
    assert np.abs(ours[ok] - ref[ok]).max() < 1e-6
    err, n_rays = st.lens_map_error(cam)  # every pixel with a ray, corners included
    assert err < 1e-6 and n_rays > 0


@settings(max_examples=25, deadline=None, derandomize=True)
@given(k=hs.lists(hs.floats(-0.05, 0.05, allow_nan=False), min_size=4, max_size=4))
def test_fisheye_lens_project_equals_cv2_fisheye(k):
    cam = gg.Sensor(160, 120, [[60.0, 0, 80.3], [0, 61.0, 59.6], [0, 0, 1]], k, model="fisheye")
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(400, 3))
    pts[:, 2] = np.abs(pts[:, 2]) + 0.05  # up to ~88° off axis
    ours = cam.project(pts)
    ok = np.isfinite(ours).all(1)
    np.testing.assert_allclose(ours[ok], st.opencv_project(cam, pts)[ok], atol=1e-6)
    theta = np.arctan2(np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2])
    assert (
        theta[~ok] >= cam.max_off_axis - 1e-9
    ).all()  # only rays past the lens's fold are dropped
    err, _ = st.lens_map_error(cam)
    assert err < 1e-6


@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    xi=hs.floats(0.0, 1.8),
    k=hs.lists(hs.floats(-0.05, 0.05, allow_nan=False), min_size=4, max_size=4),
)
def test_omni_lens_project_equals_cv2_omnidir(xi, k):
    cam = gg.Sensor(
        160,
        120,
        [[80.0, 0, 80.3], [0, 81.0, 59.6], [0, 0, 1]],
        [xi, k[0], k[1], 0.05 * k[2], 0.05 * k[3]],
        model="omni",
    )
    pts = np.random.default_rng(2).normal(size=(400, 3))
    pts[:, 2] = np.abs(pts[:, 2]) + 0.05
    ours = cam.project(pts)
    ok = np.isfinite(ours).all(1)
    np.testing.assert_allclose(ours[ok], st.opencv_project(cam, pts)[ok], atol=1e-6)
    theta = np.arctan2(np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2])
    assert (
        theta[~ok] >= cam.max_off_axis - 1e-9
    ).all()  # only rays past the lens's fold are dropped
    err, n = st.lens_map_error(cam)
    assert err < 1e-6 and n > 0


def test_lens_folds_are_dropped_not_wrapped():
    cam = st.lens_sensor("k1=-0.5 (barrel)")
    d = cam.directions()
    assert not np.isfinite(d[0, 0]).all() and np.isfinite(d[120, 160]).all()
    assert np.isnan(cam.project(np.array([[3.0, 3.0, 1.0]]))).all()  # past the fold
    fish = st.lens_sensor("fisheye 180°")
    assert np.isfinite(fish.project(np.array([[1.0, 0, 0.01]]))).all()  # 89.4° off axis
    assert np.isnan(fish.project(np.array([[1.0, 0, -0.5]]))).all()  # behind the camera


# -- calibration files ---------------------------------------------------------------------------
def test_ros_camera_info_lens_models(tmp_path):
    base = (
        "image_width: 320\nimage_height: 240\ncamera_matrix: {rows: 3, cols: 3, data: [100, 0, "
        "160, 0, 100, 120, 0, 0, 1]}\n"
    )
    cases = {
        "equidistant": ([0.01, -0.02, 0.003, -0.001], "fisheye"),
        "plumb_bob": ([0.1, -0.2, 0.001, 0.002, 0.05], "pinhole"),
        "rational_polynomial": ([0.1, -0.2, 0.001, 0.002, 0.05, 0.01, 0.02, 0.03], "pinhole"),
    }
    for name, (d, model) in cases.items():
        p = tmp_path / f"{name}.yaml"
        p.write_text(
            base + f"distortion_model: {name}\ndistortion_coefficients: {{rows: 1, cols: {len(d)}, "
            f"data: {d}}}\n"
        )
        s = gg.load_sensor(p)
        assert s.model == model and list(s.dist) == d
    # an equidistant file read as plumb-bob would put this point ~tens of px away
    s = gg.load_sensor(tmp_path / "equidistant.yaml")
    pt = np.array([[0.4, 0.3, 1.0]])
    np.testing.assert_allclose(s.project(pt), st.opencv_project(s, pt), atol=1e-9)
    p = tmp_path / "unknown.yaml"
    p.write_text(
        base + "distortion_model: double_sphere\ndistortion_coefficients: [0.1, 0.2, 0.3, 0.4]\n"
    )
    with pytest.raises(
        gg.ConfigError, match=r"unknown.yaml: distortion_model: unknown lens model 'double_sphere'"
    ):
        gg.load_sensor(p)
    p.write_text(
        base + "distortion_model: equidistant\ndistortion_coefficients: [0.1, 0.2, 0.3, 0.4, 0.5]\n"
    )
    with pytest.raises(gg.ConfigError, match=r"'equidistant' takes 4 coefficients, got 5"):
        gg.load_sensor(p)


def test_kalibr_camchain(tmp_path):
    p = tmp_path / "camchain.yaml"
    p.write_text("""cam0:
  camera_model: pinhole
  intrinsics: [458.654, 457.296, 367.215, 248.375]
  distortion_model: radtan
  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
  resolution: [752, 480]
  rostopic: /cam0/image_raw
cam1:
  camera_model: pinhole
  intrinsics: [457.587, 456.134, 379.999, 255.238]
  distortion_model: radtan
  distortion_coeffs: [-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05]
  resolution: [752, 480]
  T_cn_cnm1:
  - [1.0, 0.0, 0.0, -0.110073808]
  - [0.0, 1.0, 0.0, 0.000399121]
  - [0.0, 0.0, 1.0, -0.000853702]
  - [0.0, 0.0, 0.0, 1.0]
""")
    s = gg.load_sensor(p)
    assert s.size == (752, 480) and s.model == "pinhole" and s.fx == pytest.approx(458.654)
    assert s.stereo.baseline_m == pytest.approx(0.1100772, rel=1e-5)
    np.testing.assert_allclose(s.dist, [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05])
    text = p.read_text().replace(
        "distortion_model: radtan\n  distortion_coeffs: [-0.28340811, 0.07395907, 0.00019359, "
        "1.76187114e-05]",
        "distortion_model: equidistant\n  distortion_coeffs: [0.01, 0.02, 0.0, 0.0]",
    )
    p.write_text(text)
    assert gg.load_sensor(p).model == "fisheye"
    p.write_text(
        "cam0:\n  camera_model: omni\n  intrinsics: [0.8, 458, 457, 367, 248]\n  distortion_model: "
        "radtan\n"
        "  distortion_coeffs: [-0.1, 0.01, 0.001, 0.0005]\n  resolution: [752, 480]\n"
    )
    s = gg.load_sensor(p)
    assert s.model == "omni" and list(s.dist) == [0.8, -0.1, 0.01, 0.001, 0.0005] and s.cx == 367
    p.write_text(
        "cam0:\n  camera_model: ds\n  intrinsics: [0.5, 0.6, 458, 457, 367, 248]\n  resolution: "
        "[752, 480]\n"
    )
    with pytest.raises(
        gg.ConfigError, match=r"camchain.yaml: cam0: camera_model 'ds' is not supported"
    ):
        gg.load_sensor(p)


def test_fisheye_calibration_round_trips_through_opencv_filestorage(tmp_path):
    from genie_gl.sensors.calibration import Calibration, read_calibration, write_calibration

    K = np.array([[100.0, 0, 160], [0, 101, 120], [0, 0, 1]])
    path = write_calibration(
        Calibration(320, 240, K, np.array([0.1, 0.01, 0, 0]), model="fisheye"), tmp_path / "f.yml"
    )
    assert (
        cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ).getNode("distortion_model").string()
        == "equidistant"
    )
    assert read_calibration(path).model == "fisheye"


# -- one lens contract for every entry point -------------------------------------------------------
def tilted_plane():
    n = np.array([0.3, -0.4, -1.0])
    n /= np.linalg.norm(n)
    p0 = np.array([0.0, 0.0, 2.5])
    e1 = np.cross(n, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    scene = gg.Scene()
    scene.add(
        st.quad([p0 + 40 * (a * e1 + b * e2) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]),
        instance=5,
    )
    return scene, n, p0


@pytest.mark.parametrize("lens", ["k1=-0.5 (barrel)", "fisheye 180°"])
def test_every_entry_point_renders_through_the_lens_and_clouds_land_on_the_plane(glctx, lens):
    cam = st.lens_sensor(lens, 160, 120)
    scene, n, p0 = tilted_plane()
    pose = np.eye(4)
    pose[:3, 3] = [1e6, 2e6, 0]  # far out, too
    scene.instances[0] = replace(
        scene.instances[0], world_from_model=pose @ scene.instances[0].world_from_model
    )
    want = st.plane_depth(cam, n, p0)
    with Renderer(scene, context=glctx) as r:
        with pytest.raises(gg.ConfigError, match="renderer draws pinhole views"):
            r.render(cam, pose)  # the renderer knows no lens
        a = through_lens(r.render)(cam, pose)  # the capture stage's lens around it
    b = gg.capture(scene, cam, [pose], seed=0)[0]  # capture (no effects: the same frame)
    c = gg.render(scene, cam, pose)  # gg.render
    for f in (a, b, c):
        v = f.depth > 0
        assert v.sum() > 0.5 * np.isfinite(cam.directions()).all(-1).sum()
        np.testing.assert_allclose(f.depth[v], want[v], rtol=1e-5)
        cloud = gg.to_cloud([f])
        rel = np.abs((cloud.world_xyz - pose[:3, 3] - p0) @ n) / np.linalg.norm(
            cloud.world_xyz - pose[:3, 3], axis=1
        )
        assert rel.max() < 1e-5
    np.testing.assert_array_equal(a.depth, b.depth)
    np.testing.assert_array_equal(a.instance, c.instance)


def test_cube_faces_for_a_wide_fisheye_and_one_view_for_a_narrow_lens():
    assert len(lens_views(st.lens_sensor("fisheye 180°"))) == 5
    (m,) = lens_views(st.lens_sensor("k1=+0.5 (pincushion)"), oversample=2)
    cam = st.lens_sensor("k1=+0.5 (pincushion)")
    # the wide render's principal point lies on whole pixels of the (oversampled) sensor grid
    assert (m.render_sensor.cx - 2 * cam.cx) % 1 == pytest.approx(0) or (
        m.render_sensor.cx - 2 * cam.cx
    ) % 1 == pytest.approx(1)
    # pincushion: the view covers the rays of the corners, not more than 3 pixels beyond them
    d = cam.directions()
    x = d[..., 0] / d[..., 2]
    assert m.render_sensor.width <= np.ceil((x.max() - x.min()) * 2 * cam.fx) + 5


@pytest.mark.parametrize("mode", ["nearest", "bilinear", "plane", "exact"])
def test_resample_modes_never_blend_ids_and_exact_is_exact(glctx, mode):
    cam = st.lens_sensor("k1=+0.5 (pincushion)", 160, 120)
    scene, n, p0 = tilted_plane()
    scene.add(
        trimesh.creation.box((0.5, 0.5, 0.5)),
        np.array([[1, 0, 0, 0.1], [0, 1, 0, 0], [0, 0, 1, 1.2], [0, 0, 0, 1.0]]),
        instance=9,
    )
    with Renderer(scene, context=glctx) as r:
        f = render_through_lens(r.render, cam, np.eye(4), resample=mode)
    assert set(np.unique(f.instance)) <= {0, 5, 9}
    plane = st.interior(f.instance == 5, 2)
    want = st.plane_depth(cam, n, p0)
    err = np.abs(f.depth[plane] - want[plane]) / want[plane]
    assert err.max() < {"nearest": 5e-3, "bilinear": 1e-5, "plane": 1e-5, "exact": 1e-5}[mode]
    if mode == "nearest":
        assert err.max() > 1e-5  # nearest is what exact improves on
    with pytest.raises(gg.ConfigError, match="resample: unknown mode 'cubic'"):
        render_through_lens(lambda *a, **k: None, cam, np.eye(4), resample="cubic")


def test_subpixel_calibration_error_changes_the_image():
    from genie_gl.effects.miscalibration import CalibrationError

    s = gg.Sensor.pinhole(80, 60, 70.0)
    u, v = np.meshgrid(np.arange(80.0), np.arange(60.0))

    def inv(uu, vv):  # a slanted plane: 1/z is affine in the pixel
        return 0.5 - 0.001 * uu - 0.002 * vv

    depth = (1 / inv(u, v)).astype(np.float32)
    f = gg.Frame(
        depth, np.ones((60, 80), np.uint32), np.zeros((60, 80), np.uint16), None, s, np.eye(4)
    )
    eff = CalibrationError(sigma_f_px=0.0, sigma_c_px=0.0)
    K_true = s.K.copy()
    K_true[0, 2] += 0.3  # 0.3 px: nearest resampling would hide it
    from genie_gl.lens.distortion import distort

    out = distort(f, s, eff.maps(s, K_true), resample="bilinear")
    inner = np.s_[2:-2, 2:-2]
    np.testing.assert_allclose(
        out.depth[inner], (1 / inv(u - 0.3, v))[inner], rtol=1e-6
    )  # the plane, 0.3 px over
    assert (out.depth[inner] != depth[inner]).all()


def test_frame_and_camera_do_not_import_sensors():
    code = (
        "import sys, genie_gl.frame, genie_gl.camera; assert not [m for m in sys.modules if "
        "m.startswith('genie_gl.sensors')]"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


# -- scene precision and degenerate input ----------------------------------------------------------
def test_mesh_baked_far_from_its_origin_is_recentred_into_the_transform(glctx):
    s = gg.Sensor.pinhole(64, 48, 50.0)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    near, far = gg.Scene(), gg.Scene()
    near.add(box.copy().apply_translation([0.1234567, 0.0, 3.0]), instance=1)
    off = np.array([1e7, -3e6, 0.0])
    far.add(
        box.copy().apply_translation(off + [0.1234567, 0.0, 3.0]), instance=1
    )  # baked in float64
    assert np.abs(far.meshes[far.instances[0].mesh].vertices).max() <= 0.5 + 1e-3
    np.testing.assert_allclose(
        far.instances[0].world_from_model[:3, 3], off + [0.1234567, 0, 3.0], rtol=0, atol=1e-3
    )
    pose = np.eye(4)
    pose[:3, 3] = off
    with Renderer(near, context=glctx) as a, Renderer(far, context=glctx) as b:
        f0, f1 = a.render(s, np.eye(4)), b.render(s, pose)
    np.testing.assert_array_equal(f0.instance, f1.instance)
    v = f0.depth > 0
    np.testing.assert_allclose(f1.depth[v], f0.depth[v], rtol=1e-6)


def test_degenerate_transforms_are_named_one_line_and_never_a_traceback():
    scene = gg.Scene()
    for T, why in (
        (np.diag([0.0, 1, 1, 1]), "zero scale"),
        (np.array([[1, 1, 0, 0], [1, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]), "singular"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0.5, 0, 0, 1.0]]), "last row"),
    ):
        with pytest.raises(gg.ConfigError, match=why) as e:
            scene.add(trimesh.creation.box(), T, name="/World/Part_7")
        assert "/World/Part_7" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(gg.ConfigError, match="NaN"):
        scene.add(trimesh.creation.box(), np.full((4, 4), np.nan))


def test_usd_prim_with_zero_scale_is_dropped_and_counted_by_path(tmp_path):
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.CreateNew(str(tmp_path / "hidden.usda"))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.Xform.Define(stage, "/World/Hidden").AddScaleOp().Set(Gf.Vec3f(0, 1, 1))
    for path, pts in (
        ("/World/Hidden/Part", [(0, 0, 0), (1, 0, 0), (0, 1, 0)]),
        ("/World/Ok", [(0, 0, 0), (2, 0, 0), (0, 2, 0)]),
    ):
        m = UsdGeom.Mesh.Define(stage, path)
        (
            m.CreatePointsAttr(pts),
            m.CreateFaceVertexCountsAttr([3]),
            m.CreateFaceVertexIndicesAttr([0, 1, 2]),
        )
    stage.Save()
    rep = gg.read_usd(tmp_path / "hidden.usda").report()
    assert rep["instances"] == 1 and rep["dropped_instances"] == 1
    assert rep["dropped"][0].startswith("/World/Hidden/Part: its transform has a zero scale")


@pytest.mark.parametrize("lens", ["k1=+0.5 (pincushion)", "k1=-0.5 (barrel)", "fisheye 180°"])
def test_automatic_oversampling_gives_every_lens_pixel_its_own_view_pixel(lens):
    """k1 = +0.5 once sampled only 57 % distinct pixels of a same-focal render."""
    from genie_gl.lens.distortion import _plan

    cam = st.lens_sensor(lens)
    views = lens_views(cam)
    assert min(m.scale_min for m in views) >= 0.8
    served = sum(len(_plan(m, m.render_sensor)["sel"]) for m in views)
    distinct = sum(len(np.unique(_plan(m, m.render_sensor)["flat"])) for m in views)
    assert distinct / served > 0.85
    one = lens_views(cam, oversample=1.0)
    if lens.startswith("k1=+0.5"):
        assert min(m.scale_min for m in one) < 0.7  # the same-focal render under-samples pincushion


def test_a_profile_sets_the_sensors_range(tmp_path):
    (tmp_path / "cam.yaml").write_text(
        "image_width: 64\nimage_height: 48\ncamera_matrix: {rows: 3, cols: 3, data: [50, 0, 31.5, "
        "0, 50, 23.5, 0, 0, 1]}\n"
    )
    (tmp_path / "p.yaml").write_text("name: p\ncalibration: cam.yaml\nnear_m: 0.2\nfar_m: 12\n")
    s = gg.load_sensor(tmp_path / "p.yaml")
    assert (s.near_m, s.far_m, s.clip_near_m) == (0.2, 12.0, 0.2 / 1024)
    (tmp_path / "bad.yaml").write_text("name: p\ncalibration: cam.yaml\nnear_m: close\n")
    with pytest.raises(
        gg.ConfigError,
        match=r"bad.yaml: near_m \(m\): expected a finite number in \(0, 1000\], got 'close'",
    ):
        gg.load_sensor(tmp_path / "bad.yaml")


def test_the_pinhole_reference_renderer_refuses_a_lens_by_name():
    from genie_gl.render.reference import ReferenceRenderer

    cam = st.lens_sensor("k1=-0.5 (barrel)", 64, 48)
    with pytest.raises(
        gg.ConfigError, match=r"sensor 'k1=-0.5 \(barrel\)' has lens distortion .*gg.render"
    ):
        ReferenceRenderer(gg.Scene()).render(cam, np.eye(4))
