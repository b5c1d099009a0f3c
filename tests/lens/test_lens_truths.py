"""The lens maps (genie_gl/camera.py) and the pinhole views behind a lens image
(genie_gl/lens/distortion.py) against independent truths: OpenCV's own lens models
(cv2.projectPoints, cv2.fisheye, cv2.omnidir, cv2.undistortPoints), analytic pinhole values and
lens folds, and numpy's SVD. Every test is small (a 64x48 to 160x120 image, a few thousand
points), so the whole file runs in about two seconds: `make mutants` runs it against each
mutant of the "lens" group."""

import cv2
import numpy as np
import pytest

from genie_gl.camera import MAX_OFF_AXIS, Camera
from genie_gl.errors import ConfigError
from genie_gl.lens.distortion import _scale_min, distortion_maps, lens_views

W, H = 160, 120
K = np.array([[150.0, 0.0, 80.3], [0.0, 163.0, 58.6], [0.0, 0.0, 1.0]])  # fx ≠ fy, off-centre
PINHOLE = {  # every coefficient count OpenCV's pinhole model takes, each term large enough to count
    "radtan4": [0.11, -0.07, 0.004, -0.003],
    "radtan5": [-0.21, 0.06, 0.003, 0.002, -0.01],
    "rational8": [0.3, -0.1, 0.002, -0.004, 0.02, 0.25, -0.05, 0.03],
    "prism12": [-0.15, 0.04, 0.001, 0.002, 0.01, 0.02, -0.01, 0.005, 0.004, -0.003, 0.006, -0.002],
    "tilted14": [
        0.1,
        -0.03,
        0.002,
        -0.001,
        0.01,
        0.03,
        -0.02,
        0.01,
        0.003,
        0.002,
        -0.004,
        0.001,
        0.04,
        -0.03,
    ],
    "tilted_x": [0.1, -0.03, 0.002, -0.001, 0.01, 0, 0, 0, 0, 0, 0, 0, 0.05, 0],  # τx alone
}
CRIT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)


def image_pixels(w: int = W, h: int = H) -> np.ndarray:
    """(N, 2): the four corners, the edges' midpoints, the centre and a grid across the image."""
    u, v = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 7))
    return np.stack([u.ravel(), v.ravel()], 1)


def cv_pinhole(pts: np.ndarray, dist) -> np.ndarray:
    return cv2.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, np.array(dist, float)
    )[0].reshape(-1, 2)


# -- the pinhole lens -----------------------------------------------------------------------------
def test_ideal_pinhole_is_k_analytically_both_ways():
    """No lens: u = fx X/Z + s Y/Z + cx, v = fy Y/Z + cy, and back; the rays of every pixel."""
    Ks = K + [[0, 0.7, 0], [0, 0, 0], [0, 0, 0]]  # with skew
    cam = Camera(W, H, Ks)
    pts = np.array([[0.3, -0.2, 2.0], [-1.1, 0.4, 0.5], [0.0, 0.0, 7.0], [2.0, 1.5, 3.0]])
    X, Y, Z = pts.T
    want = np.stack([150.0 * X / Z + 0.7 * Y / Z + 80.3, 163.0 * Y / Z + 58.6], 1)
    np.testing.assert_allclose(cam.project(pts), want, rtol=1e-13)
    assert np.isnan(cam.project(np.array([[0.1, 0.1, -1.0]]))).all()  # behind the camera
    p32 = (pts * [1, 1, 1.001]).astype(np.float32)  # float32 points: float64 maths
    assert cam.project(p32).dtype == np.float64
    np.testing.assert_array_equal(cam.project(p32), cam.project(p32.astype(np.float64)))
    np.testing.assert_array_equal(
        cam.unproject(want.astype(np.float32)), cam.unproject(want.astype(np.float32).astype(float))
    )
    d = cam.unproject(want)
    np.testing.assert_allclose(d, pts / np.linalg.norm(pts, axis=1, keepdims=True), atol=1e-13)
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    y = (v - 58.6) / 163.0
    x = (u - 80.3 - 0.7 * y) / 150.0
    np.testing.assert_allclose(cam.rays(), np.stack([x, y], -1), atol=1e-15)
    dirs = np.stack([x, y, np.ones_like(x)], -1)
    np.testing.assert_allclose(
        cam.directions(), dirs / np.linalg.norm(dirs, axis=-1, keepdims=True), atol=1e-15
    )
    assert cam.max_off_axis == pytest.approx(float(MAX_OFF_AXIS), abs=1e-15)


@pytest.mark.parametrize("name", list(PINHOLE))
def test_pinhole_lens_projects_as_cv2_at_every_depth_out_to_the_corners(name):
    """Camera.project against cv2.projectPoints on points that fill and overfill the image
    (its corners included), at three depths; depth itself does not change a pixel."""
    cam = Camera(W, H, K, PINHOLE[name])
    xy = np.stack(
        np.meshgrid(np.linspace(-0.65, 0.65, 27), np.linspace(-0.45, 0.45, 19)), -1
    ).reshape(-1, 2)
    for z in (0.5, 1.0, 4.0):
        pts = np.c_[xy * z, np.full(len(xy), z)]
        ours = cam.project(pts)
        assert np.isfinite(ours).all()
        np.testing.assert_allclose(ours, cv_pinhole(pts, PINHOLE[name]), atol=1e-9)


