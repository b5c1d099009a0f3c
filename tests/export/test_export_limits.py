"""SemanticKITTI label words at their limits, the instance renumbering table and the sequence
bounds, and the PLY instance width, each against values written out by hand (FORMATS.md)."""

import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.export import semantickitti


def cloud(sem, inst, origin=(0.0, 0.0, 0.0)):
    n = len(sem)
    return gg.PointCloud(
        np.arange(3 * n, dtype=np.float32).reshape(n, 3),
        np.asarray(sem, np.uint16),
        np.asarray(inst, np.uint32),
        np.array(origin),
    )


def test_label_words_at_the_16_bit_limits():
    # both halves full, the top bit of each half alone, and the empty word
    words = semantickitti.pack_labels(
        np.array([65535, 0, 32768, 0]), np.array([65535, 32768, 0, 0])
    )
    assert words.dtype == np.dtype("<u4")
    assert words.tolist() == [0xFFFFFFFF, 0x80000000, 0x00008000, 0]
    assert words.tobytes() == bytes([255] * 4 + [0, 0, 0, 0x80] + [0, 0x80, 0, 0] + [0] * 4)
    # int64 input whose ids fit: the same words (no sign or width carried over)
    assert semantickitti.pack_labels(np.array([7], np.int64), np.array([3], np.int64)).tolist() == [
        3 * 65536 + 7
    ]
    # an empty scan: no words, no error
    assert semantickitti.pack_labels(np.zeros(0, np.uint16), np.zeros(0, np.uint32)).shape == (0,)
    # one past the limit, in either half: refused, naming the half
    with pytest.raises(gg.GenieError, match=r"16-bit semantic ids \(limit 65535\), got 65536"):
        semantickitti.pack_labels(np.array([65536]), np.array([1]))
    with pytest.raises(gg.GenieError, match=r"16-bit instance ids \(limit 65535\), got 65536"):
        semantickitti.pack_labels(np.array([1]), np.array([65536]))


def test_renumbering_table_by_hand():
    # ids that fit are written as they are, with no table (65535 is the largest that fits)
    ids, table = semantickitti.encode_instances(np.array([0, 65535, 4]))
    assert ids.tolist() == [0, 65535, 4] and table is None and ids.dtype == np.uint32
    # with a 0 (no instance): 0 stays 0, the others 1..n in increasing order of the original id
    ids, table = semantickitti.encode_instances(np.array([70000, 0, 9, 2**32 - 1, 9]))
    assert ids.tolist() == [2, 0, 1, 3, 1] and table.tolist() == [9, 70000, 2**32 - 1]
    # without a 0: still from 1, so no point reads as "no instance"
    ids, table = semantickitti.encode_instances(np.array([65536, 8]))
    assert ids.tolist() == [2, 1] and table.tolist() == [8, 65536] and ids.dtype == np.uint32
    # exactly 65535 instances (and a 0) fit: the last one gets scan id 65535
    many = np.r_[0, np.arange(100000, 100000 + 65535)]
    ids, table = semantickitti.encode_instances(many)
    assert ids[0] == 0 and ids[-1] == 65535 and len(table) == 65535 and table[-1] == 100000 + 65534
    with pytest.raises(gg.GenieError, match=r"65536 instances \(limit 65535\)"):
        semantickitti.encode_instances(np.arange(100000, 100000 + 65536))


