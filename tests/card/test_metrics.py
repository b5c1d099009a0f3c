"""The card's metrics against independent truths: synthetic walls with known Gaussian noise
(recovered within the sampling error computed here), hand-made masks, hand-counted flying
pixels, a known tilted plane, a hand-made disparity staircase. Pure numpy: no GL."""

import numpy as np
import pytest
from scipy import stats

from genie_gl.card import metrics

W, H, F = 640, 480, 500.0
K = np.array([[F, 0, (W - 1) / 2], [0, F, (H - 1) / 2], [0, 0, 1]])
RAYS = metrics.pinhole_rays(K, W, H)
ROI = metrics.central_roi(W, H)
# dropping 0.5 % at each end of a Gaussian keeps |x| <= a, a = Phi^-1(0.995): the RMS left is
# sqrt(var of the normal truncated to [-a, a]) times sigma
TRIM_A = stats.norm.ppf(1 - 0.005)
TRIM_RMS = float(np.sqrt(stats.truncnorm.var(-TRIM_A, TRIM_A)))


def roi_count():
    return (ROI[0].stop - ROI[0].start) * (ROI[1].stop - ROI[1].start)


def test_central_roi_is_the_depth_quality_tools_box():
    # DQT: {int(W (0.5 - 0.5 p)), int(H (0.5 - 0.5 p)), int(W (0.5 + 0.5 p)), int(H (0.5 + 0.5 p))},
    # p = 0.4
    rows, cols = metrics.central_roi(848, 480)
    assert (cols.start, cols.stop, rows.start, rows.stop) == (
        254,
        593,
        144,
        336,
    )  # 254.4, 593.6, 144, 336
    # in float32, as the tool computes: 0.5 - 0.5 * 0.8 = 0.099999994, 640 x that = 63.999996 -> 63
    rows, cols = metrics.central_roi(640, 576, 0.8)
    assert (cols.start, cols.stop, rows.start, rows.stop) == (63, 576, 57, 518)
    with pytest.raises(ValueError):
        metrics.central_roi(640, 480, 0.0)


def test_fit_plane_recovers_a_known_tilted_plane_on_every_regression_axis():
    rng = np.random.default_rng(1)
    for n_true in ([0.3, -0.1, 1.0], [1.0, 0.2, 0.35], [0.1, 1.0, -0.4]):  # dominant z, x, y
        n_true = np.array(n_true) / np.linalg.norm(n_true)
        n_true = n_true if n_true[2] >= 0 else -n_true
        a = np.cross(n_true, [0.0, 0.0, 1.0] if abs(n_true[2]) < 0.9 else [1.0, 0.0, 0.0])
        a /= np.linalg.norm(a)
        b = np.cross(n_true, a)
        p0 = np.array([0.2, -0.1, 2.0])
        pts = p0 + rng.uniform(-1, 1, (500, 1)) * a + rng.uniform(-1, 1, (500, 1)) * b
        plane = metrics.fit_plane(pts)
        np.testing.assert_allclose(plane.normal, n_true, atol=1e-12)
        np.testing.assert_allclose(plane.d, -n_true @ p0, atol=1e-12)
        np.testing.assert_allclose(plane.distance(pts), 0.0, atol=1e-12)
    with pytest.raises(ValueError):
        metrics.fit_plane(np.array([[0, 0, 1.0], [1, 1, 2.0], [2, 2, 3.0]]))  # collinear


def test_plane_depth_along_rays_is_the_ray_plane_intersection():
    plane = metrics.Plane(
        np.array([np.sin(0.5), 0.0, np.cos(0.5)]), -2.0 * np.cos(0.5)
    )  # through (0, 0, 2)
    z = plane.depth_along(RAYS)
    pts = np.dstack([RAYS * z[..., None], z])
    np.testing.assert_allclose(pts.reshape(-1, 3) @ plane.normal + plane.d, 0.0, atol=1e-12)
    assert plane.depth_along(np.zeros(2)) == pytest.approx(2.0, abs=1e-15)  # the optical axis
    assert plane.angle_deg == pytest.approx(np.degrees(0.5))


