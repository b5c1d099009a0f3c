"""External assets: files in five formats load in metres, Z up, on the library's origin; scene
building draws and fits them like built-in assets; bad files fail naming the file."""

import json
import re

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.resources import data_dir
from genie_gl.scene import ASSETS, Catalogue, load_asset, register_asset

EXACT = 1e-6
# the known asset: a 1.0 x 0.5 x 0.2 m box (Z up), expected centred on x = y = 0 on z = 0
EXTENTS = np.array([1.0, 0.5, 0.2])
BOUNDS = np.array([-EXTENTS / 2, EXTENTS / 2]) + [0, 0, EXTENTS[2] / 2]
Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]])  # Z-up -> Y-up coords


@pytest.fixture(autouse=True)
def no_registrations():
    ASSETS.clear()
    yield
    ASSETS.clear()


def _box(extents, centre, transform=None) -> trimesh.Trimesh:
    m = trimesh.creation.box(extents=extents)
    m.apply_translation(centre)
    if transform is not None:
        m.apply_transform(transform)
    return m


def _usd_box(path, *, scale: float, up: str, offset=(10, 20, 30), mesh=True) -> None:
    """The known box authored with pxr in ``scale`` metres per unit and ``up`` axis."""
    from pxr import Gf, Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y if up == "y" else UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, scale)
    root = UsdGeom.Xform.Define(stage, "/Asset")
    root.AddTranslateOp().Set(Gf.Vec3d(*offset))
    if mesh:
        box = _box(EXTENTS / scale, (0, 0, 0), Y_UP if up == "y" else None)
        geom = UsdGeom.Mesh.Define(stage, "/Asset/Geom")
        geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(box.vertices.astype(np.float32)))
        geom.CreateFaceVertexCountsAttr([3] * len(box.faces))
        geom.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(box.faces.astype(np.int32).ravel()))
    stage.GetRootLayer().Save()


def test_obj_in_millimetres(tmp_path):
    _box(EXTENTS * 1000, (3000, -200, 700)).export(tmp_path / "crate.obj")
    assert register_asset("pallet", tmp_path / "crate.obj", units="mm") == "crate"
    m = ASSETS.mesh("pallet", "crate")
    np.testing.assert_allclose(m.bounds, BOUNDS, atol=EXACT)
    assert m.is_volume and m.volume == pytest.approx(EXTENTS.prod(), abs=EXACT)
    assert ASSETS.variants("pallet") == ["eur", "half", "crate"]


def test_obj_authored_y_up_on_request(tmp_path):
    _box(EXTENTS, (0.3, 0.1, -2.0), Y_UP).export(tmp_path / "crate.obj")
    # read as Z up (OBJ's default here), the Y-up box stands on its 1.0 x 0.2 m side, 0.5 m tall
    np.testing.assert_allclose(
        load_asset(tmp_path / "crate.obj").bounds, [[-0.5, -0.1, 0], [0.5, 0.1, 0.5]], atol=EXACT
    )
    np.testing.assert_allclose(
        load_asset(tmp_path / "crate.obj", up="y").bounds, BOUNDS, atol=EXACT
    )


def test_stl_in_metres_and_inward_faces_turned_out(tmp_path):
    box = _box(EXTENTS, (5.0, 5.0, 1.0))
    box.invert()  # faces wound inwards: volume < 0
    assert box.volume < 0
    box.export(tmp_path / "box.stl")
    m = load_asset(tmp_path / "box.stl")
    np.testing.assert_allclose(m.bounds, BOUNDS, atol=EXACT)
    assert m.is_volume and m.volume == pytest.approx(EXTENTS.prod(), abs=EXACT)


def test_ply_in_inches_given_as_metres_per_unit(tmp_path):
    _box(EXTENTS / 0.0254, (-40, 0, 10)).export(tmp_path / "box.ply")
    np.testing.assert_allclose(
        load_asset(tmp_path / "box.ply", units=0.0254).bounds, BOUNDS, atol=EXACT
    )


def test_glb_scene_is_flattened_with_its_node_transforms_and_read_y_up(tmp_path):
    # two halves of the box (glTF: Y up, metres), each a node placed by its own transform
    s = trimesh.Scene()
    half = trimesh.creation.box(extents=(0.5, 0.2, 0.5))
    for x in (-0.25, 0.25):
        s.add_geometry(
            half,
            node_name=f"half{x}",
            transform=trimesh.transformations.translation_matrix((7 + x, 1.0, -3.0)),
        )
    s.export(tmp_path / "halves.glb")
    m = load_asset(tmp_path / "halves.glb")
    np.testing.assert_allclose(m.bounds, BOUNDS, atol=EXACT)
    assert m.volume == pytest.approx(EXTENTS.prod(), abs=EXACT)
    np.testing.assert_allclose(
        load_asset(tmp_path / "halves.glb", up="z").bounds[1], [0.5, 0.1, 0.5], atol=EXACT
    )