@pytest.mark.parametrize("name", list(PINHOLE))
def test_pinhole_unproject_gives_the_ray_cv2_projects_back_to_each_pixel(name):
    """Camera.unproject, rays() and directions() of pixels from corner to corner: cv2 projects
    each ray back to its pixel; cv2.undistortPoints (its own iterative inverse) agrees."""
    dist = PINHOLE[name]
    cam = Camera(W, H, K, dist)
    uv = image_pixels()
    d = cam.unproject(uv)
    assert np.isfinite(d).all()
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(cv_pinhole(d, dist), uv, atol=1e-7)
    und = cv2.undistortPoints(
        uv.reshape(-1, 1, 2), K, np.array(dist), None, None, None, CRIT
    ).reshape(-1, 2)
    np.testing.assert_allclose(d[:, :2] / d[:, 2:], und, atol=1e-6)
    iu, iv = uv[:, 0].astype(int), uv[:, 1].astype(int)
    whole = (iu == uv[:, 0]) & (iv == uv[:, 1])
    np.testing.assert_allclose(
        cam.rays()[iv[whole], iu[whole]], (d[:, :2] / d[:, 2:])[whole], atol=1e-12
    )
    np.testing.assert_allclose(cam.directions()[iv[whole], iu[whole]], d[whole], atol=1e-12)


def test_pinhole_fold_is_where_the_radial_map_turns_back():
    """r (1 + k1 r²) with k1 < 0 peaks at r = 1/sqrt(-3 k1): the lens images nothing beyond
    atan of that; pixels beyond the peak's image have no ray (NaN), those inside do."""
    k1 = -0.5
    r_fold = 1 / np.sqrt(-3 * k1)
    cam = Camera(W, H, K, [k1, 0, 0, 0])
    assert cam.max_off_axis == pytest.approx(np.arctan(r_fold), abs=2e-4)
    r_img = r_fold * (1 + k1 * r_fold**2)  # the largest distorted radius
    inner = np.array([[80.3 + 150.0 * 0.97 * r_img, 58.6], [80.3, 58.6 - 163.0 * 0.97 * r_img]])
    outer = np.array([[80.3 + 150.0 * 1.03 * r_img, 58.6], [80.3, 58.6 + 163.0 * 1.03 * r_img]])
    d = cam.unproject(inner)
    assert np.isfinite(d).all()
    np.testing.assert_allclose(cv_pinhole(d, [k1, 0, 0, 0]), inner, atol=1e-7)
    assert np.isnan(cam.unproject(outer)).all()
    pts = np.array(
        [
            [0.95 * r_fold, 0, 1],
            [0, 0.95 * r_fold, 1],
            [1.05 * r_fold, 0, 1],
            [0, -1.05 * r_fold, 1],
        ]
    )
    p = cam.project(pts)
    assert np.isfinite(p[:2]).all() and np.isnan(p[2:]).all()
    np.testing.assert_allclose(p[:2], cv_pinhole(pts[:2], [k1, 0, 0, 0]), atol=1e-9)
    assert np.isnan(cam.directions()[0, 0]).all() and np.isfinite(cam.directions()[60, 80]).all()


@pytest.mark.parametrize(
    "dist, r_fold",
    [
        ([0, 0, 0, 0, -0.1], (1 / 0.7) ** (1 / 6)),  # r (1 + k3 r⁶): 1 + 7 k3 r⁶ = 0
        ([0, 0, 0, 0, 0, 0, 0.2, 0], (1 / 0.6) ** (1 / 4)),  # r / (1 + k5 r⁴): 1 = 3 k5 r⁴
        ([0, 0, 0, 0, 0, 0, 0, 0.2], 1.0),  # r / (1 + k6 r⁶): 1 = 5 k6 r⁶
    ],
)
def test_pinhole_fold_of_each_radial_term(dist, r_fold):
    assert Camera(W, H, K, dist).max_off_axis == pytest.approx(np.arctan(r_fold), abs=2e-4)


@pytest.mark.parametrize(
    "k, t_fold",
    [
        ([-0.5, 0, 0, 0], np.sqrt(2 / 3)),  # 1 + 3 k1 θ² = 0 (46.8°)
        ([0, 0, -0.1, 0], (1 / 0.7) ** (1 / 6)),
    ],
)  # 1 + 7 k3 θ⁶ = 0
def test_fisheye_fold_of_each_term(k, t_fold):
    assert Camera(W, H, K, k, model="fisheye").max_off_axis == pytest.approx(t_fold, abs=1e-4)


def test_omni_fold_below_one_radian():
    """ξ = 0 is the pinhole on the sphere: r = tan θ folds where r (1 - 0.5 r²) does (39.2°)."""
    assert Camera(W, H, K, [0.0, -0.5, 0, 0, 0], model="omni").max_off_axis == pytest.approx(
        np.arctan(np.sqrt(2 / 3)), abs=1e-4
    )