def test_plane_stats_recover_known_gaussian_noise_and_bias():
    rng = np.random.default_rng(7)
    z0, sigma, bias = 1.5, 0.003, 0.004
    depth = (z0 + bias + sigma * rng.standard_normal((H, W))).astype(np.float64)
    s = metrics.plane_stats(depth, RAYS, roi=ROI, ground_truth_m=z0)
    n = roi_count()
    assert s.fill_rate_pct == 100.0 and s.n_points == n - 2 * (n // 200)
    # RMS of a trimmed Gaussian: sigma * TRIM_RMS; its sampling error ~ sigma / sqrt(2 n)
    se = sigma * TRIM_RMS / np.sqrt(2 * s.n_points)
    assert abs(s.plane_fit_rms_mm / 1000 - sigma * TRIM_RMS) < 5 * se
    # Z accuracy: the bias as % of the truth; the median's sampling error ~ 1.2533 sigma / sqrt(n)
    se_med = 1.2533 * sigma / np.sqrt(n)
    assert abs(s.z_accuracy_pct - 100 * bias / z0) < 100 * 5 * se_med / z0 + 1e-9
    assert s.distance_mm == pytest.approx(1000 * (z0 + bias), abs=0.05)
    assert s.subpixel_rms_px is None


def test_subpixel_rms_recovers_disparity_noise():
    """Noise drawn in disparity (d = B f / Z + N(0, s)): the sub-pixel RMS is s, trimmed."""
    rng = np.random.default_rng(3)
    b, z0, s = 0.05, 1.2, 0.08
    d = b * F / z0 + s * rng.standard_normal((H, W))
    st = metrics.plane_stats(b * F / d, RAYS, roi=ROI, baseline_m=b, focal_px=F)
    se = s * TRIM_RMS / np.sqrt(2 * st.n_points)
    # the plane fit and 1/Z's curvature add O(s^2 z / (B f)) ~ 1e-4 relative: inside 6 se
    assert abs(st.subpixel_rms_px - s * TRIM_RMS) < 6 * se


def test_z_accuracy_sign_positive_beyond_the_truth():
    depth = np.full((H, W), 2.02)
    assert metrics.plane_stats(
        depth, RAYS, roi=ROI, ground_truth_m=2.0
    ).z_accuracy_pct == pytest.approx(1.0)
    assert metrics.plane_stats(
        depth, RAYS, roi=ROI, ground_truth_m=2.04
    ).z_accuracy_pct == pytest.approx(-100 * 0.02 / 2.04)


def test_plane_stats_refuses_an_empty_roi():
    with pytest.raises(ValueError, match="valid pixels"):
        metrics.plane_stats(np.zeros((H, W)), RAYS, roi=ROI)


def test_fill_rate_on_a_hand_made_mask():
    depth = np.ones((10, 10))
    depth[0, :] = 0  # 10 holes in row 0
    depth[5, 5] = np.nan  # one NaN
    depth[9, 9] = -1.0  # one negative
    assert metrics.fill_rate(depth) == pytest.approx(88.0)
    roi = (slice(0, 2), slice(0, 5))  # 10 pixels, 5 of them holes
    assert metrics.fill_rate(depth, roi) == pytest.approx(50.0)
    mask = np.zeros((10, 10), bool)
    mask[4:7, 4:7] = True  # 9 pixels, one NaN
    assert metrics.fill_rate(depth, mask=mask) == pytest.approx(800 / 9)
    assert np.isnan(metrics.fill_rate(depth, mask=np.zeros((10, 10), bool)))


def test_temporal_stats_recover_known_noise_and_bias():
    rng = np.random.default_rng(11)
    n, shape, z0, sigma, bias = 12, (100, 120), 2.0, 0.004, -0.003
    stack = z0 + bias + sigma * rng.standard_normal((n, *shape))
    stack[3, 0, :10] = 0.0  # ten pixels lose one frame: left out
    t = metrics.temporal_stats(stack, truth_m=z0)
    p = shape[0] * shape[1] - 10
    assert (t.n_pixels, t.n_frames) == (p, n)
    # mean of unbiased per-pixel variances: relative sampling error sqrt(2 / (n - 1) / p); sqrt
    # halves it
    rel_se = np.sqrt(2 / (n - 1) / p) / 2
    assert abs(t.noise_rms_mm / 1000 / sigma - 1) < 5 * rel_se
    # the median per-pixel std: the median of sigma * chi_{n-1} / sqrt(n - 1)
    med = sigma * np.sqrt(stats.chi2.median(n - 1) / (n - 1))
    assert abs(t.noise_median_mm / 1000 - med) < 0.01 * sigma
    # bias: median over pixels of a mean of n draws; sampling error 1.2533 sigma / sqrt(n p)
    assert abs(t.bias_mm / 1000 - bias) < 5 * 1.2533 * sigma / np.sqrt(n * p)
    assert t.bias_rms_mm / 1000 == pytest.approx(np.sqrt(bias**2 + sigma**2 / n), rel=0.02)
    with pytest.raises(ValueError):
        metrics.temporal_stats(np.zeros((3, 4, 4)))


def test_flying_pixels_counted_by_hand():
    near, far, tol = 1.0, 1.5, 0.01
    depth = np.array(
        [
            [1.000, 1.000, 1.005, 1.200, 1.500, 1.500],  # 1.200 flies
            [1.000, 1.000, 1.300, 0.000, 1.495, 1.500],  # 1.300 flies; 0 is no return
            [
                1.000,
                1.000,
                1.011,
                1.489,
                1.500,
                1.500,
            ],  # 1.011 and 1.489 fly (just past the tolerance)
            [1.000, 1.000, 1.000, 1.500, 1.700, 1.500],  # 1.700 flies (beyond the far surface)
        ]
    )
    band = np.zeros(depth.shape, bool)
    band[:, 2:5] = True  # 12 pixels, one without return
    count, valid = metrics.flying_pixels(depth, near, far, band, tol)
    assert (count, valid) == (5, 11)
    # per-surface tolerances: 0.03 around the far surface forgives 1.489 (and no other)
    assert metrics.flying_pixels(depth, near, far, band, tol, 0.03) == (4, 11)
    # per-pixel surfaces: a far surface at 1.2 on row 0 makes 1.200 land on it
    far_map = np.full(depth.shape, far)
    far_map[0, 3] = 1.2
    assert metrics.flying_pixels(depth, near, far_map, band, tol) == (4, 11)


def test_edge_positions_and_lateral_noise_by_hand():
    rows, cols = np.arange(3), slice(2, 10)
    frames = []
    for shift in ([0, 0, 0], [1, 0, -1], [2, 0, 0]):
        z = np.full((3, 12), 2.0)
        for r, s in enumerate(shift):
            z[r, : 5 + s] = 1.0  # near surface up to column 5 + s
        frames.append(z)
    frames[1][0, 3] = 0.0  # a hole left of the edge: one near pixel fewer
    pos = np.stack([metrics.edge_positions(z, rows, cols, 1.5) for z in frames])
    np.testing.assert_array_equal(pos, [[5, 5, 5], [5, 5, 4], [7, 5, 5]])
    # per-row std over frames (ddof 1): row 0 [5, 5, 7] -> var 4/3; row 1 0; row 2 [5, 4, 5] -> 1/3
    assert metrics.lateral_noise_px(pos) == pytest.approx(np.sqrt((4 / 3 + 0 + 1 / 3) / 3))
    empty = np.zeros((3, 12))
    assert np.isnan(metrics.edge_positions(empty, rows, cols, 1.5)).all()


def test_disparity_banding_of_a_hand_made_staircase():
    # disparities on quarter-pixel steps: 4 levels out of 64 bins, each level 1/4 of the pixels
    d = 20.0 + np.arange(4000) % 40 / 4.0
    b = metrics.disparity_banding(d, bins=64)
    assert b.occupied == 4 and b.peak_ratio == pytest.approx(16.0)
    assert set(np.flatnonzero(b.counts)) == {0, 16, 32, 48}
    # through float32 depth and back (Z = B f / d): the levels stay in their bins
    bf = 0.05 * 426.2
    z = (bf / d).astype(np.float32)
    assert metrics.disparity_banding(bf / z.astype(np.float64), bins=64).occupied == 4
    # 1/32 px steps fill 32 of 64 bins; evenly spread disparities fill all 64 nearly evenly
    assert metrics.disparity_banding(30 + np.arange(3200) / 32.0, bins=64).occupied == 32
    even = metrics.disparity_banding(np.random.default_rng(0).uniform(10, 40, 200000), bins=64)
    mean = 200000 / 64  # Poisson counts: the fullest within 5 sd of the mean
    assert even.occupied == 64 and even.peak_ratio < 1 + 5 / np.sqrt(mean)