def test_usda_y_up_centimetres(tmp_path):
    _usd_box(tmp_path / "box.usda", scale=0.01, up="y")
    assert register_asset("stillage", tmp_path / "box.usda", variant="cm_box") == "cm_box"
    m = ASSETS.mesh("stillage", "cm_box")
    np.testing.assert_allclose(m.bounds, BOUNDS, atol=EXACT)
    assert m.volume == pytest.approx(EXTENTS.prod(), abs=EXACT)
    # the caller's units and up axis override the stage's metadata
    np.testing.assert_allclose(
        load_asset(tmp_path / "box.usda", units="m", up="y").bounds, BOUNDS * 100, atol=EXACT * 100
    )


def test_usdc_z_up_metres(tmp_path):
    _usd_box(tmp_path / "box.usdc", scale=1.0, up="z")
    np.testing.assert_allclose(load_asset(tmp_path / "box.usdc").bounds, BOUNDS, atol=EXACT)


def _write_bad(tmp_path, name: str):
    p = tmp_path / name
    if name == "empty.obj":
        p.write_text("")
    elif name == "cloud.ply":
        trimesh.PointCloud(np.random.default_rng(0).random((20, 3))).export(p)
    elif name == "xform_only.usda":
        _usd_box(p, scale=1.0, up="z", mesh=False)
    elif name == "nan.obj":
        p.write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    elif name == "inf.usda":
        p.write_text(
            '#usda 1.0\ndef Mesh "M" {\n point3f[] points = [(0, 0, 0), (1, 0, inf), (0, 1, 0)]\n'
            " int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 2]\n}\n"
        )
    elif name == "garbage.usda":
        p.write_text("this is not usd")
    elif name == "box.fbx":
        p.write_text("; FBX 7.4.0 project file")
    return p


@pytest.mark.parametrize(
    "name, expected",
    [
        ("empty.obj", "the file is empty; expected a mesh"),
        ("cloud.ply", "no triangle faces .* expected a triangle mesh"),
        ("xform_only.usda", "holds no mesh"),
        ("nan.obj", "1 of 3 vertices are NaN or Inf"),
        ("inf.usda", "NaN or Inf points"),
        ("garbage.usda", "could not open the stage"),
        ("missing.glb", "no such asset file"),
        ("box.fbx", r"unknown asset format '\.fbx'; expected one of \.obj, \.glb"),
    ],
)
def test_bad_files_name_the_file_and_what_was_expected(tmp_path, name, expected):
    p = _write_bad(tmp_path, name)
    with pytest.raises(gg.ConfigError, match=re.escape(name) + ".*" + expected):
        register_asset("pallet", p)
    assert ASSETS.variants("pallet") == ["eur", "half"]


def test_bad_arguments(tmp_path):
    _box(EXTENTS, (0, 0, 0)).export(tmp_path / "eur.obj")
    with pytest.raises(gg.ConfigError, match="unknown asset class 'palet'; did you mean 'pallet'"):
        register_asset("palet", tmp_path / "eur.obj")
    with pytest.raises(gg.ConfigError, match="already has a variant 'eur'; pass variant="):
        register_asset("pallet", tmp_path / "eur.obj")
    with pytest.raises(gg.ConfigError, match="unknown units 'cms'; did you mean 'cm'"):
        register_asset("pallet", tmp_path / "eur.obj", variant="x", units="cms")
    with pytest.raises(gg.ConfigError, match="positive number of metres per unit"):
        register_asset("pallet", tmp_path / "eur.obj", variant="x", units=-1.0)
    with pytest.raises(gg.ConfigError, match="up must be 'y' or 'z'"):
        register_asset("pallet", tmp_path / "eur.obj", variant="x", up="x")


def _assert_placed_inside_unscaled(scene, layout, key, extents) -> int:
    """Every instance of mesh ``key`` lies in its leaf region, rigidly; returns how many there
    are."""
    leaves = layout.leaves()
    mesh = scene.meshes[key]
    np.testing.assert_allclose(mesh.bounds[1] - mesh.bounds[0], extents, atol=EXACT)
    n = 0
    for inst in scene.instances:
        if inst.mesh != key:
            continue
        T, reg = inst.world_from_model, leaves[int(inst.name.split("_")[-2])]
        w = np.c_[trimesh.bounds.corners(mesh.bounds), np.ones(8)] @ T.T
        assert w[:, 0].min() >= reg.x - EXACT and w[:, 0].max() <= reg.x + reg.w + EXACT
        assert w[:, 1].min() >= reg.y - EXACT and w[:, 1].max() <= reg.y + reg.h + EXACT
        # rigid: a rotation, never a scale (least of all a non-uniform one)
        np.testing.assert_allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
        n += 1
    return n