def test_rational_fold_and_an_unfolded_lens():
    """The rational model's fold: r (1 + k1 r²) / (1 + k4 r²) with k1 = -0.2, k4 = 0.3 peaks
    where its derivative vanishes, (1 - 3 (-k1) r² ... ) solved here by numpy's roots; a lens that
    never turns back images everything up to 89.9°."""
    k1, k4 = -0.2, 0.3
    # d/dr [r (1 + k1 r²) / (1 + k4 r²)] = 0  <=>  k1 k4 r⁴ + (3 k1 - k4) r² + 1 = 0
    roots = np.roots([k1 * k4, 3 * k1 - k4, 1])
    r2 = roots[(roots > 0) & np.isreal(roots)].real.min()
    cam = Camera(W, H, K, [k1, 0, 0, 0, 0, k4, 0, 0])
    assert cam.max_off_axis == pytest.approx(np.arctan(np.sqrt(r2)), abs=2e-4)
    assert Camera(W, H, K, [0.1, 0.01, 0, 0, 0]).max_off_axis == pytest.approx(float(MAX_OFF_AXIS))


def test_a_rational_lens_whose_pole_lies_past_89_degrees_has_every_pixel_ray_inside_it():
    """r (1 + k3 r⁶) / (1 + k5 r⁴ + k6 r⁶) with k3 = k5 = 0.25, k6 = -1e-5 rises up to the pole
    of its denominator, r² = 25,000 (r ~ 158, 89.6° off the axis), and drops past it: the fold
    is there, and every pixel of a 160 x 120 image (within 0.7 of the axis) has a ray that
    OpenCV projects back to it. (Searched only up to 89°, the fold was missed and the inverse,
    searching on to r = 1e6, found no root: no pixel had a ray.)"""
    dist = [0, 0, 0, 0, 0.25, 0, 0.25, -1e-5]
    pole = np.sqrt(np.roots([-1e-5, 0.25, 0, 1]).real.max())  # k6 s³ + k5 s² + 1 = 0, s = r²
    cam = Camera(160, 120, [[150.0, 0, 80.3], [0, 152.0, 59.6], [0, 0, 1]], dist)
    assert np.arctan(pole) - 2e-4 <= cam.max_off_axis < np.arctan(pole)
    d = cam.directions()
    assert np.isfinite(d).all()
    uv = cv2.projectPoints(d.reshape(-1, 3), np.zeros(3), np.zeros(3), cam.K, np.array(dist))[0]
    v, u = np.mgrid[:120, :160]
    np.testing.assert_allclose(uv.reshape(120, 160, 2), np.stack([u, v], -1), atol=1e-9)


# -- the fisheye lens
# -------------------------------------------------------------------------------
FISH = [0.03, -0.01, 0.004, -0.001]


@pytest.mark.parametrize("skew", [0.0, 0.9])
def test_fisheye_projects_as_cv2_fisheye_up_to_88_degrees(skew):
    """Camera.project against cv2.fisheye.projectPoints (alpha = skew / fx), points all round
    the axis up to 88° off it; behind the camera: no pixel."""
    Kf = np.array([[60.0, skew, 80.3], [0.0, 62.0, 58.6], [0.0, 0.0, 1.0]])
    cam = Camera(W, H, Kf, FISH, model="fisheye")
    th, ph = np.meshgrid(np.radians(np.linspace(0, 88, 12)), np.linspace(0, 2 * np.pi, 13))
    pts = (
        np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
        * 2.5
    )
    Kc = Kf.copy()
    Kc[0, 1] = 0
    ref = cv2.fisheye.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), Kc, np.array(FISH), alpha=skew / 60.0
    )[0].reshape(-1, 2)
    ours = cam.project(pts)
    assert np.isfinite(ours).all()
    np.testing.assert_allclose(ours, ref, atol=1e-9)
    d = cam.unproject(ours)  # and back to the same unit directions
    np.testing.assert_allclose(d, pts / 2.5, atol=1e-9)
    assert np.isnan(cam.project(np.array([[0.0, 0.3, -1.0]]))).all()


def test_fisheye_unproject_of_every_pixel_projects_back_through_cv2_fisheye():
    Kf = np.array([[40.0, 0, 80.3], [0, 41.0, 58.6], [0, 0, 1]])
    cam = Camera(W, H, Kf, FISH, model="fisheye")
    uv = image_pixels()
    d = cam.unproject(uv)
    ok = np.isfinite(d).all(1)
    assert 30 < ok.sum() < len(uv)  # the corners lie past 90°
    theta = np.arctan2(np.hypot(d[ok, 0], d[ok, 1]), d[ok, 2])
    assert theta.max() > np.radians(75)  # the corners are far off the axis
    ref = cv2.fisheye.projectPoints(
        d[ok].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), Kf, np.array(FISH)
    )[0]
    np.testing.assert_allclose(ref.reshape(-1, 2), uv[ok], atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(d[ok], axis=1), 1, atol=1e-12)
    # the pixels without a ray are those whose distorted angle lies past the 89.9° ray's
    td = np.hypot((uv[:, 0] - 80.3) / 40.0, (uv[:, 1] - 58.6) / 41.0)
    t = MAX_OFF_AXIS
    td_max = t * (1 + FISH[0] * t**2 + FISH[1] * t**4 + FISH[2] * t**6 + FISH[3] * t**8)
    np.testing.assert_array_equal(~ok, td > td_max)
    np.testing.assert_allclose(
        cam.directions()[0, 80], cam.unproject(np.array([[80.0, 0.0]]))[0], atol=1e-15
    )


