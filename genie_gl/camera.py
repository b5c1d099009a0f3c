"""The camera model at the bottom of the package: image size, K, lens and clip range.

Frames, the renderer, unprojection, placement and the sensor effects all read the camera from
here; the lens maps are written once, in this module, in numpy (the tests hold them against
``cv2.projectPoints`` and ``cv2.fisheye.projectPoints``).

Conventions (DESIGN.md): OpenCV camera frame (x right, y down, z forward); pixel (u, v) has its
centre at integer coordinates; K = [[fx, s, cx], [0, fy, cy], [0, 0, 1]] (s, the skew, enters
as u = fx x' + s y' + cx, OpenCV's fisheye ``alpha`` = s / fx).

Lens models
-----------
``"pinhole"``: OpenCV's ``projectPoints`` model with 0, 4, 5, 8, 12 or 14 coefficients
    (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [τx τy]]]]): radial-tangential (ROS ``plumb_bob``,
    Kalibr ``radtan``), rational (ROS ``rational_polynomial``), thin prism and tilted.
``"fisheye"``: OpenCV's ``cv2.fisheye`` (Kannala-Brandt) model with 4 coefficients
    (k1 k2 k3 k4): θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸), ROS ``equidistant``, Kalibr
    ``equidistant``.
``"omni"``: the unified (Mei) omnidirectional model of ``cv2.omnidir`` and Kalibr ``omni``,
    5 coefficients (ξ k1 k2 p1 p2): the point on the unit sphere projected from (0, 0, -ξ),
    then radial-tangential distortion.

A lens folds back past some angle (strong barrel distortion, an over-fitted polynomial): rays
beyond the fold are not imaged and pixels beyond it have no ray (NaN), never a wrapped one.
Depth is z along the optical axis, so a pixel whose ray is 90° or more off the axis has no
ray either (a 180° fisheye keeps every ray short of its rim).

The clip range is a property of the sensor: ``near_m`` is its minimum range (anything nearer
gives no return, depth 0 and ids 0, never what lies behind it) and ``far_m`` its maximum;
the renderer clips at ``clip_near_m``, far below the minimum range, and masks the rest.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any

import numpy as np

from .validation.arguments import whole_number
from .errors import ConfigError

PINHOLE_LENGTHS = (0, 4, 5, 8, 12, 14)
MODELS: dict[str, tuple[int, ...]] = {"pinhole": PINHOLE_LENGTHS, "fisheye": (0, 4), "omni": (1, 5)}
NEAR_CLIP_RATIO = 1.0 / 1024  # the GL near plane, as a share of the sensor's minimum range
MAX_OFF_AXIS = np.radians(89.9)  # rays beyond this are not represented (depth is z)
MAX_SIDE_OVER_F = 1e5  # a side over 1e5 focal lengths spans 179.999 degrees through a pinhole


def tilt_matrix(tau_x: float, tau_y: float) -> np.ndarray:
    """(3, 3) float64: OpenCV's tilted-sensor projection (``computeTiltProjectionMatrix``).
    Lower triangular: T[0, 1] = T[0, 2] = T[1, 2] = 0 (to rounding), as is its inverse."""
    cx, sx, cy, sy = np.cos(tau_x), np.sin(tau_x), np.cos(tau_y), np.sin(tau_y)
    rot_x = np.array([[1, 0, 0], [0, cx, sx], [0, -sx, cx]])
    rot_y = np.array([[cy, 0, -sy], [0, 1, 0], [sy, 0, cy]])
    rot = rot_y @ rot_x
    proj_z = np.array([[rot[2, 2], 0, -rot[0, 2]], [0, rot[2, 2], -rot[1, 2]], [0, 0, 1]])
    return proj_z @ rot


def _coefficients(dist: np.ndarray) -> np.ndarray:
    """The 14 coefficients of OpenCV's pinhole lens (k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 τx τy),
    zeros after the given ones."""
    return np.pad(np.asarray(dist, np.float64), (0, 14 - len(dist)))


def _radial(r2: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The rational radial factor (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)."""
    k1, k2, _, _, k3, k4, k5, k6, *_ = k
    return (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))


