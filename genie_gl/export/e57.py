"""E57 (ASTM E2807), what mobile and terrestrial scanners export, written with ``pye57``
(FORMATS.md §8): one scan per pose, with the scan's pose in the file.

- A cloud (a chunk of a map, a merged cloud): one scan, cartesian X/Y/Z relative to the
  cloud's origin and the pose a translation to it (so pose · xyz is the world).
- A rig's recording: one scan per shot, its points in the camera's optical frame and the
  pose the camera's ``world_from_camera``; named ``<sensor> <time>``.

Colour is written where the frames carry it. E57 has no label field: ``intensity`` holds the
semantic class id (a scalar field every E57 viewer shows), and ``<file>.labels.npz`` beside
the file holds per scan ``semantic_K`` (uint16) and ``instance_K`` (uint32), K the scan's
index, in the scan's point order.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import os
import types
import uuid
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from ..cloud.pointcloud import PointCloud
from ..errors import ConfigError
from ..outputs import check_replaceable, written
from ..motion.trajectory import quaternion_xyzw
from .semantickitti_sequence import camera_points


def _pye57():
    try:
        import pye57
    except ImportError as exc:
        raise ConfigError(
            f"--format e57 needs the pye57 package: pip install 'genie-gl[sequences]' ({exc})"
        ) from None
    return pye57


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    x, y, z, w = quaternion_xyzw(R)
    return np.array([w, x, y, z])


@contextlib.contextmanager
def _guids(root: uuid.UUID, part: str):
    """pye57 gives the file and each scan a random ``uuid4``; within this block the k-th is
    ``uuid5(root, f"{part}.{k}")`` instead, so the same content gives the same bytes and
    other content other GUIDs."""
    module = _pye57().e57
    counter = itertools.count()
    saved = module.uuid
    module.uuid = types.SimpleNamespace(uuid4=lambda: uuid.uuid5(root, f"{part}.{next(counter)}"))
    try:
        yield
    finally:
        module.uuid = saved


def content_guid(*arrays: np.ndarray) -> uuid.UUID:
    """A GUID made from the bytes of ``arrays`` (the file's GUIDs derive from it)."""
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).view(np.uint8).reshape(-1))
    return uuid.UUID(bytes=h.digest()[:16], version=4)


class E57Writer:
    """Scans added one at a time; the file (and its labels) appear whole on :meth:`close`.
    ``key`` (a GUID made from the file's content, :func:`content_guid`) seeds the GUIDs the
    format asks for, so the same points give the same file."""

    def __init__(self, path: str | os.PathLike, key: uuid.UUID) -> None:
        self.path = Path(path)
        labels = self.path.with_name(self.path.name + ".labels.npz")
        check_replaceable(
            self.path, lambda p: labels_are_ours(labels), what="E57"
        )  # a user's file stays as it is
        check_replaceable(labels, labels_are_ours, what="E57 labels")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        self.key = key
        with _guids(key, "file"):
            self.e57 = _pye57().E57(str(self.tmp), mode="w")
        self.labels: dict[str, np.ndarray] = {}
        self.n = 0

    def add(
        self,
        xyz: np.ndarray,
        semantic: np.ndarray,
        instance: np.ndarray,
        world_from_scan: np.ndarray,
        *,
        rgb: np.ndarray | None = None,
        name: str | None = None,
    ) -> None:
        xyz = np.asarray(xyz, np.float64)
        data = {
            "cartesianX": np.ascontiguousarray(xyz[:, 0]),
            "cartesianY": np.ascontiguousarray(xyz[:, 1]),
            "cartesianZ": np.ascontiguousarray(xyz[:, 2]),
            "intensity": semantic.astype(np.float32),
            "cartesianInvalidState": np.zeros(len(xyz), np.int8),
        }
        if rgb is not None:
            data.update(
                colorRed=np.ascontiguousarray(rgb[:, 0]),
                colorGreen=np.ascontiguousarray(rgb[:, 1]),
                colorBlue=np.ascontiguousarray(rgb[:, 2]),
            )
        with _guids(self.key, f"scan {self.n}"):
            self.e57.write_scan_raw(
                data,
                name=name or f"scan {self.n}",
                rotation=_quat_wxyz(world_from_scan[:3, :3]),
                translation=np.asarray(world_from_scan[:3, 3], np.float64),
            )
        self.labels[f"semantic_{self.n}"] = semantic.astype(np.uint16)
        self.labels[f"instance_{self.n}"] = instance.astype(np.uint32)
        self.n += 1

    def close(self) -> Path:
        with written(self.path, self.tmp):
            self.e57.close()
            labels = self.path.with_name(self.path.name + ".labels.npz")
            tmp = labels.with_name(f".{labels.name}.{os.getpid()}.tmp.npz")
            with written(labels, tmp):
                np.savez(tmp, **self.labels)
                tmp.replace(labels)
            self.tmp.replace(self.path)
        return self.path

    def abort(self) -> None:
        """Drop what was written so far (nothing half-written is left)."""
        try:
            self.e57.close()
        except Exception:  # pye57 may refuse to close a file it failed to write
            pass
        self.tmp.unlink(missing_ok=True)


