"""The typed configuration of a dataset run, checked where it enters.

:class:`DatasetConfig` is what ``genie dataset`` and :func:`~genie_gl.dataset.run_dataset`
take; every field is validated here (numbers finite and in range, names known) so that the
run below it never sees a bad value. A mistake is one line naming the field (or option) and
what was expected, raised as :class:`~genie_gl.errors.ConfigError`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, Optional

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_serializer,
    field_validator,
    model_validator,
)

from ..cloud.balance import load_target
from ..errors import ConfigError, did_you_mean
from ..export.registry import DATASET_FORMATS
from ..labels import CLASSES
from ..limits import MAX_CAMERAS, MAX_REGIONS, available_memory_bytes  # noqa: F401  (kept importable from here)
from ..sensors.camera import Sensor
from ..sensors.accuracy import AccuracySettings, from_dict, load_accuracy
from .modes.base import CAPTURE_MODES, DEFAULT_MODE, get_mode, mode_options, users_of

# the CLI spelling of each field, for messages
OPTION = {
    "strategy": "STRATEGY",
    "scenes": "--scenes",
    "cameras": "--cameras",
    "sensor": "--sensor",
    "format": "--format",
    "out": "--out",
    "workers": "--workers",
    "seed": "--seed",
    "points": "--points",
    "chunk_m": "--chunk-m",
    "min_points": "--min-points",
    "min_labelled_share": "--min-labelled-share",
    "previews": "--previews",
    "executor": "--executor",
    "address": "--address",
    "split": "--split",
    "max_nodes": "--max-nodes",
    "max_memory_gb": "--max-memory-gb",
    "max_disk_gb": "--max-disk-gb",
    "accuracy": "--accuracy",
    "class_balance": "--class-balance",
    "points_budget": "--points-budget",
    "mount_m": "--mount",
    "capture": "--capture",
    "rig": "--rig",
    "path": "--path",
    "motion": "--motion",
    "duration_s": "--duration-s",
    "voxel_m": "--voxel-m",
    "registration": "--registration",
    "raster": "--raster",
    "cloud_stride": "--cloud-stride",
}


@dataclass(frozen=True)
class AccuracyFile:
    """``--accuracy FILE``: the file named and the settings read from it."""

    file: str
    settings: AccuracySettings

    def to_dict(self) -> dict[str, Any]:
        """``{"file", "settings"}`` as configurations and manifests hold it."""
        return {"file": self.file, "settings": self.settings.to_dict()}

    @classmethod
    def parse(cls, value: Any) -> "AccuracyFile":
        """The record of a ``{"file", "settings"}`` mapping (a manifest's inputs), checked."""
        if isinstance(value, cls):
            return value
        if not isinstance(value, dict) or set(value) != {"file", "settings"}:
            raise ConfigError(f"--accuracy {value!r:.60}: expected a file with an accuracy: block")
        return cls(str(value["file"]), from_dict(value["settings"], str(value["file"])))


class DatasetConfig(BaseModel):
    """Inputs of a dataset run (the CLI's options; see ``genie dataset --help``)."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, allow_inf_nan=False, arbitrary_types_allowed=True
    )

    strategy: str = Field(min_length=1)
    out: str = Field(min_length=1)
    scenes: int = Field(3, ge=1, le=1_000_000)
    cameras: int = Field(8, ge=1, le=MAX_CAMERAS)
    sensor: str = Field("realsense_d435", min_length=1)
    format: str = "semantickitti"
    workers: int = Field(1, ge=1, le=4096)
    seed: int = Field(0, ge=0, lt=2**63)
    points: int = Field(25000, ge=1, le=100_000_000)
    chunk_m: float = Field(12.0, gt=0, le=1e6)
    min_points: int = Field(2000, ge=0)
    min_labelled_share: float = Field(0.05, ge=0, le=1)
    previews: int = Field(3, ge=0)
    executor: Literal["process", "ray"] = "process"
    address: Optional[str] = None
    split: tuple[float, float, float] = (0.8, 0.1, 0.1)
    max_nodes: int = Field(MAX_REGIONS, ge=1)
    max_memory_gb: Optional[float] = Field(None, gt=0)
    max_disk_gb: Optional[float] = Field(None, gt=0)
    accuracy: Optional[AccuracyFile] = None  # --accuracy FILE (accuracy_option())
    # curation (genie_gl.dataset.curation): {"name": "paper" or a file, "target": {class id:
    # share}};
    # given as the name, the target is read here, so the fingerprint holds the shares
    class_balance: Optional[dict[str, Any]] = None
    points_budget: Optional[int] = Field(None, ge=1)
    mount_m: Optional[float] = Field(
        None, gt=0, le=1e4
    )  # camera height above the floor; None: from the range
    # the capture mode (genie_gl.dataset.modes): its name; the options below it are the modes'
    capture: str = DEFAULT_MODE
    rig: Optional[str] = None  # a rig file or shipped name; None: --sensor alone
    path: str = Field("aisles", min_length=1)  # aisles, random, or a waypoints file
    motion: Literal["person", "robot"] = "person"
    duration_s: float = Field(20.0, gt=0, le=3600)
    voxel_m: float = Field(0.02, gt=0, le=1.0)
    registration: Literal["mobile", "none"] = "mobile"
    # the rasteriser (genie_gl.render.rasters); None: decided where the run starts (the accuracy
    # settings', the dataset's manifest's when resuming, else the machine's default) and recorded
    raster: Optional[Literal["cpu", "gl"]] = None
    # --format rosbag: the points clouds from every k-th pixel row and column (None: every pixel)
    cloud_stride: int | None = Field(None, ge=1, le=64)

    @field_validator("format")
    @classmethod
    def _known_format(cls, v: str) -> str:
        if v not in DATASET_FORMATS:
            raise ValueError(
                f"unknown; expected one of {', '.join(DATASET_FORMATS)}"
                f"{did_you_mean(v, DATASET_FORMATS)}"
            )
        return v

    @field_validator("capture")
    @classmethod
    def _known_capture(cls, v: str) -> str:
        if v not in CAPTURE_MODES:
            raise ValueError(
                f"unknown; expected one of {', '.join(CAPTURE_MODES)}"
                f"{did_you_mean(v, CAPTURE_MODES)}"
            )
        return v

    @field_validator("accuracy", mode="before")
    @classmethod
    def _accuracy(cls, v: Any) -> Any:
        return None if v is None else AccuracyFile.parse(v)

    @field_serializer("accuracy")
    def _accuracy_dict(self, v: AccuracyFile | None) -> dict[str, Any] | None:
        return None if v is None else v.to_dict()

    @field_validator("split")
    @classmethod
    def _split(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        if min(v) < 0 or sum(v) <= 0:
            raise ValueError("expected three shares >= 0 (train, valid, test), not all 0")
        return v

    @field_validator("class_balance", mode="before")
    @classmethod
    def _class_balance(cls, v: Any) -> Any:
        return resolve_target(v)

    @model_validator(mode="after")
    def _curated_clouds(self) -> "DatasetConfig":
        fmt, mode = DATASET_FORMATS[self.format], get_mode(self.capture)
        if not mode.takes(fmt):
            takes = sorted(n for n, f in DATASET_FORMATS.items() if mode.takes(f))
            modes = [n for n, m in CAPTURE_MODES.items() if m.takes(fmt)]
            raise ConfigError(
                f"--format {self.format} takes --capture {' or '.join(modes)}, not "
                f"{self.capture}; --capture {self.capture} writes {', '.join(takes)}"
            )
        if (self.class_balance or self.points_budget) and not mode.curates(fmt):
            modes = [
                n
                for n, m in CAPTURE_MODES.items()
                if any(m.curates(f) for f in DATASET_FORMATS.values())
            ]
            raise ConfigError(
                f"--class-balance and --points-budget sub-sample point clouds; --format "
                f"{self.format} with --capture {self.capture} writes images or recordings: use a "
                f"point-cloud format with --capture {' or '.join(modes)}"
            )
        self._used_options()
        mode.check(self)
        if self.cloud_stride not in (None, 1) and self.format != "rosbag":
            raise ConfigError(
                f"--cloud-stride {self.cloud_stride}: thins the point clouds of a ROS 2 bag; "
                "--format "
                f"{self.format} does not use it (use --format rosbag)"
            )
        return self

    def _used_options(self) -> None:
        """Refuse an option the capture does not use (given, and not its default), never ignore
        it."""
        options, mode = mode_options(), get_mode(self.capture)
        given = [
            k
            for k in self.model_fields_set
            if k in options
            and getattr(self, k) is not None
            and getattr(self, k) != type(self).model_fields[k].default
        ]
        for k in sorted(given, key=options.index):
            if k not in mode.options:
                raise ConfigError(
                    f"{OPTION[k]} {getattr(self, k)!r:.40}: --capture {self.capture} does not use "
                    "it; it "
                    f"is for --capture {' or '.join(users_of(k))}"
                )

    # the fields that decide the bytes written: resuming with any other value is refused
    FINGERPRINTED: ClassVar[tuple[str, ...]] = (
        "format",
        "seed",
        "cameras",
        "points",
        "chunk_m",
        "min_points",
        "min_labelled_share",
        "split",
        "accuracy",
        "class_balance",
        "points_budget",
        "mount_m",
        "capture",
        "rig",
        "path",
        "motion",
        "duration_s",
        "voxel_m",
        "registration",
        "raster",
        "cloud_stride",
    )
    # of these, "capture" and the modes' own options enter only as the mode says
    # (genie_gl.dataset.modes)

    @classmethod
    def parse(cls, data: dict[str, Any], source: str = "dataset configuration") -> "DatasetConfig":
        """Validate ``data``; the first problem as one-line :class:`ConfigError`."""
        try:
            return cls(**data)
        except ValidationError as exc:
            e = exc.errors()[0]
            own = (e.get("ctx") or {}).get("error")
            if isinstance(own, ConfigError):  # a check that names its field itself
                raise ConfigError(f"{source + ': ' if source else ''}{own}") from None
            field = ".".join(str(p) for p in e["loc"]) or "?"
            name = OPTION.get(str(e["loc"][0]) if e["loc"] else "", field)
            msg = e["msg"].removeprefix("Value error, ")
            got = e.get("input")
            raise ConfigError(
                f"{source + ': ' if source else ''}{name} {got!r:.60}: {msg}"
            ) from None
        except TypeError as exc:
            raise ConfigError(f"{source}: {exc}") from None


def resolve_target(spec: Any) -> dict[str, Any] | None:
    """``class_balance`` as the config holds it: ``"paper"`` or a file name read into
    {"name": spec, "target": {class id (str): share}}; that dict itself is taken as it is
    (a manifest's inputs)."""
    if spec is None or spec == "":
        return None
    if (
        isinstance(spec, dict)
        and set(spec) == {"name", "target"}
        and isinstance(spec["target"], dict)
    ):
        try:
            target = {str(int(k)): float(v) for k, v in spec["target"].items()}
        except (TypeError, ValueError):
            raise ConfigError(
                f"--class-balance target {spec['target']!r:.60}: expected {{class id: share}}"
            ) from None
        if not target or min(target.values()) < 0 or not np.isclose(sum(target.values()), 1.0):
            raise ConfigError(
                f"--class-balance target {spec['target']!r:.60}: expected shares >= 0 summing to 1"
            )
        return {"name": str(spec["name"]), "target": target}
    if not isinstance(spec, (str, os.PathLike)):
        raise ConfigError(
            f"--class-balance {spec!r:.60}: expected 'paper' or a JSON file {{class: share}}"
        )
    return {
        "name": str(spec),
        "target": {str(k): v for k, v in load_target(str(spec), CLASSES).items()},
    }


def parse_split(text: str) -> tuple[float, float, float]:
    """``"0.8,0.1,0.1"`` -> (0.8, 0.1, 0.1); a bad value is a one-line ConfigError."""
    try:
        parts = tuple(float(p) for p in str(text).split(","))
    except ValueError:
        parts = ()
    if len(parts) != 3 or not all(math.isfinite(p) for p in parts):
        raise ConfigError(
            f"--split {text!r}: expected three shares TRAIN,VALID,TEST such as 0.8,0.1,0.1"
        )
    return parts  # type: ignore[return-value]


# -- the --accuracy option: what was asked for, what the captures used ---------------------------
def accuracy_option(path: str | os.PathLike | None) -> AccuracyFile | None:
    """``--accuracy FILE``: the file and its settings, read and checked now so a bad file fails
    before any work; None without the option."""
    if path is None:
        return None
    return AccuracyFile(str(path), load_accuracy(path))


def accuracy_used(cfg: DatasetConfig, sensor: Sensor) -> dict[str, Any]:
    """What a manifest records: the settings the captures used and where they came from
    (the --accuracy file, the sensor profile's accuracy: block, or the defaults)."""
    if cfg.accuracy is not None:
        return {"source": cfg.accuracy.file, "settings": cfg.accuracy.settings.to_dict()}
    return {
        "source": "sensor profile" if sensor.accuracy else "defaults",
        "settings": (sensor.accuracy or AccuracySettings()).to_dict(),
    }
