"""ROS 2 bags a user can afford: MCAP chunks compressed with zstd and, on request, point clouds
thinned to every k-th pixel row and column; every message still there and read back by rosbags
and by mcap's own reader."""

from collections import Counter

import numpy as np
import pytest

from genie_gl.capture.trajectory import record
from genie_gl.cloud.unproject import unproject
from genie_gl.errors import ConfigError
from genie_gl.export.rosbag import write_recording

from .test_sequences import room, small_rig, walk

pytestmark = pytest.mark.gl
CLOUD = [
    ("x", "<f4"),
    ("y", "<f4"),
    ("z", "<f4"),
    ("label", "<u2"),
    ("pad", "<u2"),
    ("instance", "<u4"),
]


@pytest.fixture(scope="module")
def recorded():
    rig, tr = small_rig(), walk()
    return rig, tr, list(record(room(), rig, tr, seed=0))


def _mcap(bag):
    (f,) = bag.glob("*.mcap")
    return f


def _counts_rosbags(bag) -> Counter:
    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        return Counter(c.topic for c, _, _ in reader.messages())


def _counts_mcap(bag) -> tuple[Counter, set]:
    from mcap.reader import make_reader

    with open(_mcap(bag), "rb") as fh:
        r = make_reader(fh)
        summary = r.get_summary()
        compression = {c.compression for c in summary.chunk_indexes}
        counts = Counter(ch.topic for _, ch, _ in r.iter_messages())
    return counts, compression


def test_a_compressed_bag_holds_every_message_and_is_smaller(recorded, tmp_path):
    rig, tr, pairs = recorded
    plain = write_recording(rig, tr, pairs, tmp_path / "plain", compress=False)
    packed = write_recording(rig, tr, pairs, tmp_path / "packed")
    counts, compression = _counts_mcap(packed)
    assert compression == {"zstd"}
    assert _counts_mcap(plain)[1] == {""}
    assert counts == _counts_rosbags(packed) == _counts_rosbags(plain)
    assert counts["/front/points"] == sum(s.sensor == 0 for s, _ in pairs) > 0
    assert _mcap(packed).stat().st_size < 0.8 * _mcap(plain).stat().st_size


def test_a_thinned_cloud_is_every_kth_pixel_row_and_column(recorded, tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    rig, tr, pairs = recorded
    bag = write_recording(rig, tr, pairs, tmp_path / "thin", cloud_stride=3)
    counts, _ = _counts_mcap(bag)
    assert counts == _counts_rosbags(write_recording(rig, tr, pairs, tmp_path / "full"))
    with open(_mcap(bag), "rb") as fh:
        clouds = [
            m
            for _, _, _, m in make_reader(
                fh, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages(topics=["/front/points"])
        ]
        fh.seek(0)
        depth = [
            m
            for _, _, _, m in make_reader(
                fh, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages(topics=["/front/depth/image_raw"])
        ]
    front = [f for s, f in pairs if s.sensor == 0]
    assert len(clouds) == len(depth) == len(front)
    for msg, img, frame in zip(clouds, depth, front):
        rec = np.frombuffer(bytes(msg.data), dtype=CLOUD)
        keep = np.zeros(frame.depth.shape, bool)
        keep[::3, ::3] = True
        c = unproject(frame.replace(world_from_camera=np.eye(4)))
        sel = keep[frame.depth > 0]
        assert msg.width == len(rec) == int((keep & (frame.depth > 0)).sum())
        np.testing.assert_array_equal(np.stack([rec["x"], rec["y"], rec["z"]], 1), c.xyz[sel])
        np.testing.assert_array_equal(rec["label"], c.semantic[sel])
        np.testing.assert_array_equal(rec["instance"], c.instance[sel])
        # the depth image keeps every pixel
        np.testing.assert_array_equal(
            np.frombuffer(bytes(img.data), "<f4").reshape(frame.depth.shape), frame.depth
        )


def test_a_cloud_stride_out_of_range_is_refused(recorded, tmp_path):
    rig, tr, pairs = recorded
    for bad in (0, 65, 2.5):
        with pytest.raises(ConfigError, match="--cloud-stride"):
            write_recording(rig, tr, pairs, tmp_path / "b", cloud_stride=bad)
    assert not (tmp_path / "b").exists()


def test_cloud_stride_is_an_option_of_rosbag_recordings_only(tmp_path):
    from genie_gl.dataset import DatasetConfig

    base = dict(strategy="storage_area", scenes=1, sensor="ideal_pinhole", out=str(tmp_path / "d"))
    ok = DatasetConfig.parse(base | dict(format="rosbag", capture="trajectory", cloud_stride=2))
    assert ok.cloud_stride == 2
    with pytest.raises(ConfigError, match="--cloud-stride 2: .*--format semantickitti"):
        DatasetConfig.parse(
            base | dict(format="semantickitti", capture="trajectory", cloud_stride=2)
        )
    with pytest.raises(ConfigError, match="--cloud-stride"):
        DatasetConfig.parse(base | dict(format="rosbag", capture="trajectory", cloud_stride=0))
    # a run without the option keeps the fingerprint it had (the option is fingerprinted only when
    # given)
    from genie_gl.dataset.manifest import fingerprint
    from genie_gl.layout import load_strategy
    from genie_gl.effects.profile import load_sensor

    plain = DatasetConfig.parse(base | dict(format="rosbag", capture="trajectory"))
    parts = fingerprint(plain, load_strategy("storage_area"), load_sensor("ideal_pinhole"))["parts"]
    assert "cloud_stride" not in parts
    assert (
        fingerprint(ok, load_strategy("storage_area"), load_sensor("ideal_pinhole"))["parts"][
            "cloud_stride"
        ]
        == 2
    )
