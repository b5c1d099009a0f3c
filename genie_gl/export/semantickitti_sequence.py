"""SemanticKITTI sequences of a rig's recording (FORMATS.md §1 and §8).

The rig's sensors that fire together (the same rate and offset) make one sequence; the scan
at each of their shots is the union of their frames' points in the **body frame** (REP 103:
x forward, y left, z up, like KITTI's Velodyne), so the body plays the "velodyne":

- ``velodyne/NNNNNN.bin``: float32 x, y, z, remission (0) in the body frame; ``labels/``:
  ``(instance << 16) | semantic`` (renumbered ids beside them in ``instance_maps/`` when an
  id exceeds 16 bits, as for every SemanticKITTI scan here);
- ``poses.txt``: the pose of camera 0 (the group's first sensor) at each scan in the
  coordinates of camera 0 at the first scan; ``Tr`` in ``calib.txt`` is camera 0 from body
  (the inverse of its extrinsics), so the tools' ``Tr⁻¹ · pose · Tr`` moves a scan into the
  body frame at the first scan; ``P0``-``P3``: ``K_i [R|t]`` of the group's first four
  sensors from camera 0 (the last repeated when there are fewer);
- ``times.txt``: seconds since the trajectory's start; ``world_pose.txt``: the body's pose
  at the first scan in the world (3x4), so ``world = world_pose · Tr⁻¹ · pose_i · Tr · p``.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..cloud.unproject import unproject
from ..errors import ExportError
from ..outputs import atomic_write_bytes, atomic_write_text, publish_folder, remove_files
from . import semantickitti
from .registry import register_format
from .semantickitti import (
    MAX_SEQUENCES,
    _fmt,
    _link,
    encode_instances,
    label_map_yaml,
    pack_labels,
    sequence_files,
    split_sequences,
)


def groups(rig) -> list[list[int]]:
    """Indices of the rig's sensors that fire together, in rig order."""
    out: dict[tuple[float, float], list[int]] = {}
    for k, s in enumerate(rig.sensors):
        out.setdefault((s.rate_hz, s.offset_s), []).append(k)
    return list(out.values())


def camera_points(frame):
    """The frame's returns as a PointCloud in the camera's optical frame (xyz float32,
    semantic, instance, rgb when the frame has colour), in pixel order."""
    return unproject(frame.replace(world_from_camera=np.eye(4)))


def calib_text(rig, members: list[int]) -> str:
    B0 = rig.sensors[members[0]].body_from_sensor
    lines = []
    for j in range(4):
        s = rig.sensors[members[min(j, len(members) - 1)]]
        T = np.linalg.inv(s.body_from_sensor) @ B0  # camera j from camera 0
        lines.append(f"P{j}: {_fmt((s.sensor.K @ T[:3]).ravel())}")
    lines.append(f"Tr: {_fmt(np.linalg.inv(B0)[:3].ravel())}")
    return "".join(line + "\n" for line in lines)


