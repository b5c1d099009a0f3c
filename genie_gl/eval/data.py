"""Reading labelled point-cloud datasets for training and testing: genie-gl's own outputs
(SemanticKITTI with its yaml, PLY, NPZ) and any SemanticKITTI-layout set with its yaml.

A dataset is named by its folder, optionally with a part of it: ``DIR`` (every sequence or
scene), ``DIR:train`` / ``DIR:valid`` / ``DIR:test`` (the yaml's ``split``), ``DIR:00,03``
(those sequences or scenes). Each scan is read into a :class:`Scan` in the world frame
(SemanticKITTI: ``inv(Tr) · pose · Tr`` applied to the scan, as the API's
``generate_sequential`` does), its labels mapped to our classes (:mod:`.labelmap`), and its
floor height known (genie-gl data: z = 0, DESIGN.md) or estimated (a foreign set: the 1st
percentile of the scan's z).
"""

from __future__ import annotations

import hashlib
import logging
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from ..errors import ConfigError
from . import labelmap
from .labelmap import LabelMap

log = logging.getLogger(__name__)
FLOOR_PERCENTILE = 1.0  # a foreign scan's floor: this percentile of its z
OUR_YAML = "genie-gl.yaml"


@dataclass(frozen=True, eq=False)
class Scan:
    """One labelled scan (a SemanticKITTI scan, or a PLY/NPZ chunk).

    Attributes
    ----------
    xyz : (N, 3) float32
        World frame relative to ``origin``, metres, z up.
    origin : (3,) float64
        World position of xyz = 0.
    label : (N,) int16
        Our class ids (``genie_gl.labels``); -1 = unlabelled (left out).
    floor_z : float
        World z of the floor under the scan, metres.
    key : str
        Where in its dataset: ``sequences/03/000012`` or ``scenes/0002/cloud_004``.
    path : str
        The file holding the points.
    """

    xyz: np.ndarray
    origin: np.ndarray
    label: np.ndarray
    floor_z: float
    key: str
    path: str

    def __post_init__(self) -> None:
        n = len(self.xyz)
        if self.xyz.shape != (n, 3) or self.xyz.dtype != np.float32:
            raise ConfigError(
                f"{self.path}: points must be (N, 3) float32, got {self.xyz.shape} {self.xyz.dtype}"
            )
        if self.label.shape != (n,):
            raise ConfigError(f"{self.path}: {len(self.label)} labels for {n} points")
        bad = ~np.isfinite(self.xyz).all(axis=1)
        if bad.any():  # NaN or infinite coordinates crash the feature workers: refuse them here
            raise ConfigError(
                f"{self.path}: {int(bad.sum())} of {n} points have coordinates that are not finite "
                f"(NaN or infinite; the first is point {int(np.argmax(bad))}); expected finite x, "
                "y, z"
            )

    @property
    def height(self) -> np.ndarray:
        """(N,) float32: height above the floor, metres."""
        return (self.xyz[:, 2] + np.float32(self.origin[2] - self.floor_z)).astype(np.float32)

    def __len__(self) -> int:
        return len(self.xyz)

    @property
    def digest(self) -> str:
        """SHA-256 (hex) of the scan's points as read: in the world frame (so of the scan file,
        its pose and its calibration), with their origin and floor height; everything a
        point's features depend on. Two scans of one digest are the same points, wherever
        their files lie (their labels aside)."""
        cached = self.__dict__.get("_digest")
        if cached is None:
            h = hashlib.sha256()
            h.update(np.ascontiguousarray(self.xyz, np.float32).tobytes())
            h.update(np.asarray(self.origin, np.float64).tobytes())
            h.update(np.float64(self.floor_z).tobytes())
            cached = h.hexdigest()
            object.__setattr__(self, "_digest", cached)
        return cached


@dataclass(frozen=True, eq=False)
class EvalSet:
    """A dataset read for evaluation.

    Attributes
    ----------
    root : Path
    spec : str
        As given (``DIR``, ``DIR:test``, ...).
    format : str
        ``semantickitti``, ``ply`` or ``npz``.
    scans : tuple[Scan, ...]
    label_map : LabelMap
        How its raw labels became our classes (predictions are written back through it).
    names : dict[int, str]
        Class names by id, as the set's yaml has them (genie-gl's for PLY/NPZ).
    """

    root: Path
    spec: str
    format: str
    scans: tuple[Scan, ...]
    label_map: LabelMap
    names: dict[int, str]

    @property
    def n_points(self) -> int:
        return sum(len(s) for s in self.scans)

    def counts(self, n_classes: int) -> np.ndarray:
        """(n_classes,) int64 labelled points per class."""
        out = np.zeros(n_classes, np.int64)
        for s in self.scans:
            lab = s.label[s.label >= 0].astype(np.int64)
            out += np.bincount(lab, minlength=n_classes)[:n_classes]
        return out

    def max_class(self) -> int:
        return max((int(s.label.max()) for s in self.scans if len(s)), default=-1)


