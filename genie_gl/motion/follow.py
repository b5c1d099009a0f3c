"""How a body follows a route: speed, turning rate, acceleration; the route made a trajectory.

:func:`follow` turns a route (a polyline on the free floor, :mod:`.paths`) into a
:class:`~.trajectory.Trajectory` a person or a robot could take:

1. straighten it: from each kept point, go straight to the farthest later point the line of
   sight reaches over free floor;
2. round each corner with an arc of radius ``speed / max_yaw_rate`` (or less where the legs
   are short or the arc would leave the free floor; the speed drops on a tighter arc so the
   turning rate holds); a corner no arc fits is turned on the spot;
3. limit the speed by the arcs and by ``max_accel`` (from rest at the start, to rest at the
   end), and integrate the time, no step faster in yaw than ``max_yaw_rate``;
4. with ``turn_ease_s``, ease the turns: the body's yaw is the path's averaged over that
   long a window of time around each moment, so a turn's rate builds up and dies away over
   ``turn_ease_s`` (the angular acceleration at most ``2 max_yaw_rate / turn_ease_s``)
   instead of starting at full rate where a straight leg meets an arc.

The body is level, facing where it goes (its x axis along the path; with eased turns, where
it goes averaged over the window), its origin ``height_m`` above the floor.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import ConfigError, did_you_mean
from .floor import FreeFloor
from .trajectory import Trajectory, planar_poses

MIN_ARC_M = 0.05  # tighter than this, a corner is turned on the spot
PIVOT_DEG = 150.0  # a corner turning more than this is turned on the spot (a U-turn)


@dataclass(frozen=True)
class Motion:
    """How the body moves: cruising speed (m/s), height of the body's origin above the floor
    (m), the fastest turn (rad/s), the largest acceleration (m/s²), its radius (m, the
    clearance kept from every asset), the spacing of the samples along the path (m), and the
    time over which a turn's rate builds up and dies away (s; 0: at once, where a straight
    leg meets an arc)."""

    speed_mps: float = 1.0
    height_m: float = 1.7
    max_yaw_rate_rad_s: float = float(np.radians(60.0))
    max_accel_mps2: float = 0.5
    body_radius_m: float = 0.35
    sample_m: float = 0.05
    turn_ease_s: float = 0.0

    def __post_init__(self) -> None:
        for name, v in asdict(self).items():
            zero = name == "turn_ease_s"  # 0: turns at once; every other figure > 0
            if not (isinstance(v, (int, float)) and np.isfinite(v) and (v >= 0 if zero else v > 0)):
                raise ConfigError(
                    f"motion: {name} must be a number {'>= 0' if zero else '> 0'}, got {v!r}"
                )


# [U: engineering figures] a person carrying a mobile scanner walks about 1 m/s and turns
# slowly so the scan stays registered; a warehouse robot drives about 0.8 m/s, turns 45°/s
MOTIONS: dict[str, Motion] = {
    "person": Motion(),
    "robot": Motion(
        speed_mps=0.8,
        height_m=1.2,
        max_yaw_rate_rad_s=float(np.radians(45.0)),
        max_accel_mps2=0.5,
        body_radius_m=0.45,
    ),
}


def motion_of(spec: "str | Motion") -> Motion:
    """A :class:`Motion`, or the preset of that name (``person``, ``robot``)."""
    if isinstance(spec, Motion):
        return spec
    try:
        return MOTIONS[spec]
    except (KeyError, TypeError):
        raise ConfigError(
            f"motion {spec!r}: unknown{did_you_mean(str(spec), MOTIONS)}; expected one of "
            f"{', '.join(MOTIONS)}"
        ) from None


def straighten(floor: FreeFloor, legs: list[np.ndarray]) -> np.ndarray:
    """(m, 2) corners of a route: each leg's points kept where the line of sight breaks (a
    step to the next point is always kept: the route's own steps lie on free cells), and
    the ends of every leg (a leg may turn back where the last one ended)."""
    parts = [_straighten_leg(floor, np.asarray(leg, np.float64)) for leg in legs if len(leg)]
    out = np.concatenate([p if k == 0 else p[1:] for k, p in enumerate(parts)])
    step = np.linalg.norm(np.diff(out, axis=0), axis=1)
    return out[np.r_[True, step > 1e-9]]


def _straighten_leg(floor: FreeFloor, route: np.ndarray) -> np.ndarray:
    keep = [0]
    i, n = 0, len(route)
    while i < n - 1:
        j = i + 1
        while j + 1 < n and floor.segment_free(route[i], route[j + 1]):
            j += 1
        keep.append(j)
        i = j
    return route[keep]


def _arc_fits(floor: FreeFloor, corner, d_in, d_out, r, turn, tangent) -> np.ndarray | None:
    """(k, 3) arc samples (x, y, yaw) of a fillet of radius ``r``, or None when any leaves the
    free floor."""
    a = corner - tangent * d_in
    side = np.sign(turn)
    normal = side * np.array([-d_in[1], d_in[0]])  # towards the arc's centre
    centre = a + r * normal
    yaw_in = np.arctan2(d_in[1], d_in[0])
    n = max(3, int(np.ceil(abs(turn) * r / (0.25 * floor.resolution_m))) + 1)
    yaw = yaw_in + np.linspace(0.0, turn, n)
    pts = centre - side * r * np.stack([-np.sin(yaw), np.cos(yaw)], 1)
    if not floor.is_free(pts).all():
        return None
    return np.column_stack([pts, yaw])


def eased(times: np.ndarray, yaw: np.ndarray, window_s: float) -> np.ndarray:
    """(n,) ``yaw`` at ``times`` ((n,) increasing), each averaged over the ``window_s`` around
    its time: the exact mean of the piecewise linear yaw, held at its first and last value
    beyond the ends."""
    t, y = np.asarray(times, np.float64), np.asarray(yaw, np.float64)
    if len(t) < 2:
        return y.copy()
    dt = np.diff(t)
    # the integral of the yaw from t[0] at each sample
    area = np.r_[0.0, np.cumsum(0.5 * (y[1:] + y[:-1]) * dt)]

    def integral(q: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(t, q, side="right") - 1, 0, len(t) - 2)
        u = np.clip(q, t[0], t[-1]) - t[i]
        slope = (y[i + 1] - y[i]) / dt[i]
        inner = area[i] + y[i] * u + 0.5 * slope * u * u
        return inner + y[0] * np.minimum(q - t[0], 0.0) + y[-1] * np.maximum(q - t[-1], 0.0)

    h = 0.5 * window_s
    return (integral(t + h) - integral(t - h)) / window_s


def follow(
    floor: FreeFloor, legs: list[np.ndarray], motion: Motion, *, meta: dict | None = None
) -> Trajectory:
    """The trajectory of a body with ``motion`` along a route's ``legs`` ((k, 2) each) on
    ``floor``."""
    corners = straighten(floor, legs)
    if len(corners) < 2:
        raise ConfigError(
            "trajectory: the route has no length (one free point); use a longer route or a "
            "larger free floor"
        )
    d = np.diff(corners, axis=0)
    seg = np.linalg.norm(d, axis=1)
    d = d / seg[:, None]
    r_max = motion.speed_mps / motion.max_yaw_rate_rad_s
    # per inner corner: (arc samples or None for a turn on the spot, tangent length)
    # per corner: "end", "straight", "arc" (with its samples and tangent length) or "pivot"
    fillets: list[tuple[str, np.ndarray | None, float]] = [("end", None, 0.0)]
    for k in range(1, len(corners) - 1):
        turn = float(np.arctan2(d[k - 1, 0] * d[k, 1] - d[k - 1, 1] * d[k, 0], d[k - 1] @ d[k]))
        if abs(turn) <= 1e-9:
            fillets.append(("straight", None, 0.0))
            continue
        arc, t = None, 0.0
        if abs(turn) < np.radians(PIVOT_DEG):
            half = np.tan(abs(turn) / 2)
            r = min(r_max, 0.5 * min(seg[k - 1], seg[k]) / half)
            while r >= MIN_ARC_M and arc is None:
                arc = _arc_fits(floor, corners[k], d[k - 1], d[k], r, turn, r * half)
                t = r * half
                r *= 0.5
        fillets.append(("arc", arc, t) if arc is not None else ("pivot", None, 0.0))
    fillets.append(("end", None, 0.0))
    # samples: (x, y, yaw, speed limit)
    xs: list[np.ndarray] = []
    step = motion.sample_m
    for k in range(len(corners) - 1):
        yaw = np.arctan2(d[k, 1], d[k, 0])
        kind, arc, t_in = fillets[k]
        if kind == "arc":
            r = t_in / np.tan(abs(arc[-1, 2] - arc[0, 2]) / 2)
            xs.append(
                np.column_stack(
                    [arc, np.full(len(arc), min(motion.speed_mps, motion.max_yaw_rate_rad_s * r))]
                )
            )
        elif kind == "pivot":  # a turn on the spot: at rest, facing the new way
            xs.append(np.array([[*corners[k], yaw, 0.0]]))
        a = corners[k] + t_in * d[k]
        b = corners[k + 1] - fillets[k + 1][2] * d[k]
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
        s = np.linspace(0.0, 1.0, n)[:, None]
        line = a * (1 - s) + b * s
        v = np.full(n, motion.speed_mps)
        if fillets[k + 1][0] in (
            "pivot",
            "end",
        ):  # at rest before turning on the spot, and at the end
            v[-1] = 0.0
        xs.append(np.column_stack([line, np.full(n, yaw), v]))
    S = np.concatenate(xs)
    S[:, 2] = np.unwrap(S[:, 2])
    # where a piece ends and the next begins the samples agree but for rounding: one is kept
    # (a turn on the spot keeps both, at exactly one place)
    keep = np.ones(len(S), bool)
    for i in range(1, len(S)):
        j = i - 1 if keep[i - 1] else np.flatnonzero(keep[:i])[-1]
        if np.hypot(*(S[i, :2] - S[j, :2])) < 1e-6:
            if abs(S[i, 2] - S[j, 2]) < 1e-6:
                keep[i] = False
                S[j, 3] = min(S[j, 3], S[i, 3])
            else:
                S[i, :2] = S[j, :2]
    S = S[keep]
    S[0, 3] = S[-1, 3] = 0.0
    xy, yaw, v = S[:, :2], S[:, 2], S[:, 3].copy()
    ds = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    a2 = 2.0 * motion.max_accel_mps2
    for i in range(1, len(v)):  # accelerate no faster than max_accel
        v[i] = min(v[i], np.sqrt(v[i - 1] ** 2 + a2 * ds[i - 1]))
    for i in range(len(v) - 2, -1, -1):  # and brake no harder
        v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + a2 * ds[i]))
    mean_v = 0.5 * (v[1:] + v[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(ds > 0, ds / mean_v, 0.0)
    dt = np.maximum(dt, np.abs(np.diff(yaw)) / motion.max_yaw_rate_rad_s)
    if not np.all(np.isfinite(dt)):
        raise ConfigError(
            "trajectory: a step of the route could not be timed (a zero speed while moving)"
        )
    times = np.r_[0.0, np.cumsum(dt)]
    keep = np.r_[True, dt > 0]
    yaw = yaw[keep]
    if motion.turn_ease_s > 0:
        yaw = eased(times[keep], yaw, motion.turn_ease_s)
    info = {
        "speed_mps": motion.speed_mps,
        "height_m": motion.height_m,
        "max_yaw_rate_rad_s": motion.max_yaw_rate_rad_s,
        "max_accel_mps2": motion.max_accel_mps2,
        "body_radius_m": motion.body_radius_m,
        **({"turn_ease_s": motion.turn_ease_s} if motion.turn_ease_s > 0 else {}),
        "length_m": float(ds.sum()),
        "corners": len(corners),
    }
    return Trajectory(
        times[keep], planar_poses(xy[keep], yaw, motion.height_m), {**(meta or {}), **info}
    )
