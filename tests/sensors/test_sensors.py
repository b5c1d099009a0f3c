"""Calibration I/O, effects against their models, distortion against cv2, placement."""

import cv2
import numpy as np
import pytest

import genie_gl as gg
from genie_gl.sensors.calibration import Calibration, read_calibration, write_calibration
from genie_gl.effects.simulate import simulate
from genie_gl.sensors.camera import Stereo
from genie_gl.lens.distortion import distortion_maps, project
from genie_gl.effects.registry import DepthNoise, RangeLimits, build_effects
from genie_gl.placement.genetic import CoverageProblem, genetic_placement, greedy_placement

K = np.array([[600.0, 0, 320.0], [0, 610.0, 240.0], [0, 0, 1]])


@pytest.mark.parametrize("n", [4, 5, 8, 12, 14])
@pytest.mark.parametrize("ext", [".yml", ".xml"])
def test_calibration_round_trip_through_cv2_filestorage(tmp_path, n, ext):
    d = np.linspace(-0.1, 0.1, n)
    path = write_calibration(
        Calibration(640, 480, K, d, 0.31, np.eye(3), np.array([-0.05, 0, 0])), tmp_path / f"c{ext}"
    )
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)  # the independent reader
    np.testing.assert_array_equal(fs.getNode("camera_matrix").mat(), K)
    np.testing.assert_array_equal(fs.getNode("distortion_coefficients").mat().ravel(), d)
    assert fs.getNode("image_width").real() == 640
    c = read_calibration(path)
    np.testing.assert_array_equal(c.dist, d)
    assert c.baseline_m == pytest.approx(0.05) and c.reprojection_error == pytest.approx(0.31)


