"""A rig's recording as a ROS 2 bag in MCAP storage (FORMATS.md §8), written with ``rosbags``
(pure Python: no ROS install to write it or to read it back, with ``rosbags`` or ``mcap``).

Per rig sensor ``NAME``, at each of its shots (stamped with the trajectory's clock):

- ``/NAME/depth/image_raw``: ``sensor_msgs/msg/Image``, ``32FC1``, z in metres (0: no return);
- ``/NAME/depth/camera_info``: ``sensor_msgs/msg/CameraInfo`` (K, the lens's ``plumb_bob``,
  ``rational_polynomial`` or ``equidistant`` coefficients, R = I, P = [K|0]);
- ``/NAME/color/image_raw``: ``rgb8``, when the frames carry colour;
- ``/NAME/points``: ``sensor_msgs/msg/PointCloud2``, fields x, y, z (FLOAT32), ``label``
  (UINT16, the semantic id) and ``instance`` (UINT32), in the optical frame;

all with ``frame_id`` ``NAME_optical_frame`` (REP 103: z forward, x right, y down), and

- ``/tf``: ``map`` → ``base_link`` (the body: x forward, y left, z up) at every shot time;
- ``/tf_static`` (transient local, as ROS latches it): ``base_link`` →
  ``NAME_optical_frame``, the rig's extrinsics, once.

The MCAP file's chunks are compressed with zstd (MCAP's chunk compression, which the ``mcap``
readers, rosbag2's MCAP storage, Foxglove and rosbags read; its metadata says
``compression_mode: ''`` as rosbag2 writes it for storage-level compression). ``cloud_stride``
k > 1 thins the ``points`` clouds to every k-th pixel row and column of each frame (1/k² of
the points; the depth images keep every pixel, so the full cloud can be made from them).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import ConfigError
from ..motion.trajectory import quaternion_xyzw
from .semantickitti_sequence import camera_points

DISTORTION = {
    "fisheye": "equidistant"
}  # pinhole: plumb_bob (<= 5 coefficients) or rational_polynomial
MAP, BODY = "map", "base_link"
STAMP_KEY = "genie-gl"  # the bag's custom_data key holding the version that wrote it


MAX_CLOUD_STRIDE = 64


def _modules():
    try:
        from rosbags.interfaces import (
            Qos,
            QosDurability,
            QosHistory,
            QosLiveliness,
            QosReliability,
            QosTime,
        )
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise ConfigError(
            f"--format rosbag needs the rosbags package: pip install 'genie-gl[sequences]' ({exc})"
        ) from None

    def writer(path: Path, compress: bool):
        w = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        if compress:  # MCAP chunk compression (zstd): what rosbag2 calls storage-level compression
            w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        return w

    return (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
        writer,
        get_typestore(Stores.ROS2_HUMBLE),
    )


class _Messages:
    """Builders of the messages, from the typestore's classes."""

    def __init__(self, ts) -> None:
        self.ts, self.T = ts, ts.types

    def header(self, t_ns: int, frame: str):
        return self.T["std_msgs/msg/Header"](
            stamp=self.T["builtin_interfaces/msg/Time"](
                sec=int(t_ns // 1_000_000_000), nanosec=int(t_ns % 1_000_000_000)
            ),
            frame_id=frame,
        )

    def transform(self, t_ns: int, parent: str, child: str, pose: np.ndarray):
        q = quaternion_xyzw(pose[:3, :3])
        return self.T["geometry_msgs/msg/TransformStamped"](
            header=self.header(t_ns, parent),
            child_frame_id=child,
            transform=self.T["geometry_msgs/msg/Transform"](
                translation=self.T["geometry_msgs/msg/Vector3"](
                    x=float(pose[0, 3]), y=float(pose[1, 3]), z=float(pose[2, 3])
                ),
                rotation=self.T["geometry_msgs/msg/Quaternion"](
                    x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3])
                ),
            ),
        )

    def image(self, t_ns: int, frame: str, data: np.ndarray, encoding: str):
        h, w = data.shape[:2]
        raw = np.ascontiguousarray(data).view(np.uint8).reshape(-1)
        return self.T["sensor_msgs/msg/Image"](
            header=self.header(t_ns, frame),
            height=h,
            width=w,
            encoding=encoding,
            is_bigendian=0,
            step=raw.size // h,
            data=raw,
        )

    def camera_info(self, t_ns: int, frame: str, sensor):
        model = DISTORTION.get(
            sensor.model, "plumb_bob" if len(sensor.dist) <= 5 else "rational_polynomial"
        )
        if sensor.model == "omni":
            raise ConfigError(
                f"sensor {sensor.name!r}: ROS camera_info has no omnidirectional model"
            )
        d = (
            np.zeros(5)
            if model == "plumb_bob" and not len(sensor.dist)
            else np.asarray(sensor.dist, np.float64)
        )
        P = np.zeros((3, 4))
        P[:, :3] = sensor.K
        roi = self.T["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        )
        return self.T["sensor_msgs/msg/CameraInfo"](
            header=self.header(t_ns, frame),
            height=sensor.height,
            width=sensor.width,
            distortion_model=model,
            d=d,
            k=np.asarray(sensor.K, np.float64).ravel(),
            r=np.eye(3).ravel(),
            p=P.ravel(),
            binning_x=0,
            binning_y=0,
            roi=roi,
        )

    def points(self, t_ns: int, frame: str, xyz: np.ndarray, sem: np.ndarray, inst: np.ndarray):
        F = self.T["sensor_msgs/msg/PointField"]
        rec = np.zeros(
            len(xyz),
            dtype=[
                ("x", "<f4"),
                ("y", "<f4"),
                ("z", "<f4"),
                ("label", "<u2"),
                ("pad", "<u2"),
                ("instance", "<u4"),
            ],
        )
        rec["x"], rec["y"], rec["z"] = xyz.T
        rec["label"], rec["instance"] = sem, inst
        fields = [
            F(name="x", offset=0, datatype=F.FLOAT32, count=1),
            F(name="y", offset=4, datatype=F.FLOAT32, count=1),
            F(name="z", offset=8, datatype=F.FLOAT32, count=1),
            F(name="label", offset=12, datatype=F.UINT16, count=1),
            F(name="instance", offset=16, datatype=F.UINT32, count=1),
        ]
        return self.T["sensor_msgs/msg/PointCloud2"](
            header=self.header(t_ns, frame),
            height=1,
            width=len(xyz),
            fields=fields,
            is_bigendian=False,
            point_step=rec.itemsize,
            row_step=rec.itemsize * len(xyz),
            data=rec.view(np.uint8).reshape(-1),
            is_dense=True,
        )


def write_recording(
    rig,
    trajectory,
    recording,
    bag_dir: str | os.PathLike,
    *,
    compress: bool = True,
    cloud_stride: int = 1,
) -> Path:
    """Write the recording ((Shot, Frame) pairs in time order) as an MCAP bag in ``bag_dir``
    (a folder the writer makes: ``metadata.yaml`` and ``<name>.mcap``); returns it.
    ``compress``: zstd chunk compression; ``cloud_stride``: the ``points`` clouds from every
    k-th pixel row and column (1 = every pixel)."""
    if not isinstance(cloud_stride, int) or not 1 <= cloud_stride <= MAX_CLOUD_STRIDE:
        raise ConfigError(
            f"--cloud-stride {cloud_stride!r}: expected an integer 1..{MAX_CLOUD_STRIDE} (every "
            "k-th "
            "pixel row and column of a frame's points)"
        )
    Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime, writer, ts = _modules()
    bag_dir = Path(bag_dir)
    if bag_dir.exists() and not bag_is_ours(bag_dir):
        raise ConfigError(
            f"{bag_dir}: already exists and was not written by genie-gl; it is left as it is "
            "(remove "
            "or rename it, or write the ROS 2 bag elsewhere)"
        )
    # written whole in a temporary folder of ours, then moved into place (the bag's file is named
    # after its folder, so the folder keeps its name inside the temporary one)
    tmp_root = bag_dir.parent / f".{bag_dir.name}.{os.getpid()}.tmp"
    shutil.rmtree(tmp_root, ignore_errors=True)
    tmp_root.mkdir(parents=True)
    try:
        _write_bag(
            rig,
            trajectory,
            recording,
            writer(tmp_root / bag_dir.name, compress),
            ts,
            Qos,
            (QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime),
            cloud_stride,
        )
        if bag_dir.exists():
            shutil.rmtree(bag_dir)  # a bag genie-gl wrote (checked above)
        (tmp_root / bag_dir.name).rename(bag_dir)
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
    return bag_dir


def bag_is_ours(bag_dir: Path) -> bool:
    """True when ``bag_dir`` is a bag folder :func:`write_recording` wrote: its metadata and its
    one MCAP file only, the metadata carrying genie-gl's custom data."""
    names = {p.name for p in bag_dir.iterdir()} if bag_dir.is_dir() else set()
    if (
        not names
        or not names <= {"metadata.yaml", f"{bag_dir.name}.mcap"}
        or "metadata.yaml" not in names
    ):
        return False
    try:
        return f"{STAMP_KEY}:" in (bag_dir / "metadata.yaml").read_text(errors="replace")
    except OSError:
        return False


def cloud_arrays(frame, stride: int = 1):
    """xyz (n, 3) float32 in the optical frame, semantic (n,) and instance (n,) of the frame's
    returns at every ``stride``-th pixel row and column, in pixel order (stride 1: every
    return, as :func:`~.semantickitti_sequence.camera_points` gives them)."""
    cloud = camera_points(frame)
    if stride == 1:
        return cloud.xyz, cloud.semantic, cloud.instance
    valid = frame.depth > 0
    keep = np.zeros_like(valid)
    keep[::stride, ::stride] = True
    sel = keep[valid]  # the returns in pixel order, as camera_points lists them
    return cloud.xyz[sel], cloud.semantic[sel], cloud.instance[sel]


def _write_bag(rig, trajectory, recording, bag, ts, Qos, qos_kinds, cloud_stride: int = 1) -> None:
    QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime = qos_kinds
    m = _Messages(ts)
    never = QosTime(sec=0, nsec=0)
    latched = Qos(
        QosHistory.KEEP_LAST,
        1,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL,
        never,
        never,
        QosLiveliness.AUTOMATIC,
        never,
        False,
    )

    def ns(t: float) -> int:
        return (
            int(round((t - trajectory.start_s) * 1e9)) + 1
        )  # the bag's clock: ns from the start, never 0

    with bag as w:
        w.set_custom_data(STAMP_KEY, __version__)  # how a later run knows the bag as its own

        def conn(topic: str, msgtype: str, qos=()):
            return w.add_connection(topic, msgtype, typestore=ts, offered_qos_profiles=qos)

        tf_static = conn("/tf_static", "tf2_msgs/msg/TFMessage", [latched])
        tf = conn("/tf", "tf2_msgs/msg/TFMessage")
        topics = {}
        for s in rig.sensors:
            topics[s.name] = {
                "depth": conn(f"/{s.name}/depth/image_raw", "sensor_msgs/msg/Image"),
                "info": conn(f"/{s.name}/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
                "points": conn(f"/{s.name}/points", "sensor_msgs/msg/PointCloud2"),
            }
        t0 = ns(trajectory.start_s)
        statics = [
            m.transform(t0, BODY, f"{s.name}_optical_frame", s.body_from_sensor)
            for s in rig.sensors
        ]
        msg = ts.types["tf2_msgs/msg/TFMessage"](transforms=statics)
        w.write(tf_static, t0, ts.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
        last_tf = None
        for shot, frame in recording:
            t = ns(shot.time_s)
            s = rig.sensors[shot.sensor]
            if last_tf != t:
                msg = ts.types["tf2_msgs/msg/TFMessage"](
                    transforms=[m.transform(t, MAP, BODY, shot.world_from_body)]
                )
                w.write(tf, t, ts.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
                last_tf = t
            optical = f"{s.name}_optical_frame"
            c = topics[s.name]
            w.write(
                c["info"],
                t,
                ts.serialize_cdr(m.camera_info(t, optical, s.sensor), "sensor_msgs/msg/CameraInfo"),
            )
            w.write(
                c["depth"],
                t,
                ts.serialize_cdr(
                    m.image(t, optical, frame.depth.astype("<f4"), "32FC1"), "sensor_msgs/msg/Image"
                ),
            )
            if frame.rgb is not None:
                if "color" not in c:
                    c["color"] = conn(f"/{s.name}/color/image_raw", "sensor_msgs/msg/Image")
                w.write(
                    c["color"],
                    t,
                    ts.serialize_cdr(
                        m.image(t, optical, frame.rgb, "rgb8"), "sensor_msgs/msg/Image"
                    ),
                )
            xyz, sem, inst = cloud_arrays(frame, cloud_stride)
            w.write(
                c["points"],
                t,
                ts.serialize_cdr(
                    m.points(t, optical, xyz, sem, inst), "sensor_msgs/msg/PointCloud2"
                ),
            )


def _write_scene(data, folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    stride = int(getattr(data.options, "cloud_stride", 1) or 1)
    write_recording(data.rig, data.trajectory, data.recording, folder / "bag", cloud_stride=stride)


from .registry import DatasetFormat, register_format  # noqa: E402

DATASET = register_format(
    DatasetFormat(
        "rosbag",
        "scenes",
        colour=False,
        chunks=False,
        write_sequence=_write_scene,
        description="ROS 2 bag (MCAP): depth, camera_info, labelled PointCloud2, tf and tf_static "
        "per rig sensor",
    )
)
