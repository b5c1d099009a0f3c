"""A rig's recording as TUM RGB-D sequences (FORMATS.md §8), one folder per rig sensor:

- ``rgb/T.png`` (8-bit colour) and ``depth/T.png`` (16-bit, **depth x 5000**, 0 = no
  return; depth beyond 65535/5000 = 13.107 m does not fit and is written as 0) named by the
  timestamp T (seconds, six decimals, on the trajectory's clock);
- ``rgb.txt``, ``depth.txt``: ``timestamp filename`` per frame; ``associations.txt``:
  ``t rgb/T.png t depth/T.png`` (the pairs TUM's ``associate.py`` would find: one camera);
- ``groundtruth.txt``: ``timestamp tx ty tz qx qy qz qw``, the optical centre and
  orientation of the camera (OpenCV frame) in the world, quaternion last (``evo`` reads it);
- ``semantic/T.png`` and ``instance/T.png``: 16-bit class and instance ids per pixel (this
  project's addition; an instance id above 65535 is refused).
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from ..errors import ExportError
from ..outputs import atomic_write_bytes, atomic_write_text
from ..motion.trajectory import quaternion_xyzw

DEPTH_SCALE = 5000.0
MAX_DEPTH_M = 65535 / DEPTH_SCALE


def stamp(t: float) -> str:
    return f"{t:.6f}"


def _png(path: Path, image: np.ndarray) -> None:
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise ExportError(f"{path}: PNG encoding failed")
    atomic_write_bytes(path, buf.tobytes())


def depth_png(depth: np.ndarray) -> np.ndarray:
    """(H, W) uint16 TUM depth (z x 5000, rounded; 0 for no return and beyond 13.107 m)."""
    d = np.round(depth.astype(np.float64) * DEPTH_SCALE)
    return np.where((depth > 0) & (d <= 65535), d, 0).astype(np.uint16)


def write_recording(rig, trajectory, recording, folder: str | os.PathLike) -> list[Path]:
    """Write the recording ((Shot, Frame) pairs) as ``folder/NAME/`` per rig sensor."""
    folder = Path(folder)
    rows: dict[int, dict[str, list[str]]] = {}
    for shot, frame in recording:
        s = rig.sensors[shot.sensor]
        d = folder / s.name
        t = stamp(shot.time_s)
        r = rows.setdefault(shot.sensor, {"rgb": [], "depth": [], "assoc": [], "gt": []})
        if frame.rgb is None:
            raise ExportError("TUM RGB-D sequences need colour frames (capture without depth_only)")
        _png(d / "rgb" / f"{t}.png", cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
        _png(d / "depth" / f"{t}.png", depth_png(frame.depth))
        _png(d / "semantic" / f"{t}.png", frame.semantic)
        if frame.instance.size and int(frame.instance.max()) > 0xFFFF:
            raise ExportError(
                f"TUM instance PNGs hold 16-bit ids; frame {t} of {s.name} has "
                f"{int(frame.instance.max())}"
            )
        _png(d / "instance" / f"{t}.png", frame.instance.astype(np.uint16))
        r["rgb"].append(f"{t} rgb/{t}.png")
        r["depth"].append(f"{t} depth/{t}.png")
        r["assoc"].append(f"{t} rgb/{t}.png {t} depth/{t}.png")
        p = shot.world_from_camera
        q = quaternion_xyzw(p[:3, :3])
        r["gt"].append(f"{t} " + " ".join(f"{v:.9f}" for v in (*p[:3, 3], *q)))
    out = []
    for k, r in sorted(rows.items()):
        d = folder / rig.sensors[k].name
        head = (
            f"# genie-gl TUM RGB-D sequence: rig sensor {rig.sensors[k].name}\n# timestamp "
            "filename\n"
        )
        atomic_write_text(d / "rgb.txt", head + "".join(x + "\n" for x in r["rgb"]))
        atomic_write_text(d / "depth.txt", head + "".join(x + "\n" for x in r["depth"]))
        atomic_write_text(d / "associations.txt", "".join(x + "\n" for x in r["assoc"]))
        atomic_write_text(
            d / "groundtruth.txt",
            "# ground truth trajectory (optical frame, world)\n"
            "# timestamp tx ty tz qx qy qz qw\n" + "".join(x + "\n" for x in r["gt"]),
        )
        out.append(d)
    return out


def _write_scene(data, folder: Path) -> None:
    write_recording(data.rig, data.trajectory, data.recording, folder)


from .registry import DatasetFormat, register_format  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "tum",
        "scenes",
        colour=True,
        chunks=False,
        write_sequence=_write_scene,
        description="TUM RGB-D sequences per rig sensor (rgb/, depth/ x5000, associations, "
        "groundtruth)",
    )
)
