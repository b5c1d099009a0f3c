"""OpenCV, ROS and Kalibr calibration files in and out.

Reads the calibration files of the field, liberally (:mod:`.calibration_keys`): OpenCV
``FileStorage`` YAML/XML/JSON as OpenCV's tutorial program, its ``calibration.cpp`` sample,
``stereoCalibrate`` programs (``M1 D1 M2 D2 R T ...``, either camera) and
``cv2.fisheye.calibrate`` programs write them; ROS ``camera_info`` YAML (``distortion_model``
``plumb_bob``, ``rational_polynomial``, ``equidistant``); Kalibr camchains (:mod:`.kalibr`,
any camera by name); vendors' files that give ``fx fy cx cy`` and ``k1 k2 p1 p2 k3``. Keys
genie-gl does not need are left unread (listed at debug level). Writes OpenCV YAML/XML with
OpenCV's lower-case keys (plus ``distortion_model`` for a fisheye lens). A file without K or
the image size, with a malformed or non-finite matrix, a focal length not above 0, a size of
0, or a lens model genie-gl does not know is refused with one line naming the file and the
field, never read as another model.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from ..camera import MODELS
from ..validation.arguments import expect, expect_path, whole_number
from ..errors import ConfigError
from ..outputs import check_replaceable
from . import calibration_keys as keys
from .calibration_keys import Fields, is_matrix, is_number, lens_model, matrix
from .kalibr import is_camchain, read_camchain

__all__ = [
    "Calibration",
    "camera_index",
    "is_calibration",
    "lens_model",
    "read_calibration",
    "write_calibration",
]


@dataclass(frozen=True, eq=False)
class Calibration:
    """A camera calibration: size, K (3x3), lens coefficients (N,), optional RMS error, stereo
    R, T (X2 = R·X1 + T: this camera to the other of a stereo pair), and the lens model
    (``"pinhole"``, ``"fisheye"`` or ``"omni"``, see :mod:`genie_gl.camera`)."""

    width: int
    height: int
    K: np.ndarray
    dist: np.ndarray
    reprojection_error: float | None = None
    R: np.ndarray | None = None
    T: np.ndarray | None = None
    source: str = ""
    model: str = "pinhole"

    @property
    def baseline_m(self) -> float | None:
        return None if self.T is None else float(np.linalg.norm(self.T))


def camera_index(camera: Any, where: str) -> int | None:
    """The index of a camera named ``camera`` (0, 1, "cam1", "1"); None for None."""
    if camera is None:
        return None
    text = str(camera).strip().lower()
    if isinstance(camera, (int, np.integer)) and not isinstance(camera, bool) and camera >= 0:
        return int(camera)
    for prefix in ("cam", "camera", ""):
        rest = text[len(prefix) :] if text.startswith(prefix) else None
        if rest is not None and rest.isdigit():
            return int(rest)
    raise ConfigError(
        f"{where}: camera {camera!r}: expected a camera's index (0, 1, ...) or name (cam0, cam1, "
        "...)"
    )


def is_calibration(data: Any) -> bool:
    """True when a parsed YAML/JSON mapping looks like a calibration file (a camera matrix or
    its numbers under any common name, or a Kalibr camchain) rather than a sensor profile."""
    if not isinstance(data, dict) or "calibration" in data:
        return False
    if is_camchain(data):
        return True
    f = Fields(data, "")
    return any(
        f.find(names)[0] is not None
        for names in (keys.K_NAMES, tuple(n + "1" for n in keys.STEREO_K), keys.FX)
    )


def _read_data(path: Path) -> dict:
    text = path.read_text(errors="replace")
    head = text.lstrip()
    if head.startswith("%YAML") or head.startswith("<?xml") or "opencv-matrix" in text:
        return keys.read_filestorage(path)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: expected a mapping of calibration fields, got {type(data).__name__}"
        )
    return data


def read_calibration(path: str | os.PathLike, *, camera: int | str | None = None) -> Calibration:
    """Read a calibration file: OpenCV (YAML/XML/JSON, any program's key spelling), ROS
    camera_info, Kalibr camchain or a vendor's ``fx fy cx cy`` file.

    camera : which camera of a file of several: an index or a name (``cam1``; a Kalibr
        camchain's own names; 0 and 1 are the cameras 1 and 2 of an OpenCV stereo file, M1/D1
        and M2/D2). None: the first.
    """
    path = expect_path(path, "calibration")
    if not path.is_file():
        raise ConfigError(f"{path}: no such calibration file")
    data = _read_data(path)
    if is_camchain(data):
        return Calibration(**read_camchain(data, path, camera), source=str(path))
    index = camera_index(camera, str(path)) or 0
    f = Fields(data, str(path))
    calib = _opencv(f, path, index)
    f.log_unread()
    return calib


def _find_k(f: Fields, path: Path, index: int) -> tuple[str, np.ndarray]:
    names = (
        keys.K_NAMES + tuple(n + "1" for n in keys.STEREO_K)
        if index == 0
        else tuple(f"{n}{index + 1}" for n in keys.STEREO_K)
    )
    k_key, K = f.find(names, is_matrix(0))
    if K is not None and np.size(K if not isinstance(K, dict) else K.get("data", ())) == 4:
        fx, fy, cx, cy = matrix(K, f"{path}: {k_key}", (4,))  # [fu, fv, pu, pv]
        K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
    if K is None and index == 0:  # K as numbers (vendors' tools)
        parts = [f.find(n, is_number) for n in (keys.FX, keys.FY, keys.CX, keys.CY)]
        if all(k is not None for k, _ in parts):
            k_key = "/".join(k for k, _ in parts)
            fx, fy, cx, cy = (float(v) for _, v in parts)
            K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
    if K is None:
        if index > 0:
            raise ConfigError(
                f"{path}: camera {index}: no camera matrix for it (M{index + 1}, K{index + 1} or "
                f"cameraMatrix{index + 1}; the file's first camera is camera 0)"
            )
        raise ConfigError(
            f"{path}: missing field camera_matrix (K): no camera matrix under any of the names "
            "calibration programs use (camera_matrix, Camera_Matrix, cameraMatrix, K, M1, "
            "intrinsics; "
            f"or fx, fy, cx, cy){f.near(keys.K_NAMES)}"
        )
    K = matrix(K, f"{path}: {k_key}", (3, 3))
    if not K[0, 0] > 0 or not K[1, 1] > 0:
        raise ConfigError(
            f"{path}: {k_key}: fx and fy must be > 0, got {K[0, 0]:g} and {K[1, 1]:g}"
        )
    if not np.array_equal(K[2], [0, 0, 1]) or K[1, 0] != 0:
        raise ConfigError(
            f"{path}: {k_key}: not a camera matrix (expected [[fx, s, cx], [0, fy, cy], [0, 0, "
            "1]], "
            f"got rows {K[1].tolist()} and {K[2].tolist()})"
        )
    return k_key, K


def _find_dist(f: Fields, path: Path, index: int) -> tuple[str | None, np.ndarray]:
    names = (
        keys.D_NAMES + tuple(n + "1" for n in keys.STEREO_D)
        if index == 0
        else tuple(f"{n}{index + 1}" for n in keys.STEREO_D)
    )
    d_key, D = f.find(names, is_matrix(0))
    if D is not None:
        return d_key, matrix(D, f"{path}: {d_key}").ravel()
    found = [f.find((n,), is_number) for n in keys.D_SCALARS] if index == 0 else []
    if any(k is not None for k, _ in found):  # k1 k2 p1 p2 [k3 ...]: up to the last one given
        last = max(i for i, (k, _) in enumerate(found) if k is not None)
        n = next(c for c in MODELS["pinhole"] if c > last)
        values = [0.0 if v is None else float(v) for _, v in found[: last + 1]] + [0.0] * (
            n - last - 1
        )
        return "k1/k2/p1/p2", matrix(values, f"{path}: k1/k2/p1/p2")
    near = f.near(keys.D_NAMES)
    if near:
        keys.logger.warning(
            "%s: no distortion coefficients read, so none are applied%s", path, near
        )
    return None, np.zeros(0)


def _find_size(f: Fields, path: Path) -> tuple[int, int]:
    w_key, W = f.find(keys.W_NAMES, is_number)
    h_key, H = f.find(keys.H_NAMES, is_number)
    if W is None or H is None:
        s_key, size = f.find(keys.SIZE_NAMES, is_matrix(2))
        if size is None:
            raise ConfigError(
                f"{path}: missing field image_width/image_height (the image size; also read as "
                f"image_Width/image_Height, imageSize or resolution [width, height])"
                f"{f.near(keys.W_NAMES + keys.H_NAMES + keys.SIZE_NAMES)}"
            )
        w_key = h_key = s_key
        W, H = (v.item() if isinstance(v, np.generic) else v for v in np.asarray(size).ravel())
    return (
        whole_number(W, f"{path}: {w_key}", 1, 1_000_000),
        whole_number(H, f"{path}: {h_key}", 1, 1_000_000),
    )


def _find_model(f: Fields, path: Path, d_key: str | None, dist: np.ndarray) -> str:
    m_key, name = f.find(keys.MODEL_NAMES, lambda v: isinstance(v, str) and v.strip() != "")
    if name is None:  # Kalibr-like files say camera_model; OpenCV's tutorial says fisheye_model: 1
        m_key, name = f.find(
            ("cameramodel",), lambda v: isinstance(v, str) and v.strip().lower() in keys.LENS_NAMES
        )
    if name is None:
        fe_key, fisheye = f.find(keys.FISHEYE_NAMES, lambda v: is_number(v) or isinstance(v, bool))
        if fisheye:
            m_key, name = fe_key, "fisheye"
    if name is not None:
        return lens_model(name, len(dist), f"{path}: {m_key}")
    if len(dist) not in MODELS["pinhole"]:
        raise ConfigError(
            f"{path}: {d_key}: expected 4, 5, 8, 12 or 14 coefficients, got {len(dist)}"
        )
    return "pinhole"


def _stereo(f: Fields, path: Path, index: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """R, T from this camera to the other of a stereo file (camera 0: the file's own R, T)."""
    r_key, R = f.find(("r", "rotation"), is_matrix(9))
    t_key, T = f.find(("t", "translation"), is_matrix(3))
    if R is None or T is None:
        return None, None
    R, T = matrix(R, f"{path}: {r_key}", (3, 3)), matrix(T, f"{path}: {t_key}").ravel()
    if index == 0:
        return R, T
    return R.T, -R.T @ T


def _opencv(f: Fields, path: Path, index: int) -> Calibration:
    _, K = _find_k(f, path, index)
    d_key, dist = _find_dist(f, path, index)
    model = _find_model(f, path, d_key, dist)
    W, H = _find_size(f, path)
    e_key, err = f.find(keys.ERR_NAMES, is_number)
    err = float(err) if err is not None and np.isfinite(float(err)) and float(err) >= 0 else None
    R, T = _stereo(f, path, index)
    return Calibration(W, H, K, dist, err, R, T, str(path), model)


STAMP = "written by genie-gl"


def _written_by_genie(path: Path) -> bool:
    with open(path, "rb") as fh:
        return STAMP.encode() in fh.read(512)


def write_calibration(calib: Calibration, path: str | os.PathLike) -> Path:
    """Write OpenCV FileStorage YAML (.yml/.yaml) or XML (.xml) with OpenCV's key names. An
    existing file is replaced only when genie-gl wrote it (a comment says so)."""
    expect(calib, Calibration, "write_calibration: calib")
    path = check_replaceable(
        expect_path(path, "write_calibration: path"), _written_by_genie, what="calibration"
    )
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
    fs.writeComment(STAMP)
    fs.write("image_width", int(calib.width))
    fs.write("image_height", int(calib.height))
    fs.write("camera_matrix", np.asarray(calib.K, np.float64))
    fs.write("distortion_coefficients", np.asarray(calib.dist, np.float64).reshape(-1, 1))
    if calib.model != "pinhole":
        fs.write("distortion_model", {"fisheye": "equidistant", "omni": "omni"}[calib.model])
    if calib.reprojection_error is not None:
        fs.write("avg_reprojection_error", float(calib.reprojection_error))
    if calib.R is not None:
        fs.write("R", np.asarray(calib.R, np.float64))
    if calib.T is not None:
        fs.write("T", np.asarray(calib.T, np.float64).reshape(3, 1))
    fs.release()
    tmp.replace(path)
    return path
