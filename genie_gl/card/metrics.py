"""The depth-quality metrics of the field, computed from depth images (pure numpy, no GL).

Single-frame metrics follow Intel's depth quality tool (librealsense ``tools/depth-quality``:
``rs-depth-quality.cpp``, ``depth-metrics.h``, ``depth-quality-model.cpp``), the reference
implementation of Intel's "Camera Depth Testing Methodology":

* the region of interest (ROI) is the central box ``[W(1/2 - p/2), W(1/2 + p/2))`` by
  ``[H(1/2 - p/2), H(1/2 + p/2))`` (integer-truncated), ``p`` = 0.4 by default;
* **fill rate**: valid (non-zero) pixels over all ROI pixels, in %;
* the **plane** is fitted to the ROI's points by the tool's method (the "plane from points"
  regression on the axis whose determinant is largest, :func:`fit_plane`);
* before the other metrics the 0.5 % nearest and 0.5 % farthest points (by z) are dropped
  (``n // 200`` each side);
* **plane-fit RMS** (spatial noise): RMS of the signed point-to-plane distances, in mm;
* **sub-pixel RMS**: RMS of ``B·f/Z_i - B·f/ZP_i``, in px, where ``ZP_i`` is the depth of the
  point's orthogonal projection onto the plane (the documented formula, in depth; the tool's
  code divides by the point's range instead, which differs off the axis);
* **Z accuracy**: the plane's depth on the optical axis minus the ground truth (GT), plus each
  point's signed distance to the plane, median over points, as % of GT (signed: positive =
  the measurement lies beyond the GT). The documented "Transposed Z - GT"; the tool's code
  subtracts the distance instead of adding it, which gives the same median for noise
  symmetric about the plane.

Multi-frame metrics follow the Azure Kinect definitions (Microsoft, "Azure Kinect DK depth
camera", Camera performance): the **random error** of a pixel is the standard deviation of its
depth over the frames of a static scene; the **systematic error** is its temporal mean minus
the ground truth depth. :func:`temporal_stats` summarises both over the pixels valid in
every frame.

Edge and stereo metrics (no single standard; defined here and tested on hand-made images):
:func:`flying_pixels` (a valid pixel near a depth edge that lies on neither surface),
:func:`edge_positions` and :func:`lateral_noise_px` (the position of a vertical step edge per
row, and its spread over frames), and
:func:`disparity_banding` (the histogram of the sub-pixel part of disparity on a tilted plane).

Units: depth images in metres (0 = no return), results in the units their names carry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ROI_FRACTION = 0.4  # the depth quality tool's default ROI (40 % of width and of height)
TRIM_DIVISOR = 200  # n // 200 points dropped at each end (0.5 %)


def central_roi(width: int, height: int, fraction: float = ROI_FRACTION) -> tuple[slice, slice]:
    """(rows, cols) slices of the central ROI covering ``fraction`` of the width and of the
    height, truncated to whole pixels as the depth quality tool does."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"central_roi: fraction must be in (0, 1], got {fraction}")
    f = np.float32(fraction)
    lo, hi = np.float32(0.5) - np.float32(0.5) * f, np.float32(0.5) + np.float32(0.5) * f
    return (
        slice(int(np.float32(height) * lo), int(np.float32(height) * hi)),
        slice(int(np.float32(width) * lo), int(np.float32(width) * hi)),
    )


def pinhole_rays(K: np.ndarray, width: int, height: int) -> np.ndarray:
    """(H, W, 2) float64: x and y on the plane z = 1 of every pixel's ray through a pinhole
    camera with intrinsics ``K`` (pixel centres at integer coordinates)."""
    K = np.asarray(K, np.float64)
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    y = (v - K[1, 2]) / K[1, 1]
    return np.stack([(u - K[0, 2] - K[0, 1] * y) / K[0, 0], y], -1)