def labels_are_ours(path: Path) -> bool:
    """True when ``path`` is the labels file an :class:`E57Writer` wrote (its arrays only)."""
    with np.load(path) as z:
        return bool(z.files) and all(k.startswith(("semantic_", "instance_")) for k in z.files)


@contextlib.contextmanager
def e57_writer(path: str | os.PathLike, key: uuid.UUID) -> Iterator[E57Writer]:
    """An :class:`E57Writer` that leaves nothing behind when its scans fail half way."""
    w = E57Writer(path, key)
    try:
        yield w
    except BaseException:
        w.abort()
        raise


def cloud_pose(cloud: PointCloud) -> np.ndarray:
    pose = np.eye(4)
    pose[:3, 3] = cloud.origin
    return pose


def write(clouds: list[PointCloud], path: str | os.PathLike) -> Path:
    """``clouds`` as the scans of one E57 file (each posed at its origin)."""
    with e57_writer(
        path, content_guid(*(a for c in clouds for a in (c.xyz, c.semantic, c.instance)))
    ) as w:
        for k, c in enumerate(clouds):
            w.add(c.xyz, c.semantic, c.instance, cloud_pose(c), rgb=c.rgb, name=f"chunk {k}")
        return w.close()


def read(path: str | os.PathLike) -> list[PointCloud]:
    """The scans of an E57 file written here, as world-frame clouds (origin = the pose's
    translation; a rotated scan is turned into the world) with their labels."""
    e = _pye57().E57(str(path))
    labels = np.load(Path(path).with_name(Path(path).name + ".labels.npz"))
    out = []
    for k in range(e.scan_count):
        d = e.read_scan_raw(k)
        h = e.get_header(k)
        xyz = (
            np.stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]], 1)
            @ np.asarray(h.rotation_matrix).T
        )
        rgb = (
            np.stack([d["colorRed"], d["colorGreen"], d["colorBlue"]], 1).astype(np.uint8)
            if "colorRed" in d
            else None
        )
        out.append(
            PointCloud(
                xyz.astype(np.float32),
                labels[f"semantic_{k}"],
                labels[f"instance_{k}"],
                np.asarray(h.translation, np.float64),
                rgb,
            )
        )
    return out


def write_recording(rig, trajectory, recording, path: str | os.PathLike) -> Path:
    """A recording ((Shot, Frame) pairs) as one E57 file, a scan per shot in its optical frame."""
    key = content_guid(
        *(
            a
            for shot, frame in recording
            for a in (shot.world_from_camera, frame.depth, frame.instance)
        )
    )
    with e57_writer(path, key) as w:
        for shot, frame in recording:
            c = camera_points(frame)
            w.add(
                c.xyz,
                c.semantic,
                c.instance,
                shot.world_from_camera,
                rgb=c.rgb,
                name=f"{rig.sensors[shot.sensor].name} {shot.time_s - trajectory.start_s:.6f}",
            )
        return w.close()


def _write_scene(data, folder: Path) -> None:
    write([tile for _, tile in data.chunks], folder / "chunks.e57")


def _write_sequence(data, folder: Path) -> None:
    write_recording(data.rig, data.trajectory, data.recording, folder / "recording.e57")


def _write_cloud(
    cloud: PointCloud, out_dir: str | os.PathLike, *, name: str = "cloud", **_: object
) -> Path:
    return write([cloud], Path(out_dir) / f"{name}.e57")


from .registry import DatasetFormat, register_format  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "e57",
        "scenes",
        write_scene=_write_scene,
        write_cloud=_write_cloud,
        write_sequence=_write_sequence,
        cloud_outputs=lambda name: (f"{name}.e57", f"{name}.e57.labels.npz"),
        description="E57 (ASTM E2807) scans with their poses; labels in intensity and a "
        ".labels.npz beside",
    )
)
