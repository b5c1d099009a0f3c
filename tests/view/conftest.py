"""A small dataset made once for the tests of ``genie view``: one scene of a 96 x 72 sensor,
standing cameras and a short recording."""

import pytest

from genie_gl.dataset import DatasetConfig, run_dataset
from genie_gl.effects.profile import load_sensor

SMALL_CALIB = """%YAML 1.2
---
image_width: 96
image_height: 72
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 80., 0., 47.5, 0., 80., 35.5, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ 0., 0., 0., 0., 0. ]
"""


@pytest.fixture(scope="package")
def datasets(tmp_path_factory):
    """One scene, two standing cameras (SemanticKITTI), and the same scene's 0.3 s recording
    in TUM and SemanticKITTI, all with a 96 x 72 sensor."""
    root = tmp_path_factory.mktemp("view")
    (root / "small.calib.yml").write_text(SMALL_CALIB)
    (root / "small.yaml").write_text("name: small\ncalibration: small.calib.yml\neffects: []\n")
    base = dict(
        strategy="storage_area",
        scenes=1,
        sensor=str(root / "small.yaml"),
        workers=1,
        seed=3,
        previews=0,
        split=[1, 0, 0],
    )
    out = {}
    for name, kw in {
        "static": dict(format="semantickitti", cameras=2),
        "tum": dict(format="tum", capture="trajectory", duration_s=0.3),
        "kitti": dict(format="semantickitti", capture="trajectory", duration_s=0.3),
    }.items():
        run_dataset(DatasetConfig.parse(base | kw | {"out": str(root / name)}), progress=False)
        out[name] = root / name
    out["sensor"] = load_sensor(str(root / "small.yaml"))
    return out