def points(depth: np.ndarray, rays_xy: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(N, 3) float64 camera-frame points of the pixels in ``mask`` (row-major order):
    ``depth · (x, y, 1)`` with (x, y) from ``rays_xy`` (H, W, 2)."""
    z = np.asarray(depth, np.float64)[mask]
    xy = np.asarray(rays_xy, np.float64)[mask]
    return np.column_stack([xy[:, 0] * z, xy[:, 1] * z, z])


@dataclass(frozen=True)
class Plane:
    """The plane ``normal · p + d = 0`` (camera frame, metres); ``normal`` (3,) is a unit
    vector with ``normal[2] >= 0``, so points beyond the plane (seen from the camera) lie at a
    positive distance. (The depth quality tool leaves the sign to its regression axis, which
    gives the same orientation while the plane faces the camera within 45°.)"""

    normal: np.ndarray
    d: float

    def distance(self, pts: np.ndarray) -> np.ndarray:
        """(N,) signed distances in metres of points (N, 3) from the plane."""
        return np.asarray(pts, np.float64) @ self.normal + self.d

    def depth_along(self, rays_xy: np.ndarray) -> np.ndarray:
        """Depth z (m) at which each ray (..., 2) (x, y on z = 1) meets the plane; NaN where
        the ray runs parallel to it or meets it behind the camera."""
        r = np.asarray(rays_xy, np.float64)
        den = r[..., 0] * self.normal[0] + r[..., 1] * self.normal[1] + self.normal[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = -self.d / den
        return np.where(np.isfinite(z) & (z > 0), z, np.nan)

    @property
    def angle_deg(self) -> float:
        """Angle between the plane's normal and the optical axis, in degrees (the tool's
        "angle": 0 = the wall faces the camera squarely)."""
        return float(np.degrees(np.arccos(min(1.0, abs(float(self.normal[2]))))))


def fit_plane(pts: np.ndarray) -> Plane:
    """The depth quality tool's plane fit of points (N, 3), N >= 3: the centroid, then a
    linear regression of two coordinates against the third, on the axis whose 2x2 covariance
    determinant is largest (the exact least-squares plane for that choice of dependent axis).

    Raises ValueError when there are fewer than 3 points or they span no plane.
    """
    p = np.asarray(pts, np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) < 3:
        raise ValueError(f"fit_plane: need at least 3 points (N, 3), got shape {p.shape}")
    c = p.mean(axis=0)
    q = p - c
    xx, xy, xz = q[:, 0] @ q[:, 0], q[:, 0] @ q[:, 1], q[:, 0] @ q[:, 2]
    yy, yz, zz = q[:, 1] @ q[:, 1], q[:, 1] @ q[:, 2], q[:, 2] @ q[:, 2]
    det_x, det_y, det_z = yy * zz - yz * yz, xx * zz - xz * xz, xx * yy - xy * xy
    det_max = max(det_x, det_y, det_z)
    if not det_max > 0:
        raise ValueError("fit_plane: the points span no plane (collinear or coincident)")
    if det_max == det_x:
        n = np.array([1.0, (xz * yz - xy * zz) / det_x, (xy * yz - xz * yy) / det_x])
    elif det_max == det_y:
        n = np.array([(yz * xz - xy * zz) / det_y, 1.0, (xy * xz - yz * xx) / det_y])
    else:
        n = np.array([(yz * xy - xz * yy) / det_z, (xz * xy - yz * xx) / det_z, 1.0])
    n /= np.linalg.norm(n)
    if n[2] < 0:
        n = -n
    return Plane(n, float(-(n @ c)))


def fill_rate(
    depth: np.ndarray, roi: tuple[slice, slice] | None = None, mask: np.ndarray | None = None
) -> float:
    """Percentage of valid (non-zero, finite) pixels among those of ``roi`` (and ``mask``,
    a (H, W) bool array, when given); NaN when the region holds no pixel."""
    z = np.asarray(depth)
    region = np.ones(z.shape, bool) if mask is None else np.asarray(mask, bool).copy()
    if roi is not None:
        inside = np.zeros(z.shape, bool)
        inside[roi] = True
        region &= inside
    n = int(region.sum())
    if n == 0:
        return float("nan")
    valid = region & np.isfinite(z) & (z > 0)
    return 100.0 * int(valid.sum()) / n


@dataclass(frozen=True)
class PlaneStats:
    """The depth quality tool's metrics of one depth frame of a flat target.

    Attributes
    ----------
    fill_rate_pct : valid pixels in the ROI, %.
    n_points : points kept after the 0.5 % trimming at each end.
    plane : the plane fitted to all the ROI's points (before trimming, as the tool does).
    plane_fit_rms_mm : RMS point-to-plane distance, mm.
    subpixel_rms_px : RMS disparity error, px (None without a baseline and focal length).
    z_accuracy_pct : signed median depth error as % of the ground truth (None without one).
    distance_mm : the plane's depth on the optical axis, mm.
    """

    fill_rate_pct: float
    n_points: int
    plane: Plane
    plane_fit_rms_mm: float
    subpixel_rms_px: float | None
    z_accuracy_pct: float | None
    distance_mm: float


def plane_stats(
    depth: np.ndarray,
    rays_xy: np.ndarray,
    *,
    roi: tuple[slice, slice],
    ground_truth_m: float | None = None,
    baseline_m: float | None = None,
    focal_px: float | None = None,
    axis_xy: tuple[float, float] = (0.0, 0.0),
) -> PlaneStats:
    """The metrics of :class:`PlaneStats` for a depth image (H, W) in metres whose pixels'
    rays are ``rays_xy`` (H, W, 2); ``axis_xy`` is the optical axis's ray (the principal
    point's: (0, 0) for an untilted lens). Raises ValueError when the ROI holds fewer than
    3 valid pixels or they span no plane (an empty result is not a measurement)."""
    z = np.asarray(depth)
    inside = np.zeros(z.shape, bool)
    inside[roi] = True
    valid = inside & np.isfinite(z) & (z > 0)
    fill = fill_rate(z, roi)
    pts = points(z, rays_xy, valid)
    if len(pts) < 3:
        raise ValueError(f"plane_stats: {len(pts)} valid pixels in the ROI; a plane needs 3")
    plane = fit_plane(pts)
    order = np.argsort(pts[:, 2], kind="stable")
    cut = len(pts) // TRIM_DIVISOR
    kept = pts[order[cut : len(pts) - cut]]
    dist = plane.distance(kept)
    rms_mm = float(np.sqrt(np.mean(dist * dist))) * 1000.0
    pivot = float(plane.depth_along(np.asarray(axis_xy, np.float64)))
    sub = None
    if baseline_m is not None and focal_px is not None:
        bf = float(baseline_m) * float(focal_px)
        projected_z = kept[:, 2] - dist * plane.normal[2]
        disparity_error = bf / kept[:, 2] - bf / projected_z
        sub = float(np.sqrt(np.mean(disparity_error * disparity_error)))
    acc = None
    if ground_truth_m is not None:
        errors = (pivot - float(ground_truth_m)) + dist
        acc = 100.0 * float(np.median(errors)) / float(ground_truth_m)
    return PlaneStats(fill, len(kept), plane, rms_mm, sub, acc, pivot * 1000.0)


@dataclass(frozen=True)
class TemporalStats:
    """Random and systematic error over frames of a static scene (Azure Kinect definitions).

    Attributes
    ----------
    n_pixels : pixels valid in every frame (those the statistics cover).
    n_frames : frames.
    noise_rms_mm : sqrt of the mean over pixels of each pixel's unbiased temporal variance
        (the RMS random error), mm.
    noise_median_mm, noise_p95_mm : median and 95th percentile of the per-pixel temporal
        standard deviations (ddof = 1), mm.
    bias_mm : median over pixels of (temporal mean - ground truth), mm (None without truth).
    bias_rms_mm : RMS over pixels of (temporal mean - ground truth), mm (None without truth).
    """

    n_pixels: int
    n_frames: int
    noise_rms_mm: float
    noise_median_mm: float
    noise_p95_mm: float
    bias_mm: float | None
    bias_rms_mm: float | None


def temporal_stats(
    stack: np.ndarray, mask: np.ndarray | None = None, truth_m: np.ndarray | float | None = None
) -> TemporalStats:
    """:class:`TemporalStats` of depth frames ``stack`` (N, H, W) in metres, N >= 2, over the
    pixels in ``mask`` (H, W) valid in every frame; ``truth_m`` is the ground-truth depth per
    pixel (H, W) or one number. Raises ValueError when no pixel is valid in every frame."""
    s = np.asarray(stack, np.float64)
    if s.ndim != 3 or len(s) < 2:
        raise ValueError(f"temporal_stats: need (N, H, W) with N >= 2 frames, got shape {s.shape}")
    ok = np.all(np.isfinite(s) & (s > 0), axis=0)
    if mask is not None:
        ok &= np.asarray(mask, bool)
    n = int(ok.sum())
    if n == 0:
        raise ValueError("temporal_stats: no pixel holds a return in every frame")
    px = s[:, ok]
    var = px.var(axis=0, ddof=1)
    sd = np.sqrt(var)
    bias = bias_rms = None
    if truth_m is not None:
        t = np.broadcast_to(np.asarray(truth_m, np.float64), ok.shape)[ok]
        e = px.mean(axis=0) - t
        bias, bias_rms = float(np.median(e)) * 1000.0, float(np.sqrt(np.mean(e * e))) * 1000.0
    return TemporalStats(
        n,
        len(s),
        float(np.sqrt(var.mean())) * 1000.0,
        float(np.median(sd)) * 1000.0,
        float(np.percentile(sd, 95)) * 1000.0,
        bias,
        bias_rms,
    )


def flying_pixels(
    depth: np.ndarray,
    near_m: np.ndarray,
    far_m: np.ndarray,
    band: np.ndarray,
    tolerance_near_m: float,
    tolerance_far_m: float | None = None,
) -> tuple[int, int]:
    """Flying pixels at a depth edge: (count, valid) over the pixels of ``band`` (H, W bool,
    the pixels near the edge), where a valid pixel flies when its depth lies farther than
    ``tolerance_near_m`` from the near surface and farther than ``tolerance_far_m`` (default:
    the same) from the far one; ``near_m`` and ``far_m`` are each surface's depth along that
    pixel's ray, (H, W) or one number each."""
    z = np.asarray(depth, np.float64)
    b = np.asarray(band, bool)
    valid = b & np.isfinite(z) & (z > 0)
    near = np.broadcast_to(np.asarray(near_m, np.float64), z.shape)
    far = np.broadcast_to(np.asarray(far_m, np.float64), z.shape)
    tol_far = tolerance_near_m if tolerance_far_m is None else tolerance_far_m
    off = (np.abs(z - near) > tolerance_near_m) & (np.abs(z - far) > tol_far)
    return int((valid & off).sum()), int(valid.sum())