def test_tutorial_spellings_and_ros_camera_info(tmp_path):
    fs = cv2.FileStorage(str(tmp_path / "t.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("image_Width", 800), fs.write("image_Height", 600)
    fs.write("Camera_Matrix", K), fs.write("Distortion_Coefficients", np.zeros((5, 1)))
    fs.release()
    assert read_calibration(tmp_path / "t.yml").width == 800
    (tmp_path / "ros.yaml").write_text(
        "image_width: 640\nimage_height: 480\ncamera_name: cam\ncamera_matrix:\n  rows: 3\n  cols: "
        "3\n"
        "  data: [600, 0, 320, 0, 610, 240, 0, 0, 1]\ndistortion_model: plumb_bob\n"
        "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0.1, -0.2, 0, 0, 0.05]\n"
    )
    c = read_calibration(tmp_path / "ros.yaml")
    np.testing.assert_array_equal(c.K, K)
    assert gg.Sensor.from_opencv(tmp_path / "ros.yaml").dist[4] == pytest.approx(0.05)


def test_bad_calibrations_name_file_and_field(tmp_path):
    (tmp_path / "nok.yaml").write_text("image_width: 640\nimage_height: 480\n")
    with pytest.raises(gg.ConfigError, match=r"nok.yaml: missing field camera_matrix"):
        read_calibration(tmp_path / "nok.yaml")
    (tmp_path / "nosize.yaml").write_text(
        "camera_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n"
    )
    with pytest.raises(gg.ConfigError, match=r"nosize.yaml: missing field image_width"):
        read_calibration(tmp_path / "nosize.yaml")
    (tmp_path / "bad.yaml").write_text(
        "image_width: 1\nimage_height: 1\ncamera_matrix: {rows: 3, cols: 3, data: [1, 2]}\n"
    )
    with pytest.raises(gg.ConfigError, match=r"bad.yaml: camera_matrix: malformed matrix"):
        read_calibration(tmp_path / "bad.yaml")
    with pytest.raises(
        gg.ConfigError, match=r"unknown effect 'depth_nosie'; did you mean 'depth_noise'"
    ):
        build_effects([{"type": "depth_nosie"}], "p.yaml")


def wall(z=2.0, size=(200, 160), f=500.0):
    s = gg.Sensor.pinhole(size[0], size[1], f)
    d = np.full((size[1], size[0]), z, np.float32)
    return gg.Frame(d, np.ones_like(d, np.uint32), np.ones_like(d, np.uint16), None, s, np.eye(4))


def model_sigma(model, z):
    """σ_z written out from the papers (not from the package): Nguyen et al. 2012 (Kinect),
    z²·σ_d/(f·b) for stereo (σ_d 0.08 px, f 500 px, b 0.05 m), a + b·(z − z0) for ToF."""
    return {
        "kinect_nguyen2012": 0.0012 + 0.0019 * (z - 0.4) ** 2,
        "stereo": z * z * 0.08 / (500.0 * 0.05),
        "tof_linear": 0.0005 + 0.001 * max(z - 0.5, 0.0),
    }[model]


@pytest.mark.parametrize("model", ["kinect_nguyen2012", "stereo", "tof_linear"])
@pytest.mark.parametrize("z", [0.5, 1.0, 2.0, 4.0])
def test_noise_sigma_on_a_flat_wall_matches_the_model(model, z):
    """σ(z) at four depths (z² and 2z agree only at 2 m), unbiased and Gaussian."""
    f = wall(z)
    out = DepthNoise(model=model).apply(f, rng=np.random.default_rng(0))
    err = out.depth.astype(np.float64) - z
    expected = model_sigma(model, z)
    n = err.size
    assert n >= 30_000
    assert np.std(err) == pytest.approx(expected, rel=0.03)  # σ of a σ over 32 000 draws: 0.4 %
    assert abs(np.mean(err)) < 5 * expected / np.sqrt(n) + 2e-7 * z  # float32 rounding of z
    inside = np.mean(np.abs(err) < expected)  # 68.27 % within 1σ for a Gaussian
    assert inside == pytest.approx(0.6827, abs=0.015)
    again = DepthNoise(model=model).apply(f, rng=np.random.default_rng(0))
    assert out.depth.tobytes() == again.depth.tobytes()
    assert np.isfinite(out.depth).all()


def test_stereo_noise_grows_with_the_square_of_depth():
    """σ(4 m) / σ(1 m) = 16 for stereo (it would be 4 were σ linear in z)."""
    s = [
        np.std(
            DepthNoise(model="stereo")
            .apply(wall(z), rng=np.random.default_rng(1))
            .depth.astype(np.float64)
            - z
        )
        for z in (1.0, 4.0)
    ]
    assert s[1] / s[0] == pytest.approx(16.0, rel=0.04)


def test_disparity_quantisation_steps_equal_theory():
    f = wall(3.0)
    f = f.replace(
        depth=np.linspace(2.0, 3.0, f.depth.size, dtype=np.float32).reshape(f.depth.shape)
    )
    out = DepthNoise(model="stereo", subpixel=1e-9, subpixel_step=0.125, baseline_m=0.05).apply(
        f, rng=np.random.default_rng(0)
    )
    disp = 500.0 * 0.05 / np.unique(out.depth.astype(np.float64))
    steps = np.diff(np.sort(disp))
    np.testing.assert_allclose(steps, 0.125, rtol=1e-4)


def test_range_limits_drop_returns_and_ids():
    f = wall(5.0)
    out = RangeLimits(0.3, 4.0).apply(f, rng=np.random.default_rng(0))
    assert not out.depth.any() and not out.instance.any()
    d = np.tile(np.array([0.0, 0.5, 1.0, 1.5, 2.0, 2.5], np.float32), (160, 34))[:, :200]
    g = f.replace(depth=d, instance=np.where(d > 0, 3, 0).astype(np.uint32))
    out = RangeLimits(1.0, 2.0).apply(g, rng=np.random.default_rng(0))
    keep = (d >= 1.0) & (d <= 2.0)  # the limits themselves are in range
    np.testing.assert_array_equal(out.depth, np.where(keep, d, 0))
    np.testing.assert_array_equal(out.instance, np.where(keep, 3, 0))


def test_no_effects_means_the_ideal_frame_bit_for_bit_and_no_draw():
    s = gg.Sensor.pinhole(32, 24, 30.0)
    f = wall().replace(
        sensor=s,
        depth=np.ones((24, 32), np.float32),
        instance=np.ones((24, 32), np.uint32),
        semantic=np.ones((24, 32), np.uint16),
    )
    rng = np.random.default_rng(5)
    state = rng.bit_generator.state
    out = simulate(s, np.eye(4), render=lambda sensor, pose: f, rng=rng)
    assert out is f and rng.bit_generator.state == state
    # so a capture gives such a sensor no generator at all; one with effects must have one
    assert simulate(s, np.eye(4), render=lambda sensor, pose: f, rng=None) is f
    noisy = gg.Sensor(32, 24, s.K, effects=(RangeLimits(0.1, 10.0),))
    with pytest.raises(gg.ConfigError, match="need an rng"):
        simulate(noisy, np.eye(4), render=lambda sensor, pose: f.replace(sensor=noisy), rng=None)


@pytest.mark.parametrize(
    "dist",
    [
        [0.1, -0.05, 0.001, -0.002, 0.01],
        [3.1306, 2.3249, 8.1e-5, -5.1e-5, 0.1304, 3.4587, 3.3501, 0.6629],
        [-0.2, 0.05, 0, 0, 0, 0, 0, 0, 0.001, 0, -0.001, 0],
    ],
)
def test_distortion_maps_put_rays_where_cv2_projects_them(dist):
    s = gg.Sensor(320, 240, np.array([[300, 0, 160], [0, 305, 120], [0, 0, 1.0]]), dist)
    m = distortion_maps(s)
    Kr = m.render_sensor.K
    v, u = np.nonzero(m.valid)
    sel = np.linspace(0, len(u) - 1, 2000).astype(int)
    u, v = u[sel], v[sel]
    x = (m.map_x[v, u] - Kr[0, 2]) / Kr[0, 0]
    y = (m.map_y[v, u] - Kr[1, 2]) / Kr[1, 1]
    pts = np.stack([x, y, np.ones_like(x)], -1).astype(np.float64)
    uv, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), s.K, s.dist)
    # map coordinates are float32: the residual includes their rounding
    assert np.abs(uv.reshape(-1, 2) - np.stack([u, v], -1)).max() < 0.1
    corners = [(0, 0), (0, 319), (239, 0), (239, 319)]
    assert all(m.valid[c] for c in corners)