def parse_spec(spec: str | os.PathLike) -> tuple[Path, str | None]:
    """``DIR[:PART]`` -> (DIR, PART or None); a colon inside an existing path is part of it."""
    text = str(spec)
    if Path(text).exists() or ":" not in text:
        return Path(text), None
    root, part = text.rsplit(":", 1)
    return Path(root), part.strip() or None


def detect_format(root: Path) -> str:
    """The format of a dataset folder, or a one-line error naming what it is instead."""
    if not root.exists():
        raise ConfigError(f"{root}: no such dataset folder")
    if not root.is_dir():
        raise ConfigError(f"{root}: expected a dataset folder (sequences/ or scenes/), got a file")
    if (root / "sequences").is_dir():
        return "semantickitti"
    if (root / "train_pbr").is_dir() or (root / "scene_camera.json").exists():
        raise ConfigError(
            f"{root}: a BOP image dataset (RGB-D frames), not labelled point clouds; "
            "make the dataset with --format semantickitti, ply or npz"
        )
    scenes = root / "scenes"
    for ext in ("ply", "npz"):
        if scenes.is_dir() and next(scenes.glob(f"*/cloud_*.{ext}"), None) is not None:
            return ext
    if scenes.is_dir() and next(scenes.glob("*/cloud_*.pcd"), None) is not None:
        raise ConfigError(
            f"{root}: PCD clouds are not read for evaluation; make the dataset with "
            "--format semantickitti, ply or npz"
        )
    if (root / "velodyne").is_dir():
        raise ConfigError(
            f"{root}: a single sequence folder; give the dataset root (the folder holding "
            f"sequences/), with :{root.name} to choose this sequence"
        )
    raise ConfigError(
        f"{root}: not a dataset genie eval reads (expected sequences/ with a label-map yaml, "
        "or scenes/NNNN/cloud_*.ply|npz)"
    )


def _find_yaml(root: Path) -> Path:
    if (root / OUR_YAML).exists():
        return root / OUR_YAML
    found = sorted(root.glob("*.yaml")) + sorted((root / "config").glob("*.yaml"))
    if not found:
        raise ConfigError(
            f"{root}: a SemanticKITTI layout needs its label-map yaml (labels, learning_map) "
            f"beside sequences/; none found"
        )
    return found[0]


def _read_yaml(path: Path) -> dict:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{path}: cannot read the label-map yaml (not a text file: byte {exc.start} is not "
            "UTF-8)"
        ) from None
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(
            f"{path}: cannot read the label-map yaml ({str(exc).splitlines()[0]})"
        ) from None
    if not isinstance(data, dict) or not isinstance(data.get("labels"), dict):
        raise ConfigError(
            f"{path}: a SemanticKITTI label-map yaml needs 'labels: {{raw id: name}}'"
        )
    bad = [
        k
        for k in data["labels"]
        if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < labelmap.RAW_IDS
    ]
    if bad:
        raise ConfigError(
            f"{path}: labels: {bad[0]!r} is not a raw id; expected whole numbers in "
            f"0..{labelmap.RAW_IDS - 1}"
        )
    return data


def _text_lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{path}: not a text file (byte {exc.start} is not UTF-8); expected lines of 12 "
            "numbers (a 3x4 matrix)"
        ) from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from None


def _matrix(text: str, where: str) -> np.ndarray:
    """A 3x4 matrix (12 numbers) as a 4x4 one; ``where`` names the file, line and field."""
    try:
        v = np.array([float(x) for x in text.split()], np.float64)
    except ValueError as exc:
        word = str(exc).rsplit(":", 1)[-1].strip()
        raise ConfigError(
            f"{where}: {word} is not a number; expected 12 numbers (a 3x4 matrix)"
        ) from None
    if v.size != 12:
        raise ConfigError(f"{where}: expected 12 numbers (a 3x4 matrix), got {v.size}")
    if not np.isfinite(v).all():
        raise ConfigError(
            f"{where}: number {int(np.argmin(np.isfinite(v))) + 1} of 12 is {v[~np.isfinite(v)][0]}"
            "; "
            "expected 12 finite numbers (a 3x4 matrix)"
        )
    m = np.eye(4)
    m[:3] = v.reshape(3, 4)
    return m