def test_fisheye_fold_is_where_theta_d_turns_back():
    """θ (1 + k1 θ²) with k1 = -0.3 peaks at θ = 1/sqrt(0.9) (60.4°): nothing beyond is imaged."""
    cam = Camera(
        W, H, np.array([[40.0, 0, 80], [0, 40.0, 60], [0, 0, 1]]), [-0.3, 0, 0, 0], model="fisheye"
    )
    t_fold = 1 / np.sqrt(0.9)
    assert cam.max_off_axis == pytest.approx(t_fold, abs=1e-4)
    inside = np.array([[np.sin(t_fold - 0.02), 0, np.cos(t_fold - 0.02)]])
    beyond = np.array([[0, np.sin(t_fold + 0.02), np.cos(t_fold + 0.02)]])
    assert np.isfinite(cam.project(inside)).all() and np.isnan(cam.project(beyond)).all()
    td_fold = t_fold * (1 - 0.3 * t_fold**2)
    assert np.isnan(cam.unproject(np.array([[80 + 40.0 * 1.02 * td_fold, 60.0]]))).all()
    d = cam.unproject(np.array([[80 + 40.0 * 0.98 * td_fold, 60.0]]))
    assert np.isfinite(d).all() and np.arccos(d[0, 2]) < t_fold


def test_fisheye_without_coefficients_is_equidistant():
    """No coefficients: r = f θ exactly (Kannala-Brandt with k = 0)."""
    cam = Camera(W, H, np.array([[40.0, 0, 80], [0, 44.0, 60], [0, 0, 1]]), [], model="fisheye")
    th = np.radians([0.0, 10, 45, 80, 89])
    pts = np.stack([np.sin(th), np.zeros(5), np.cos(th)], 1)
    np.testing.assert_allclose(
        cam.project(pts), np.stack([80 + 40 * th, np.full(5, 60.0)], 1), atol=1e-12
    )
    np.testing.assert_allclose(
        cam.project(pts[:, [1, 0, 2]]), np.stack([np.full(5, 80.0), 60 + 44 * th], 1), atol=1e-12
    )
    np.testing.assert_allclose(
        cam.unproject(np.stack([80 + 40 * th, np.full(5, 60.0)], 1)), pts, atol=1e-12
    )
    assert cam.max_off_axis == pytest.approx(float(MAX_OFF_AXIS))
    u = np.arange(21, 140, dtype=float)  # the rays on z = 1 along the middle row: tan θ
    np.testing.assert_allclose(cam.rays()[60, 21:140, 0], np.tan((u - 80) / 40), rtol=1e-12)
    assert not cam.rays().flags.writeable and not Camera(W, H, K).rays().flags.writeable
    assert not cam.directions().flags.writeable


# -- the omnidirectional (Mei) lens
# -----------------------------------------------------------------
@pytest.mark.parametrize(
    "xi, k",
    [
        (0.8, [0.02, -0.01, 0.001, -0.002]),
        (1.6, [-0.05, 0.01, -0.002, 0.001]),
        (1.0, [0.0, 0.0, 0.0, 0.0]),
        (1.0, [0.1, 0.0, 0.0, 0.0]),
    ],
)
def test_omni_projects_as_cv2_omnidir_and_unprojects_back(xi, k):
    Ko = np.array([[50.0 * (1 + xi), 0.4, 80.3], [0, 52.0 * (1 + xi), 58.6], [0, 0, 1]])
    cam = Camera(W, H, Ko, [xi, *k], model="omni")
    th, ph = np.meshgrid(np.radians(np.linspace(0, 85, 10)), np.linspace(0, 2 * np.pi, 11))
    pts = (
        np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
        * 1.7
    )
    ref = cv2.omnidir.projectPoints(
        pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), Ko, xi, np.array(k)
    )[0].reshape(-1, 2)
    ours = cam.project(pts)
    ok = np.isfinite(ours).all(1)
    assert ok.all()
    np.testing.assert_allclose(ours, ref, atol=1e-9)
    np.testing.assert_allclose(cam.unproject(ref), pts / 1.7, atol=1e-8)
    uv = image_pixels()
    d = cam.unproject(uv)
    good = np.isfinite(d).all(1)
    assert good.sum() > 20  # (the corners lie past 89.9°)
    back = cv2.omnidir.projectPoints(
        d[good].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), Ko, xi, np.array(k)
    )[0]
    np.testing.assert_allclose(back.reshape(-1, 2), uv[good], atol=1e-7)
    theta = np.degrees(np.arccos(d[good, 2]))
    assert theta.max() > 60