def write_recording(rig, trajectory, recording: Iterable, folder: str | os.PathLike) -> list[Path]:
    """Write a recording ((Shot, Frame) pairs in time order) as one sequence per group of
    sensors firing together: ``folder/SS`` (SS = 00, 01, ...); returns the sequence folders."""
    folder = Path(folder)
    gs = groups(rig)
    group_of = {k: g for g, members in enumerate(gs) for k in members}
    dirs = [folder / f"{g:02d}" for g in range(len(gs))]
    poses: list[list[str]] = [[] for _ in gs]
    times: list[list[str]] = [[] for _ in gs]
    first: list[np.ndarray | None] = [None] * len(gs)
    pending: dict[int, list] = {}

    def flush(g: int) -> None:
        parts = pending.pop(g, None)
        if not parts:
            return
        shot0 = parts[0][0]
        xyz = np.concatenate([p[1] for p in parts])
        sem = np.concatenate([p[2] for p in parts])
        inst = np.concatenate([p[3] for p in parts])
        j = len(poses[g])
        scan = np.zeros((len(xyz), 4), "<f4")
        scan[:, :3] = xyz
        ids, table = encode_instances(inst)
        atomic_write_bytes(dirs[g] / "velodyne" / f"{j:06d}.bin", scan.tobytes())
        atomic_write_bytes(dirs[g] / "labels" / f"{j:06d}.label", pack_labels(sem, ids).tobytes())
        if table is not None:
            atomic_write_text(
                dirs[g] / "instance_maps" / f"{j:06d}.txt",
                "".join(f"{i + 1} {int(v)}\n" for i, v in enumerate(table)),
            )
        cam0 = shot0.world_from_body @ rig.sensors[gs[g][0]].body_from_sensor
        if first[g] is None:
            first[g] = cam0
            atomic_write_text(
                dirs[g] / "world_pose.txt", _fmt(shot0.world_from_body[:3].ravel()) + "\n"
            )
        poses[g].append(_fmt((np.linalg.inv(first[g]) @ cam0)[:3].ravel()))
        times[g].append(f"{shot0.time_s - trajectory.start_s:.9e}")

    for shot, frame in recording:
        g = group_of[shot.sensor]
        if g in pending and pending[g][0][0].time_s != shot.time_s:
            flush(g)
        c = camera_points(frame)
        xyz, sem, inst = c.xyz, c.semantic, c.instance
        B = rig.sensors[shot.sensor].body_from_sensor
        body = (xyz.astype(np.float64) @ B[:3, :3].T + B[:3, 3]).astype(np.float32)
        pending.setdefault(g, []).append((shot, body, sem, inst))
    for g in list(pending):
        flush(g)
    for g, members in enumerate(gs):
        if not poses[g]:
            raise ExportError(
                f"SemanticKITTI sequence {g:02d}: the trajectory is shorter than one frame of "
                f"sensor {rig.sensors[members[0]].name!r}"
            )
        atomic_write_text(dirs[g] / "poses.txt", "".join(p + "\n" for p in poses[g]))
        atomic_write_text(dirs[g] / "times.txt", "".join(t + "\n" for t in times[g]))
        atomic_write_text(dirs[g] / "calib.txt", calib_text(rig, members))
    return dirs


def write_scene(data, folder: Path) -> None:
    write_recording(data.rig, data.trajectory, data.recording, folder)


def assemble(
    out: str | os.PathLike, scene_dirs: list[Path], *, counts=None, split=(0.8, 0.1, 0.1)
) -> dict[int, list[int]]:
    """``sequences/NN`` from every scene's group folders in order (hard links), and the label
    map; returns {sequence: [scene]}. More than 100 sequences is refused (two digits)."""
    src = [
        (i, d)
        for i, scene in enumerate(scene_dirs)
        for d in sorted(Path(scene).iterdir())
        if d.is_dir() and d.name.isdigit() and len(d.name) == 2
    ]
    if len(src) > MAX_SEQUENCES:
        raise ExportError(
            f"SemanticKITTI holds {MAX_SEQUENCES} sequences (two digits); this dataset's "
            "recordings "
            f"make {len(src)}: use fewer scenes, or --format tum or rosbag"
        )
    root = Path(out) / "sequences"
    root.mkdir(parents=True, exist_ok=True)
    made: dict[int, list[int]] = {}
    for q, (i, d) in enumerate(src):
        tmp = root / f".tmp-{q:02d}-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        for f in sorted(d.rglob("*")):
            if f.is_file():
                (tmp / f.relative_to(d)).parent.mkdir(parents=True, exist_ok=True)
                _link(f, tmp / f.relative_to(d))
        publish_folder(
            tmp, root / f"{q:02d}", previous=sequence_files(root / f"{q:02d}")
        )  # a user's files stay
        made[q] = [i]
    for old in root.iterdir():  # sequences of an earlier run that made more: genie-gl's files go
        if (
            old.name.isdigit()
            and int(old.name) not in made
            and old.is_dir()
            and not old.is_symlink()
        ):
            remove_files(old, sequence_files(old))
    atomic_write_text(
        Path(out) / "genie-gl.yaml", label_map_yaml(counts, split_sequences(len(made), split))
    )
    return made


def _finish(out: Path, cfg, stats: list[dict]) -> None:
    """The dataset's sequences, each scene's recording its own (hard links), and the label map."""
    counts: dict[int, int] = {}
    for s in stats:
        for k, v in s["class_points"].items():
            counts[int(k)] = counts.get(int(k), 0) + int(v)
    made = assemble(
        out,
        [DATASET.scene_dir(out, i) for i in range(len(stats))],
        counts=counts,
        split=tuple(cfg.split),
    )
    for s in stats:
        s["sequence"] = min(q for q, members in made.items() if s["scene"] in members)


# the SemanticKITTI format takes recordings too: its registration, with the sequence writer
DATASET = register_format(
    dataclasses.replace(
        semantickitti.DATASET, write_sequence=write_scene, finish_recordings=_finish
    )
)