def _matrices(path: Path) -> list[np.ndarray]:
    """The poses of ``poses.txt``, one 3x4 matrix a line (blank lines skipped)."""
    rows = []
    for i, line in enumerate(_text_lines(path), 1):
        line = line.split(":", 1)[1] if ":" in line else line
        if line.strip():
            rows.append(_matrix(line, f"{path}: line {i}"))
    return rows


def _calib_tr(seq: Path) -> np.ndarray:
    calib = seq / "calib.txt"
    if not calib.exists():
        return np.eye(4)
    for i, line in enumerate(_text_lines(calib), 1):
        if line.startswith("Tr:"):
            tr = _matrix(line.split(":", 1)[1], f"{calib}: line {i} (Tr)")
            if abs(np.linalg.det(tr[:3, :3])) < 1e-9:
                raise ConfigError(
                    f"{calib}: line {i} (Tr): a singular matrix (its rotation has determinant 0); "
                    "expected the velodyne-to-camera transform"
                )
            return tr
    return np.eye(4)


def _select(names: list[str], part: str | None, split: dict | None, where: Path) -> list[str]:
    if part is None:
        return names
    if part in ("train", "valid", "test"):
        if not split or part not in split:
            raise ConfigError(f"{where}:{part}: the yaml has no split {part!r}")
        chosen = [f"{int(s):02d}" for s in split[part]]
        return [n for n in names if n in chosen]
    wanted = [p.strip() for p in part.split(",") if p.strip()]
    if not wanted or not all(w.isdigit() for w in wanted):
        raise ConfigError(
            f"{where}:{part}: expected train, valid, test or a list of numbers such as 00,03"
        )
    width = len(names[0]) if names else 2
    chosen = [f"{int(w):0{width}d}" for w in wanted]
    missing = [c for c in chosen if c not in names]
    if missing:
        raise ConfigError(
            f"{where}:{part}: no {missing[0]} here (there are {', '.join(names[:8])}"
            f"{' ...' if len(names) > 8 else ''})"
        )
    return chosen


def _floor(world_z: np.ndarray, ours: bool) -> float:
    if ours or not world_z.size:
        return 0.0
    return float(np.percentile(world_z, FLOOR_PERCENTILE))


def _read_semantickitti(root: Path, part: str | None, mapping: str | os.PathLike | None) -> tuple:
    ypath = _find_yaml(root)
    data = _read_yaml(ypath)
    their = {int(k): str(v) for k, v in data["labels"].items()}
    ours = str(data.get("name", "")) == "genie-gl" or ypath.name == OUR_YAML
    if mapping is not None:  # the user's map, for their set or to ignore ids in one of ours
        lmap = labelmap.load(mapping, their)
    elif ours:  # genie-gl's own classes: the ids its yaml names, and no other
        lmap = labelmap.identity(
            {k: v for k, v in their.items() if k > 9}, only=their, source=str(ypath)
        )
        labelmap.check_same_classes(
            their, str(ypath), labelmap.identity().names, "genie-gl's classes"
        )
    else:
        try:
            labelmap.check_same_classes(
                their, str(ypath), labelmap.identity().names, "genie-gl's classes"
            )
        except ConfigError:
            raise ConfigError(
                f"{ypath}: this set's classes are not genie-gl's (e.g. {next(iter(their.items()))}"
                "); "
                "give --label-map FILE mapping their classes to ours"
            ) from None
        lmap = labelmap.identity(their, only=their, source=str(ypath))
    seq_root = root / "sequences"
    names = sorted(p.name for p in seq_root.iterdir() if p.is_dir() and p.name.isdigit())
    scans = []
    for name in _select(names, part, data.get("split"), root):
        seq = seq_root / name
        bins = sorted((seq / "velodyne").glob("*.bin"))
        if bins and not (seq / "labels").is_dir():
            raise ConfigError(
                f"{seq}: unlabelled sequence (velodyne/ but no labels/): cannot train or test on it"
            )
        poses = _matrices(seq / "poses.txt") if (seq / "poses.txt").exists() else []
        tr = _calib_tr(seq)
        tr_inv = np.linalg.inv(tr)
        for b in bins:
            lab_path = seq / "labels" / (b.stem + ".label")
            if not lab_path.exists():
                raise ConfigError(f"{lab_path}: missing (every scan needs its labels)")
            pts = np.fromfile(b, dtype="<f4")
            if pts.size % 4:
                raise ConfigError(
                    f"{b}: size {pts.size * 4} bytes is not a whole number of (x, y, z, remission) "
                    "records"
                )
            pts = pts.reshape(-1, 4)[:, :3]
            raw = np.fromfile(lab_path, dtype="<u4")
            if len(raw) != len(pts):
                raise ConfigError(
                    f"{lab_path}: {len(raw)} labels for {len(pts)} points in {b.name}"
                )
            k = int(b.stem)
            if poses and k >= len(poses):
                raise ConfigError(
                    f"{seq / 'poses.txt'}: {len(poses)} poses, but scan {b.name} needs line {k + 1}"
                    "; "
                    "expected one pose per scan"
                )
            pose = tr_inv @ poses[k] @ tr if k < len(poses) else np.eye(4)
            # world = R xyz + t; keep float32 relative to the translation
            rot, origin = pose[:3, :3], pose[:3, 3].copy()
            xyz = (
                pts
                if np.allclose(rot, np.eye(3))
                else (pts.astype(np.float64) @ rot.T).astype(np.float32)
            )
            label = lmap.apply(raw & 0xFFFF, str(lab_path))
            world_z = xyz[:, 2].astype(np.float64) + origin[2]
            scans.append(
                Scan(
                    xyz=np.ascontiguousarray(xyz, np.float32),
                    origin=origin,
                    label=label,
                    floor_z=_floor(world_z, ours),
                    key=f"sequences/{name}/{b.stem}",
                    path=str(b),
                )
            )
    names_out = dict(lmap.names)
    return scans, lmap, names_out