def edge_positions(depth: np.ndarray, rows: np.ndarray, cols: slice, split_m: float) -> np.ndarray:
    """Column position of a vertical step edge in each row of ``rows``: within the columns
    ``cols`` the near surface lies left of the edge, and a row's edge is placed after its
    count of valid pixels nearer than ``split_m`` (``cols.start`` + count; exact for a clean
    step). Rows without a valid pixel in ``cols`` give NaN. (R,) float64, px."""
    z = np.asarray(depth, np.float64)[np.asarray(rows)][:, cols]
    valid = np.isfinite(z) & (z > 0)
    near = (valid & (z < split_m)).sum(axis=1)
    pos = float(cols.start or 0) + near.astype(np.float64)
    return np.where(valid.any(axis=1), pos, np.nan)


def lateral_noise_px(positions: np.ndarray) -> float:
    """Lateral noise of an edge (Nguyen et al.'s and Fankhauser et al.'s quantity): the
    standard deviation over frames (ddof = 1) of each row's edge position, RMS over the rows
    measured in every frame. ``positions`` is (N frames, R rows) in px, NaN where a row had
    no edge; NaN when no row has one in at least two frames."""
    p = np.asarray(positions, np.float64)
    ok = np.isfinite(p).all(axis=0)
    if p.ndim != 2 or len(p) < 2 or not ok.any():
        return float("nan")
    return float(np.sqrt(p[:, ok].var(axis=0, ddof=1).mean()))


