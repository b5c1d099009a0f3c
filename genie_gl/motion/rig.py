"""Rigs: several sensors with fixed extrinsics on one moving body (DESIGN.md ``Rig``).

The body frame follows REP 103: x forward, y left, z up; its origin is the point a
:class:`~genie_gl.motion.trajectory.Trajectory` carries (at the trajectory's height above the
floor). Each sensor keeps the OpenCV optical frame (x right, y down, z forward) and sits on the
body at ``body_from_sensor`` (4x4 float64), so its pose at time t is
``world_from_body(t) @ body_from_sensor``.

A rig file (YAML; shipped ones in ``rigs/``, found by bare name)::

    name: d435_quad
    sensors:
      - name: front                 # unique, [a-z0-9_], names its topics and folders
        profile: realsense_d435     # a sensor profile: shipped name or path beside this file
        rate_hz: 10                 # frames per second
        position_m: [0.1, 0.0, 0.0] # in the body frame
        yaw_deg: 0                  # the sensor's heading on the body (90: looking left)
        pitch_deg: 15               # downward tilt of its optical axis
        roll_deg: 0                 # about its optical axis

The three angles turn a REP 103 "link" frame (x along the optical axis) as ROS's fixed-axis
roll, pitch, yaw do (``Rz(yaw) Ry(pitch) Rx(roll)``, positive pitch tilting the axis down).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import ConfigError, did_you_mean
from ..resources import read_text, resolve
from ..sensors.camera import Sensor
from ..effects.profile import load_sensor

# the OpenCV optical frame's axes in a REP 103 link frame (columns: optical x, y, z)
LINK_FROM_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
NAME = re.compile(r"^[a-z0-9_]{1,40}$")


def body_from_sensor(
    position_m=(0.0, 0.0, 0.0),
    *,
    yaw_rad: float = 0.0,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
) -> np.ndarray:
    """(4, 4) float64 pose of an OpenCV sensor on the body: at ``position_m`` (body frame),
    its link frame turned by ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cy, sy, cp, sp, cr, sr = (
        np.cos(yaw_rad),
        np.sin(yaw_rad),
        np.cos(pitch_rad),
        np.sin(pitch_rad),
        np.cos(roll_rad),
        np.sin(roll_rad),
    )
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    out = np.eye(4)
    out[:3, :3] = rz @ ry @ rx @ LINK_FROM_OPTICAL
    out[:3, 3] = np.asarray(position_m, np.float64)
    return out


@dataclass(frozen=True, eq=False)
class RigSensor:
    """One sensor on the rig.

    name : str, [a-z0-9_]; sensor : Sensor; body_from_sensor : (4, 4) float64 (OpenCV sensor
    frame in the body frame); rate_hz : float > 0, frames per second; offset_s : float, the
    time of its first frame after the trajectory's start (s, in [0, 1/rate_hz)).
    """

    name: str
    sensor: Sensor
    body_from_sensor: np.ndarray
    rate_hz: float
    offset_s: float = 0.0

    def __post_init__(self) -> None:
        T = np.asarray(self.body_from_sensor, np.float64)
        if (
            T.shape != (4, 4)
            or not np.allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-9)
            or not np.allclose(T[3], [0, 0, 0, 1])
            or np.linalg.det(T[:3, :3]) < 0
        ):
            raise ConfigError(
                f"rig sensor {self.name!r}: body_from_sensor must be a rigid (4, 4) transform"
            )
        if not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigError(f"rig sensor {self.name!r}: rate_hz must be > 0, got {self.rate_hz}")
        if not 0 <= self.offset_s < 1 / self.rate_hz:
            raise ConfigError(
                f"rig sensor {self.name!r}: offset_s must lie in [0, 1/rate_hz), got "
                f"{self.offset_s}"
            )
        object.__setattr__(self, "body_from_sensor", T)

    def times(self, t0: float, t1: float) -> np.ndarray:
        """(n,) float64 frame times in [t0, t1] (s): t0 + offset_s + k / rate_hz."""
        n = (
            int(np.floor((t1 - t0 - self.offset_s) * self.rate_hz + 1e-9)) + 1
            if t1 >= t0 + self.offset_s
            else 0
        )
        return t0 + self.offset_s + np.arange(n, dtype=np.float64) / self.rate_hz


