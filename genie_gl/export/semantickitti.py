"""SemanticKITTI (FORMATS.md §1): ``sequences/NN/velodyne/NNNNNN.bin``, ``labels/NNNNNN.label``,
``poses.txt``, ``calib.txt``, ``times.txt``, and ``genie-gl.yaml``, a label map in the
semantic-kitti-api's own format (``labels``, ``color_map`` (BGR), ``content``,
``learning_map``, ``learning_map_inv``, ``learning_ignore``, ``split``).

Points are written in the scan frame: the cloud's own frame (world minus its origin), and the
scan's pose (``poses.txt``) is the translation to the origin, so ``pose @ xyz`` is the world.
Labels: ``(instance << 16) | semantic`` as little-endian uint32. Instance ids hold 16 bits:
a scan whose ids exceed 65535 is written with its ids renumbered 1..n in increasing order and
the table beside it (``instance_maps/NNNNNN.txt``: one ``scan_id original_id`` line per id);
more than 65535 instances in one scan is refused. Sequence folders are two digits (00-99), as
the API formats them.
"""

from __future__ import annotations

import math
import os
import re
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from .. import labels as label_map
from ..cloud.pointcloud import PointCloud
from ..errors import ExportError
from ..outputs import atomic_write_bytes, atomic_write_text, publish_folder, remove_files
from .registry import DatasetFormat, register_format

CLASSES = label_map.CLASSES  # kept for callers of genie-gl <= 0.1
COLORS_RGB = label_map.COLORS_RGB
MAX_SEQUENCES = 100  # '{:02d}'
MAX_ID16 = 0xFFFF


def label_map_yaml(
    counts: Mapping[int, int] | None = None, split: Mapping[str, Sequence[int]] | None = None
) -> str:
    """The label map in the API's format; ``counts``: points per class over the whole dataset
    (``content``), ``split``: sequence numbers of train/valid/test."""
    counts = {int(k): int(v) for k, v in (counts or {}).items()}
    ids = sorted(set(label_map.CLASSES) | set(counts))
    total = sum(counts.values()) or 1
    split = split or {"train": [], "valid": [], "test": []}
    data = {
        "name": "genie-gl",
        "labels": {k: label_map.name(k) for k in ids},
        "color_map": {k: list(label_map.color(k)[::-1]) for k in ids},  # BGR, as SemanticKITTI
        "content": {k: counts.get(k, 0) / total for k in ids},
        # raw id -> train id: the classes are already dense (0 = background, ignored)
        "learning_map": {k: k for k in ids},
        "learning_map_inv": {k: k for k in ids},
        "learning_ignore": {k: k == 0 for k in ids},
        "split": {s: [int(q) for q in split.get(s, [])] for s in ("train", "valid", "test")},
    }
    return yaml.safe_dump(data, sort_keys=False)


SPLITS = ("train", "valid", "test")


def split_sizes(n: int, ratios: Sequence[float] = (0.8, 0.1, 0.1)) -> list[int]:
    """How many of ``n`` sequences each split gets: as close to ``ratios`` as whole sequences
    allow (largest remainder, which minimises the total deviation; ties go to the earlier
    split). A split may get none when ``n`` is too small: see :func:`split_note`."""
    if len(ratios) != 3 or any(not math.isfinite(r) or r < 0 for r in ratios) or sum(ratios) <= 0:
        raise ExportError(
            f"split ratios {tuple(ratios)}: expected three numbers >= 0 (train, valid, test), not "
            "all 0"
        )
    exact = [n * r / sum(ratios) for r in ratios]
    sizes = [math.floor(e) for e in exact]
    for i in sorted(range(3), key=lambda i: (sizes[i] - exact[i], i))[: n - sum(sizes)]:
        sizes[i] += 1
    return sizes


def split_sequences(n: int, ratios: Sequence[float] = (0.8, 0.1, 0.1)) -> dict[str, list[int]]:
    """Sequences 0..n-1 into train/valid/test, contiguous in that order (as KITTI's), sized by
    :func:`split_sizes`: every sequence in exactly one split, never two."""
    out, start = {}, 0
    for name, size in zip(SPLITS, split_sizes(n, ratios)):
        out[name] = list(range(start, start + size))
        start += size
    return out


