"""The fields genie-gl reads from a calibration file, under the names calibration programs give
them.

A calibration file belongs to the program that wrote it, and every program writes keys of its
own in its own spelling: OpenCV's tutorial program (``Camera_Matrix``, ``image_Width``,
``calibration_Time``, ``nrOfFrames``, ...), its ``calibration.cpp`` sample (``camera_matrix``,
``nframes``, ``aspectRatio``, ...), ``stereoCalibrate`` programs (``M1 D1 M2 D2 R T E F ...``),
ROS ``camera_info`` (``camera_matrix: {rows, cols, data}``), vendors' tools (``fx``, ``ppx``,
``coeffs``). So a file is read for the fields genie-gl needs, found by name with case, ``_``
and ``-`` ignored (:func:`norm`), and every other key is left unread (listed once at debug
level). A needed field that is absent or malformed is refused by name.
"""

from __future__ import annotations

import difflib
import logging
import re
from typing import Any

import cv2
import numpy as np

from ..camera import MODELS
from ..errors import ConfigError

logger = logging.getLogger("genie_gl.sensors.calibration")


def norm(key: Any) -> str:
    """A key as it is compared: lower case, letters and digits only (``Camera_Matrix``,
    ``cameraMatrix`` and ``camera-matrix`` are one name)."""
    return re.sub(r"[^0-9a-z]", "", str(key).lower())


# the names of each field, as :func:`norm` writes them, in the order they are looked for
K_NAMES = (
    "cameramatrix",
    "k",
    "intrinsicmatrix",
    "cameraintrinsics",
    "intrinsics",
    "intrinsic",
    "mtx",
    "m",
)
D_NAMES = (
    "distortioncoefficients",
    "distortioncoeffs",
    "distcoeffs",
    "distcoeff",
    "distortion",
    "dist",
    "d",
    "coeffs",
    "distortioncoefficents",
)  # the last as some camera_info files spell it
# the cameras of a stereo file: OpenCV's stereo programs number them 1 and 2 (M1, D1, cameraMatrix2
# ...)
STEREO_K = ("m", "k", "cameramatrix", "intrinsicmatrix")
STEREO_D = ("d", "distcoeffs", "distortioncoefficients", "distortion")
W_NAMES = ("imagewidth", "width", "imgwidth")
H_NAMES = ("imageheight", "height", "imgheight")
SIZE_NAMES = ("imagesize", "resolution", "imgsize", "size")  # [width, height]
ERR_NAMES = (
    "avgreprojectionerror",
    "reprojectionerror",
    "meanreprojectionerror",
    "rms",
    "rmserror",
    "reprojerror",
)
MODEL_NAMES = ("distortionmodel", "lensmodel", "distortiontype")
FISHEYE_NAMES = (
    "fisheyemodel",
    "usefisheye",
    "isfisheye",
    "fisheye",
)  # OpenCV's tutorial: fisheye_model 0/1
# a K given as numbers, as vendors' tools write it
FX, FY = ("fx", "fu", "focallengthx"), ("fy", "fv", "focallengthy")
CX, CY = ("cx", "ppx", "u0", "pu", "principalpointx"), ("cy", "ppy", "v0", "pv", "principalpointy")
D_SCALARS = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")  # OpenCV's order

# lens model names as ROS, OpenCV programs and Kalibr write them -> (genie-gl model, counts)
LENS_NAMES: dict[str, tuple[str, tuple[int, ...]]] = {
    "plumb_bob": ("pinhole", (4, 5)),
    "radtan": ("pinhole", (4, 5)),
    "radial-tangential": ("pinhole", (4, 5)),
    "rational_polynomial": ("pinhole", (8, 12, 14)),
    "opencv": ("pinhole", MODELS["pinhole"]),
    "pinhole": ("pinhole", MODELS["pinhole"]),
    "none": ("pinhole", (0,)),
    "equidistant": ("fisheye", (4,)),
    "fisheye": ("fisheye", (4,)),
    "kannala_brandt": ("fisheye", (4,)),
    "kannala-brandt": ("fisheye", (4,)),
    "omni": ("omni", (5,)),
    "mei": ("omni", (5,)),
}


def lens_model(name: Any, n: int, where: str) -> str:
    """The genie-gl lens model of a file's model name with ``n`` coefficients; an unknown
    name, or a count the model does not have, is refused by name."""
    key = str(name).strip().lower()
    if key not in LENS_NAMES:
        raise ConfigError(
            f"{where}: unknown lens model {name!r}; genie-gl reads {', '.join(sorted(LENS_NAMES))}"
        )
    model, counts = LENS_NAMES[key]
    if n not in counts and not (n == 0 and key != "none"):
        raise ConfigError(
            f"{where}: lens model {name!r} takes {' or '.join(map(str, counts))} coefficients, got "
            f"{n}"
        )
    return model


