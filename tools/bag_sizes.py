"""Sizes of ROS 2 bags per sensor-second, and their read-back (docs/formats.md's table).

    python tools/bag_sizes.py BAG_STRIDE1 BAG_STRIDE2 SENSOR_SECONDS

BAG_STRIDE1, BAG_STRIDE2: the bag folders (``scenes/0000/bag``) of two ``genie dataset ...
--format rosbag`` runs of the same recording, without and with ``--cloud-stride 2``. The first
bag's messages are rewritten uncompressed (the bag as written before chunk compression); every
bag is read with rosbags and with mcap's reader (the same messages per topic in all three), and
the first cloud of the thinned bag is checked against the full one (every 2nd pixel row and
column; the full cloud's z equal to its depth image)."""

import shutil
import sys
import tempfile
from collections import Counter
from pathlib import Path
import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader, Writer, StoragePlugin
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

z1, z2, sensor_seconds = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
plain = Path(tempfile.mkdtemp()) / "bag"  # removed at the end


def counts_rosbags(bag):
    with AnyReader([bag]) as r:
        return Counter(c.topic for c, _, _ in r.messages())


def counts_mcap(bag):
    (f,) = bag.glob("*.mcap")
    with open(f, "rb") as fh:
        r = make_reader(fh)
        comp = {c.compression for c in r.get_summary().chunk_indexes}
        return Counter(ch.topic for _, ch, _ in r.iter_messages()), comp


# the same messages, uncompressed (what the writer made before chunk compression)
with Reader(z1) as r, Writer(plain, version=9, storage_plugin=StoragePlugin.MCAP) as w:
    conns = {}
    for c in r.connections:
        conns[c.id] = w.add_connection(
            c.topic,
            c.msgtype,
            msgdef=c.msgdef.data,
            rihs01=c.digest,
            offered_qos_profiles=c.ext.offered_qos_profiles,
        )
    for c, t, raw in r.messages():
        w.write(conns[c.id], t, raw)

sizes = {}
for name, bag in (("uncompressed", plain), ("zstd", z1), ("zstd, --cloud-stride 2", z2)):
    (f,) = bag.glob("*.mcap")
    cr = counts_rosbags(bag)
    cm, comp = counts_mcap(bag)
    assert cr == cm, name
    sizes[name] = f.stat().st_size
    print(
        f"{name}: {f.stat().st_size / 1e6:.1f} MB, chunks {comp}, {sum(cr.values())} messages, "
        f"{len(cr)} topics, "
        f"{sizes[name] / 1e6 / sensor_seconds:.1f} MB per sensor-second"
    )
assert counts_rosbags(z1) == counts_rosbags(z2) == counts_rosbags(plain)
print("per topic:", dict(sorted(counts_rosbags(z1).items())))
# a cloud's content: the stride-2 cloud is the full cloud's every 2nd pixel row and column
topic = sorted(t for t in counts_rosbags(z1) if t.endswith("/points"))[0]
dtopic = topic.replace("/points", "/depth/image_raw")


def first(bag, t):
    (f,) = bag.glob("*.mcap")
    with open(f, "rb") as fh:
        for _, _, _, m in make_reader(
            fh, decoder_factories=[DecoderFactory()]
        ).iter_decoded_messages(topics=[t]):
            return m


full, half, depth = first(z1, topic), first(z2, topic), first(z1, dtopic)
dt = [
    ("x", "<f4"),
    ("y", "<f4"),
    ("z", "<f4"),
    ("label", "<u2"),
    ("pad", "<u2"),
    ("instance", "<u4"),
]
a, b = np.frombuffer(bytes(full.data), dt), np.frombuffer(bytes(half.data), dt)
d = np.frombuffer(bytes(depth.data), "<f4").reshape(depth.height, depth.width)
valid = d > 0
keep = np.zeros_like(valid)
keep[::2, ::2] = True
assert len(a) == valid.sum() and np.array_equal(a[keep[valid]], b), "stride-2 cloud differs"
assert np.allclose(a["z"], d[valid]), "cloud z is not the depth"
print(
    f"{topic}: first cloud {len(a)} points (= valid depth pixels, z = depth), stride 2: {len(b)} = "
    "every 2nd row and column"
)
print(
    f"ratio zstd/uncompressed {sizes['zstd'] / sizes['uncompressed']:.3f}, stride 2 "
    f"{sizes['zstd, --cloud-stride 2'] / sizes['uncompressed']:.3f}"
)
shutil.rmtree(plain.parent)