def _decentring(
    x: np.ndarray, y: np.ndarray, r2: np.ndarray, k: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The tangential and thin-prism shifts (p1, p2, s1..s4) of the point (x, y), r² = x² + y²."""
    _, _, p1, p2, _, _, _, _, s1, s2, s3, s4, _, _ = k
    r4 = r2 * r2
    return (
        2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r4,
        p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r4,
    )


def distort_normalized(
    x: np.ndarray, y: np.ndarray, dist: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """OpenCV's pinhole lens on normalised points (x, y) = (X/Z, Y/Z): the distorted (x', y')."""
    k = _coefficients(dist)
    r2 = x * x + y * y
    radial = _radial(r2, k)
    dx, dy = _decentring(x, y, r2, k)
    xd, yd = x * radial + dx, y * radial + dy
    tx, ty = k[12:]
    if tx or ty:
        xd, yd = _homography(tilt_matrix(tx, ty), xd, yd)
    return xd, yd


def _homography(T: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) through a lower-triangular homography T (the sensor tilt or its inverse)."""
    w = T[2, 0] * x + T[2, 1] * y + T[2, 2]
    return T[0, 0] * x / w, (T[1, 0] * x + T[1, 1] * y) / w


def fisheye_theta_d(theta: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Kannala-Brandt: θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)."""
    k1, k2, k3, k4 = np.pad(k, (0, 4 - len(k)))
    t2 = theta * theta
    return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))


def _find_fold(model: str, dist: bytes) -> float:
    """The off-axis limit of the lens: the radius r = tan θ (pinhole model) or the angle θ
    (fisheye) where its radial map stops increasing; past it rays are not imaged."""
    d = np.frombuffer(dist)
    if model == "omni":  # the angle where the sphere's projection reaches the radtan fold
        r_fold = _fold("pinhole", np.ascontiguousarray(d[1:]).tobytes())
        t = np.linspace(0, MAX_OFF_AXIS, 200001)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.sin(t) / (np.cos(t) + d[0])
        # (where cos t + ξ reaches 0, r leaps to ±inf: the diff or r_fold flags it)
        bad = np.flatnonzero((np.diff(r) <= 0) | (r[1:] >= r_fold))
        return float(t[bad[0]]) if len(bad) else float(MAX_OFF_AXIS)
    if model == "fisheye":
        t = np.linspace(0, np.pi, 200001)
        f = fisheye_theta_d(t, d)
        lim = np.pi
    elif model == "pinhole":
        # r up to tan(89°) finely, then on to the 1e6 the inverse searches (a rational lens's
        # pole can lie past 89°: beyond it r·radial drops, and a search there finds no root)
        t = np.concatenate([np.linspace(0, 60.0, 600001), np.geomspace(60.0, 1e6, 20001)[1:]])
        f = t * _radial(t * t, _coefficients(d))
        lim = np.inf
    else:
        raise ValueError(f"no lens model {model!r}: expected one of {sorted(MODELS)}")
    bad = np.flatnonzero((np.diff(f) <= 0) | ~np.isfinite(f[1:]))
    return float(t[bad[0]]) if len(bad) else lim


# cached here rather than decorated, so that mutation testing (mutmut leaves decorated
# functions alone) reaches the body
_fold = lru_cache(maxsize=64)(_find_fold)