@pytest.mark.parametrize("K_r", [(300.0, 360.0), (360.0, 300.0)])  # fx ≠ fy either way round
@pytest.mark.parametrize("dist", [[0.1, -0.05, 0.001, -0.002, 0.01], [-0.25, 0.06, 0, 0, 0]])
def test_distortion_maps_stay_inside_the_wide_render(K_r, dist):
    """Every valid distorted pixel samples the wide pinhole render inside its image (nearest
    neighbour: the rounded sample lies in [0, W) x [0, H)), and the wide render covers the
    distorted field: the rays of the distorted image's four edges, from cv2.undistortPoints
    (the independent inverse), land inside it."""
    fx, fy = K_r
    s = gg.Sensor(320, 240, np.array([[fx, 0, 161.0], [0, fy, 118.5], [0, 0, 1.0]]), dist)
    m = distortion_maps(s)
    r = m.render_sensor
    assert m.valid.all()  # a mild lens: every pixel has a ray
    mx, my = np.rint(m.map_x[m.valid]), np.rint(m.map_y[m.valid])
    assert mx.min() >= 0 and my.min() >= 0 and mx.max() <= r.width - 1 and my.max() <= r.height - 1
    u = np.r_[np.arange(320), np.arange(320), np.zeros(240), np.full(240, 319)]
    v = np.r_[np.zeros(320), np.full(320, 239), np.arange(240), np.arange(240)]
    xy = cv2.undistortPoints(
        np.stack([u, v], -1).reshape(-1, 1, 2),
        s.K,
        s.dist,
        None,
        None,
        None,
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12),
    ).reshape(-1, 2)
    wide = np.c_[xy, np.ones(len(xy))] @ r.K.T
    assert (wide[:, 0] >= -0.5).all() and (wide[:, 0] <= r.width - 0.5).all()
    assert (wide[:, 1] >= -0.5).all() and (wide[:, 1] <= r.height - 0.5).all()


