"""The spinning LiDAR scanner: channels, firing timing, range and returns (LIDAR.md §9).

A :class:`Scanner` is a head that spins about its z axis and fires its channels in
*firings* (Velodyne: a firing sequence of 16 lasers; Ouster: a column of all rows), one
firing every ``firing_period_s``. The scanner frame follows REP 103: x forward, y left,
z up. Azimuth is measured in that frame counter-clockwise from +x seen from above (the
REP 103 sense); both shipped families spin **clockwise** seen from above (LIDAR.md §9.1,
§9.3), so the head's azimuth falls with time:

``azimuth(c, t) = start_azimuth - 2 pi rate (t + channel_time[c]) * spin - azimuth_offset[c]``

where ``t`` is the firing's time and ``spin`` is +1 (clockwise) or -1. A channel c at
elevation ``e[c]`` then looks along ``(cos e cos a, cos e sin a, sin e)``. Per-point time is
the channel's own firing time relative to the **scan start** (a scan is one revolution,
``1 / rate_hz`` s), as ROS drivers give it with ``timestamp_first_packet`` (Velodyne) and
as ouster-ros gives ``t`` (all rows of a column share the column time, Ouster's
``channel_time`` is 0).

``ring`` follows each family's driver: Velodyne's ROS ring is the rank by elevation, 0 the
lowest beam; ouster-ros's ring is the row, 0 the top beam (LIDAR.md §9.1, §9.3).

Profiles are YAML files (``sensors/<name>.yaml`` with ``kind: scanner``), read by
:mod:`.scanner_profile`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import ConfigError

RETURN_MODES = ("strongest", "last", "dual")
RING_ORDERS = ("elevation", "row")
STYLES = ("velodyne", "ouster", "generic")


@dataclass(frozen=True, eq=False)
class Scanner:
    """A spinning multi-channel LiDAR head.

    Attributes
    ----------
    name : str.
    elevation_rad : (C,) float64, each channel's elevation (rad, + up), in channel order
        (Velodyne: laser id = firing order; Ouster: row, 0 the top beam).
    azimuth_offset_rad : (C,) float64, each channel's azimuth offset (rad), subtracted from the
        head's azimuth (Ouster ``beam_azimuth_angles``; 0 for a Velodyne Puck).
    channel_time_s : (C,) float64, each channel's firing time within its firing (s), in channel
        order, non-decreasing, below ``firing_period_s``.
    firing_period_s : float, time between the starts of two firings (s).
    rate_hz : float, revolutions per second (one scan per revolution).
    min_range_m, max_range_m : float, returns nearer or farther than these are not reported
        (the minimum only when the profile's ``blind_zone`` effect asks; the maximum always).
    fov_deg : float in (0, 360], the horizontal window fired: the firings of the first
        ``fov_deg / 360`` of each revolution (360: the whole turn).
    start_azimuth_rad : float, the head's azimuth (rad) at the start of each scan.
    spin : +1 clockwise seen from above (both shipped families), -1 counter-clockwise.
    returns : "strongest", "last" or "dual" (what the head reports from several echoes).
    beam_divergence_rad : float or None, full-angle divergence of a beam (None: not known).
    beam_origin_m : float, distance of each beam's origin from the spin axis along the
        head's azimuth (Ouster ``lidar_origin_to_beam_origin_mm``, in m; 0 for a Puck).
    ring_order : "elevation" (rank by elevation, 0 = lowest) or "row" (the channel index).
    style : "velodyne", "ouster" or "generic": which driver's point fields exports follow.
    range_accuracy_m, range_resolution_m : the datasheet's figures (0: unknown).
    effects : tuple of lidar effects, in the order they run.
    sources : dict, field -> where its figure comes from (LIDAR.md tags).
    profile : str, the file it was read from ("" for one made in code).
    """

    name: str
    elevation_rad: np.ndarray
    azimuth_offset_rad: np.ndarray
    channel_time_s: np.ndarray
    firing_period_s: float
    rate_hz: float
    min_range_m: float = 0.0
    max_range_m: float = 100.0
    fov_deg: float = 360.0
    start_azimuth_rad: float = 0.0
    spin: int = 1
    returns: str = "strongest"
    beam_divergence_rad: float | None = None
    beam_origin_m: float = 0.0
    ring_order: str = "elevation"
    style: str = "generic"
    range_accuracy_m: float = 0.0
    range_resolution_m: float = 0.0
    effects: tuple = ()
    sources: dict = field(default_factory=dict)
    profile: str = ""

    def __post_init__(self) -> None:
        where = self.profile or f"scanner {self.name!r}"
        e = np.asarray(self.elevation_rad, np.float64).reshape(-1)
        if e.size == 0:
            raise ConfigError(
                f"{where}: elevation_deg: a scanner needs at least one channel, got none"
            )
        if not np.all(np.isfinite(e)) or np.any(np.abs(e) > np.pi / 2):
            bad = int(np.flatnonzero(~np.isfinite(e) | (np.abs(e) > np.pi / 2))[0])
            raise ConfigError(
                f"{where}: elevation_deg[{bad}]: expected a finite angle in [-90, 90] degrees, "
                f"got {np.degrees(e[bad])}"
            )
        a = np.broadcast_to(np.asarray(self.azimuth_offset_rad, np.float64), e.shape).copy()
        t = np.broadcast_to(np.asarray(self.channel_time_s, np.float64), e.shape).copy()
        if not np.all(np.isfinite(a)):
            raise ConfigError(f"{where}: azimuth_offset_deg: expected finite angles, got {a}")
        if not np.all(np.isfinite(t)) or np.any(t < 0):
            raise ConfigError(f"{where}: channel_time_us: expected finite times >= 0")
        if np.any(np.diff(t) < 0):
            bad = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
            raise ConfigError(
                f"{where}: channel_time_us[{bad}]: firing times out of order ({t[bad] * 1e6:g} us "
                f"after {t[bad - 1] * 1e6:g} us); list the channels in firing order"
            )
        for name in ("rate_hz", "firing_period_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ConfigError(f"{where}: {name}: expected a number > 0, got {v!r}")
        if t[-1] >= self.firing_period_s:
            raise ConfigError(
                f"{where}: channel_time_us: the last channel fires at {t[-1] * 1e6:g} us, not "
                "within "
                f"the firing period {self.firing_period_s * 1e6:g} us"
            )
        if self.firing_period_s * self.rate_hz > 0.5:
            raise ConfigError(
                f"{where}: fewer than two firings per revolution at {self.rate_hz} Hz; "
                "expected a shorter firing period"
            )
        if not (np.isfinite(self.fov_deg) and 0 < self.fov_deg <= 360):
            raise ConfigError(
                f"{where}: fov_deg: expected a field of view in (0, 360] degrees, got "
                f"{self.fov_deg}"
            )
        if not (0 <= self.min_range_m < self.max_range_m and np.isfinite(self.max_range_m)):
            raise ConfigError(
                f"{where}: range_m: expected 0 <= min < max (finite), got {self.min_range_m}, "
                f"{self.max_range_m}"
            )
        checks = (("returns", RETURN_MODES), ("ring_order", RING_ORDERS), ("style", STYLES))
        for name, allowed in checks:
            if getattr(self, name) not in allowed:
                raise ConfigError(
                    f"{where}: {name}: expected one of {', '.join(allowed)}, got "
                    f"{getattr(self, name)!r}"
                )
        if self.spin not in (1, -1):
            raise ConfigError(f"{where}: spin: expected clockwise or counterclockwise")
        object.__setattr__(self, "elevation_rad", e)
        object.__setattr__(self, "azimuth_offset_rad", a)
        object.__setattr__(self, "channel_time_s", t)
        object.__setattr__(self, "effects", tuple(self.effects))

    @property
    def channels(self) -> int:
        return len(self.elevation_rad)

    @property
    def ring(self) -> np.ndarray:
        """(C,) uint16 ring of each channel (see ``ring_order``)."""
        if self.ring_order == "row":
            return np.arange(self.channels, dtype=np.uint16)
        ring = np.empty(self.channels, np.uint16)
        ring[np.argsort(self.elevation_rad, kind="stable")] = np.arange(
            self.channels, dtype=np.uint16
        )
        return ring

    @property
    def scan_period_s(self) -> float:
        return 1.0 / self.rate_hz

    @property
    def firings_per_scan(self) -> float:
        """Firings per revolution (not a whole number for a Velodyne: 1808.4 at 10 Hz)."""
        return 1.0 / (self.rate_hz * self.firing_period_s)

    @property
    def azimuth_step_rad(self) -> float:
        """Azimuth turned between two firings (rad): 2 pi rate firing_period."""
        return 2 * np.pi * self.rate_hz * self.firing_period_s

    @property
    def points_per_second(self) -> float:
        """Beams fired per second over the field of view (single return)."""
        return self.channels / self.firing_period_s * self.fov_deg / 360.0

    def with_rate(self, rate_hz: float, *, columns: int | None = None) -> "Scanner":
        """The same head at ``rate_hz``; ``columns`` (an Ouster mode) sets the firing period
        to 1 / (columns rate); otherwise the firing period stays (a Velodyne's azimuth step
        grows with the rate)."""
        period = self.firing_period_s if columns is None else 1.0 / (columns * rate_hz)
        return replace(self, rate_hz=float(rate_hz), firing_period_s=float(period))

    def summary(self) -> dict[str, Any]:
        """The profile's figures, for manifests and report cards."""
        return {
            "name": self.name,
            "channels": self.channels,
            "rate_hz": self.rate_hz,
            "firing_period_us": self.firing_period_s * 1e6,
            "azimuth_step_deg": float(np.degrees(self.azimuth_step_rad)),
            "elevation_deg": [
                float(np.degrees(self.elevation_rad.min())),
                float(np.degrees(self.elevation_rad.max())),
            ],
            "fov_deg": self.fov_deg,
            "range_m": [self.min_range_m, self.max_range_m],
            "range_accuracy_m": self.range_accuracy_m,
            "returns": self.returns,
            "points_per_second": self.points_per_second,
            "beam_divergence_mrad": None
            if self.beam_divergence_rad is None
            else self.beam_divergence_rad * 1e3,
            "effects": [e.name for e in self.effects],
            "sources": dict(self.sources),
        }