@dataclass(frozen=True, eq=False)
class Rig:
    """Sensors with fixed extrinsics on one body; ``name`` names the rig (its file's stem)."""

    name: str
    sensors: tuple[RigSensor, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "sensors", tuple(self.sensors))
        if not self.sensors:
            raise ConfigError(f"rig {self.name!r}: needs at least one sensor")
        names = [s.name for s in self.sensors]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ConfigError(
                f"rig {self.name!r}: sensor names must be unique ({', '.join(dup)} repeated)"
            )

    def __len__(self) -> int:
        return len(self.sensors)

    @classmethod
    def single(
        cls,
        sensor: Sensor,
        *,
        rate_hz: float = 10.0,
        pitch_rad: float = 0.0,
        name: str | None = None,
    ) -> "Rig":
        """One sensor at the body's origin looking forward, tilted down by ``pitch_rad``."""
        label = re.sub(r"[^a-z0-9_]", "_", sensor.name.lower())[:40] or "sensor"
        return cls(
            name or label,
            (RigSensor(label, sensor, body_from_sensor(pitch_rad=pitch_rad), rate_hz),),
        )


class MountSpec(BaseModel):
    """What a rig file says of any device on the rig: its name, its profile, when it starts
    (``offset_s``) and where it sits on the platform (position, yaw, pitch, roll)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    name: str = Field(pattern=NAME.pattern)
    profile: str = Field(min_length=1)
    offset_s: float = Field(0.0, ge=0)
    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw_deg: float = Field(0.0, ge=-360, le=360)
    pitch_deg: float = Field(0.0, ge=-90, le=90)
    roll_deg: float = Field(0.0, ge=-180, le=180)


class _SensorSpec(MountSpec):
    rate_hz: float = Field(10.0, gt=0, le=1000)


class _RigSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str | None = None
    description: str = ""
    sensors: list[_SensorSpec] = Field(min_length=1)


def read_spec(
    path: Path, model: type[BaseModel], item: type[BaseModel], what: str, items: str
) -> Any:
    """A rig file (``what``: "rig", "scanner rig") read into ``model``, whose ``items`` list holds
    ``item`` records; a mistake is one line naming the file and the field (did-you-mean for an
    unknown key)."""
    try:
        data = yaml.safe_load(read_text(path, f"{what} (YAML)"))
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a {what} file is a mapping with a '{items}' list")
    try:
        return model(**data)
    except ValidationError as exc:
        e = exc.errors()[0]
        where = ".".join(str(p) for p in e["loc"]) or "?"
        if e["type"] == "extra_forbidden":
            known = list((item if len(e["loc"]) > 1 else model).model_fields)
            raise ConfigError(
                f"{path}: {where}: unknown field{did_you_mean(str(e['loc'][-1]), known)}; "
                f"expected {', '.join(known)}"
            ) from None
        raise ConfigError(f"{path}: {where} {e.get('input')!r:.60}: {e['msg']}") from None


def load_rig(name_or_path: str | os.PathLike) -> Rig:
    """A rig from a YAML file (``rigs/<name>.yaml`` or a path); a mistake is one line naming
    the file and the field."""
    path = resolve(name_or_path, "rigs", (".yaml", ".yml"))
    spec = read_spec(path, _RigSpec, _SensorSpec, "rig", "sensors")
    sensors = []
    for k, s in enumerate(spec.sensors):
        beside = path.parent / s.profile
        try:
            sensor = load_sensor(beside if beside.is_file() else s.profile)
        except ConfigError as exc:
            raise ConfigError(f"{path}: sensors.{k}.profile: {exc}") from None
        if s.offset_s >= 1 / s.rate_hz:
            raise ConfigError(
                f"{path}: sensors.{k}.offset_s {s.offset_s}: must be below 1/rate_hz = "
                f"{1 / s.rate_hz:g} s"
            )
        T = body_from_sensor(
            s.position_m,
            yaw_rad=np.radians(s.yaw_deg),
            pitch_rad=np.radians(s.pitch_deg),
            roll_rad=np.radians(s.roll_deg),
        )
        sensors.append(RigSensor(s.name, sensor, T, float(s.rate_hz), float(s.offset_s)))
    return Rig(spec.name or Path(path).stem, tuple(sensors))