@pytest.mark.parametrize(
    "dist",
    [
        [0.1, 0, 0, 0],
        [0.1, -0.05, 0.001, -0.002, 0.01],
        [3.1306, 2.3249, 8.1e-5, -5.1e-5, 0.1304, 3.4587, 3.3501, 0.6629],
        [-0.2, 0.05, 0, 0, 0, 0, 0, 0, 0.001, 0, -0.001, 0.002],
        [0.1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0.01, -0.02],
    ],
)
def test_numpy_lens_projection_equals_cv2(dist):
    xy = np.random.default_rng(0).uniform(-0.6, 0.6, (5000, 2))
    pts = np.concatenate([xy, np.ones((len(xy), 1))], 1).reshape(-1, 1, 3)
    ref = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K, np.array(dist))[0].reshape(-1, 2)
    np.testing.assert_allclose(project(xy, K, np.array(dist)), ref, atol=1e-9)
    # cv2.projectPoints ignores K's skew; genie-gl's K applies it as the renderer does:
    # u = fx x' + s y' + cx, with y' = (v - cy) / fy the distorted normalised y
    skewed = project(xy, K + [[0, 0.5, 0], [0, 0, 0], [0, 0, 0]], np.array(dist))
    np.testing.assert_allclose(
        skewed[:, 0], ref[:, 0] + 0.5 * (ref[:, 1] - K[1, 2]) / K[1, 1], atol=1e-9
    )


def test_strong_barrel_distortion_drops_what_the_model_folds():
    s = gg.Sensor(
        320, 240, np.array([[150.0, 0, 160], [0, 150.0, 120], [0, 0, 1]]), [-0.5, 0, 0, 0, 0]
    )
    m = distortion_maps(s)
    assert not m.valid.all() and m.valid[120, 160]
    assert not m.valid[0, 0]  # past the fold of r(1 + k1 r^2): dropped, not wrapped
    assert np.isfinite(m.map_x).all() and np.isfinite(m.map_y).all()


def test_shipped_profiles_load():
    for name in ("ideal_pinhole", "realsense_d435", "azure_kinect_nfov", "kinect_v2", "zivid2_m70"):
        s = gg.load_sensor(name)
        assert s.width > 0 and s.fx > 0
    assert gg.load_sensor("realsense_d435").stereo.baseline_m == pytest.approx(0.05)
    zivid = gg.load_sensor("zivid2_m70")
    # Zivid's nominal Zivid 2 M70: 1785 px at 1944x1200, projector (111.2, 0, 9.7) mm from the
    # camera
    assert zivid.size == (972, 600) and zivid.stereo.baseline_m == pytest.approx(
        np.hypot(0.1112, 0.0097)
    )
    assert np.degrees(2 * np.arctan(486 / zivid.fx)) == pytest.approx(57.1, abs=0.1)
    assert [e.name for e in zivid.effects] == [
        "range",
        "stereo_shadow",
        "specular_loss",
        "incidence_dropout",
        "depth_noise",
    ]
    # 60 um point precision at 0.7 m, the figure the profile's sigma_d was derived from
    assert zivid.effects[-1].sigma(np.array([0.7]), zivid.fx, None, zivid)[0] == pytest.approx(
        60e-6, rel=0.02
    )
    with pytest.raises(gg.ConfigError, match="did you mean 'kinect_v2'"):
        gg.load_sensor("kinect_v3")


def test_placement_elitism_and_more_sensors_never_cover_less():
    layout = gg.generate_layout("assembly_line", seed=2)
    problem = CoverageProblem(layout, radius_m=5.0)
    ga = genetic_placement(
        problem, 6, rng=np.random.default_rng(0), seed_greedy=False, generations=60
    )
    assert all(b >= a for a, b in zip(ga.history, ga.history[1:]))
    covers = [greedy_placement(problem, n).coverage for n in range(1, 10)]
    assert all(b >= a for a, b in zip(covers, covers[1:]))
    seeded = genetic_placement(problem, 6, rng=np.random.default_rng(0))
    assert seeded.coverage >= greedy_placement(problem, 6).coverage
    poses = gg.place_sensors(layout, None, n=5, seed=1)
    assert len(poses) == 5 and all(p.shape == (4, 4) and np.isfinite(p).all() for p in poses)
    assert all(
        p[2, 3] == pytest.approx(3.5) and p[2, 2] < 0 for p in poses
    )  # mounted, looking down