_PLY_TYPES = {
    "float": "<f4",
    "float32": "<f4",
    "double": "<f8",
    "uchar": "u1",
    "uint8": "u1",
    "char": "i1",
    "short": "<i2",
    "ushort": "<u2",
    "int": "<i4",
    "int32": "<i4",
    "uint": "<u4",
    "uint32": "<u4",
}


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xyz float32 (N, 3), semantic (N,), origin (3,)) of a binary little-endian PLY with
    ``x y z`` and ``semantic`` vertex properties, as ``genie_gl.export.ply`` writes them."""
    raw = path.read_bytes()
    end = raw.find(b"end_header\n")
    if not raw.startswith(b"ply") or end < 0:
        raise ConfigError(f"{path}: not a PLY file")
    header = raw[:end].decode("ascii", "replace").splitlines()
    if "format binary_little_endian 1.0" not in header:
        raise ConfigError(f"{path}: only binary little-endian PLY is read (genie-gl writes it)")
    fields, n, origin, in_vertex = [], 0, np.zeros(3), False
    for i, line in enumerate(header, 1):
        parts = line.split()
        try:
            if parts[:2] == ["comment", "origin"]:
                origin = np.array([float(x) for x in parts[2:5]])
                if origin.shape != (3,) or not np.isfinite(origin).all():
                    raise ValueError(
                        f"expected three finite numbers, got {' '.join(parts[2:])!r:.60}"
                    )
            elif parts[:1] == ["element"]:
                in_vertex = len(parts) > 1 and parts[1] == "vertex"
                if in_vertex:
                    n = int(parts[2])
                    if n < 0:
                        raise ValueError(f"a count of {n}")
            elif parts[:1] == ["property"] and in_vertex:
                if parts[1] not in _PLY_TYPES:
                    raise ConfigError(f"{path}: vertex property type {parts[1]!r} not read")
                fields.append((parts[2], _PLY_TYPES[parts[1]]))
        except (ValueError, IndexError) as exc:
            raise ConfigError(f"{path}: header line {i} ({line.strip()!r:.60}): {exc}") from None
    names = [f for f, _ in fields]
    if "semantic" not in names or not {"x", "y", "z"} <= set(names):
        raise ConfigError(
            f"{path}: unlabelled cloud (expected vertex properties x, y, z and semantic; "
            f"got {', '.join(names)})"
        )
    dtype = np.dtype(fields)
    body = len(raw) - end - len(b"end_header\n")
    if body < n * dtype.itemsize:
        raise ConfigError(
            f"{path}: truncated: {body} bytes of vertex data for the {n} vertices of "
            f"{dtype.itemsize} bytes its header announces"
        )
    rec = np.frombuffer(raw, dtype=dtype, count=n, offset=end + len(b"end_header\n"))
    xyz = np.stack([rec["x"], rec["y"], rec["z"]], 1).astype(np.float32)
    return xyz, rec["semantic"].astype(np.int64), origin


def _read_npz(f: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(xyz float32 (N, 3), semantic (N,) int64, origin (3,)) of a cloud as
    ``genie_gl.export.npz`` writes it; a file numpy cannot read, labels that are not whole
    numbers or an origin that is not three finite numbers is one line naming the file."""
    try:
        with np.load(f, allow_pickle=False) as z:
            if "semantic" not in z.files or "xyz" not in z.files:
                raise ConfigError(
                    f"{f}: unlabelled cloud (expected arrays xyz and semantic; got "
                    f"{', '.join(z.files)})"
                )
            xyz, sem = z["xyz"], z["semantic"]
            origin = z["origin"] if "origin" in z.files else np.zeros(3)
    except (OSError, ValueError, EOFError) as exc:  # not a .npz, truncated, or object arrays
        raise ConfigError(
            f"{f}: not a readable NPZ cloud ({str(exc).splitlines()[0][:80]})"
        ) from None
    if sem.dtype.kind not in "iub":
        raise ConfigError(
            f"{f}: semantic is {sem.dtype}; expected whole class ids (an integer array)"
        )
    origin = np.asarray(origin, np.float64)
    if origin.shape != (3,) or not np.isfinite(origin).all():
        raise ConfigError(f"{f}: origin {origin.tolist()!r:.60}: expected three finite numbers")
    return xyz.astype(np.float32), sem.astype(np.int64), origin