def matrix(value: Any, where: str, shape: tuple | None = None) -> np.ndarray:
    """``value`` (a nested list, an array, or ROS's ``{rows, cols, data}``) as a finite float
    array of ``shape``; a :class:`ConfigError` naming ``where`` otherwise."""
    if isinstance(value, dict):  # ROS style {rows, cols, data}
        try:
            a = np.asarray(value["data"], float).reshape(int(value["rows"]), int(value["cols"]))
        except (KeyError, ValueError, TypeError) as exc:
            raise ConfigError(f"{where}: malformed matrix ({exc})") from None
    else:
        try:
            a = np.asarray(value, float)
        except (ValueError, TypeError):
            raise ConfigError(f"{where}: expected numbers, got {str(value)[:60]!r}") from None
    if shape is not None and a.size == np.prod(shape):
        a = a.reshape(shape)
    if shape is not None and a.shape != shape:
        spelled = "x".join(map(str, shape)) + (" matrix" if len(shape) == 2 else " values")
        raise ConfigError(f"{where}: expected a {spelled}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{where}: contains NaN or Inf")
    return a


def _node(node: Any) -> Any:
    """An OpenCV FileNode as Python: a matrix as an array, maps and sequences as dicts and
    lists, numbers and strings as themselves."""
    if node.isMap():
        try:
            m = node.mat()
        except cv2.error:  # a map that is not an opencv-matrix
            m = None
        return m if m is not None else {k: _node(node.getNode(k)) for k in node.keys()}
    if node.isSeq():
        return [_node(node.at(i)) for i in range(node.size())]
    if node.isInt():
        return int(node.real())
    if node.isReal():
        return node.real()
    if node.isString():
        return node.string()
    return None


def read_filestorage(path: Any) -> dict:
    """The top-level fields of an OpenCV FileStorage file (YAML, XML or JSON)."""
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except cv2.error as exc:
        raise ConfigError(
            f"{path}: OpenCV cannot read this file ({str(exc).strip().splitlines()[-1][:120]})"
        ) from None
    if not fs.isOpened():
        raise ConfigError(f"{path}: OpenCV cannot read this file")
    try:
        root = fs.root()
        return {key: _node(fs.getNode(key)) for key in root.keys()}
    finally:
        fs.release()


class Fields:
    """A calibration file's top-level fields, looked up by any of a field's names; remembers
    which keys were read."""

    def __init__(self, data: dict, where: str) -> None:
        self.data, self.where = data, where
        self.keys: dict[str, str] = {}
        for key in data:
            self.keys.setdefault(norm(key), key)
        self.read: set[str] = set()

    def find(self, names: tuple[str, ...], accept=None) -> tuple[str | None, Any]:
        """(key, value) of the first of ``names`` present (and, with ``accept``, whose value it
        accepts); (None, None) when there is none."""
        for n in names:
            key = self.keys.get(n)
            if (
                key is not None
                and self.data[key] is not None
                and (accept is None or accept(self.data[key]))
            ):
                self.read.add(key)
                return key, self.data[key]
        return None, None

    def unread(self) -> list[str]:
        return [str(k) for k in self.data if k not in self.read]

    def near(self, names: tuple[str, ...]) -> str:
        """``" (the file's 'X' is not read: did you mean 'y'?)"`` for an unread key that looks
        like a misspelling of one of ``names``; ``""`` when none does."""
        for key in self.unread():
            close = difflib.get_close_matches(norm(key), names, n=1, cutoff=0.8)
            if close and len(norm(key)) > 3:
                return f" (the file's {key!r} is not read: did you mean {close[0]!r}?)"
        return ""

    def log_unread(self) -> None:
        left = self.unread()
        if left:
            logger.debug(
                "%s: fields not read (genie-gl needs none of them): %s", self.where, ", ".join(left)
            )


def is_matrix(n: int):
    """An ``accept`` for :meth:`Fields.find`: a value of ``n`` numbers (a matrix, a list, or
    ROS's ``{rows, cols, data}``), not a scalar nor a string."""

    def accept(value: Any) -> bool:
        if isinstance(value, dict):
            return "data" in value
        if isinstance(value, (str, bool, int, float)):
            return False
        try:
            return np.size(np.asarray(value, dtype=object)) == n if n else np.size(value) > 0
        except (TypeError, ValueError):
            return False

    return accept


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