@pytest.mark.parametrize("radius", [0.7, 3.0, 6.0])
def test_sparse_disc_coverage_equals_brute_force(radius):
    layout = gg.generate_layout("storage_area", seed=2)
    p = CoverageProblem(layout, radius, resolution_m=0.5, step_m=1.5)
    # every candidate against every weighted cell centre, densely
    dense = ((p.candidates[:, None, :] - p.px[None, :, :]) ** 2).sum(-1) <= radius**2
    np.testing.assert_array_equal(p.cover, dense)
    pop = np.random.default_rng(3).integers(0, len(p.candidates), (12, 7))
    expected = [p.weight[dense[c].any(0)].sum() / p.total for c in pop]
    np.testing.assert_allclose(p.fitnesses(pop), expected, rtol=1e-12)
    np.testing.assert_allclose(
        [p.fitness(c) for c in pop], expected, rtol=1e-12
    )  # marks never collide


@pytest.mark.parametrize(
    "z,noise,p_lost",
    [
        (1.0, dict(model="tof_linear", a_m=5.0, b=0.0), 0.4207),  # σ = 5 m: Φ(−0.2)
        # Nguyen 2012 at z = 0.5 mm: σ = 0.0012 + 0.0019·(0.0005 − 0.4)² = 1.5033 mm: Φ(−0.3326)
        (0.0005, dict(model="kinect_nguyen2012", incidence=False), 0.3697),
        # stereo: disparity f·b/z = 500·0.05/10 = 2.5 px, σ_d = 5 px, lost when ≤ 0: Φ(−0.5)
        (10.0, dict(model="stereo", subpixel=5.0, baseline_m=0.05), 0.3085),
        (0.5, dict(model="stereo", subpixel=100.0, baseline_m=0.05), 0.3085),
    ],
)  # 50 px, σ_d 100 px
def test_depth_noise_drops_what_it_pushes_behind_the_camera_and_keeps_holes(z, noise, p_lost):
    """Noise that would make a depth ≤ 0 drops the return (depth 0, ids 0), at the rate the
    Gaussian gives (P(z + ε ≤ 0) = Φ(−z/σ)); holes stay holes."""
    f = wall(z)
    d = f.depth.copy()
    d[:, :20] = 0  # a hole: no return, no noise
    f = f.replace(
        depth=d,
        instance=np.where(d > 0, 7, 0).astype(np.uint32),
        semantic=np.where(d > 0, 2, 0).astype(np.uint16),
    )
    out = DepthNoise(**noise).apply(f, rng=np.random.default_rng(3))
    assert (out.depth >= 0).all() and not out.depth[:, :20].any()
    lost = (out.depth[:, 20:] == 0).mean()
    assert lost == pytest.approx(p_lost, abs=0.01)
    np.testing.assert_array_equal(out.instance == 0, out.depth == 0)
    np.testing.assert_array_equal(out.semantic == 0, out.depth == 0)


@pytest.mark.parametrize("model", ["stereo", "tof_linear", "kinect_nguyen2012"])
def test_depth_noise_draws_one_normal_per_return(model):
    """Same seed, same dataset: every model takes exactly one normal per pixel with a return
    (none for holes), so the effects after it see the generator where the Kinect model leaves it."""
    f = wall(2.0)
    d = f.depth.copy()
    d[:40] = 0
    f = f.replace(depth=d)
    rng = np.random.default_rng(9)
    DepthNoise(model=model, incidence=False).apply(f, rng=rng)
    ref = np.random.default_rng(9)
    ref.standard_normal(int((d > 0).sum()))
    assert rng.random() == ref.random()


def test_disparity_quantisation_rounds_to_the_nearest_step_with_the_calibration_baseline():
    """z = f·b / (step · round(f·b / (z · step))), with b from the sensor's calibration."""
    s = gg.Sensor.pinhole(200, 160, 500.0, stereo=Stereo(0.1))
    z = np.linspace(0.4, 3.0, 200 * 160).reshape(160, 200)
    f = gg.Frame(
        z.astype(np.float32),
        np.ones((160, 200), np.uint32),
        np.ones((160, 200), np.uint16),
        None,
        s,
        np.eye(4),
    )
    out = DepthNoise(model="stereo", subpixel=1e-9, subpixel_step=0.125).apply(
        f, rng=np.random.default_rng(0)
    )
    fb = 500.0 * 0.1
    expected = fb / (0.125 * np.round(fb / (f.depth.astype(np.float64) * 0.125)))
    np.testing.assert_allclose(out.depth, expected, rtol=1e-6)