def _read_chunks(root: Path, fmt: str, part: str | None) -> tuple:
    scene_dirs = sorted(
        p.name for p in (root / "scenes").iterdir() if p.is_dir() and p.name.isdigit()
    )
    lmap = labelmap.identity()
    scans = []
    for name in _select(scene_dirs, part, None, root):
        for f in sorted((root / "scenes" / name).glob(f"cloud_*.{fmt}")):
            if fmt == "ply":
                xyz, sem, origin = read_ply(f)
            else:
                xyz, sem, origin = _read_npz(f)
            if sem.size and (sem.min() < 0 or sem.max() >= labelmap.RAW_IDS):
                raise ConfigError(
                    f"{f}: label {int(sem.min() if sem.min() < 0 else sem.max())} is outside "
                    f"0..{labelmap.RAW_IDS - 1}"
                )
            scans.append(
                Scan(
                    xyz=np.ascontiguousarray(xyz),
                    origin=origin,
                    label=lmap.apply(sem, str(f)),
                    floor_z=0.0,
                    key=f"scenes/{name}/{f.stem}",
                    path=str(f),
                )
            )
    return scans, lmap, dict(lmap.names)


def read_set(spec: str | os.PathLike, *, label_map: str | os.PathLike | None = None) -> EvalSet:
    """Read a dataset (``DIR`` or ``DIR:PART``) for training or testing.

    Parameters
    ----------
    spec : str or path
        The dataset folder, optionally ``:train``, ``:valid``, ``:test`` or ``:00,03``.
    label_map : path, optional
        A label-map file from the set's raw classes to ours (required for a foreign
        SemanticKITTI set whose classes are not genie-gl's).

    Raises
    ------
    ConfigError
        A folder of another format, an unlabelled or empty set, a label outside the map.
    """
    root, part = parse_spec(spec)
    fmt = detect_format(root)
    if fmt == "semantickitti":
        scans, lmap, names = _read_semantickitti(root, part, label_map)
    else:
        if label_map is not None:
            log.warning(
                "%s: --label-map %s is not used: it applies to SemanticKITTI sets; %s holds "
                "genie-gl's "
                "classes",
                spec,
                label_map,
                fmt,
            )
        scans, lmap, names = _read_chunks(root, fmt, part)
    scans = [s for s in scans if len(s)]
    if not scans:
        raise ConfigError(f"{spec}: empty set (no scan with points{' in ' + part if part else ''})")
    if not any((s.label >= 0).any() for s in scans):
        raise ConfigError(
            f"{spec}: unlabelled set (every point maps to ignore): nothing to train or test on"
        )
    log.info("%s: %d scans, %d points (%s)", spec, len(scans), sum(len(s) for s in scans), fmt)
    return EvalSet(
        root=root, spec=str(spec), format=fmt, scans=tuple(scans), label_map=lmap, names=names
    )


_SCENE_RE = re.compile(r"^(sequences|scenes)/(\d+)/")


def group_of(scan: Scan) -> str:
    """The sequence or scene a scan belongs to (``sequences/03``), for splits by scene."""
    m = _SCENE_RE.match(scan.key)
    return m.group(0).rstrip("/") if m else scan.key
