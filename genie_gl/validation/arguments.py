"""Checks of the arguments the public entry points share (bottom of the package, numpy only).

Each check raises :class:`~genie_gl.errors.ConfigError` in one line naming the argument, what
was expected and what came; the CLI's option types use the same words (``genie_gl.commands``),
so ``gg.capture(..., seed=-1)`` and ``genie capture --seed -1`` say the same thing.

- :func:`whole_number`, :func:`check_seed`, :func:`finite_number`: numbers, whole where they
  count something (``1.5`` cameras is refused, never rounded), seeds in 0..2**63-1.
- :func:`expect`: an object of the stage's own type (a path or a name where a ``Scene`` or a
  ``Sensor`` is expected is refused with the call that makes one).
- :func:`check_pose`, :func:`check_poses`: a camera pose is a rigid transform (rotation and
  translation): finite, last row (0, 0, 0, 1), rotation orthonormal with determinant +1 (no
  scale, shear or mirror); poses are a list of them (one bare 4x4 is refused, not iterated).
- :data:`MAX_COORD_M`: coordinates beyond it (1e9 m, a million kilometres) are refused as
  absurd; float64 still resolves 0.1 um there, so every real site fits far inside.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from .bounds import MAX_SEED, number_problem, whole_problem  # noqa: F401  (the words of every number check)
from ..errors import ConfigError

MAX_COORD_M = 1e9
ROTATION_TOL = 1e-6

#: how to make each stage's object, for the message when something else came
MAKERS = {
    "Layout": "gg.generate_layout(strategy, seed=...) or gg.Layout.from_json(path)",
    "Scene": "gg.read_usd(path) or gg.build_scene(layout, seed=...)",
    "Sensor": "gg.load_sensor(name or path)",
    "Strategy": "gg.load_strategy(name or path)",
    "PointCloud": "gg.to_cloud(frames)",
    "Frame": "gg.render(...) or gg.capture(...)",
    "Rig": "gg.load_rig(name or path) or Rig.single(sensor)",
    "Trajectory": "gg.make_trajectory(layout, scene)",
    "Plan": "gg.plan(scene, sensor, poses)",
}


def describe(value: Any) -> str:
    """A short description of ``value`` for a message: its type and, when short, the value."""
    kind = type(value).__name__
    if isinstance(value, np.ndarray):
        return f"a numpy array of shape {value.shape}"
    if isinstance(value, (str, bytes, int, float, Path)) or value is None:
        return (
            f"{kind} {str(value)[:60]!r}"
            if isinstance(value, (str, Path))
            else f"{kind} {value!r:.60}"
        )
    if isinstance(value, (list, tuple, dict)):
        return f"a {kind} of {len(value)}"
    return f"a {kind}"


def whole_number(value: Any, where: str, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an int in ``lo..hi``; a :class:`ConfigError` naming ``where`` otherwise."""
    why = whole_problem(value, lo, hi)
    if why:
        raise ConfigError(f"{where}: {why}")
    return int(value)


def check_seed(seed: Any, where: str = "seed") -> int:
    """A seed: a whole number in 0..2**63-1 (numpy's SeedSequence takes no negatives)."""
    return whole_number(seed, where, 0, MAX_SEED)


def finite_number(
    value: Any,
    where: str,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
) -> float:
    """``value`` as a finite float in [lo, hi] (``lo_open``: (lo, hi]); a ConfigError otherwise."""
    why = number_problem(value, lo, hi, lo_open=lo_open)
    if why:
        raise ConfigError(f"{where}: {why}")
    return float(value)


def expect(value: Any, cls: type, where: str) -> Any:
    """``value`` when it is a ``cls``; otherwise a ConfigError naming what came and how to make
    a ``cls`` (:data:`MAKERS`)."""
    if isinstance(value, cls):
        return value
    make = MAKERS.get(cls.__name__)
    hint = f"; make one with {make}" if make else ""
    raise ConfigError(f"{where}: expected a {cls.__name__}, got {describe(value)}{hint}")


def expect_path(value: Any, where: str) -> Path:
    """``value`` (a str or path-like naming a file) as a Path; anything else is refused by name."""
    if isinstance(value, (str, os.PathLike)) and str(value).strip():
        return Path(value)
    raise ConfigError(f"{where}: expected a file name (str or pathlib.Path), got {describe(value)}")


def expect_sequence(values: Any, cls: type, where: str) -> list:
    """``values`` as a non-empty list of ``cls``; one ``cls`` or anything else is refused."""
    if isinstance(values, cls):
        raise ConfigError(
            f"{where}: expected a list of {cls.__name__}s, got one {cls.__name__}: pass a list "
            f"of it"
        )
    if isinstance(values, (str, bytes, dict)) or not hasattr(values, "__iter__"):
        raise ConfigError(f"{where}: expected a list of {cls.__name__}s, got {describe(values)}")
    out = list(values)
    if not out:
        raise ConfigError(f"{where}: expected at least one {cls.__name__}, got none")
    for i, v in enumerate(out):
        expect(v, cls, f"{where}[{i}]")
    return out