def test_omni_fold_is_where_the_sphere_meets_the_radial_fold():
    """ξ = 1 (stereographic): r = tan(θ/2); with k1 = -0.5 the radial map folds at
    r = sqrt(2/3), so the lens images up to θ = 2 atan(sqrt(2/3)) (78.5°); ξ = 0.5 with no
    radial term folds nowhere short of 90°."""
    cam = Camera(W, H, K, [1.0, -0.5, 0, 0, 0], model="omni")
    t_fold = 2 * np.arctan(np.sqrt(2 / 3))
    assert cam.max_off_axis == pytest.approx(t_fold, abs=1e-4)
    pts = np.array(
        [
            [np.sin(t_fold - 0.02), 0, np.cos(t_fold - 0.02)],
            [0, np.sin(t_fold + 0.02), np.cos(t_fold + 0.02)],
        ]
    )
    p = cam.project(pts)
    assert np.isfinite(p[0]).all() and np.isnan(p[1]).all()
    assert Camera(W, H, K, [0.5, 0, 0, 0, 0], model="omni").max_off_axis == pytest.approx(
        float(MAX_OFF_AXIS)
    )
    r = 0.99 * np.sqrt(2 / 3) * (1 - 0.5 * 2 / 3)  # just inside the fold's distorted radius
    d = cam.unproject(np.array([[80.3 + 150.0 * r, 58.6]]))
    assert np.isfinite(d).all()
    np.testing.assert_allclose(
        cv2.omnidir.projectPoints(
            d.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, 1.0, np.array([-0.5, 0, 0, 0])
        )[0].reshape(2),
        [80.3 + 150.0 * r, 58.6],
        atol=1e-7,
    )


def test_omni_rays_past_90_degrees_have_no_pixel_ray():
    """ξ = 0.5 images the sphere out to 120° (cos θ = -ξ), but depth is z: pixels whose lifted
    ray lies past 89.9° (along x or along y) get no ray, those just inside do; ξ = 1.6 folds at
    r = 1/sqrt(ξ² - 1), beyond which the sphere has no point (NaN), and a lens given ξ alone is
    the same as one with zero radial-tangential terms."""
    Ko = np.array([[30.0, 0, 80], [0, 30.0, 60], [0, 0, 1]])
    cam = Camera(W, H, Ko, [0.5, 0, 0, 0, 0], model="omni")
    alone = Camera(W, H, Ko, [0.5], model="omni")
    for th, finite in ((89.85, True), (89.95, False), (100.0, False), (115.0, False)):
        r = np.sin(np.radians(th)) / (np.cos(np.radians(th)) + 0.5)
        uv = np.array([[80 + 30 * r, 60.0], [80.0, 60 - 30 * r]])
        for c in (cam, alone):
            d = c.unproject(uv)
            assert np.isfinite(d).all() == finite and np.isfinite(d).any() == finite, (th, c.dist)
            if finite:
                np.testing.assert_allclose(np.degrees(np.arccos(d[:, 2])), th, atol=1e-9)
    np.testing.assert_allclose(alone.directions(), cam.directions(), atol=1e-15, equal_nan=True)
    fold = Camera(W, H, Ko, [1.6, 0, 0, 0, 0], model="omni")
    r_max = 1 / np.sqrt(1.6**2 - 1)
    assert np.isnan(fold.unproject(np.array([[80 + 30 * 1.05 * r_max, 60.0]]))).all()


