"""A user's asset that no region can hold (a pallet in millimetres read as metres) is one line
naming the file, its size, the unit it was read in and the units that would make it fit;
never a scene of built-in assets only, without a word."""

import json

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.resources import data_dir
from genie_gl.scene.assets.catalogue import Catalogue

from .common import cli, fault, refused


def _pallet(path, size=(1200.0, 800.0, 150.0)):
    box = trimesh.creation.box(size)
    box.apply_translation((0, 0, size[2] / 2))
    box.export(path)
    return path


def _strategy(tmp_path, entry) -> str:
    s = json.loads((data_dir("layouts") / "storage_area.json").read_text())
    s["scene"]["assets"] = {"pallet": [entry]}
    p = tmp_path / "s.json"
    p.write_text(json.dumps(s))
    return str(p)


@pytest.fixture(scope="module")
def layout_json():
    return gg.generate_layout("storage_area", seed=0)


@fault("bad file", "wrong")
def test_a_pallet_in_millimetres_without_units_is_refused(tmp_path, layout_json):
    """1200 x 800 x 150 read as metres: it fits no region, and the scene used to be built with
    the built-in pallets alone (exit 0, no word)."""
    obj = _pallet(tmp_path / "pallet.obj")
    with pytest.raises(ConfigError) as e:
        gg.build_scene(
            layout_json,
            seed=0,
            options={**layout_json.meta["scene"], "assets": {"pallet": [str(obj)]}},
        )
    msg = str(e.value)
    assert (
        "pallet.obj: a pallet asset of 1200 x 800 x 150 m (read in metres: the file states no "
        "units)" in msg
    )
    assert "fits none of the" in msg and '"units": "mm" (1.2 x 0.8 x 0.15 m)' in msg
    assert len(msg.splitlines()) == 1


@fault("bad file", "wrong")
def test_the_same_pallet_with_its_units_is_used(tmp_path, layout_json):
    obj = _pallet(tmp_path / "pallet.obj")
    scene = gg.build_scene(
        layout_json,
        seed=0,
        options={
            **layout_json.meta["scene"],
            "assets": {"pallet": [{"path": str(obj), "units": "mm"}]},
        },
    )
    used = [i for i in scene.instances if "pallet_pallet" in i.mesh]
    assert used, sorted({i.mesh for i in scene.instances})
    ext = scene.meshes[used[0].mesh].vertices.max(0) - scene.meshes[used[0].mesh].vertices.min(0)
    np.testing.assert_allclose(sorted(ext), [0.15, 0.8, 1.2], atol=1e-6)


@fault("bad file", "wrong")
def test_genie_scene_refuses_it_in_one_line(tmp_path):
    obj = _pallet(tmp_path / "pallet.obj")
    p = _strategy(tmp_path, str(obj))
    assert cli("layout", p, "--out", tmp_path / "lay").rc == 0
    run = cli("scene", tmp_path / "lay" / "layout.json", "--out", tmp_path / "s.usda", timeout=120)
    refused(
        run, "pallet.obj: a pallet asset of 1200 x 800 x 150 m", "read in metres", '"units": "mm"'
    )
    assert not (tmp_path / "s.usda").exists()


@fault("bad API call", "wrong")
def test_a_registered_asset_in_the_wrong_unit_names_the_unit_it_was_read_in(tmp_path, layout_json):
    """Millimetres registered as centimetres: read as 120 x 80 m; the fix is mm."""
    cat = Catalogue()
    cat.register("pallet", _pallet(tmp_path / "big.obj"), units="cm")
    with pytest.raises(
        ConfigError,
        match=r"big.obj: a pallet asset of 12 x 8 x 1.5 m \(read in cm\) fits none of the "
        r".*\"units\": \"mm\" \(1.2 x 0.8 x 0.15 m\)",
    ):
        gg.build_scene(layout_json, seed=0, assets=cat)
