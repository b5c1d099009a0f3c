"""Bad input files (strategies, layouts, sensor profiles, calibrations, accuracy files, USD
stages, poses): one line naming the file, the field and what was expected, or (where a file
means something else than it says) the meaning taken exactly; never a traceback, never read
as something it is not."""

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

import genie_gl as gg
from genie_gl.resources import data_dir

from .common import cli, fault, refused

BAD = fault("bad file", "traceback")
WRONG = fault("bad file", "wrong")


def strategy(**change) -> dict:
    s = json.loads((data_dir("layouts") / "assembly_line.json").read_text())
    for path, value in change.items():
        *head, last = path.split("__")
        d = s
        for k in head:
            d = d[int(k)] if isinstance(d, list) else d[k]
        key = int(last) if isinstance(d, list) else last
        if value is None:
            del d[key]
        else:
            d[key] = value
    return s


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


STRATEGIES = [
    (BAD, "binary", bytes(range(256)) * 8, "a binary file, expected a strategy JSON"),
    (BAD, "invalid JSON", b'{"name": "x",', "invalid JSON at line 1"),
    (BAD, "nested JSON", nested(100_000).encode(), "JSON nested too deeply"),
    (BAD, "not UTF-8", b'{"name": "\xff"}', "not UTF-8 text at byte"),
    (
        WRONG,
        "a misspelt top-level key",
        strategy(levls=[]),
        "$.levls: unknown key; did you mean 'levels'",
    ),
    (
        WRONG,
        "a misspelt rule key",
        strategy(levels__0__hall__childen={}),
        "childen: unknown key; did you mean 'children'",
    ),
    (
        WRONG,
        "a misspelt fill key",
        strategy(region_types__car_station__fill={"mod": "row"}),
        "did you mean 'mode'",
    ),
    (
        WRONG,
        "a misspelt argument",
        strategy(levels__0__hall__args__pahts=2),
        "args.pahts: not an argument of",
    ),
    (
        BAD,
        "an unknown generator",
        strategy(levels__0__hall__generator="asembly_line"),
        "did you mean 'assembly_line'",
    ),
    (
        BAD,
        "an undeclared region type",
        strategy(levels__0__hall__children={"line": "lien"}),
        "'lien' is not declared",
    ),
    (
        BAD,
        "a NaN grid cell",
        strategy(levels__1__line__args__cell=[float("nan"), 5.6]),
        "args.cell[0]: nan is not a finite number",
    ),
    (
        BAD,
        "an infinite spacing",
        strategy(levels__1__line__args__spacing=float("inf")),
        "args.spacing",
    ),
    (
        WRONG,
        "fractional paths",
        strategy(levels__0__hall__args__paths=1.5),
        "args.paths: expected whole numbers",
    ),
    (BAD, "a text size", strategy(levels__0__hall__args__line_width="wide"), "args.line_width"),
    (BAD, "a level that is not merge", strategy(levels__1="merj"), "did you mean 'merge'"),
    (BAD, "no root", strategy(root=None), "$.root: Field required"),
]


@pytest.mark.parametrize(
    "mark, name, data, needle", [pytest.param(*c, marks=c[0], id=c[1]) for c in STRATEGIES]
)
def test_a_bad_strategy_is_one_line(mark, name, data, needle, tmp_path):
    p = tmp_path / "s.json"
    p.write_bytes(data if isinstance(data, bytes) else json.dumps(data).encode())
    refused(cli("layout", p, "--out", tmp_path / "o"), "s.json", needle)
    assert not (tmp_path / "o").exists()


def layout_dict() -> dict:
    return json.loads(json.dumps(gg.generate_layout("assembly_line", seed=0).to_dict()))


def _set(d: dict, path: str, value):
    *head, last = path.split("__")
    for k in head:
        d = d[int(k)] if isinstance(d, list) else d[k]
    d[int(last) if isinstance(d, list) else last] = value
    return d