def test_the_table_file_and_reading_through_it(tmp_path):
    c = cloud([3, 3, 4, 5], [2**31, 0, 66000, 2**31])
    b = semantickitti.write(c, tmp_path, sequence=2, frame=0)
    seq = tmp_path / "sequences" / "02"
    assert (seq / "instance_maps" / "000000.txt").read_text() == "1 66000\n2 2147483648\n"
    words = np.fromfile(seq / "labels" / "000000.label", "<u4")
    assert words.tolist() == [2 * 65536 + 3, 3, 1 * 65536 + 4, 2 * 65536 + 5]
    xyz, sem, inst = semantickitti.read(b)
    assert sem.tolist() == [3, 3, 4, 5] and inst.tolist() == [2**31, 0, 66000, 2**31]
    assert inst.dtype == np.uint32 and sem.dtype == np.uint32
    # the same scan rewritten with ids that fit: the stale table is removed, ids read as written
    semantickitti.write(cloud([1, 1], [65535, 6]), tmp_path, sequence=2, frame=0)
    assert not (seq / "instance_maps" / "000000.txt").exists()
    assert semantickitti.read(b)[2].tolist() == [65535, 6]
    assert semantickitti.read(b)[1].tolist() == [1, 1]
    # the full table: 65535 instances, the last one read back through scan id 65535
    orig = np.r_[0, np.arange(100000, 100000 + 65535)]
    b = semantickitti.write(cloud(np.ones(len(orig)), orig), tmp_path, sequence=2, frame=1)
    lines = (seq / "instance_maps" / "000001.txt").read_text().splitlines()
    assert len(lines) == 65535 and lines[-1] == "65535 165534"
    assert (np.fromfile(seq / "labels" / "000001.label", "<u4") >> 16)[-1] == 65535
    np.testing.assert_array_equal(semantickitti.read(b)[2], orig)


def test_write_defaults_to_scan_0_of_sequence_00(tmp_path):
    b = semantickitti.write(cloud([1], [1]), tmp_path)
    assert b == tmp_path / "sequences" / "00" / "velodyne" / "000000.bin"
    assert (tmp_path / "sequences" / "00" / "poses.txt").read_text().count("\n") == 1


def test_sequence_bounds_poses_times_and_the_label_map(tmp_path):
    for bad in (-1, 100):
        with pytest.raises(gg.GenieError, match=f"sequence {bad}: folders are two digits, 00-99"):
            semantickitti.write(cloud([1], [1]), tmp_path, sequence=bad)
    assert not (tmp_path / "sequences").exists()
    b = semantickitti.write(
        cloud([1, 2, 2, 0], [0, 0, 0, 0], origin=(5.0, -6.0, 7.0)),
        tmp_path,
        sequence=99,
        frame=2,
        time_s=0.25,
    )
    assert b == tmp_path / "sequences" / "99" / "velodyne" / "000002.bin"
    seq = tmp_path / "sequences" / "99"
    # frame 2 written first: lines 0 and 1 are left empty for their scans, line 2 is this one
    poses = (seq / "poses.txt").read_text().split("\n")
    assert poses[:2] == ["", ""] and poses[3:] == [""]
    np.testing.assert_array_equal(
        np.array(poses[2].split(), float), [1, 0, 0, 5, 0, 1, 0, -6, 0, 0, 1, 7]
    )
    assert (seq / "times.txt").read_text().split("\n") == ["", "", "2.500000e-01", ""]
    semantickitti.write(cloud([1], [0]), tmp_path, sequence=99, frame=0)
    assert (seq / "times.txt").read_text().split("\n") == ["0.000000e+00", "", "2.500000e-01", ""]
    # the label map: written by the first scan (its class shares), kept by the later ones
    cfg = yaml.safe_load((tmp_path / "genie-gl.yaml").read_text())
    assert cfg["content"][2] == 0.5 and cfg["content"][1] == 0.25 and cfg["content"][0] == 0.25
    assert cfg["split"] == {
        "train": [99],
        "valid": [],
        "test": [],
    }  # one sequence: in one split only


def test_ply_instance_field_is_int32_up_to_its_limit_then_uint32(tmp_path):
    import plyfile

    def instance_field(inst):
        c = cloud(np.ones(len(inst)), inst)
        data = plyfile.PlyData.read(str(gg.export(c, tmp_path, format="ply")))["vertex"].data
        return data.dtype["instance"].str, data["instance"].tolist()

    assert instance_field([0, 2**31 - 1]) == ("<i4", [0, 2**31 - 1])  # the largest int32: int
    assert instance_field([2**31, 7]) == ("<u4", [2**31, 7])  # one past it: uint
    assert instance_field([2**32 - 1]) == ("<u4", [2**32 - 1])