# -- the pinhole views behind a lens (distortion.py)
# -------------------------------------------------
@pytest.mark.parametrize(
    "dist, oversample",
    [
        ([0.12, -0.05, 0.002, -0.003, 0.01], 1.0),
        ([-0.25, 0.06, 0.001, 0.002, 0], 2.0),
        ([0.4, 0, 0, 0], 1.5),
    ],
)
def test_the_wide_view_holds_every_ray_one_pixel_inside_its_border(dist, oversample):
    """The single wide pinhole view behind a lens: focal lengths the sensor's times the
    oversampling (fy from fy, fx from fx), principal point on the sensor's scaled pixel grid,
    each pixel's sample where cv2.undistortPoints puts its ray, the extreme rays between 1 and 2
    pixels inside the near border and between 3 and 4 inside the far one."""
    sensor = Camera(W, H, K, dist, near_m=0.3, far_m=9.0)
    (m,) = lens_views(sensor, oversample=oversample)
    r = m.render_sensor
    np.testing.assert_array_equal(m.rotation, np.eye(3))
    np.testing.assert_allclose([r.fx, r.fy], [150.0 * oversample, 163.0 * oversample], rtol=1e-15)
    for c, c0 in ((r.cx, 80.3), (r.cy, 58.6)):
        frac = (c - oversample * c0) % 1
        assert min(frac, 1 - frac) < 1e-9
    np.testing.assert_array_equal(r.K, [[r.fx, 0, r.cx], [0, r.fy, r.cy], [0, 0, 1]])  # no skew
    assert (r.near_m, r.far_m) == (0.3, 9.0) and r.is_pinhole and m.z_scale is None
    assert m.map_x.dtype == np.float32 and m.map_y.dtype == np.float32
    assert m.valid.all()
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    und = cv2.undistortPoints(
        np.stack([u, v], -1).reshape(-1, 1, 2), K, np.array(dist), None, None, None, CRIT
    ).reshape(H, W, 2)
    np.testing.assert_allclose(m.ray_x, und[..., 0], atol=1e-7)
    np.testing.assert_allclose(m.ray_y, und[..., 1], atol=1e-7)
    mx, my = r.fx * und[..., 0] + r.cx, r.fy * und[..., 1] + r.cy
    np.testing.assert_allclose(m.map_x, mx, atol=2e-3)
    np.testing.assert_allclose(m.map_y, my, atol=2e-3)
    assert 1 <= mx.min() < 2 and 1 <= my.min() < 2
    # the view's own pinhole projection of each ray lands on the pixel's sample
    uv = r.project(np.stack([und[..., 0], und[..., 1], np.ones((H, W))], -1))
    np.testing.assert_allclose(uv[:, 0], m.map_x.ravel(), atol=2e-3)
    np.testing.assert_allclose(uv[:, 1], m.map_y.ravel(), atol=2e-3)
    assert r.width - 4 < mx.max() <= r.width - 3 and r.height - 4 < my.max() <= r.height - 3


def test_a_folding_lens_serves_only_pixels_with_a_ray():
    sensor = Camera(W, H, np.array([[70.0, 0, 80], [0, 70.0, 60], [0, 0, 1]]), [-0.5, 0, 0, 0])
    (m,) = lens_views(sensor, oversample=1.0)
    np.testing.assert_array_equal(m.valid, np.isfinite(sensor.directions()).all(-1))
    assert 0 < m.valid.sum() < W * H
    assert (m.map_x[~m.valid] == -1).all() and (m.map_y[~m.valid] == -1).all()
    assert (m.ray_x[~m.valid] == 0).all() and (m.ray_y[~m.valid] == 0).all()
    assert m.map_x[m.valid].min() >= 1 and m.map_y[m.valid].min() >= 1


@pytest.mark.parametrize("cx, faces", [(79.5, 5), (5.0, 4)])
def test_a_fisheye_past_150_degrees_renders_cube_faces_that_hold_its_rays(cx, faces):
    """A 180° fisheye: a front view and four side faces (three when its principal point sits at
    the image's left edge: nothing looks along -x); each served pixel's ray, turned by its face's
    rotation, is the lens's ray (cv2.fisheye projects it back onto the pixel), lies 1 pixel or
    more inside its face, and z_scale converts the face's depth to the camera's."""
    f = 47.0
    sensor = Camera(
        W,
        H,
        np.array([[f, 0, cx], [0, f, 59.5], [0, 0, 1]]),
        [0.0] * 4,
        model="fisheye",
        near_m=0.2,
        far_m=5.0,
    )
    views = lens_views(sensor, oversample=1.0)
    assert len(views) == faces
    served = np.zeros((H, W), int)
    for m in views:
        served += m.valid
        r = m.render_sensor
        assert r.fx == r.fy == f and r.is_pinhole
        front = not np.any(m.rotation - np.eye(3))
        assert (r.near_m, r.far_m) == ((0.2, 5.0) if front else (sensor.clip_near_m, 5000.0))
        v, u = np.nonzero(m.valid)
        ray = np.stack([m.ray_x[v, u], m.ray_y[v, u], np.ones(len(u))], 1) @ m.rotation.T
        back = cv2.fisheye.projectPoints(
            ray.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), sensor.K, np.zeros(4)
        )[0]
        np.testing.assert_allclose(back.reshape(-1, 2), np.stack([u, v], 1), atol=1e-6)
        np.testing.assert_allclose(m.z_scale[v, u], ray[:, 2], rtol=1e-12)  # view z = 1 on each ray
        assert (m.z_scale[~m.valid] == 0).all()
        assert m.map_x[v, u].min() >= 1 and m.map_y[v, u].min() >= 1
        assert m.map_x[v, u].max() <= r.width - 3 and m.map_y[v, u].max() <= r.height - 3
        np.testing.assert_allclose(m.map_x[v, u], f * m.ray_x[v, u] + r.cx, atol=2e-3)
        assert (np.abs(m.ray_x[v, u]) <= 1 + 1e-9).all() and (
            np.abs(m.ray_y[v, u]) <= 1 + 1e-9
        ).all()
    np.testing.assert_array_equal(
        served, np.isfinite(sensor.directions()).all(-1)
    )  # each pixel once