LAYOUTS = [
    (
        WRONG,
        "a misspelt key",
        lambda d: _set(d, "nodez", []),
        "$.nodez: not a field of a genie-gl layout; did you mean",
    ),
    (
        BAD,
        "an unknown region type",
        lambda d: _set(d, "nodes__3__region__type", "car_statoin"),
        "'car_statoin' is not declared in $.region_types; did you mean 'car_station'",
    ),
    (
        BAD,
        "a parent after its child",
        lambda d: _set(d, "nodes__3__parent", 9),
        "$.nodes[3].parent: 9",
    ),
    (
        BAD,
        "a parent that does not exist",
        lambda d: _set(d, "nodes__3__parent", -5),
        "$.nodes[3].parent: -5",
    ),
    (
        BAD,
        "children that disagree",
        lambda d: _set(d, "nodes__0__children", [1]),
        "$.nodes[0].children",
    ),
    (
        BAD,
        "a NaN width",
        lambda d: _set(d, "nodes__2__region__w", float("nan")),
        "$.nodes[2].region.w",
    ),
    (BAD, "a negative height", lambda d: _set(d, "nodes__2__region__h", -1), "$.nodes[2].region.h"),
    (
        BAD,
        "a misspelt orientation",
        lambda d: _set(d, "nodes__2__region__orientation", "upp"),
        "did you mean 'up'",
    ),
    (
        BAD,
        "a wrong depth",
        lambda d: _set(d, "nodes__2__depth", 7),
        "$.nodes[2].depth: 7, expected 1",
    ),
    (
        BAD,
        "a type colour of text",
        lambda d: _set(d, "region_types__hall__color", "red"),
        "color: expected [r, g, b]",
    ),
    (
        BAD,
        "not a layout",
        lambda d: {"name": "assembly_line"},
        "$.name: not a field of a genie-gl layout",
    ),
]


@pytest.mark.parametrize(
    "mark, name, change, needle", [pytest.param(*c, marks=c[0], id=c[1]) for c in LAYOUTS]
)
def test_a_bad_layout_json_is_one_line(mark, name, change, needle, tmp_path):
    d = layout_dict()
    d = change(d) if name == "not a layout" else (change(d), d)[1]
    p = tmp_path / "layout.json"
    p.write_text(json.dumps(d))
    refused(cli("scene", p, "--out", tmp_path / "s.usda", "--no-progress"), "layout.json", needle)
    assert not (tmp_path / "s.usda").exists()


@BAD
def test_a_layout_json_nested_too_deeply_is_one_line(tmp_path):
    p = tmp_path / "layout.json"
    p.write_text(nested(200_000))
    refused(cli("scene", p, "--out", tmp_path / "s.usda"), "JSON nested too deeply")


def write_calibration(
    path: Path, w=64, h=48, k_key="camera_matrix", d_key="distortion_coefficients", **extra
) -> Path:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", w)
    fs.write("image_height", h)
    fs.write(k_key, np.array([[60.0, 0, 32], [0, 60.0, 24], [0, 0, 1]]))
    fs.write(d_key, np.zeros((5, 1)))
    for k, v in extra.items():
        fs.write(k, v)
    fs.release()
    return path


def profile(tmp_path: Path, **fields) -> Path:
    write_calibration(tmp_path / "c.yml")
    data = {
        "name": "x",
        "calibration": "c.yml",
        "effects": [{"type": "range", "min_m": 0.2, "max_m": 8.0}],
        **fields,
    }
    (tmp_path / "x.yaml").write_text(yaml.safe_dump(data))
    return tmp_path / "x.yaml"


@WRONG
def test_a_misspelt_profile_key_is_refused_not_an_ideal_sensor(tmp_path):
    p = profile(tmp_path)
    data = yaml.safe_load(p.read_text())
    data["efects"] = data.pop("effects")
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(
        gg.ConfigError,
        match=r"x\.yaml: efects: not a field of a sensor profile; did you mean 'effects'",
    ):
        gg.load_sensor(p)
    refused(cli("plan", "--scene", "none.usda", "--sensor", p), "efects", "did you mean 'effects'")


@WRONG
def test_an_effect_listed_twice_is_refused_not_run_twice(tmp_path):
    p = profile(
        tmp_path,
        effects=[
            {"type": "depth_noise", "model": "tof_linear", "a_m": 0.001},
            {"type": "range", "min_m": 0.2, "max_m": 8},
            {"type": "depth_noise", "model": "tof_linear", "a_m": 0.002},
        ],
    )
    with pytest.raises(
        gg.ConfigError, match=r"effects\[2\]: 'depth_noise' is listed twice \(also effects\[0\]\)"
    ):
        gg.load_sensor(p)