@dataclass(frozen=True, eq=False)
class Camera:
    """A camera: image size, OpenCV K, lens model and coefficients, clip range.

    Attributes
    ----------
    width, height : int, image size in pixels.
    K : (3, 3) float64, ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist : (N,) float64, lens coefficients (see the module docstring; empty = ideal pinhole).
    near_m : float, minimum range: nearer surfaces give no return (depth 0, ids 0).
    far_m : float, maximum range: farther surfaces give no return.
    model : str, ``"pinhole"`` (OpenCV) or ``"fisheye"`` (cv2.fisheye, Kannala-Brandt).
    """

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(0))
    near_m: float = 0.05
    far_m: float = 1.0e4
    model: str = field(default="pinhole", kw_only=True)

    def __post_init__(self) -> None:
        who = f"sensor {getattr(self, 'name', 'camera')}"
        K = np.array(self.K, dtype=np.float64)
        if K.shape != (3, 3) or not np.all(np.isfinite(K)):
            raise ConfigError(f"{who}: K must be a finite 3x3 matrix, got shape {K.shape}")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ConfigError(f"{who}: fx and fy must be > 0 (fx={K[0, 0]}, fy={K[1, 1]})")
        if not np.allclose(K[2], [0, 0, 1]) or K[1, 0] != 0:
            raise ConfigError(f"{who}: K's last row must be [0, 0, 1] and K[1,0] = 0")
        for side in ("width", "height"):
            whole_number(getattr(self, side), f"{who}: {side}", 1, 1_000_000)
        for f, side in ((K[0, 0], self.width), (K[1, 1], self.height)):
            if side / f > MAX_SIDE_OVER_F:  # a pinhole image that wide spans 180 degrees (and more)
                raise ConfigError(
                    f"{who}: focal length {f:g} px for a {int(side)} px side: a field of view no "
                    "lens "
                    f"renders; expected fx, fy >= {side / MAX_SIDE_OVER_F:g} px (a real lens has "
                    "about "
                    "the image width)"
                )
        if self.model not in MODELS:
            raise ConfigError(
                f"{who}: unknown lens model {self.model!r}; known: {', '.join(MODELS)}"
            )
        d = np.asarray(self.dist, dtype=np.float64).ravel()
        if len(d) not in MODELS[self.model] or not np.all(np.isfinite(d)):
            n = ", ".join(str(n) for n in MODELS[self.model] if n)
            raise ConfigError(
                f"{who}: the {self.model} lens distortion needs {n} finite coefficients, "
                f"got {len(d)}"
            )
        if not (0 < self.near_m < self.far_m and np.isfinite(self.far_m)):
            raise ConfigError(f"{who}: need 0 < near_m < far_m, got {self.near_m}, {self.far_m}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", d)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))
        object.__setattr__(self, "near_m", float(self.near_m))
        object.__setattr__(self, "far_m", float(self.far_m))

    # -- intrinsics -------------------------------------------------------------------------
    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return (self.width, self.height)

    @property
    def is_pinhole(self) -> bool:
        """True when the lens has no distortion (one pinhole render is the image)."""
        return self.model == "pinhole" and not np.any(self.dist)

    @property
    def clip_near_m(self) -> float:
        """The renderer's near clipping plane: far below the minimum range, so that a surface
        nearer than ``near_m`` is drawn (and masked to no return) instead of clipped away."""
        return self.near_m * NEAR_CLIP_RATIO

    @property
    def lens_key(self) -> tuple:
        """A hashable key of the camera model (what the lens maps depend on)."""
        return (self.model, self.width, self.height, self.K.tobytes(), self.dist.tobytes())

    def ideal(self, **changes: Any) -> "Camera":
        """The same K and size without a lens (an ideal pinhole camera)."""
        return replace(self, dist=np.zeros(0), model="pinhole", **changes)

    @property
    def max_off_axis(self) -> float:
        """The largest angle (radians) from the optical axis that the lens images."""
        return _max_off_axis(self.model, self.dist)

    # -- the lens, forward ------------------------------------------------------------------
    def project(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) float64 pixels of camera-frame ``points`` (N, 3); NaN for a point the lens
        does not image (behind the camera, or beyond the lens's fold)."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            theta = np.arctan2(np.hypot(x, y), z)
            ok = theta < self.max_off_axis + 1e-12
            if self.model == "omni":  # onto the unit sphere, seen from (0, 0, -ξ)
                norm = np.sqrt(x * x + y * y + z * z)
                den = z / norm + self.dist[0]
                ok &= den > 0
                xd, yd = x / norm / den, y / norm / den
                if np.any(self.dist[1:]):
                    xd, yd = distort_normalized(xd, yd, self.dist[1:])
            elif self.model == "fisheye":  # the image direction of the point, scaled to θ_d
                r = np.hypot(x, y)
                s = fisheye_theta_d(theta, self.dist) / np.where(r > 0, r, 1)  # θ_d = 0 on the axis
                xd, yd = x * s, y * s
            else:
                ok &= z > 0
                xd, yd = (
                    distort_normalized(x / z, y / z, self.dist)
                    if len(self.dist)
                    else (x / z, y / z)
                )
            K = self.K  # (a point at z = 0 gives inf here, masked just below)
            uv = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], 1)
        uv[~ok] = np.nan
        return uv

    # -- the lens, inverse ------------------------------------------------------------------
    def unproject(self, uv: np.ndarray) -> np.ndarray:
        """(N, 3) float64 unit camera-frame directions of pixels ``uv`` (N, 2); NaN where the
        lens has no ray (past its fold, or 90° or more off the axis)."""
        uv = np.asarray(uv, np.float64).reshape(-1, 2)
        uv = np.where(np.isfinite(uv), uv, np.nan)  # an infinite pixel has no ray: NaN, quietly
        K = self.K
        yd = (uv[:, 1] - K[1, 2]) / K[1, 1]
        xd = (uv[:, 0] - K[0, 2] - K[0, 1] * yd) / K[0, 0]
        if self.model == "fisheye":
            d = _fisheye_inverse(xd, yd, self.dist, self.max_off_axis)
        elif self.model == "omni":
            d = _omni_inverse(xd, yd, self.dist, self.max_off_axis)
        else:
            x, y = _pinhole_inverse(xd, yd, self.dist, np.tan(self.max_off_axis))
            d = np.stack([x, y, np.ones_like(x)], 1)
            d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d

    def directions(self) -> np.ndarray:
        """(H, W, 3) float64 unit ray of every pixel (NaN where none); cached, read-only."""
        return _directions(self.lens_key)

    def rays(self) -> np.ndarray:
        """(H, W, 2) float64: x and y of every pixel's ray on the plane z = 1 (NaN where the
        pixel has none); the undistorted rays of a lens. Cached, read-only."""
        return _rays(self.lens_key)