def split_note(n: int, ratios: Sequence[float] = (0.8, 0.1, 0.1)) -> str | None:
    """What a user must be told about the split of ``n`` sequences: the splits asked for (a
    share above 0) that get no sequence, and how many sequences would give each one; None
    when every such split gets at least one."""
    sizes = split_sizes(n, ratios)
    empty = [SPLITS[i] for i in range(3) if ratios[i] > 0 and sizes[i] == 0]
    if not empty:
        return None
    need = next(
        (
            m
            for m in range(n + 1, 100_000)
            if all(s > 0 or r == 0 for s, r in zip(split_sizes(m, ratios), ratios))
        ),
        None,
    )
    shares = ",".join(f"{r:g}" for r in ratios)
    got = ", ".join(f"{name} {size}" for name, size in zip(SPLITS, sizes))
    more = f"; {need} sequences would give every split one" if need else ""
    return (
        f"--split {shares}: {n} sequence{'s are' if n != 1 else ' is'} too few for these shares: "
        f"{' and '.join(empty)} get{'s' * (len(empty) == 1)} none, the rest is in train ({got}"
        f"){more}"
    )


def encode_instances(instance: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """16-bit instance ids of a scan, and the table (original ids, index = scan id - 1) when
    they had to be renumbered; None when every id fits."""
    instance = np.asarray(instance)
    if not len(instance) or int(instance.max()) <= MAX_ID16:
        return instance.astype(np.uint32), None
    ids, inverse = np.unique(instance, return_inverse=True)
    nonzero = ids[ids != 0]
    if len(nonzero) > MAX_ID16:
        raise ExportError(
            f"SemanticKITTI labels hold 16-bit instance ids: a scan has {len(nonzero)} instances "
            f"(limit {MAX_ID16}); use smaller chunks, or the ply/npz formats (32-bit ids)"
        )
    scan_ids = np.arange(len(ids), dtype=np.uint32) + (0 if ids[0] == 0 else 1)
    return scan_ids[inverse.ravel()], nonzero


def pack_labels(semantic: np.ndarray, instance: np.ndarray) -> np.ndarray:
    """``(instance << 16) | semantic`` as '<u4'; an id that does not fit its 16 bits is refused."""
    semantic, instance = np.asarray(semantic), np.asarray(instance)
    for what, a in (("semantic", semantic), ("instance", instance)):
        if a.size and int(a.max()) > MAX_ID16:
            raise ExportError(
                f"SemanticKITTI labels hold 16-bit {what} ids (limit {MAX_ID16}), got "
                f"{int(a.max())}"
                + ("; renumber the scan's ids with encode_instances" if what == "instance" else "")
            )
    return (instance.astype(np.uint32) << 16 | semantic.astype(np.uint32)).astype("<u4")


def _fmt(values) -> str:
    return " ".join(f"{float(v):.12e}" for v in values)


def write_scans(
    clouds: Sequence[PointCloud],
    seq_dir: str | os.PathLike,
    *,
    times: Sequence[float] | None = None,
) -> list[Path]:
    """Write ``clouds`` as scans 0..n-1 of one sequence folder (velodyne, labels, poses, times,
    calib; instance tables where needed); returns the .bin paths."""
    seq = Path(seq_dir)
    paths, poses = [], []
    for j, cloud in enumerate(clouds):
        paths.append(_write_scan(cloud, seq, j))
        pose = np.eye(4)[:3]
        pose[:, 3] = cloud.origin
        poses.append(_fmt(pose.ravel()))
    times = list(range(len(clouds))) if times is None else times
    atomic_write_text(seq / "poses.txt", "".join(p + "\n" for p in poses))
    atomic_write_text(seq / "times.txt", "".join(f"{float(t):e}\n" for t in times))
    eye = _fmt(np.eye(4)[:3].ravel())
    atomic_write_text(
        seq / "calib.txt", "".join(f"{k}: {eye}\n" for k in ("P0", "P1", "P2", "P3", "Tr"))
    )
    return paths


def _write_scan(cloud: PointCloud, seq: Path, frame: int) -> Path:
    scan = np.zeros((len(cloud), 4), "<f4")
    scan[:, :3] = cloud.xyz
    if (
        cloud.intensity is not None
    ):  # a scanner's reflectivity, 0-1 as KITTI's remission (LIDAR.md §9.5)
        scan[:, 3] = cloud.intensity
    inst, table = encode_instances(cloud.instance)
    bin_path = atomic_write_bytes(seq / "velodyne" / f"{frame:06d}.bin", scan.tobytes())
    atomic_write_bytes(
        seq / "labels" / f"{frame:06d}.label", pack_labels(cloud.semantic, inst).tobytes()
    )
    table_path = seq / "instance_maps" / f"{frame:06d}.txt"
    if table is not None:
        atomic_write_text(table_path, "".join(f"{i + 1} {int(v)}\n" for i, v in enumerate(table)))
    elif table_path.exists():
        table_path.unlink()
    return bin_path


def write(
    cloud: PointCloud,
    out_dir: str | os.PathLike,
    *,
    sequence: int = 0,
    frame: int = 0,
    time_s: float | None = None,
) -> Path:
    """Put ``cloud`` as scan ``frame`` of ``sequence`` under ``out_dir`` (other scans of the
    sequence are kept); writes ``genie-gl.yaml`` (content: this scan) when there is none.
    Returns the .bin path."""
    if not 0 <= sequence < MAX_SEQUENCES:
        raise ExportError(f"SemanticKITTI sequence {sequence}: folders are two digits, 00-99")
    root = Path(out_dir)
    seq = root / "sequences" / f"{sequence:02d}"
    bin_path = _write_scan(cloud, seq, frame)
    pose = np.eye(4)[:3]
    pose[:, 3] = cloud.origin
    for name, line in (
        ("poses.txt", _fmt(pose.ravel())),
        ("times.txt", f"{(frame if time_s is None else time_s):e}"),
    ):
        p = seq / name
        old = p.read_text().splitlines() if p.exists() else []
        old = (old + [""] * (frame + 1))[: max(len(old), frame + 1)]
        old[frame] = line
        atomic_write_text(p, "\n".join(old) + "\n")
    eye = _fmt(np.eye(4)[:3].ravel())
    atomic_write_text(
        seq / "calib.txt", "".join(f"{k}: {eye}\n" for k in ("P0", "P1", "P2", "P3", "Tr"))
    )
    cfg = root / "genie-gl.yaml"
    if not cfg.exists():
        counts = dict(zip(*np.unique(cloud.semantic, return_counts=True)))
        atomic_write_text(
            cfg, label_map_yaml(counts, {"train": [sequence], "valid": [], "test": []})
        )
    return bin_path


def read(bin_path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a scan back as the SemanticKITTI API does: (xyz, semantic, instance), with the
    scan's renumbered instance ids turned back into the original ones when it has a table."""
    bin_path = Path(bin_path)
    scan = np.fromfile(bin_path, dtype="<f4").reshape(-1, 4)
    label = np.fromfile(bin_path.parent.parent / "labels" / (bin_path.stem + ".label"), dtype="<u4")
    inst = label >> 16
    table = bin_path.parent.parent / "instance_maps" / (bin_path.stem + ".txt")
    if table.exists():
        lut = np.zeros(MAX_ID16 + 1, np.uint32)
        for line in table.read_text().splitlines():
            a, b = line.split()
            lut[int(a)] = int(b)
        inst = lut[inst]
    return scan[:, :3], label & 0xFFFF, inst


# --- the dataset format: each scene is one sequence's worth of scans in DIR/scenes/NNNN;
# once every scene is there the sequences are assembled (hard links) into DIR/sequences/NN,
# several scenes to a sequence past 100 scenes, with the label map and split over them all.


def _link(src: Path, dst: Path) -> None:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


#: the files genie-gl writes in a sequence folder (relative paths); a user's own files there
#: (a model's ``predictions/``, notes) are never replaced or removed
SEQUENCE_FILE = re.compile(
    r"(velodyne/\d{6}\.bin|labels/\d{6}\.label|instance_maps/\d{6}\.txt"
    r"|poses\.txt|times\.txt|calib\.txt|world_pose\.txt)"
)


def sequence_files(folder: Path) -> list[str]:
    """The files of sequence ``folder`` that genie-gl wrote (:data:`SEQUENCE_FILE`)."""
    if not folder.is_dir() or folder.is_symlink():
        return []
    return [
        rel
        for rel in (p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
        if SEQUENCE_FILE.fullmatch(rel)
    ]


def scenes_per_sequence(n_scenes: int) -> int:
    return max(1, -(-n_scenes // MAX_SEQUENCES))


def assemble_sequences(
    out: str | os.PathLike,
    scene_dirs: Sequence[Path],
    *,
    counts: Mapping[int, int] | None = None,
    split: Sequence[float] = (0.8, 0.1, 0.1),
) -> dict[int, list[int]]:
    """Build ``sequences/NN`` from the scenes' scan folders (in order, several to a sequence
    past 100) and ``genie-gl.yaml``; returns {sequence: [scene indices]}."""
    root = Path(out) / "sequences"
    root.mkdir(parents=True, exist_ok=True)
    per = scenes_per_sequence(len(scene_dirs))
    groups = {
        s: list(range(s * per, min(len(scene_dirs), (s + 1) * per)))
        for s in range(-(-len(scene_dirs) // per))
    }
    for s, members in groups.items():
        tmp = root / f".tmp-{s:02d}-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        for sub in ("velodyne", "labels"):
            (tmp / sub).mkdir(parents=True)
        poses: list[str] = []
        for i in members:
            src = Path(scene_dirs[i])
            lines = (
                (src / "poses.txt").read_text().splitlines() if (src / "poses.txt").exists() else []
            )
            for j, pose in enumerate(lines):
                k = len(poses)
                _link(src / "velodyne" / f"{j:06d}.bin", tmp / "velodyne" / f"{k:06d}.bin")
                _link(src / "labels" / f"{j:06d}.label", tmp / "labels" / f"{k:06d}.label")
                table = src / "instance_maps" / f"{j:06d}.txt"
                if table.exists():
                    (tmp / "instance_maps").mkdir(exist_ok=True)
                    _link(table, tmp / "instance_maps" / f"{k:06d}.txt")
                poses.append(pose)
        (tmp / "poses.txt").write_text("".join(p + "\n" for p in poses))
        (tmp / "times.txt").write_text("".join(f"{float(t):e}\n" for t in range(len(poses))))
        eye = _fmt(np.eye(4)[:3].ravel())
        (tmp / "calib.txt").write_text(
            "".join(f"{k}: {eye}\n" for k in ("P0", "P1", "P2", "P3", "Tr"))
        )
        final = root / f"{s:02d}"
        publish_folder(tmp, final, previous=sequence_files(final))  # a user's files there stay
    for old in root.iterdir():  # sequences of an earlier, larger grouping: genie-gl's files go
        if (
            old.name.isdigit()
            and int(old.name) not in groups
            and old.is_dir()
            and not old.is_symlink()
        ):
            remove_files(old, sequence_files(old))
    atomic_write_text(
        Path(out) / "genie-gl.yaml", label_map_yaml(counts, split_sequences(len(groups), split))
    )
    return groups


def _write_scene(data, folder: Path) -> None:
    write_scans([tile for _, tile in data.chunks], folder)


def _finish(out: Path, cfg, stats: list[dict]) -> None:
    counts: dict[int, int] = {}
    for s in stats:
        for k, v in s["class_points"].items():
            counts[int(k)] = counts.get(int(k), 0) + int(v)
    groups = assemble_sequences(
        out,
        [DATASET.scene_dir(out, i) for i in range(len(stats))],
        counts=counts,
        split=tuple(cfg.split) if cfg is not None else (0.8, 0.1, 0.1),
    )
    for s in stats:
        s["sequence"] = next(q for q, members in groups.items() if s["scene"] in members)


def _notes(cfg) -> list[str]:
    """Before a dataset run: a split that cannot give every asked split a sequence."""
    n = -(-cfg.scenes // scenes_per_sequence(cfg.scenes))
    note = split_note(n, tuple(cfg.split))
    return [f"--scenes {cfg.scenes}: {note}"] if note else []


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, sequence: int = 0, frame: int = 0, **_: object
) -> Path:
    return write(cloud, out_dir, sequence=sequence, frame=frame)


DATASET = register_format(
    DatasetFormat(
        "semantickitti",
        "scenes",
        colour=False,
        write_scene=_write_scene,
        finish=_finish,
        write_cloud=_write_cloud,
        stale=("sequences",),
        cloud_outputs=lambda name: ("sequences", "genie-gl.yaml"),
        dataset_outputs=("sequences", "genie-gl.yaml"),
        notes=_notes,
        bytes_per_point=16,
        description="SemanticKITTI sequences (scans, labels, poses, label-map YAML)",
    )
)