@WRONG
@pytest.mark.parametrize("w, h", [(160.5, 120), (160, 119.9)])
def test_a_fractional_image_size_is_refused_not_rounded(tmp_path, w, h):
    p = write_calibration(tmp_path / "c.yml", w, h)
    side = "image_width" if w != int(w) else "image_height"
    with pytest.raises(
        gg.ConfigError, match=rf"c\.yml: {side}: expected a whole number in 1\.\.1000000, got"
    ):
        gg.load_sensor(p)
    ros = tmp_path / "ros.yaml"
    ros.write_text(
        yaml.safe_dump(
            {
                "image_width": w,
                "image_height": h,
                "camera_matrix": {
                    "rows": 3,
                    "cols": 3,
                    "data": [60.0, 0, 32, 0, 60.0, 24, 0, 0, 1],
                },
                "distortion_model": "plumb_bob",
                "distortion_coefficients": {"rows": 1, "cols": 5, "data": [0, 0, 0, 0, 0]},
            }
        )
    )
    with pytest.raises(gg.ConfigError, match="expected a whole number"):
        gg.load_sensor(ros)


@WRONG
def test_a_whole_float_image_size_still_reads(tmp_path):
    """160.0 is a whole number: read as 160 (ROS tools write floats)."""
    s = gg.load_sensor(write_calibration(tmp_path / "c.yml", 160.0, 120.0))
    assert (s.width, s.height) == (160, 120)


@WRONG
def test_a_misspelt_calibration_key_is_not_read_silently(tmp_path, caplog):
    """A calibration file belongs to the program that wrote it: a key genie-gl does not know is
    not read; one that looks like a needed field is named (K: refused; distortion: a warning)."""
    p = write_calibration(tmp_path / "c.yml", k_key="camera_matirx")
    with pytest.raises(
        gg.ConfigError,
        match=r"c\.yml: missing field camera_matrix .*the file's 'camera_matirx' "
        r"is not read: did you mean 'cameramatrix'",
    ):
        gg.load_sensor(p)
    p = write_calibration(tmp_path / "d.yml", d_key="distortion_coeficients")
    with caplog.at_level("WARNING", logger="genie_gl.sensors.calibration"):
        s = gg.load_sensor(p)
    assert len(s.dist) == 0
    assert any(
        "the file's 'distortion_coeficients' is not read" in r.getMessage() for r in caplog.records
    )


@WRONG
def test_the_keys_calibration_programs_write_are_read(tmp_path):
    """What OpenCV's calibration sample writes beside K and D is left unread, not refused."""
    p = write_calibration(
        tmp_path / "c.yml",
        calibration_time="Mon",
        nr_of_frames=25,
        board_width=9,
        board_height=6,
        square_size=0.025,
        flags=0,
        avg_reprojection_error=0.3,
        per_view_reprojection_errors=np.zeros((25, 1)),
        extrinsic_parameters=np.zeros((25, 6)),
        calibration_Time="Mon",
        nrOfFrames=25,
        flagValue=14,
        Image_points=np.zeros((2, 4, 2)),
    )
    assert gg.load_sensor(p).width == 64


@pytest.mark.parametrize(
    "text, needle",
    [
        pytest.param(
            "acuracy:\n  supersample: 2\n",
            "did you mean 'accuracy'",
            marks=WRONG,
            id="misspelt block",
        ),
        pytest.param(
            "accuracy:\n  supersampel: 2\n",
            "did you mean 'supersample'",
            marks=WRONG,
            id="misspelt setting",
        ),
        pytest.param(
            "accuracy:\n  supersample: 2\nnmae: x\n",
            "did you mean 'name'",
            marks=WRONG,
            id="misspelt beside",
        ),
        pytest.param("accuracy:\n  supersample: 3\n", "supersample", marks=BAD, id="a bad value"),
        pytest.param("accuracy: [1, 2\n", "not valid YAML or JSON", marks=BAD, id="invalid YAML"),
    ],
)
def test_a_bad_accuracy_file_is_one_line(tmp_path, text, needle):
    p = tmp_path / "acc.yaml"
    p.write_text(text)
    with pytest.raises(gg.ConfigError, match=needle.replace(".", r"\.")):
        gg.load_accuracy(p)
    refused(cli("dataset", "assembly_line", "--accuracy", p, "--out", tmp_path / "o"), "acc.yaml")