def test_build_scene_draws_registered_assets_inside_their_regions_unscaled(tmp_path):
    crate, big = np.array([1.0, 0.6, 0.3]), np.array([5.0, 4.0, 1.0])
    _box(crate, (0, 0, 0)).export(tmp_path / "crate.stl")
    _box(big, (0, 0, 0)).export(tmp_path / "big.stl")
    register_asset("pallet", tmp_path / "crate.stl")
    register_asset("pallet", tmp_path / "big.stl")  # fits no region: refused, never shrunk
    layout = gg.generate_layout("storage_area", seed=1)
    with pytest.raises(
        gg.ConfigError, match=r"big.stl: a pallet asset of 5 x 4 x 1 m .* fits none of the"
    ):
        gg.build_scene(layout, seed=0)
    ASSETS.clear()
    register_asset("pallet", tmp_path / "crate.stl")
    scene = gg.build_scene(layout, seed=0)
    pallets = sum(i.semantic == 1 for i in scene.instances)
    assert 0 < _assert_placed_inside_unscaled(scene, layout, "pallet_crate", crate) < pallets
    # the same registrations handed over as a catalogue give the same scene
    ASSETS.clear()
    cat = Catalogue()
    cat.register("pallet", tmp_path / "crate.stl")
    again = gg.build_scene(layout, seed=0, assets=cat)
    assert [i.mesh for i in again.instances] == [i.mesh for i in scene.instances]


def test_strategy_assets_are_relative_to_the_strategy_and_do_not_leak(tmp_path):
    (tmp_path / "strategies" / "meshes").mkdir(parents=True)
    _box([0.9, 0.5, 0.25], (0, 0, 0)).export(tmp_path / "strategies" / "meshes" / "crate.obj")
    _box([60, 40, 28], (0, 0, 0), Y_UP).export(tmp_path / "strategies" / "meshes" / "tote.glb")
    strategy = json.loads((data_dir("layouts") / "storage_area.json").read_text())
    strategy["scene"]["assets"] = {
        "pallet": ["meshes/crate.obj"],
        "klt": [{"path": "meshes/tote.glb", "variant": "tote", "units": "cm"}],
    }
    path = tmp_path / "strategies" / "mine.json"
    path.write_text(json.dumps(strategy))
    for seed in range(10):  # variants are drawn at random: find a layout that draws both
        layout = gg.generate_layout(path, seed=seed)
        scene = gg.build_scene(layout, seed=0)
        if {"pallet_crate", "klt_tote"} <= set(scene.meshes):
            break
    assert _assert_placed_inside_unscaled(scene, layout, "pallet_crate", [0.9, 0.5, 0.25]) > 0
    assert _assert_placed_inside_unscaled(scene, layout, "klt_tote", [0.6, 0.4, 0.28]) > 0
    assert ASSETS.variants("pallet") == ["eur", "half"]
    # a layout written to JSON keeps working from elsewhere: the paths were made absolute
    layout.to_json(tmp_path / "layout.json")
    back = gg.Layout.from_json(tmp_path / "layout.json")
    assert [i.mesh for i in gg.build_scene(back, seed=0).instances] == [
        i.mesh for i in scene.instances
    ]

    strategy["scene"]["assets"] = {"pallet": ["meshes/nothing.obj"]}
    path.write_text(json.dumps(strategy))
    with pytest.raises(
        gg.ConfigError, match=r"scene\.assets\.pallet\[0\]: .*nothing\.obj: no such asset file"
    ):
        gg.build_scene(gg.generate_layout(path, seed=1), seed=0)


def test_dataset_worker_processes_refuse_process_local_registrations(tmp_path):
    from genie_gl.dataset import run_dataset

    _box(EXTENTS, (0, 0, 0)).export(tmp_path / "crate.obj")
    register_asset("pallet", tmp_path / "crate.obj")
    assert ASSETS.registered() == {"pallet": ["crate"]}
    with pytest.raises(
        gg.ConfigError, match="worker processes would not see them; list them in the strategy"
    ):
        run_dataset(
            {"executor": "process", "workers": 2, "out": str(tmp_path / "out")}, progress=False
        )
    assert not (tmp_path / "out").exists()


def test_scene_meshes_are_converted_once_and_shared(tmp_path):
    """A variant's scene mesh is made once (per process for built-in variants, per catalogue
    for registered ones) and equals a fresh conversion of the variant's mesh."""
    v = next(iter(gg.scene.assets.library.VARIANTS["pallet"]))
    a, b = Catalogue().scene_mesh("pallet", v), Catalogue().scene_mesh("pallet", v)
    assert a is b
    fresh = gg.Mesh.from_trimesh(ASSETS.mesh("pallet", v))
    assert a.digest() == fresh.digest() and np.array_equal(a.vertices, fresh.vertices)
    path = tmp_path / "crate.stl"
    _box(EXTENTS, [0, 0, EXTENTS[2] / 2]).export(path)
    one, other = Catalogue(), Catalogue()
    name = one.register("klt", path)
    other.register("klt", path)
    m = one.scene_mesh("klt", name)
    assert m is one.scene_mesh("klt", name) and m is not other.scene_mesh("klt", name)
    assert (
        np.allclose(m.bounds, BOUNDS, atol=EXACT)
        and m.digest() == other.scene_mesh("klt", name).digest()
    )
