"""The surface, edge and calibration effects against their models, on synthetic frames (no GL)."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.effects.simulate import simulate
from genie_gl.effects.edges import EdgeDropout, FlyingPixels
from genie_gl.effects.registry import EFFECTS, DepthNoise
from genie_gl.effects.miscalibration import CalibrationError
from genie_gl.sensors.camera import Stereo
from genie_gl.effects.surface import IncidenceDropout, LateralNoise, Multipath

W, H = 200, 160  # 32 000 pixels: a σ measured over them is good to ~0.4 %


def frame(depth, f=500.0, normal=None, sensor_fields=None, instance=None):
    s = gg.Sensor.pinhole(depth.shape[1], depth.shape[0], f, **(sensor_fields or {}))
    d = depth.astype(np.float32)
    inst = (
        np.where(d > 0, 1, 0).astype(np.uint32) if instance is None else instance.astype(np.uint32)
    )
    n = (
        None
        if normal is None
        else np.broadcast_to(np.asarray(normal, np.float32), d.shape + (3,)).copy()
    )
    return gg.Frame(d, inst, (inst > 0).astype(np.uint16), None, s, np.eye(4), n)


def tilted_normal(theta):
    """Unit normal facing a camera on the optical axis at incidence theta (about y)."""
    return (np.sin(theta), 0.0, -np.cos(theta))


def step(z_left=1.0, z_right=2.0):
    d = np.full((H, W), z_right)
    d[:, : W // 2] = z_left
    return frame(d, instance=np.where(np.arange(W) < W // 2, 1, 2)[None].repeat(H, 0))


@pytest.mark.parametrize("theta_deg", [0.0, 40.0, 70.0])
def test_lateral_noise_sigma_matches_nguyen2012(theta_deg):
    theta = np.radians(theta_deg)
    ramp = 2.0 + 1e-3 * np.arange(W)[None].repeat(H, 0)  # depth linear in u: du = Δz / 1e-3
    f = frame(ramp, f=5000.0, normal=tilted_normal(theta))  # narrow field: θ the same everywhere
    out = LateralNoise().apply(f, rng=np.random.default_rng(1))
    du = (out.depth.astype(np.float64) - f.depth) / 1e-3
    inner = du[8:-8, 8:-8]  # away from the clamped border
    assert inner.size >= 10_000 and np.isfinite(out.depth).all()
    expected = 0.8 + 0.035 * theta / (np.pi / 2 - theta)
    assert np.std(inner) == pytest.approx(expected, rel=0.05)
    assert abs(np.mean(inner)) < 0.02
    again = LateralNoise().apply(f, rng=np.random.default_rng(1))
    assert out.depth.tobytes() == again.depth.tobytes()


def test_lateral_noise_jitters_silhouettes_without_blending():
    f = step()
    out = LateralNoise(model="constant", sigma_px=1.0).apply(f, rng=np.random.default_rng(0))
    assert set(np.unique(out.depth)) == {1.0, 2.0}  # nearest across the edge: no mixing
    moved = out.depth != f.depth
    assert moved[:, : W // 2 - 6].sum() == 0 and moved[:, W // 2 + 6 :].sum() == 0
    assert 0.1 < moved[:, W // 2 - 3 : W // 2 + 3].mean() < 0.6
    np.testing.assert_array_equal(out.instance == 1, out.depth == 1.0)  # ids travel with depth


@pytest.mark.parametrize("theta_deg, z", [(50.0, 1.5), (70.0, 1.5), (75.0, 3.0)])
def test_nguyen2012_axial_sigma_with_the_angle_term_beyond_60_degrees(theta_deg, z):
    theta = np.radians(theta_deg)
    f = frame(np.full((H, W), z), f=5000.0, normal=tilted_normal(theta))
    out = DepthNoise(model="kinect_nguyen2012").apply(f, rng=np.random.default_rng(2))
    expected = 0.0012 + 0.0019 * (z - 0.4) ** 2
    if theta_deg > 60:
        expected += 0.0001 / np.sqrt(z) * theta**2 / (np.pi / 2 - theta) ** 2
    assert np.std(out.depth.astype(np.float64) - z) == pytest.approx(expected, rel=0.05)
    off = DepthNoise(model="kinect_nguyen2012", incidence=False).apply(
        f, rng=np.random.default_rng(2)
    )
    base = 0.0012 + 0.0019 * (z - 0.4) ** 2
    assert np.std(off.depth.astype(np.float64) - z) == pytest.approx(base, rel=0.05)


def test_incidence_dropout_follows_the_analytic_angle():
    n = np.array(tilted_normal(np.radians(60.0)))
    f = frame(np.full((H, W), 2.0), f=150.0, normal=n)  # wide field: θ varies over the image
    out = IncidenceDropout(max_angle_deg=60.0).apply(f, rng=np.random.default_rng(0))
    u, v = np.meshgrid(np.arange(W) - (W - 1) / 2, np.arange(H) - (H - 1) / 2)
    rays = np.stack([u / 150.0, v / 150.0, np.ones_like(u)], -1)
    theta = np.degrees(np.arccos(-(rays @ n) / np.linalg.norm(rays, axis=-1)))
    clear = np.abs(theta - 60.0) > 1e-3
    np.testing.assert_array_equal((out.depth == 0)[clear], (theta > 60.0)[clear])
    assert 0.3 < (out.depth == 0).mean() < 0.7
    assert not out.instance[out.depth == 0].any()
    assert out.meta["incidence_dropout"]["dropped"] == int((out.depth == 0).sum())


def test_flying_pixels_blend_the_two_sides_of_an_edge():
    f = step()
    out = FlyingPixels(probability=0.5, jump_m=0.05).apply(f, rng=np.random.default_rng(3))
    assert out.meta["flying_pixels"]["edge_pixels"] == 2 * H  # one column each side
    changed = out.depth != f.depth
    assert not changed[:, : W // 2 - 1].any() and not changed[:, W // 2 + 1 :].any()
    n = int(changed.sum())
    assert abs(n - H) < 3 * np.sqrt(2 * H * 0.25)  # binomial(320, 0.5)
    z = out.depth[changed].astype(np.float64)
    assert ((z > 1.0) & (z < 2.0)).all()
    every = FlyingPixels(probability=1.0).apply(f, rng=np.random.default_rng(3))
    assert every.meta["flying_pixels"]["mixed"] == 2 * H
    edge = every.depth[:, W // 2 - 1 : W // 2 + 1].astype(np.float64)
    alpha = np.abs(edge - f.depth[:, W // 2 - 1 : W // 2 + 1])  # step 1 m: α itself
    assert np.mean(alpha) == pytest.approx(0.5, abs=0.06)  # U(0, 1): σ of the mean 0.016
    assert np.std(alpha) == pytest.approx(np.sqrt(1 / 12), rel=0.15)
    small = FlyingPixels(jump_m=1.5).apply(f, rng=np.random.default_rng(3))
    assert small.depth.tobytes() == f.depth.tobytes()


@pytest.mark.parametrize("far, dropped", [(2.0, 2 * H), (1.5, 0)])
def test_edge_dropout_uses_the_3x3_span(far, dropped):
    f = step(1.0, far)
    out = EdgeDropout(span_m=0.8).apply(f, rng=np.random.default_rng(0))
    gone = out.depth == 0
    assert int(gone.sum()) == dropped
    if dropped:
        assert gone[:, W // 2 - 1].all() and gone[:, W // 2].all() and not out.instance[gone].any()


def groove(kind, z0=2.0, g=1.0, f=500.0):
    """A V groove (concave: its apex farthest) or ridge (convex) along v, seen frontally."""
    x = (np.arange(W) - (W - 1) / 2) / f
    sgn = np.sign(x)
    if kind == "concave":  # z = z0 − g|X|
        z = z0 / (1 + g * np.abs(x))
        n = np.stack([-g * sgn, 0 * x, -np.ones_like(x)], -1)
    else:  # z = z0 + g|X|
        z = z0 / (1 - g * np.abs(x))
        n = np.stack([g * sgn, 0 * x, -np.ones_like(x)], -1)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    f = frame(z[None].repeat(H, 0), f=f)
    return f.replace(normal=n[None].repeat(H, 0).astype(np.float32))


def test_multipath_biases_concave_corners_only():
    eff = Multipath(bias_m=0.01, radius_px=8)
    flat = frame(np.full((H, W), 2.0), normal=(0.0, 0.0, -1.0))
    assert eff.apply(flat, rng=None).depth.tobytes() == flat.depth.tobytes()
    ridge = groove("convex")
    assert eff.apply(ridge, rng=None).depth.tobytes() == ridge.depth.tobytes()
    g = groove("concave")
    out = eff.apply(g, rng=None)
    v, u = np.mgrid[0:H, 0:W]
    ray_len = np.sqrt(((u - (W - 1) / 2) / 500.0) ** 2 + ((v - (H - 1) / 2) / 500.0) ** 2 + 1)
    grow = (out.depth.astype(np.float64) - g.depth) * ray_len  # range bias, metres
    apex = grow[H // 2, W // 2 - 1 : W // 2 + 1]
    assert (apex > 0.25 * 0.01).all() and grow.max() <= 0.01 + 1e-6
    far = np.abs(np.arange(W) - (W - 1) / 2) > 8.5
    assert (grow[:, far] == 0).all()


def test_calibration_error_resamples_into_the_true_camera():
    cols = np.arange(W)[None].repeat(H, 0)
    f = frame(np.full((H, W), 2.0), instance=cols + 1)
    out = CalibrationError(sigma_f_px=4.0, sigma_c_px=3.0).apply(f, rng=np.random.default_rng(7))
    Kt = np.array(out.meta["calibration_error"]["K_true"])
    K = f.sensor.K
    assert not np.allclose(Kt, K)
    rows = np.arange(H)[:, None].repeat(W, 1)
    src = K[0, 0] / Kt[0, 0] * (cols - Kt[0, 2]) + K[0, 2]  # where each true pixel looks
    src_v = K[1, 1] / Kt[1, 1] * (rows - Kt[1, 2]) + K[1, 2]
    ok = out.depth > 0
    np.testing.assert_array_equal(out.instance[ok], np.rint(src[ok]).astype(np.uint32) + 1)
    np.testing.assert_array_equal(
        ok, (src > -0.5) & (src < W - 0.5) & (src_v > -0.5) & (src_v < H - 0.5)
    )
    np.testing.assert_array_equal(out.sensor.K, K)  # the calibrated K is what we report
    eff = CalibrationError(2.0, 0.5)
    draws = np.array([eff.true_K(f.sensor, np.random.default_rng(i)) - K for i in range(2000)])
    assert np.std(draws[:, 0, 0]) == pytest.approx(2.0, rel=0.05)
    assert np.std(draws[:, 1, 2]) == pytest.approx(0.5, rel=0.05)


def test_sigma_d_and_baseline_come_from_the_calibration_unless_the_profile_sets_them():
    fields = {"reprojection_error_px": 0.3, "stereo": Stereo(0.06)}
    f = frame(np.full((H, W), 2.0), sensor_fields=fields)
    eff = DepthNoise(model="stereo")
    assert eff.sigma_d_px(f.sensor) == 0.3 and eff.baseline(f.sensor) == 0.06
    out = eff.apply(f, rng=np.random.default_rng(0))
    assert np.std(out.depth.astype(np.float64) - 2.0) == pytest.approx(
        4.0 * 0.3 / (500.0 * 0.06), rel=0.05
    )
    assert DepthNoise(model="stereo", subpixel=0.08).sigma_d_px(f.sensor) == 0.08
    assert DepthNoise(model="stereo").sigma_d_px(gg.Sensor.pinhole(8, 8, 10.0)) == 0.08
    d435 = gg.load_sensor("realsense_d435")
    assert d435.reprojection_error_px == 0.25
    np.testing.assert_allclose(d435.stereo.T, [-0.05, 0, 0])
    np.testing.assert_array_equal(d435.stereo.R, np.eye(3))


ZERO = {
    "lateral_noise": dict(model="constant", sigma_px=0.0),
    "flying_pixels": dict(probability=0.0),
    "multipath": dict(bias_m=0.0),
    "calibration_error": dict(sigma_f_px=0.0, sigma_c_px=0.0),
    "depth_noise": dict(model="tof_linear", a_m=0.0, b=0.0),
    "edge_dropout": dict(span_m=100.0),
    "incidence_dropout": dict(max_angle_deg=90.0),
    "range": {},
    "ambiguity": dict(ambiguity_m=1e6),
}


# strengths that must change scene_like() (defaults where they already do)
STRONG = {
    "range": dict(min_m=1.5, max_m=3.5),
    "incidence_dropout": dict(max_angle_deg=30.0),
    "edge_dropout": dict(span_m=0.5),
    "ambiguity": dict(ambiguity_m=2.5),
}


def scene_like():
    """A frame with a hole, a step and a slanted part."""
    d = np.full((H, W), 3.0)
    d[40:120, 60:140] = 1.2
    d[:, 160:] = np.linspace(2.0, 4.0, 40)[None]
    d[:20, :30] = 0
    return frame(d, instance=np.where(d == 1.2, 2, np.where(d > 0, 1, 0)))


@pytest.mark.parametrize(
    "name", sorted(n for n in set(EFFECTS) - {"stereo_shadow"} if not EFFECTS[n].needs_materials)
)  # those: tests/sensors/test_plan.py
def test_zero_strength_effects_give_the_ideal_frame_and_strong_ones_stay_finite(name):
    f = scene_like()
    s = f.sensor
    zero = EFFECTS[name](**ZERO[name])
    out = simulate(
        gg.Sensor(s.width, s.height, s.K, effects=(zero,)),
        np.eye(4),
        render=lambda sensor, pose, **kw: f.replace(sensor=sensor),
        rng=np.random.default_rng(0),
    )
    assert (
        out.depth.tobytes() == f.depth.tobytes() and out.instance.tobytes() == f.instance.tobytes()
    )
    assert out.normal is None
    strong = EFFECTS[name](**STRONG.get(name, {}))
    a = simulate(
        gg.Sensor(s.width, s.height, s.K, effects=(strong,)),
        np.eye(4),
        render=lambda sensor, pose, **kw: f.replace(sensor=sensor),
        rng=np.random.default_rng(4),
    )
    b = simulate(
        gg.Sensor(s.width, s.height, s.K, effects=(strong,)),
        np.eye(4),
        render=lambda sensor, pose, **kw: f.replace(sensor=sensor),
        rng=np.random.default_rng(4),
    )
    assert np.isfinite(a.depth).all() and (a.depth >= 0).all()
    assert a.depth.tobytes() == b.depth.tobytes()
    assert not a.instance[a.depth == 0].any()
    # an effect that does nothing fails here: at strength it changes the frame
    assert a.depth.tobytes() != f.depth.tobytes()
    if name == "range":  # exactly what lies outside [1.5, 3.5] m is dropped
        np.testing.assert_array_equal(a.depth > 0, (f.depth >= 1.5) & (f.depth <= 3.5))


def test_steep_angles_are_the_incidence_beyond_60_degrees_pixel_by_pixel():
    """θ = arccos(−n·r̂) with r the pixel's ray through its centre, reported where θ > 60°
    (the Nguyen term's threshold) and 0 elsewhere, for normals that differ pixel by pixel."""
    h, w, fpx = 40, 60, 50.0  # wide field: rays far off axis
    rng = np.random.default_rng(4)
    n = rng.normal(size=(h, w, 3))
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    d = np.full((h, w), 2.0)
    d[:3] = 0  # holes are not in the list
    valid = d > 0
    u, v = np.meshgrid(np.arange(w) + 0.5 - w / 2, np.arange(h) + 0.5 - h / 2)
    r = np.stack([u / fpx, v / fpx, np.ones_like(u)], -1)
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    n *= -np.sign((n * r).sum(-1, keepdims=True))  # every surface seen from the front
    n[5, :10] = 0  # no normal: no angle
    f = frame(d, f=fpx, normal=n)
    theta = np.arccos(np.clip(-(n * r).sum(-1), -1.0, 1.0))
    expected = np.where((theta > np.pi / 3) & (n != 0).any(-1), theta, 0.0)[valid]
    got = DepthNoise.steep_angles(f, valid)
    assert 0.2 < (expected > 0).mean() < 0.9
    np.testing.assert_allclose(got, expected, atol=2e-6)
