"""OpenCV, ROS and Kalibr calibration files in and out.

Reads OpenCV ``FileStorage`` YAML/XML as ``calibrateCamera`` / ``stereoCalibrate`` /
``cv2.fisheye.calibrate`` programs write them (any of the common key spellings), ROS
``camera_info`` YAML (``distortion_model`` ``plumb_bob``, ``rational_polynomial``,
``equidistant``) and Kalibr camchain YAML (``camera_model: pinhole`` with ``distortion_model``
``radtan``, ``equidistant`` or ``none``, and ``camera_model: omni``; the first camera, and the
baseline to the second);
writes OpenCV YAML/XML with OpenCV's lower-case keys (plus ``distortion_model`` for a
fisheye lens). A file without K or the image size, with a malformed matrix, or with a lens
model genie-gl does not know is rejected with an error naming the file, the field and the
model, never read as another model.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from ..checks import whole_number
from ..errors import ConfigError, did_you_mean
from ..outputs import check_replaceable
from ..camera import MODELS

K_KEYS = ("camera_matrix", "Camera_Matrix", "cameraMatrix", "K", "K1", "M1", "intrinsics")
D_KEYS = ("distortion_coefficients", "Distortion_Coefficients", "dist_coeffs", "distCoeffs", "D", "D1")
W_KEYS = ("image_width", "image_Width", "imageWidth", "width")
H_KEYS = ("image_height", "image_Height", "imageHeight", "height")
ERR_KEYS = ("avg_reprojection_error", "Avg_Reprojection_Error", "reprojection_error", "rms")
MODEL_KEYS = ("distortion_model", "Distortion_Model", "lens_model", "camera_model")
# what calibration programs write beside the fields read above (OpenCV's calibration samples,
# stereoCalibrate/stereoRectify, ROS camera_info): known, kept unread; any other key is refused
OTHER_KEYS = (
    "calibration_time", "calibrationDate", "nframes", "nr_of_frames", "nrOfFrames", "board_width", "board_height",
    "board_Width", "board_Height", "square_size", "square_Size", "marker_size", "aspectRatio", "aspect_ratio",
    "fix_aspect_ratio", "flags", "flagValue", "calibration_flags", "fisheye_model", "per_view_reprojection_errors",
    "extrinsic_parameters", "image_points", "grid_points", "camera_name", "rectification_matrix",
    "projection_matrix", "binning_x", "binning_y", "roi", "E", "F", "R1", "R2", "P1", "P2", "Q", "M2", "D2", "K2",
    "validRoi1", "validRoi2", "header", "name", "description", "source")
# lens model names as ROS, OpenCV programs and Kalibr write them -> (genie-gl model, counts)
LENS_NAMES: dict[str, tuple[str, tuple[int, ...]]] = {
    "plumb_bob": ("pinhole", (4, 5)), "radtan": ("pinhole", (4, 5)), "radial-tangential": ("pinhole", (4, 5)),
    "rational_polynomial": ("pinhole", (8, 12, 14)), "opencv": ("pinhole", MODELS["pinhole"]),
    "pinhole": ("pinhole", MODELS["pinhole"]), "none": ("pinhole", (0,)),
    "equidistant": ("fisheye", (4,)), "fisheye": ("fisheye", (4,)), "kannala_brandt": ("fisheye", (4,)),
    "kannala-brandt": ("fisheye", (4,)), "omni": ("omni", (5,)), "mei": ("omni", (5,)),
}


@dataclass(frozen=True, eq=False)
class Calibration:
    """A camera calibration: size, K (3x3), lens coefficients (N,), optional RMS error, stereo
    R, T (X2 = R·X1 + T), and the lens model (``"pinhole"`` or ``"fisheye"``, see
    :mod:`genie_gl.camera`)."""

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


def _matrix(value, where: str, shape: tuple | None = None) -> np.ndarray:
    if isinstance(value, dict):  # ROS style {rows, cols, data}
        try:
            a = np.asarray(value["data"], float).reshape(int(value["rows"]), int(value["cols"]))
        except (KeyError, ValueError) as exc:
            raise ConfigError(f"{where}: malformed matrix ({exc})") from None
    else:
        a = np.asarray(value, float)
    if shape is not None and a.size == np.prod(shape):
        a = a.reshape(shape)
    if shape is not None and a.shape != shape:
        raise ConfigError(f"{where}: expected a {shape[0]}x{shape[1]} matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{where}: contains NaN or Inf")
    return a


def _read_filestorage(path: Path) -> dict:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise ConfigError(f"{path}: OpenCV cannot read this file")
    out = {}
    root = fs.root()
    for key in root.keys():
        node = fs.getNode(key)
        if node.isMap() and node.mat() is not None:
            out[key] = node.mat()
        elif node.isInt() or node.isReal():
            out[key] = node.real()
        elif node.isString():
            out[key] = node.string()
        else:
            m = node.mat()
            if m is not None:
                out[key] = m
    fs.release()
    return out


def lens_model(name: Any, n: int, where: str) -> str:
    """The genie-gl lens model of a file's model name with ``n`` coefficients; an unknown
    name, or a count the model does not have, is refused by name."""
    key = str(name).strip().lower()
    if key not in LENS_NAMES:
        raise ConfigError(f"{where}: unknown lens model {name!r}; genie-gl reads {', '.join(sorted(LENS_NAMES))}")
    model, counts = LENS_NAMES[key]
    if n not in counts and not (n == 0 and key != "none"):
        raise ConfigError(f"{where}: lens model {name!r} takes {' or '.join(map(str, counts))} coefficients, got {n}")
    return model


def _kalibr(data: dict, path: Path) -> Calibration:
    """The first camera of a Kalibr camchain (and the baseline to the second, if any)."""
    cam = data["cam0"]
    where = f"{path}: cam0"
    if not isinstance(cam, dict):
        raise ConfigError(f"{where}: expected a mapping of camera fields")
    kind = str(cam.get("camera_model", "pinhole"))
    if kind not in ("pinhole", "omni"):
        raise ConfigError(f"{where}: camera_model {kind!r} is not supported (genie-gl reads Kalibr 'pinhole' "
                          "cameras with 'radtan', 'equidistant' or 'none' distortion, and 'omni' with 'radtan' or "
                          "'none')")
    for key in ("intrinsics", "resolution"):
        if key not in cam:
            raise ConfigError(f"{where}: missing field {key}")
    n_in = 5 if kind == "omni" else 4
    if np.size(cam["intrinsics"]) != n_in:
        spelled = "[xi, fu, fv, pu, pv]" if kind == "omni" else "[fu, fv, pu, pv]"
        raise ConfigError(f"{where}: intrinsics: expected {spelled}, got {cam['intrinsics']!r}")
    values = _matrix(cam["intrinsics"], f"{where}: intrinsics", (n_in,))
    fu, fv, pu, pv = values[-4:]
    if np.size(cam["resolution"]) != 2 or isinstance(cam["resolution"], (str, dict)):
        raise ConfigError(f"{where}: resolution: expected [width, height], got {cam['resolution']!r:.60}")
    W, H = (whole_number(v, f"{where}: resolution", 1, 1_000_000) for v in cam["resolution"])
    dist = np.asarray(cam.get("distortion_coeffs") or [], float)
    model = lens_model(cam.get("distortion_model", "none"), len(dist), f"{where}: distortion_model")
    if kind == "omni":
        if model != "pinhole":
            raise ConfigError(f"{where}: an omni camera takes 'radtan' or 'none' distortion, got "
                              f"{cam.get('distortion_model')!r}")
        dist = np.concatenate([[values[0]], dist if len(dist) else np.zeros(4)])
        model = "omni"
    K = np.array([[fu, 0, pu], [0, fv, pv], [0, 0, 1.0]])
    R = T = None
    if isinstance(data.get("cam1"), dict) and "T_cn_cnm1" in data["cam1"]:
        M = _matrix(data["cam1"]["T_cn_cnm1"], f"{path}: cam1: T_cn_cnm1", (4, 4))
        R, T = M[:3, :3], M[:3, 3]
    return Calibration(W, H, K, dist, None, R, T, str(path), model)


def read_calibration(path: str | os.PathLike) -> Calibration:
    """Read an OpenCV (YAML/XML), ROS camera_info or Kalibr camchain calibration file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such calibration file")
    text = path.read_text(errors="replace")
    if text.lstrip().startswith("%YAML") or text.lstrip().startswith("<?xml") or "opencv-matrix" in text:
        data = _read_filestorage(path)
    else:
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ConfigError(f"{path}: not valid YAML ({exc})") from None
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a mapping of calibration fields")
        if "cam0" in data:
            return _kalibr(data, path)

    _known_keys(data, path)

    def first(keys, field):
        for k in keys:
            if k in data and data[k] is not None:
                return k, data[k]
        return None, None

    k_key, K = first(K_KEYS, "camera_matrix")
    if K is None:
        raise ConfigError(f"{path}: missing field camera_matrix (K); accepted names: {', '.join(K_KEYS)}")
    K = _matrix(K, f"{path}: {k_key}", (3, 3))
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise ConfigError(f"{path}: {k_key}: fx and fy must be > 0")
    w_key, W = first(W_KEYS, "image_width")
    h_key, H = first(H_KEYS, "image_height")
    if W is None or H is None:
        raise ConfigError(f"{path}: missing field image_width/image_height (the image size)")
    d_key, D = first(D_KEYS, "distortion_coefficients")
    dist = np.zeros(0) if D is None else _matrix(D, f"{path}: {d_key}").ravel()
    m_key, name = first(MODEL_KEYS, "distortion_model")
    if name is None or name == "":
        model = "pinhole"
        if len(dist) not in MODELS["pinhole"]:
            raise ConfigError(f"{path}: {d_key}: expected 4, 5, 8, 12 or 14 coefficients, got {len(dist)}")
    else:
        model = lens_model(name, len(dist), f"{path}: {m_key}")
    _, err = first(ERR_KEYS, "avg_reprojection_error")
    R = _matrix(data["R"], f"{path}: R", (3, 3)) if "R" in data and np.size(data["R"]) == 9 else None
    T = _matrix(data["T"], f"{path}: T").ravel() if "T" in data and np.size(data["T"]) == 3 else None
    W = whole_number(W, f"{path}: {w_key}", 1, 1_000_000)
    H = whole_number(H, f"{path}: {h_key}", 1, 1_000_000)
    return Calibration(W, H, K, dist, None if err is None else float(err), R, T, str(path), model)


def _known_keys(data: dict, path: Path) -> None:
    """Refuse a key no calibration program writes (a misspelt field would be read as absent)."""
    known = (*K_KEYS, *D_KEYS, *W_KEYS, *H_KEYS, *ERR_KEYS, *MODEL_KEYS, "R", "T", *OTHER_KEYS)
    for key in data:
        if key not in known:
            near = did_you_mean(key, known)
            raise ConfigError(f"{path}: {key}: not a field of an OpenCV or ROS calibration{near or ''} (it reads "
                              f"camera_matrix, distortion_coefficients, image_width, image_height, distortion_model, "
                              f"R, T and the other fields calibration programs write)")


STAMP = "written by genie-gl"


def _written_by_genie(path: Path) -> bool:
    with open(path, "rb") as fh:
        return STAMP.encode() in fh.read(512)


def write_calibration(calib: Calibration, path: str | os.PathLike) -> Path:
    """Write OpenCV FileStorage YAML (.yml/.yaml) or XML (.xml) with OpenCV's key names. An
    existing file is replaced only when genie-gl wrote it (a comment says so)."""
    path = check_replaceable(path, _written_by_genie, what="calibration")
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