def test_nguyen_incidence_term_only_past_60_degrees_clamped_at_85_and_only_when_asked():
    z, f = np.array([1.5]), 500.0
    base = 0.0012 + 0.0019 * (1.5 - 0.4) ** 2

    def term(deg):
        t = np.radians(deg)
        return 0.0001 / np.sqrt(1.5) * t**2 / (np.pi / 2 - t) ** 2

    on, off = DepthNoise(), DepthNoise(incidence=False)
    for deg in (0.0, 30.0, 50.0, 59.0):
        assert on.sigma(z, f, np.radians([deg]))[0] == pytest.approx(base, rel=1e-12)
    for deg in (61.0, 70.0, 84.0):
        assert on.sigma(z, f, np.radians([deg]))[0] == pytest.approx(base + term(deg), rel=1e-9)
    for deg in (85.0, 88.0, 89.9):
        assert on.sigma(z, f, np.radians([deg]))[0] == pytest.approx(base + term(85.0), rel=1e-9)
    assert off.sigma(z, f, np.radians([80.0]))[0] == pytest.approx(base, rel=1e-12)
    near = (
        0.0012
        + 0.0019 * (0.5 - 0.4) ** 2
        + 0.0001 / np.sqrt(0.5) * np.radians(70.0) ** 2 / np.radians(20.0) ** 2
    )
    assert on.sigma(np.array([0.5]), f, np.radians([70.0]))[0] == pytest.approx(near, rel=1e-9)
    # without a sensor: the default baseline (0.05 m) and σ_d (0.08 px)
    assert DepthNoise(model="stereo").sigma(np.array([2.0]), f)[0] == pytest.approx(
        4 * 0.08 / (500 * 0.05)
    )
    with pytest.raises(ValueError, match="needs f_px"):
        DepthNoise(model="stereo").sigma(np.array([2.0]))
    assert on.sigma(z, f, None)[0] == pytest.approx(base, rel=1e-12)


def test_sigma_models_against_the_papers_at_several_depths():
    """σ_z as each model's formula gives it, evaluated independently: ToF a + b·max(z − z0, 0)
    (flat below z0), stereo z²·σ_d/(f·b) with σ_d and b from the calibration, Nguyen's
    incidence term only beyond 60° (not at it)."""
    z = np.array([0.2, 0.5, 1.0, 2.5, 6.0])
    tof = DepthNoise(model="tof_linear", a_m=0.002, b=0.004, z0_m=0.8)
    np.testing.assert_allclose(
        tof.sigma(z, 500.0), [0.002, 0.002, 0.0028, 0.0088, 0.0228], rtol=1e-12
    )
    s = gg.Sensor.pinhole(200, 160, 400.0, stereo=Stereo(0.12), reprojection_error_px=0.3)
    np.testing.assert_allclose(
        DepthNoise(model="stereo").sigma(z, 400.0, None, s),
        z * z * 0.3 / (400.0 * 0.12),
        rtol=1e-12,
    )
    kin = DepthNoise(model="kinect_nguyen2012")
    base = 0.0012 + 0.0019 * (1.5 - 0.4) ** 2
    th = np.array([np.pi / 3, np.radians(70.0)])
    np.testing.assert_allclose(
        kin.sigma(np.full(2, 1.5), 500.0, th),
        [base, base + 0.0001 / np.sqrt(1.5) * th[1] ** 2 / (np.pi / 2 - th[1]) ** 2],
        rtol=1e-12,
    )


def test_project_without_distortion_is_the_pinhole_k():
    """No coefficients: u = fx·x + cx, v = fy·y + cy, each from its own coordinate."""
    K = np.array([[400.0, 0.0, 321.0], [0.0, 380.0, 239.0], [0.0, 0.0, 1.0]])
    xy = np.array([[0.1, -0.2], [-0.3, 0.05], [0.0, 0.4]])
    want = np.stack([400.0 * xy[:, 0] + 321.0, 380.0 * xy[:, 1] + 239.0], 1)
    np.testing.assert_allclose(project(xy, K, np.zeros(0)), want, rtol=1e-12)
    np.testing.assert_allclose(project(xy, K, np.zeros(5)), want, rtol=1e-12)
