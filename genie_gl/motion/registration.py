"""The registration error of a mobile scanner's map: a sensor effect on poses.

A mobile scanner registers its frames by SLAM: each frame lands in the map at an *estimated*
pose. The estimate drifts along the path (a random walk in position and heading whose spread
grows with the square root of the distance walked) and, where the path passes an area again,
the passes disagree by a little (loop closure leaves a residual per pass). The model here:

    world_from_camera_est = E(s) · world_from_camera,   E(s) = T(p) R(s) T(-p) · T(d(s) + o_k)

with s the distance walked at the shot, p the body's position, R(s) a rotation (roll, pitch,
yaw drift and the pass's residual turn) about the body, d(s) the drifted translation and o_k
the residual offset of pass k (passes are ``pass_length_m`` of path each). The whole error
path is drawn once per recording from one generator, so the frames of a pass move together,
as a real map's do. :meth:`RegistrationError.sigma_m` predicts the misplacement of a point
at a given range and distance, which the planner reports per frame.

Default figures [U: engineering estimates for a wearable SLAM scanner of the NavVis VLX
class, whose maker quotes a few millimetres to a centimetre of absolute accuracy]: 2 mm/√m
translation drift, 0.1 mrad/√m heading drift, 0.02 mrad/√m tilt drift, 3 mm and 0.3 mrad
residual per 20 m pass.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ConfigError, did_you_mean

MID_RANGE_M = (
    3.0  # the range at which a frame's predicted misplacement is reported (plans, frame meta)
)


@dataclass(frozen=True)
class RegistrationError:
    """The error model's spreads (1 sigma): drift per square-root metre walked (translation m,
    heading rad, roll/pitch rad) and the residual of each pass (m, rad)."""

    drift_m_per_sqrt_m: float = 0.002
    drift_yaw_rad_per_sqrt_m: float = 1e-4
    drift_tilt_rad_per_sqrt_m: float = 2e-5
    pass_length_m: float = 20.0
    pass_sigma_m: float = 0.003
    pass_sigma_rad: float = 3e-4

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if not (np.isfinite(v) and v >= 0) or (k == "pass_length_m" and v <= 0):
                raise ConfigError(
                    f"registration: {k} must be a number >= 0 (pass_length_m > 0), got {v!r}"
                )

    def sigma_m(self, distance_m, range_m) -> np.ndarray:
        """Predicted RMS misplacement (m, per axis summed over three) of a point ``range_m`` from
        the sensor in a frame taken after walking ``distance_m``."""
        s, r = np.asarray(distance_m, np.float64), np.asarray(range_m, np.float64)
        rot2 = (
            self.drift_yaw_rad_per_sqrt_m**2 + 2 * self.drift_tilt_rad_per_sqrt_m**2
        ) * s + 3 * self.pass_sigma_rad**2
        return np.sqrt(3 * self.drift_m_per_sqrt_m**2 * s + 3 * self.pass_sigma_m**2 + rot2 * r**2)

    def sample(self, length_m: float, *, rng: np.random.Generator) -> "ErrorPath":
        """One realisation of the error along a path of ``length_m`` (knots every metre)."""
        n = int(np.ceil(max(length_m, 0.0))) + 2
        knots = np.arange(n, dtype=np.float64)
        steps = rng.normal(size=(n - 1, 6)) * np.array(
            [self.drift_m_per_sqrt_m] * 3
            + [self.drift_tilt_rad_per_sqrt_m] * 2
            + [self.drift_yaw_rad_per_sqrt_m]
        )
        drift = np.vstack([np.zeros(6), np.cumsum(steps, axis=0)])
        passes = int(np.ceil(knots[-1] / self.pass_length_m)) + 1
        offsets = rng.normal(size=(passes, 6)) * np.array(
            [self.pass_sigma_m] * 3 + [self.pass_sigma_rad] * 3
        )
        return ErrorPath(knots, drift, offsets, self.pass_length_m)


@dataclass(frozen=True, eq=False)
class ErrorPath:
    """A drawn error: ``drift`` (K, 6) at ``knots_m`` (K,) and ``offsets`` (P, 6) per pass, each
    row (tx, ty, tz, roll, pitch, yaw) in metres and radians."""

    knots_m: np.ndarray
    drift: np.ndarray
    offsets: np.ndarray
    pass_length_m: float

    def error(self, distance_m: float) -> np.ndarray:
        """(6,) the error at ``distance_m`` walked."""
        d = np.array([np.interp(distance_m, self.knots_m, self.drift[:, k]) for k in range(6)])
        k = min(int(distance_m // self.pass_length_m), len(self.offsets) - 1)
        return d + self.offsets[k]

    def apply(
        self, world_from_camera: np.ndarray, world_from_body: np.ndarray, distance_m: float
    ) -> np.ndarray:
        """(4, 4) the estimated pose of a camera at ``world_from_camera`` (the body at
        ``world_from_body``) after walking ``distance_m``."""
        e = self.error(distance_m)
        p = world_from_body[:3, 3]
        E = np.eye(4)
        E[:3, :3] = Rotation.from_euler("xyz", e[3:]).as_matrix()
        E[:3, 3] = p - E[:3, :3] @ p + e[:3]
        return E @ world_from_camera


REGISTRATIONS: dict[str, RegistrationError | None] = {"mobile": RegistrationError(), "none": None}


def registration_of(name: str) -> RegistrationError | None:
    try:
        return REGISTRATIONS[name]
    except KeyError:
        raise ConfigError(
            f"--registration {name!r}: unknown{did_you_mean(name, REGISTRATIONS)}; expected one of "
            f"{', '.join(REGISTRATIONS)}"
        ) from None