def test_the_fewest_view_pixels_per_lens_pixel_is_the_smallest_singular_value():
    u, v = np.meshgrid(np.arange(12.0), np.arange(9.0))
    for J in ([[2.0, 0.5], [0.0, 3.0]], [[0.6, -0.2], [0.3, 0.9]], [[1.0, 0.0], [0.0, 0.4]]):
        mx, my = J[0][0] * u + J[0][1] * v + 3, J[1][0] * u + J[1][1] * v - 1
        want = np.linalg.svd(np.array(J), compute_uv=False).min()
        assert _scale_min(mx, my, np.ones(u.shape, bool)) == pytest.approx(want, rel=1e-9)
    grow = (u / 20) ** 2 * 10 + u  # steps of 1 + (2u + 1) / 40: the least is 1.025
    assert _scale_min(grow, 5.0 * v, np.ones(u.shape, bool)) == pytest.approx(1.025, rel=1e-9)
    serve = u >= 5  # only where the three pixels are served
    assert _scale_min(np.where(serve, 2 * u, -1.0), 3.0 * v, serve) == pytest.approx(2.0)
    assert _scale_min(mx, my, np.zeros(u.shape, bool)) == 1.0
    assert _scale_min(mx[:1], my[:1], np.ones((1, 12), bool)) == 1.0  # one row: no d/dv
    assert _scale_min(mx[:, :1], my[:, :1], np.ones((9, 1), bool)) == 1.0  # one column: no d/du
    J = np.array([[0.6, -0.2], [0.3, 0.9]])  # two rows, two columns
    smin = np.linalg.svd(J, compute_uv=False).min()
    mx, my = J[0, 0] * u + J[0, 1] * v, J[1, 0] * u + J[1, 1] * v
    assert _scale_min(mx[:2], my[:2], np.ones((2, 12), bool)) == pytest.approx(smin, rel=1e-9)
    assert _scale_min(mx[:, :2], my[:, :2], np.ones((9, 2), bool)) == pytest.approx(smin, rel=1e-9)
    rows = v >= 4  # served rows only: the squeezed top rows do not count
    squeeze = np.where(rows, 2 * u, 0.1 * u)
    assert _scale_min(squeeze, 3.0 * v, rows) == pytest.approx(2.0)
    cols = u <= 6  # served columns only
    assert _scale_min(np.where(cols, 2 * u, 0.1 * u), 3.0 * v, cols) == pytest.approx(2.0)


@pytest.mark.parametrize(
    "dist, want",
    [([0.2, 0, 0, 0], 2), ([0.5, 0, 0, 0], 3), ([0.9, 0.3, 0, 0], 4), ([-0.2, 0, 0, 0], 1)],
)
def test_automatic_oversampling_is_the_smallest_whole_factor_giving_0_8_view_pixels(dist, want):
    """Pincushion spreads the lens's pixels apart in the view: the automatic factor is the
    smallest whole one giving at least 0.8 view pixels per lens pixel (up to 4); barrel needs 1.
    distortion_maps() keeps the sensor's focal unless told otherwise."""
    sensor = Camera(W, H, np.array([[60.0, 0, 80], [0, 64.0, 60], [0, 0, 1]]), dist)
    (auto,) = lens_views(sensor)
    factor = auto.render_sensor.fx / 60.0
    assert factor == want and auto.render_sensor.fy == 64.0 * factor
    assert auto.scale_min >= 0.8
    if factor > 1:
        (less,) = lens_views(sensor, oversample=factor - 1)
        assert less.scale_min < 0.8
    assert distortion_maps(sensor).render_sensor.fx == 60.0
    assert distortion_maps(sensor, oversample=2.0).render_sensor.fy == 128.0
    (one,) = lens_views(sensor, oversample=1.0)
    assert auto.scale_min == pytest.approx(
        factor * one.scale_min, rel=1e-4
    )  # the maps scale with the focal


def test_one_view_up_to_75_degrees_and_4096_pixels_else_cube_faces():
    """One pinhole view holds a lens whose rays stay within 75° of the axis on each image axis
    and whose view needs at most 4096 pixels; otherwise cube faces. Two-row images keep it cheap:
    f = 1000 and 4000 columns (63.4°) fit one 4008-pixel view, 4098 columns (64.0°) do not; a
    fisheye wide along x only (86°) and narrow along y needs faces; a 3000 px telephoto fits."""

    def views(w, h, K, dist, model="pinhole"):
        return lens_views(Camera(w, h, np.array(K, float), dist, model=model), oversample=1.0)

    (one,) = views(4000, 2, [[1000, 0, 1999.5], [0, 1000, 0.5], [0, 0, 1]], [1e-4, 0, 0, 0])
    assert 4000 < one.render_sensor.width <= 4096
    many = views(4098, 2, [[1000, 0, 2048.5], [0, 1000, 0.5], [0, 0, 1]], [1e-4, 0, 0, 0])
    assert len(many) == 3 and all(m.render_sensor.width <= 2010 for m in many)
    tall = views(2, 4098, [[1000, 0, 0.5], [0, 1000, 2048.5], [0, 0, 1]], [1e-4, 0, 0, 0])
    assert len(tall) == 3 and all(m.render_sensor.height <= 2010 for m in tall)
    wide_x = views(64, 2, [[21.0, 0, 31.5], [0, 21.0, 0.5], [0, 0, 1]], [], model="fisheye")
    wide_y = views(2, 64, [[21.0, 0, 0.5], [0, 21.0, 31.5], [0, 0, 1]], [], model="fisheye")
    assert len(wide_x) == len(wide_y) == 3
    # telephotos (a 3000 px focal, the second folding at 36 px from the centre): one front view
    for dist in ([0.1, 0, 0, 0], [-1000.0, 0, 0, 0]):
        (tele,) = views(64, 48, [[3000, 0, 31.5], [0, 3000, 23.5], [0, 0, 1]], dist)
        assert (
            tele.z_scale is None
            and tele.render_sensor.width < 100
            and tele.render_sensor.height < 80
        )
    assert not tele.valid.all() and tele.valid[24, 32]
    # a lens with no ray at any pixel (its centre far off the image, past its fold): an empty view
    (empty,) = views(16, 12, [[50.0, 0, 1000], [0, 50.0, 6], [0, 0, 1]], [-0.5, 0, 0, 0])
    assert (
        not empty.valid.any() and empty.render_sensor.width <= 4 and empty.render_sensor.height <= 4
    )