def _max_off_axis(model: str, dist: np.ndarray) -> float:
    fold = _fold(model, dist.tobytes())
    lim = fold if model in ("fisheye", "omni") else np.arctan(fold)
    return float(min(lim, MAX_OFF_AXIS))


def _pinhole_inverse(
    xd: np.ndarray, yd: np.ndarray, dist: np.ndarray, r_max: float
) -> tuple[np.ndarray, np.ndarray]:
    """Solve distort_normalized(x, y) = (xd, yd); NaN where no root lies inside the fold.

    The start undoes the lens step by step: the sensor's tilt exactly (a homography), then,
    twice, the decentring shift at the current estimate and the radial factor by bisection on
    [0, r_max], where r·radial(r²) increases (r_max is the radial fold; 1e6 for a lens that
    never folds, ~89.99994° off the axis). Damped Newton steps
    on the whole lens finish it. (A start from the distorted point itself, refined by cv2's
    fixed-point steps, can land past a strong lens's fold or pole and converge to the root
    outside it: ~1 % of strong random lenses' points inside the fold had no ray.)"""
    if not np.any(dist):
        return xd.copy(), yd.copy()
    k = _coefficients(dist)
    xs, ys = _untilt(xd, yd, k)
    x, y = np.zeros_like(xs), np.zeros_like(ys)
    for _ in range(2):
        dx, dy = _decentring(x, y, x * x + y * y, k)
        ux, uy = xs - dx, ys - dy
        rd = np.hypot(ux, uy)
        r = _increasing_inverse(lambda t: t * _radial(t * t, k), rd, min(r_max, 1e6))
        s = r / np.where(rd > 0, rd, 1)  # (rd = 0: ux = uy = 0)
        x, y = ux * s, uy * s
    x, y, ok = _newton(x, y, xd, yd, dist, r_max)
    return np.where(ok, x, np.nan), np.where(ok, y, np.nan)