def usd(up="Z", point="(0, 0, 0)", mpu="1", counts="[3]") -> str:
    return (
        f'#usda 1.0\n(\n    metersPerUnit = {mpu}\n    upAxis = "{up}"\n)\ndef Mesh "m" {{\n'
        f"    point3f[] points = [{point}, (1, 0, 0), (0, 1, 0)]\n    int[] faceVertexCounts = "
        f"{counts}\n"
        "    int[] faceVertexIndices = [0, 1, 2]\n}\n"
    )


@pytest.mark.parametrize(
    "text, needle",
    [
        pytest.param(usd(up="X"), "upAxis 'X': a USD stage is Y or Z up", marks=WRONG, id="X up"),
        pytest.param(
            usd(point="(1e30, 0, 0)"), "absurd coordinates", marks=BAD, id="a point at 1e30"
        ),
        pytest.param(
            usd(point="(1e12, 0, 0)", mpu="0.01"),
            "absurd coordinates",
            marks=BAD,
            id="1e10 m in cm",
        ),
        pytest.param(usd(point="(nan, 0, 0)"), "NaN or Inf points", marks=BAD, id="a NaN point"),
        pytest.param(usd(mpu="0"), "metersPerUnit 0.0", marks=BAD, id="zero units"),
        pytest.param(
            usd(counts="[4]"), "faceVertexCounts (sum 4)", marks=BAD, id="counts disagree"
        ),
        pytest.param("not usd at all\n", "USD could not open the stage", marks=BAD, id="not USD"),
    ],
)
def test_a_bad_usd_stage_is_one_line(tmp_path, text, needle):
    p = tmp_path / "s.usda"
    p.write_text(text)
    refused(cli("plan", "--scene", p, "--cameras", "1", "--no-progress"), "s.usda", needle)
    with pytest.raises(
        gg.ConfigError, match=needle.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")
    ):
        gg.read_usd(p)


@WRONG
def test_a_y_up_stage_is_turned_z_up_exactly(tmp_path):
    """Y up: +90 degrees about x, (x, y, z) -> (x, -z, y), exactly (the points are whole
    numbers)."""
    p = tmp_path / "s.usda"
    p.write_text(
        usd(up="Y", point="(2, 3, 5)").replace("(1, 0, 0), (0, 1, 0)", "(7, 0, -11), (0, 13, 0)")
    )
    s = gg.read_usd(p)
    inst = s.instances[0]
    m = s.meshes[inst.mesh]
    world = (
        (inst.world_from_model[:3, :3] @ m.vertices.T.astype(np.float64)).T
        + inst.world_from_model[:3, 3]
        + inst.world_from_model[:3, :3] @ m.origin
    )
    np.testing.assert_array_equal(world, [[2, -5, 3], [7, 11, 0], [0, 0, 13]])


@pytest.mark.parametrize(
    "content, needle",
    [
        pytest.param("[[1, 0], [0, 1]]", "expected K finite 4x4 matrices", marks=BAD, id="2x2"),
        pytest.param(
            json.dumps([np.diag([2.0, 1, 1, 1]).tolist()]), "not a rotation", marks=BAD, id="scaled"
        ),
        pytest.param(
            json.dumps([[[float("nan")] * 4] * 4]).replace("NaN", "NaN"),
            "finite",
            marks=BAD,
            id="NaN",
        ),
        pytest.param(nested(100_000), "nested too deeply", marks=BAD, id="nested"),
        pytest.param('{"poses": 1}', "expected", marks=BAD, id="an object"),
    ],
)
def test_bad_poses_are_one_line(tmp_path, content, needle):
    p = tmp_path / "poses.json"
    p.write_text(content)
    s = gg.Scene()
    import trimesh

    s.add(trimesh.creation.box((1, 1, 1)), np.eye(4), semantic=1)
    usd_path = gg.write_usd(s, tmp_path / "s.usda")
    refused(cli("plan", "--scene", usd_path, "--poses", p, "--no-progress"), needle)