@dataclass(frozen=True)
class Banding:
    """The histogram of disparity's sub-pixel part.

    Attributes
    ----------
    counts : (bins,) int64, pixels per bin; bin k holds sub-pixel parts within half a bin of
        k / bins (bins centred on the levels, so quantised disparities land mid-bin).
    occupied : bins holding at least one pixel.
    peak_ratio : the fullest bin over the mean bin (1 = perfectly even).
    """

    counts: np.ndarray
    occupied: int
    peak_ratio: float


def disparity_banding(disparity_px: np.ndarray, bins: int = 64) -> Banding:
    """:class:`Banding` of the disparities (any shape, px; NaN and values <= 0 ignored).
    A stereo matcher whose sub-pixel step is 1/s px fills s bins (for ``bins`` a multiple of
    s); an even spread of disparities over a tilted plane fills them all evenly."""
    d = np.asarray(disparity_px, np.float64).ravel()
    d = d[np.isfinite(d) & (d > 0)]
    if d.size == 0:
        raise ValueError("disparity_banding: no valid disparity")
    k = np.floor((d - np.floor(d)) * bins + 0.5).astype(np.int64) % bins
    counts = np.bincount(k, minlength=bins)
    return Banding(counts, int((counts > 0).sum()), float(counts.max() / counts.mean()))