def check_pose(pose: Any, where: str = "pose") -> np.ndarray:
    """``pose`` as a (4, 4) float64 world_from_camera, or a one-line ConfigError saying why not."""
    try:
        T = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{where}: expected a (4, 4) matrix of numbers, got {pose!r:.60}"
        ) from None
    if T.shape == (4, 4) and _plainly_rigid(T):
        return T
    if T.shape != (4, 4):
        raise ConfigError(f"{where}: expected a (4, 4) matrix, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise ConfigError(f"{where}: contains NaN or Inf")
    if np.abs(T[:3, 3]).max() > MAX_COORD_M:
        raise ConfigError(f"{where}: translation {T[:3, 3].tolist()} m is beyond {MAX_COORD_M:g} m")
    if not np.allclose(T[3], [0, 0, 0, 1], atol=1e-12):
        raise ConfigError(
            f"{where}: last row {T[3].tolist()}, expected [0, 0, 0, 1] (a rigid transform)"
        )
    R = T[:3, :3]
    err = float(np.abs(R.T @ R - np.eye(3)).max())
    if err > ROTATION_TOL or np.linalg.det(R) < 0:
        raise ConfigError(
            f"{where}: not a rotation (|RᵀR - I| = {err:.3g}, det {np.linalg.det(R):.3g}); a "
            "camera pose "
            "has no scale, shear or mirror"
        )
    return T


def _plainly_rigid(T: np.ndarray) -> bool:
    """True when the (4, 4) float64 ``T`` passes every test of :func:`check_pose` with room
    to spare (its rotation error under half the tolerance), decided in plain floats: a few
    microseconds where the array tests take ~50 (a capture checks every pose two or three
    times). False leaves the decision, and the message, to those tests."""
    (a, b, c, x), (d, e, f, y), (g, h, i, z), (p, q, r, s) = T.tolist()
    if not all(map(math.isfinite, (a, b, c, x, d, e, f, y, g, h, i, z, p, q, r, s))):
        return False
    if max(abs(x), abs(y), abs(z)) > MAX_COORD_M:
        return False
    # np.allclose(T[3], [0, 0, 0, 1], atol=1e-12): |T[3] - row| <= 1e-12 + 1e-5 * |row|
    if abs(p) > 1e-12 or abs(q) > 1e-12 or abs(r) > 1e-12 or abs(s - 1.0) > 1e-12 + 1e-5:
        return False
    err = max(
        abs(a * a + d * d + g * g - 1.0),
        abs(b * b + e * e + h * h - 1.0),
        abs(c * c + f * f + i * i - 1.0),
        abs(a * b + d * e + g * h),
        abs(a * c + d * f + g * i),
        abs(b * c + e * f + h * i),
    )
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return err <= ROTATION_TOL / 2 and det > 0


def check_poses(poses: Any, where: str = "poses") -> list[np.ndarray]:
    """``poses`` (a list of 4x4 world_from_camera, or a (K, 4, 4) array) as checked float64
    matrices; one bare (4, 4) pose, an empty list or anything else is refused by name."""
    if isinstance(poses, (str, bytes, dict, Path)) or not hasattr(poses, "__len__"):
        raise ConfigError(
            f"{where}: expected a list of (4, 4) world_from_camera poses, got {describe(poses)}"
        )
    shape = np.shape(poses) if not isinstance(poses, (list, tuple)) or len(poses) else (0,)
    if shape == (4, 4):
        raise ConfigError(
            f"{where}: expected a list of (4, 4) poses, got one (4, 4) matrix; pass [pose]"
        )
    if len(poses) == 0:
        raise ConfigError(f"{where}: expected at least one pose, got none")
    return [check_pose(p, f"{where}[{i}]") for i, p in enumerate(poses)]


def read_poses(path: str | Path) -> list[np.ndarray]:
    """Poses from a .npy (K, 4, 4) array or a JSON list of 4x4 matrices."""
    path = Path(path)
    try:
        data = (
            np.load(path)
            if path.suffix == ".npy"
            else np.array(json.loads(path.read_text()), dtype=np.float64)
        )
    except RecursionError:
        raise ConfigError(
            f"{path}: JSON nested too deeply; expected .npy (K, 4, 4) or JSON [[4x4], ...]"
        ) from None
    except (OSError, ValueError, TypeError) as exc:
        raise ConfigError(
            f"{path}: cannot read poses ({exc}); expected .npy (K, 4, 4) or JSON [[4x4], ...]"
        ) from None
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 3 or data.shape[1:] != (4, 4) or not np.isfinite(data).all():
        raise ConfigError(f"{path}: poses: expected K finite 4x4 matrices, got shape {data.shape}")
    return list(data)


def capture_arguments(
    scene: Any,
    sensor: Any,
    poses: Any,
    seed: Any,
    scene_cls: type,
    sensor_cls: type,
    call: str = "capture",
) -> tuple[Any, Any, list[np.ndarray], int]:
    """The arguments of ``capture`` and ``plan`` checked (the stages' classes passed in, so this
    module stays at the bottom of the package): a Scene, a Sensor, a list of rigid poses, a seed."""
    expect(scene, scene_cls, f"{call}: scene")
    expect(sensor, sensor_cls, f"{call}: sensor")
    return scene, sensor, check_poses(poses, f"{call}: poses"), check_seed(seed, f"{call}: seed")
