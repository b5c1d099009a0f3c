"""Kalibr camchains: ``cam0``, ``cam1``, ... each with ``camera_model``, ``intrinsics``,
``distortion_model``, ``distortion_coeffs``, ``resolution`` and (past the first)
``T_cn_cnm1``, the transform from the previous camera's frame into its own.

genie-gl reads ``camera_model: pinhole`` with ``radtan``, ``equidistant`` or ``none``
distortion, and ``camera_model: omni`` with ``radtan`` or ``none``; any camera of the chain
by name or index. Other keys (``rostopic``, ``cam_overlaps``, ``T_cam_imu``, ...) are not read.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from ..validation.arguments import whole_number
from ..errors import ConfigError, did_you_mean
from .calibration_keys import lens_model, logger, matrix

CAM = re.compile(r"cam(\d+)$")


def is_camchain(data: Any) -> bool:
    """A parsed file is a camchain when it has a ``cam0`` mapping."""
    return isinstance(data, dict) and isinstance(data.get("cam0"), dict)


def _chosen(data: dict, path: Path, camera: Any) -> tuple[str, int]:
    cams = sorted(
        (int(m.group(1)), k) for k in data if (m := CAM.match(str(k))) and isinstance(data[k], dict)
    )
    names = [k for _, k in cams]
    if camera is None:
        return "cam0", 0
    name = (
        f"cam{camera}"
        if isinstance(camera, (int, np.integer)) and not isinstance(camera, bool)
        else str(camera)
    )
    if name.isdigit():
        name = f"cam{name}"
    if name not in names:
        raise ConfigError(
            f"{path}: camera {camera!r}: not in this camchain{did_you_mean(name, names)} "
            f"(its cameras: {', '.join(names)})"
        )
    return name, int(CAM.match(name).group(1))


def _extrinsics(data: dict, path: Path, k: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """R, T from camera k to a neighbour (X_other = R·X_k + T): to the next camera when it
    gives ``T_cn_cnm1``, else back to the previous one."""
    nxt = data.get(f"cam{k + 1}")
    if isinstance(nxt, dict) and "T_cn_cnm1" in nxt:
        M = matrix(nxt["T_cn_cnm1"], f"{path}: cam{k + 1}: T_cn_cnm1", (4, 4))
        return M[:3, :3], M[:3, 3]
    own = data[f"cam{k}"]
    if k > 0 and "T_cn_cnm1" in own:
        M = matrix(own["T_cn_cnm1"], f"{path}: cam{k}: T_cn_cnm1", (4, 4))
        R, t = M[:3, :3], M[:3, 3]
        return R.T, -R.T @ t
    return None, None


def read_camchain(data: dict, path: Path, camera: Any = None) -> dict[str, Any]:
    """The :class:`~.calibration.Calibration` fields (all but ``source``) of one camera of a
    Kalibr camchain (``camera``: its name, ``cam1``, or index; None: ``cam0``)."""
    name, k = _chosen(data, path, camera)
    cam = data[name]
    where = f"{path}: {name}"
    kind = str(cam.get("camera_model", "pinhole"))
    if kind not in ("pinhole", "omni"):
        raise ConfigError(
            f"{where}: camera_model {kind!r} is not supported (genie-gl reads Kalibr 'pinhole' "
            "cameras with 'radtan', 'equidistant' or 'none' distortion, and 'omni' with 'radtan' "
            "or "
            "'none')"
        )
    for key in ("intrinsics", "resolution"):
        if key not in cam:
            raise ConfigError(f"{where}: missing field {key}")
    n_in = 5 if kind == "omni" else 4
    if np.size(cam["intrinsics"]) != n_in or isinstance(cam["intrinsics"], (str, dict)):
        spelled = "[xi, fu, fv, pu, pv]" if kind == "omni" else "[fu, fv, pu, pv]"
        raise ConfigError(f"{where}: intrinsics: expected {spelled}, got {cam['intrinsics']!r:.80}")
    values = matrix(cam["intrinsics"], f"{where}: intrinsics", (n_in,))
    fu, fv, pu, pv = values[-4:]
    if not fu > 0 or not fv > 0:
        raise ConfigError(f"{where}: intrinsics: fu and fv must be > 0, got {fu:g} and {fv:g}")
    if np.size(cam["resolution"]) != 2 or isinstance(cam["resolution"], (str, dict)):
        raise ConfigError(
            f"{where}: resolution: expected [width, height], got {cam['resolution']!r:.60}"
        )
    W, H = (whole_number(v, f"{where}: resolution", 1, 1_000_000) for v in cam["resolution"])
    coeffs = cam.get("distortion_coeffs")
    dist = (
        np.zeros(0)
        if coeffs is None or np.size(coeffs) == 0
        else matrix(coeffs, f"{where}: distortion_coeffs").ravel()
    )
    model = lens_model(cam.get("distortion_model", "none"), len(dist), f"{where}: distortion_model")
    if kind == "omni":
        if model != "pinhole":
            raise ConfigError(
                f"{where}: an omni camera takes 'radtan' or 'none' distortion, got "
                f"{cam.get('distortion_model')!r}"
            )
        dist = np.concatenate([[values[0]], dist if len(dist) else np.zeros(4)])
        model = "omni"
    K = np.array([[fu, 0, pu], [0, fv, pv], [0, 0, 1.0]])
    R, T = _extrinsics(data, path, k)
    logger.debug(
        "%s: read %s of the camchain's %s",
        path,
        name,
        ", ".join(str(c) for c in data if CAM.match(str(c))),
    )
    return {
        "width": W,
        "height": H,
        "K": K,
        "dist": dist,
        "reprojection_error": None,
        "R": R,
        "T": T,
        "model": model,
    }
