"""The capture modes' registry (genie_gl/dataset/modes): each mode answers for itself which
formats write what it captures, which options it uses and what enters the fingerprint; an
unknown name is refused with did-you-mean. No GL: nothing is captured here."""

import pytest

from genie_gl.dataset import DatasetConfig
from genie_gl.dataset.manifest import fingerprint
from genie_gl.dataset.modes import CAPTURE_MODES, get_mode
from genie_gl.dataset.modes.base import mode_options, users_of
from genie_gl.errors import ConfigError
from genie_gl.export.registry import DATASET_FORMATS
from genie_gl.layout import load_strategy
from genie_gl.effects.profile import load_sensor

# the formats each capture wrote before the modes were objects (each format declared them)
TAKEN = {
    "semantickitti": {"static", "mobile-map", "trajectory"},
    "ply": {"static", "mobile-map"},
    "pcd": {"static", "mobile-map"},
    "npz": {"static", "mobile-map"},
    "las": {"static", "mobile-map"},
    "e57": {"static", "mobile-map", "trajectory"},
    "bop": {"static"},
    "tum": {"trajectory"},
    "rosbag": {"trajectory"},
}
# a scanner rig's raw scans go to the scanner formats; the map fused from them to any chunk format
for _name in ("semantickitti", "rosbag", "las", "e57", "pcd", "ply"):
    TAKEN[_name] = TAKEN[_name] | {"scans"}
for _name in ("semantickitti", "ply", "pcd", "npz", "las", "e57"):
    TAKEN[_name] = TAKEN[_name] | {"scan-map"}


def test_each_mode_takes_the_formats_it_took():
    got = {
        name: {m for m, mode in CAPTURE_MODES.items() if mode.takes(fmt)}
        for name, fmt in DATASET_FORMATS.items()
    }
    assert {k: v for k, v in got.items() if k in TAKEN} == TAKEN


def test_the_modes_and_their_options_in_order():
    assert list(CAPTURE_MODES) == ["static", "trajectory", "mobile-map", "scans", "scan-map"]
    assert mode_options() == (
        "cameras",
        "mount_m",
        "rig",
        "path",
        "motion",
        "duration_s",
        "cloud_stride",
        "voxel_m",
        "registration",
    )
    assert users_of("cloud_stride") == ("trajectory",)
    assert users_of("voxel_m") == ("mobile-map", "scan-map")
    assert users_of("path") == ("trajectory", "mobile-map", "scans", "scan-map")


def test_an_unknown_mode_is_refused_with_did_you_mean(tmp_path):
    with pytest.raises(
        ConfigError, match="--capture 'trajectry': unknown; did you mean 'trajectory'"
    ):
        get_mode("trajectry")
    with pytest.raises(ConfigError, match="--capture 'statik'.*did you mean 'static'"):
        DatasetConfig.parse(
            {"strategy": "assembly_line", "out": str(tmp_path), "capture": "statik"}, ""
        )


@pytest.mark.parametrize(
    "capture, present, absent",
    [
        (
            "static",
            {"cameras"},
            {"capture", "rig", "path", "motion", "duration_s", "voxel_m", "registration"},
        ),
        (
            "trajectory",
            {"capture", "path", "motion", "duration_s"},
            {"cameras", "mount_m", "voxel_m", "registration"},
        ),
        (
            "mobile-map",
            {"capture", "path", "duration_s", "voxel_m", "registration"},
            {"cameras", "mount_m"},
        ),
        (
            "scans",
            {"capture", "rig", "rig head 0 profile", "path", "duration_s"},
            {"cameras", "voxel_m", "registration"},
        ),
        (
            "scan-map",
            {"capture", "rig", "path", "duration_s", "voxel_m"},
            {"cameras", "mount_m", "registration"},
        ),
    ],
)
def test_the_fingerprint_holds_the_modes_own_options(tmp_path, capture, present, absent):
    rig = {"rig": "forklift_vlp16"} if capture.startswith("scan") else {}
    cfg = DatasetConfig.parse(
        {"strategy": "assembly_line", "out": str(tmp_path), "capture": capture, **rig}, ""
    )
    parts = fingerprint(cfg, load_strategy("assembly_line"), load_sensor("realsense_d435"))["parts"]
    assert present <= set(parts) and not absent & set(parts)