def _untilt(xd: np.ndarray, yd: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distorted point before the sensor's tilt (τx, τy = k[12:]): the tilt's homography
    inverted."""
    if not (k[12] or k[13]):
        return xd, yd
    return _homography(np.linalg.inv(tilt_matrix(k[12], k[13])), xd, yd)


def _increasing_inverse(f, target: np.ndarray, top: float) -> np.ndarray:
    """t in [0, top] with f(t) = target, for f increasing there, by 60 halvings (top / 2⁶⁰:
    double precision); top where the target lies past f(top)."""
    lo, hi = np.zeros_like(target), np.full_like(target, top)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        above = f(mid) > target
        lo, hi = np.where(above, lo, mid), np.where(above, mid, hi)
    return 0.5 * (lo + hi)


def _newton(
    x: np.ndarray, y: np.ndarray, xd: np.ndarray, yd: np.ndarray, dist: np.ndarray, r_max: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Damped Newton steps (numerical Jacobian) from (x, y) towards distort_normalized = (xd, yd);
    (x, y, ok) with ok where the root reproduces the pixel inside the fold."""
    h = 1e-7
    with np.errstate(all="ignore"):
        for _ in range(12):
            fx, fy = distort_normalized(x, y, dist)
            ex, ey = fx - xd, fy - yd
            ax, ay = distort_normalized(x + h, y, dist)
            bx, by = distort_normalized(x - h, y, dist)
            cx, cy = distort_normalized(x, y + h, dist)
            dx, dy = distort_normalized(x, y - h, dist)
            j11, j21 = (ax - bx) / (2 * h), (ay - by) / (2 * h)
            j12, j22 = (cx - dx) / (2 * h), (cy - dy) / (2 * h)
            det = j11 * j22 - j12 * j21
            sx = (j22 * ex - j12 * ey) / det
            sy = (-j21 * ex + j11 * ey) / det
            step = np.hypot(sx, sy)
            cap = np.maximum(0.25 * np.hypot(x, y), 0.05)  # damped: never jump across the fold
            s = np.where(step > cap, cap / step, 1.0)
            x, y = x - s * sx, y - s * sy
        fx, fy = distort_normalized(x, y, dist)
        res = np.hypot(fx - xd, fy - yd)
        ok = (
            (res < 1e-9 * (1 + np.hypot(xd, yd)))
            & (np.hypot(x, y) < r_max)
            & np.isfinite(x)
            & np.isfinite(y)
        )
    return x, y, ok


def _fisheye_inverse(
    xd: np.ndarray, yd: np.ndarray, dist: np.ndarray, theta_max: float
) -> np.ndarray:
    """Unit directions of the Kannala-Brandt lens: θ from θ_d by bisection on [0, θ_max]
    (the map is increasing there); 60 halvings leave θ_max / 2⁶⁰ < 3e-18 rad, double precision
    (a Newton step after them moves θ by ~1e-16 at most)."""
    td = np.hypot(xd, yd)
    inside = td <= fisheye_theta_d(
        np.array(theta_max + 1e-12), dist
    )  # project's tolerance at the rim
    theta = _increasing_inverse(lambda t: fisheye_theta_d(t, dist), td, theta_max)
    c = np.sin(theta) / np.where(td > 0, td, 1)  # the centre pixel (td = 0): xd = yd = 0, the axis
    d = np.stack([xd * c, yd * c, np.cos(theta)], 1)
    d[~inside] = np.nan
    return d


def _omni_inverse(xd: np.ndarray, yd: np.ndarray, dist: np.ndarray, theta_max: float) -> np.ndarray:
    """Unit directions of the unified model: undistort the radial-tangential part, then lift
    the point back onto the unit sphere."""
    xi = dist[0]
    rad = dist[1:]
    r_fold = _fold("pinhole", np.ascontiguousarray(rad).tobytes())
    x, y = _pinhole_inverse(xd, yd, rad, r_fold)
    r2 = x * x + y * y
    with np.errstate(invalid="ignore"):
        disc = 1 + (1 - xi * xi) * r2
        f = (xi + np.sqrt(disc)) / (r2 + 1)
    d = np.stack([f * x, f * y, f - xi], 1)
    bad = ~(disc >= 0) | ~(np.arctan2(np.hypot(d[:, 0], d[:, 1]), d[:, 2]) < theta_max + 1e-12)
    d[bad] = np.nan
    return d


def _pixel_directions(key: tuple) -> np.ndarray:
    model, w, h, K, dist = key
    cam = Camera(w, h, np.frombuffer(K).reshape(3, 3), np.frombuffer(dist), model=model)
    u, v = np.meshgrid(np.arange(w), np.arange(h))  # whole pixel numbers, exact in any dtype
    d = cam.unproject(np.stack([u.ravel(), v.ravel()], 1)).reshape(h, w, 3)
    d.setflags(write=False)
    return d


def _pixel_rays(key: tuple) -> np.ndarray:
    model, w, h, K, dist = key
    if model == "pinhole" and not np.any(np.frombuffer(dist)):
        Km = np.frombuffer(K).reshape(3, 3)
        u, v = np.meshgrid(np.arange(w), np.arange(h))  # whole pixel numbers, exact in any dtype
        y = (v - Km[1, 2]) / Km[1, 1]
        xy = np.stack([(u - Km[0, 2] - Km[0, 1] * y) / Km[0, 0], y], -1)
    else:
        d = _directions(key)  # z > 0 wherever there is a ray (at most 89.9° off the axis)
        xy = d[..., :2] / d[..., 2:]
    xy.setflags(write=False)
    return xy


_directions = lru_cache(maxsize=32)(_pixel_directions)
_rays = lru_cache(maxsize=32)(_pixel_rays)