def test_cube_faces_render_everything_and_the_range_is_applied_after():
    """A side face's depth is not the camera's: it renders from the GL near plane to 1000x the
    sensor's range (at least 1 m), and the range is applied after resampling."""
    Kf = np.array([[20.0, 0, 31.5], [0, 20.0, 23.5], [0, 0, 1]])
    for far, want in ((5.0, 5000.0), (0.0015, 1.5)):
        views = lens_views(
            Camera(64, 48, Kf, [], model="fisheye", near_m=1e-4, far_m=far), oversample=1.0
        )
        sides = [m for m in views if np.any(m.rotation - np.eye(3))]
        assert len(sides) == 4 and all(m.render_sensor.far_m == want for m in sides)
        assert all(m.render_sensor.near_m == 1e-4 / 1024 for m in sides)


def test_view_size_limit_is_inclusive_at_4096_pixels():
    """A view of exactly MAX_VIEW_PX = 4096 columns is made; one more column is refused by
    name. With focal 1 and rays on z = 1 from x = 0 to x = X, the view's principal point
    lands 1 px inside (cx = 1) and its width is ceil(X + cx) + 3: X = 4092 gives 4096."""
    from genie_gl.lens.distortion import MAX_VIEW_PX, _view

    cam = Camera(
        2, 1, np.array([[1.0, 0, 0.5], [0, 1.0, 0], [0, 0, 1]]), [], near_m=0.1, far_m=10.0
    )
    serve = np.ones((1, 2), bool)
    ok = _view(
        cam,
        np.eye(3),
        "t",
        serve,
        np.array([[0.0, 4092.0]]),
        np.zeros((1, 2)),
        1.0,
        1.0,
        0.0,
        0.0,
        None,
    )
    assert MAX_VIEW_PX == 4096
    assert (ok.render_sensor.width, ok.render_sensor.height) == (4096, 4)
    assert ok.render_sensor.cx == 1.0 and ok.map_x.tolist() == [[1.0, 4093.0]]
    with pytest.raises(ConfigError, match="4097x4 pinhole view"):
        _view(
            cam,
            np.eye(3),
            "t",
            serve,
            np.array([[0.0, 4093.0]]),
            np.zeros((1, 2)),
            1.0,
            1.0,
            0.0,
            0.0,
            None,
        )


def test_one_front_view_while_twice_the_widest_ray_plus_8_fits_4096_pixels():
    """An ideal-ish pinhole (k1 = 1e-12) 4000 px wide with f = 1000 and its principal point at
    u = 2043.8: the widest ray is 2043.8 px from the axis, and 2 x 2043.8 + 8 = 4095.6 <= 4096,
    so one front view holds it (4003 px wide: 1 px of margin on the left, 3 on the right); at
    u = 2044.3 (4096.6) the lens needs cube faces; exactly 4096 still fits."""

    def views(cx):
        K = np.array([[1000.0, 0, cx], [0, 1000.0, 0.5], [0, 0, 1]])
        return lens_views(
            Camera(4000, 2, K, [1e-12, 0, 0, 0], near_m=0.1, far_m=10.0), oversample=1.0
        )

    (one,) = views(2043.8)
    assert one.z_scale is None and one.render_sensor.width == 4003
    assert one.render_sensor.cx == pytest.approx(2044.8, abs=1e-9)
    assert len(views(2044.3)) > 1
    # the bound itself: f = 1024 and the principal point at u = 2044 put the widest ray at
    # exactly 2044 px (binary fractions), and 2 x 2044 + 8 = 4096 still takes one view
    K = np.array([[1024.0, 0, 2044.0], [0, 1024.0, 0.5], [0, 0, 1]])
    (edge,) = lens_views(Camera(4000, 2, K, [0.0, 0, 0, 0], near_m=0.1, far_m=10.0), oversample=1.0)
    assert edge.z_scale is None and edge.render_sensor.width == 4003
