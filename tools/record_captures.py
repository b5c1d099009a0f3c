"""Record depth captures of a flat wall with an Intel RealSense camera, for ``genie report-card``.

Usage (the camera facing a flat, matte wall squarely, at a distance you measured from the
camera's depth origin, e.g. with a laser meter)::

    pip install pyrealsense2
    .venv/bin/python tools/record_captures.py --out my_d435 --frames 30
    .venv/bin/genie report-card --sensor realsense_d435 --captures my_d435 \
        --calibration my_d435/calibration.yml --wall-distance 1.50

It writes into ``--out`` (which must not exist yet, or be empty):

* ``depth_0000.png`` ... one single-channel 16-bit PNG per frame, the camera's raw Z16 values
  (``--depth-scale`` metres per unit: the camera's depth unit, printed and saved below);
* ``calibration.yml``: the depth stream's intrinsics as an OpenCV calibration file, with the
  left-to-right infrared extrinsics as the stereo ``T`` (the baseline of the sub-pixel RMS);
* ``capture.json``: the device, serial number, firmware, stream, depth unit and frame count.

The first ``--warmup`` frames are dropped (auto exposure settling). The depth frames are the
camera's own, with whatever presets and post-processing its firmware applies; no host-side
filter is added.

Other cameras: this script records RealSense only (pyrealsense2). For an Azure Kinect use
``pyk4a`` (``capture.depth`` is uint16 millimetres; the intrinsics from
``calibration.get_camera_matrix(CalibrationType.DEPTH)`` and
``get_distortion_coefficients``), for a Kinect v2 ``pylibfreenect2`` (float millimetres: round
to uint16), for a Zivid camera ``zivid`` (the point cloud's z in millimetres); save the frames
as 16-bit PNGs and the intrinsics as an OpenCV calibration file (``cv2.FileStorage`` with
``camera_matrix``, ``distortion_coefficients``, ``image_width``, ``image_height``) and pass
them to ``genie report-card`` the same way.

Without pyrealsense2 installed the script exits with one line saying so.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

MISSING = (
    "record_captures: pyrealsense2 is not installed (pip install pyrealsense2); this script "
    "records from "
    "Intel RealSense cameras; see its docstring for other cameras"
)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description="record depth PNGs of a wall with a RealSense camera")
    p.add_argument("--out", required=True, help="folder to write (must not exist, or be empty)")
    p.add_argument("--frames", type=int, default=30, help="frames to record (default 30)")
    p.add_argument("--warmup", type=int, default=30, help="frames dropped first (default 30)")
    p.add_argument("--width", type=int, default=848)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--fps", type=int, default=30)
    p.add_argument("--serial", help="the camera's serial number (default: the first camera found)")
    return p.parse_args(argv)


def write_png16(path: Path, depth: np.ndarray) -> None:
    """A single-channel 16-bit PNG of ``depth`` (uint16), written whole or not at all."""
    from PIL import Image

    tmp = path.with_name(path.name + ".tmp")
    Image.fromarray(np.ascontiguousarray(depth, dtype=np.uint16)).save(tmp, format="PNG")
    tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        import pyrealsense2 as rs
    except ImportError:
        print(MISSING, file=sys.stderr)
        return 2
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        print(f"record_captures: {out} is not empty; give a new folder", file=sys.stderr)
        return 2
    if args.frames < 2:
        print(f"record_captures: --frames must be >= 2, got {args.frames}", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    pipe, cfg = rs.pipeline(), rs.config()
    if args.serial:
        cfg.enable_device(args.serial)
    cfg.enable_stream(rs.stream.depth, args.width, args.height, rs.format.z16, args.fps)
    try:
        profile = pipe.start(cfg)
    except RuntimeError as exc:
        print(f"record_captures: cannot start the depth stream ({exc})", file=sys.stderr)
        return 2
    try:
        dev = profile.get_device()
        scale = float(dev.first_depth_sensor().get_depth_scale())
        stream = profile.get_stream(rs.stream.depth).as_video_stream_profile()
        intr = stream.get_intrinsics()
        baseline_T = None
        try:  # infrared 1 -> 2: the stereo pair's translation (the baseline)
            ir1 = profile.get_stream(rs.stream.infrared, 1)
            ir2 = profile.get_stream(rs.stream.infrared, 2)
            baseline_T = list(ir1.get_extrinsics_to(ir2).translation)
        except RuntimeError:
            pass
        for _ in range(max(0, args.warmup)):
            pipe.wait_for_frames()
        for i in range(args.frames):
            depth = np.asanyarray(pipe.wait_for_frames().get_depth_frame().get_data())
            write_png16(out / f"depth_{i:04d}.png", depth)
    finally:
        pipe.stop()
    from genie_gl.sensors.calibration import Calibration, write_calibration

    if any(intr.coeffs) and "brown_conrady" != str(intr.model).split(".")[-1]:
        print(
            f"record_captures: warning: the depth stream's lens model is {intr.model}, not "
            "OpenCV's plumb bob; "
            "its coefficients are written as plumb bob",
            file=sys.stderr,
        )

    K = np.array([[intr.fx, 0.0, intr.ppx], [0.0, intr.fy, intr.ppy], [0.0, 0.0, 1.0]])
    T = None if baseline_T is None else np.array(baseline_T, np.float64)
    write_calibration(
        Calibration(
            intr.width,
            intr.height,
            K,
            np.array(intr.coeffs[:5], np.float64),
            R=None if T is None else np.eye(3),
            T=T,
        ),
        out / "calibration.yml",
    )
    info = {
        "device": dev.get_info(rs.camera_info.name),
        "serial": dev.get_info(rs.camera_info.serial_number),
        "firmware": dev.get_info(rs.camera_info.firmware_version),
        "width": intr.width,
        "height": intr.height,
        "fps": args.fps,
        "depth_scale_m": scale,
        "frames": args.frames,
        "distortion_model": str(intr.model),
    }
    (out / "capture.json").write_text(json.dumps(info, indent=1) + "\n", encoding="utf-8")
    print(
        f"record_captures: {args.frames} frames in {out}; depth unit {scale:g} m: pass "
        f"--depth-scale {scale:g}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
