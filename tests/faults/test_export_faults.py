"""Exports given names and numbers that would write outside their folder, points at infinity,
and entry points given None: one error naming the argument, nothing written anywhere."""

import hashlib

import numpy as np
import pytest
import trimesh

import genie_gl as gg

from .common import cli, fault, refused

LOSS = fault("bad API call", "loss")
API = fault("bad API call", "traceback")
WRONG = fault("bad API call", "wrong")
OPTION = fault("bad option", "traceback")


def cloud(n=5, **kw) -> gg.PointCloud:
    xyz = np.arange(3 * n, dtype=np.float32).reshape(n, 3)
    return gg.PointCloud(xyz, np.ones(n, np.uint16), np.arange(1, n + 1, dtype=np.uint32), **kw)


def tree(root) -> dict[str, str]:
    """Every file under ``root`` and its hash."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


FORMATS = ("ply", "pcd", "npz", "e57", "las", "semantickitti")


@LOSS
@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(
    "name", ["../../escaped", "../other/cloud", "sub/cloud", "..", ".", "", "a\\b", "ABS"]
)
def test_a_name_that_is_not_a_plain_file_name_is_refused(tmp_path, fmt, name):
    """A name is joined to out_dir: one with a folder in it, absolute, '.' or '..' would write
    elsewhere (another run's finished cloud, /etc/...): refused before anything is written."""
    other = tmp_path / "other"
    gg.export(cloud(), other, format="ply")  # another run's finished cloud.ply
    out = tmp_path / "runs" / "a"
    out.mkdir(parents=True)
    if name == "ABS":
        name = str(tmp_path / "abs" / "x")
    before = tree(tmp_path)
    with pytest.raises(gg.ConfigError, match=r"export: name: .*expected a plain file name") as info:
        gg.export(cloud(), out, format=fmt, name=name)
    assert "\n" not in str(info.value)
    assert tree(tmp_path) == before and not (tmp_path / "abs").exists()
    assert not list(out.iterdir())


@API
@pytest.mark.parametrize(
    "kw, needle",
    [
        ({"frame": -1}, r"export: frame: expected a whole number in 0\.\.999999, got -1"),
        ({"frame": 10**6}, r"export: frame: expected a whole number in 0\.\.999999"),
        ({"frame": 1.5}, r"export: frame: .*got 1\.5"),
        ({"frame": "3"}, r"export: frame: expected a whole number"),
        ({"sequence": -1}, r"export: sequence: expected a whole number in 0\.\.99, got -1"),
        ({"sequence": 100}, r"export: sequence: expected a whole number in 0\.\.99, got 100"),
        ({"sequence": 2.5}, r"export: sequence: .*got 2\.5"),
        ({"name": None}, r"export: name: expected a file name \(a string\), got NoneType"),
    ],
)
def test_an_out_of_range_frame_or_sequence_is_one_line(tmp_path, kw, needle):
    with pytest.raises(gg.ConfigError, match=needle):
        gg.export(cloud(), tmp_path / "o", format="semantickitti", **kw)
    assert not (tmp_path / "o").exists()


@API
@pytest.mark.parametrize(
    "call, needle",
    [
        (lambda p: gg.read_usd(None), "read_usd: path: expected a file name .*got NoneType"),
        (lambda p: gg.read_usd(3), "read_usd: path: expected a file name .*got int 3"),
        (
            lambda p: gg.read_usd(p / "s.usda", segments=2),
            "read_usd: segments must be an integer >= 3",
        ),
        (lambda p: gg.write_usd(gg.Scene(), None), "write_usd: path: expected a file name"),
        (
            lambda p: gg.write_usd(None, p / "x.usda"),
            "write_usd: scene: expected a Scene, got NoneType",
        ),
        (
            lambda p: gg.export(cloud(), None),
            "export: out_dir: expected a folder name, got NoneType",
        ),
        (lambda p: gg.Sensor.from_opencv(None), "calibration: expected a file name .*got NoneType"),
        (lambda p: gg.load_accuracy(None), "accuracy: expected a file name .*got NoneType"),
        (
            lambda p: gg.sensors.write_calibration(None, p / "c.yml"),
            "write_calibration: calib: expected a Calibration",
        ),
    ],
)
def test_an_entry_point_given_none_or_a_wrong_type_says_which_argument(tmp_path, call, needle):
    s = gg.Scene()
    s.add(trimesh.creation.box((1, 1, 1)), np.eye(4), semantic=1)
    gg.write_usd(s, tmp_path / "s.usda")
    before = tree(tmp_path)
    with pytest.raises(gg.GenieError, match=needle) as info:
        call(tmp_path)
    assert "\n" not in str(info.value)
    assert tree(tmp_path) == before


def frame_of(depth: np.ndarray) -> gg.Frame:
    h, w = depth.shape
    cam = gg.Sensor.pinhole(w, h, float(w))
    return gg.Frame(
        depth.astype(np.float32),
        np.ones((h, w), np.uint32),
        np.ones((h, w), np.uint16),
        None,
        cam,
        np.eye(4),
    )


@WRONG
def test_an_infinite_depth_is_no_return(tmp_path):
    """+Inf is no return, as NaN, 0 and negatives are: to_cloud keeps the finite depths alone
    (through the vector path, rows of 64 and more, and the scalar tail)."""
    depth = np.full((3, 70), 2.0)
    depth[0, 5], depth[1, 66], depth[2, 0] = np.inf, np.inf, np.nan
    depth[2, 1], depth[2, 69] = -1.0, 0.0
    depth[0, 7:40:3] = np.inf  # scattered: the pixel-by-pixel compaction
    c = gg.to_cloud([frame_of(depth)])
    want = int(((depth > 0) & np.isfinite(depth)).sum())
    assert len(c) == want == 210 - 2 - 11 - 3
    assert np.isfinite(c.xyz).all()
    np.testing.assert_allclose(c.xyz[:, 2], 2.0)  # the camera looks along +z from the origin


@WRONG
@pytest.mark.parametrize("fmt", FORMATS)
def test_a_cloud_with_a_point_at_infinity_is_not_written(tmp_path, fmt):
    xyz = np.zeros((4, 3), np.float32)
    xyz[2, 1] = np.inf
    bad = gg.PointCloud(xyz, np.ones(4, np.uint16), np.ones(4, np.uint32))
    with pytest.raises(
        gg.GenieError,
        match=r"1 of the cloud's 4 points have NaN or infinite coordinates; nothing "
        r"was written",
    ):
        gg.export(bad, tmp_path / "o", format=fmt)
    assert not (tmp_path / "o").exists()
    assert len(gg.export(bad.select(bad.finite()), tmp_path / "o", format=fmt).name) > 0


@OPTION
@pytest.mark.parametrize("kind", ["dangling", "loop"])
def test_a_dangling_or_looping_out_says_so(tmp_path, kind):
    link = tmp_path / "out"
    if kind == "dangling":
        link.symlink_to(tmp_path / "gone")
    else:
        link.symlink_to(tmp_path / "out2")
        (tmp_path / "out2").symlink_to(link)
    for out in (link, link / "sub"):
        err = refused(
            cli("layout", "assembly_line", "--out", out), "is a symbolic link that leads nowhere"
        )
        assert "File exists" not in err
    assert not (tmp_path / "gone").exists()
