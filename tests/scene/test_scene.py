"""Asset library dimensions and sanity, scene building, USD round trip and foreign stages."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.scene.assets import library as lib

DECLARED = {
    ("pallet", "eur"): (1.2, 0.8, 0.144),
    ("pallet", "half"): (0.8, 0.6, 0.144),
    ("klt", "6428"): (0.6, 0.4, 0.28),
    ("stillage", "standard"): (1.24, 0.835, 0.97),
    ("rack", "1bay_3lv"): (2.7, 1.1, 3.2),
    ("car", "sedan"): (1.8, 4.6, 1.45),
    ("cabinet", "two_door"): (1.0, 0.5, 1.95),
    ("dolly", "standard"): (1.2, 0.8, 0.225),
}


@pytest.mark.parametrize("key", sorted(DECLARED))
def test_asset_bounding_boxes_match_declared_dimensions(key):
    m = lib.make(*key)
    ext = m.bounds[1] - m.bounds[0]
    tol = np.array(DECLARED[key]) * 0.01
    # cabinet handles stand proud of the doors by design (+28 mm)
    if key[0] == "cabinet":
        tol[1] = 0.03
    np.testing.assert_allclose(ext, DECLARED[key], atol=tol.max() if key[0] != "cabinet" else 0.03)


@pytest.mark.parametrize("cls", sorted(lib.VARIANTS))
def test_every_variant_is_clean_and_watertight(cls):
    assert len(lib.VARIANTS[cls]) >= 2
    for v in lib.VARIANTS[cls]:
        m = lib.make(cls, v)
        assert np.isfinite(m.vertices).all()
        assert (m.area_faces > 1e-10).all()
        assert m.is_watertight, (cls, v)
        assert m.bounds[0][2] == pytest.approx(0.0, abs=1e-6)


def test_build_scene_is_deterministic_and_assets_sit_in_their_regions(tmp_path):
    layout = gg.generate_layout("assembly_line", seed=4)
    a = gg.build_scene(layout, seed=1)
    b = gg.build_scene(layout, seed=1)
    gg.write_usd(a, tmp_path / "a.usda")
    gg.write_usd(b, tmp_path / "b.usda")
    assert (tmp_path / "a.usda").read_bytes() == (tmp_path / "b.usda").read_bytes()
    leaves = layout.leaves()
    placed = 0
    for inst in a.instances:
        if not inst.name or inst.name.startswith(("floor", "wall", "column")):
            continue
        idx = int(inst.name.split("_")[-2])
        reg = leaves[idx]
        m = a.meshes[inst.mesh]
        corners = np.c_[trimesh.bounds.corners(m.bounds), np.ones(8)] @ inst.world_from_model.T
        assert corners[:, 0].min() >= reg.x - 1e-6 and corners[:, 0].max() <= reg.x + reg.w + 1e-6
        assert corners[:, 1].min() >= reg.y - 1e-6 and corners[:, 1].max() <= reg.y + reg.h + 1e-6
        placed += 1
    assert placed > 30
    with_group = [r for r in leaves if layout.region_types[r.type].asset_group]
    assert placed >= 0.8 * len(with_group)


def test_randomisation_off_means_no_draw():
    layout = gg.generate_layout("assembly_line", seed=4)
    opts = {"walls": True}
    rng = np.random.default_rng(0)
    gg.build_scene(layout, options=opts, rng=rng)
    used = rng.bit_generator.state["state"]["state"]
    rng2 = np.random.default_rng(0)
    gg.build_scene(
        layout,
        options={**opts, "jitter": None, "dropout": 0, "stack": False, "color": False},
        rng=rng2,
    )
    assert rng2.bit_generator.state["state"]["state"] == used


@pytest.mark.parametrize("suffix", [".usda", ".usdc"])
def test_usd_round_trip(tmp_path, suffix):
    scene = gg.build_scene(gg.generate_layout("assembly_line", seed=0), seed=0)
    gg.write_usd(scene, tmp_path / f"s{suffix}")
    back = gg.read_usd(tmp_path / f"s{suffix}")
    a = sorted(scene.instances, key=lambda i: i.instance)
    b = sorted(back.instances, key=lambda i: i.instance)
    assert [i.instance for i in a] == [i.instance for i in b]
    for x, y in zip(a, b):
        assert np.abs(x.world_from_model - y.world_from_model).max() < 1e-9
        assert x.semantic == y.semantic
        mx, my = scene.meshes[x.mesh], back.meshes[y.mesh]
        np.testing.assert_array_equal(mx.vertices, my.vertices)
        np.testing.assert_array_equal(mx.faces, my.faces)
    assert len(back.meshes) == len(scene.meshes)


def test_semantic_labels_are_authored_in_both_apis(tmp_path):
    from pxr import Usd, UsdSemantics

    scene = gg.Scene()
    scene.add(trimesh.creation.box((1, 1, 1)), semantic=1, name="pallet_a")
    gg.write_usd(scene, tmp_path / "s.usda")
    stage = Usd.Stage.Open(str(tmp_path / "s.usda"))
    prim = stage.GetPrimAtPath("/World/pallet_a")
    assert prim.GetAttribute("semantic:Semantics:params:semanticData").Get() == "pallet"
    assert list(UsdSemantics.LabelsAPI(prim, "class").GetLabelsAttr().Get()) == ["pallet"]
    assert prim.IsInstanceable()
    assert stage.GetMetadata("upAxis") == "Z" and stage.GetMetadata("metersPerUnit") == 1.0


FOREIGN = """#usda 1.0
(
    upAxis = "Y"
    metersPerUnit = 0.01
    defaultPrim = "Root"
)
def Xform "Root"
{
    def Xform "Crate" (
        prepend apiSchemas = ["SemanticsAPI:Semantics"]
        prepend references = </Protos/Quad>
    )
    {
        custom string semantic:Semantics:params:semanticType = "class"
        custom string semantic:Semantics:params:semanticData = "pallet"
        double3 xformOp:translate = (100, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def PointInstancer "Boxes"
    {
        rel prototypes = </Root/Boxes/Protos/Tri>
        int[] protoIndices = [0, 0]
        point3f[] positions = [(0, 0, 0), (0, 200, 0)]
        def Scope "Protos"
        {
            def Mesh "Tri" (
                prepend apiSchemas = ["SemanticsLabelsAPI:class"]
            )
            {
                token[] semantics:labels:class = ["rack"]
                point3f[] points = [(0, 0, 0), (10, 0, 0), (0, 10, 0)]
                int[] faceVertexCounts = [3]
                int[] faceVertexIndices = [0, 1, 2]
            }
        }
    }
}
class "Protos"
{
    def Xform "Quad"
    {
        def Mesh "Geom"
        {
            point3f[] points = [(0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0), (5, 15, 0)]
            int[] faceVertexCounts = [5]
            int[] faceVertexIndices = [0, 1, 2, 4, 3]
        }
    }
}
"""


def test_foreign_stage_y_up_centimetres_references_pointinstancer_ngons(tmp_path):
    (tmp_path / "f.usda").write_text(FOREIGN)
    scene = gg.read_usd(tmp_path / "f.usda")
    by_sem = {}
    for inst in scene.instances:
        m = scene.meshes[inst.mesh]
        w = np.c_[m.vertices, np.ones(len(m.vertices))] @ inst.world_from_model.T
        by_sem.setdefault(inst.semantic, []).append((w[:, :3], m.faces))
    crate_v, crate_f = by_sem[1][0]
    assert len(crate_f) == 3  # a pentagon fan-triangulated
    # Y up, cm: local (100 + x, y, 0) cm -> world (1 + x/100, 0, y/100) m
    np.testing.assert_allclose(crate_v[:, 0].min(), 1.0, atol=1e-9)
    np.testing.assert_allclose(crate_v[:, 2].max(), 0.15, atol=1e-9)
    np.testing.assert_allclose(crate_v[:, 1], 0.0, atol=1e-9)
    racks = by_sem[2]
    assert len(racks) == 2
    assert sorted(round(v[:, 2].min(), 9) for v, _ in racks) == [
        0.0,
        2.0,
    ]  # 200 cm apart along Y up


def _boxes(scene, shrink):
    """(centre, rotation, half extents) of every non-background instance's mesh box, shrunk
    by ``shrink`` on every side; background (floor, walls, columns) is left out."""
    out = []
    for inst in scene.instances:
        if inst.mesh.split("_")[0] in ("floor", "wall", "column"):
            continue
        v = scene.meshes[inst.mesh].vertices.astype(np.float64)
        lo, hi = v.min(0), v.max(0)
        T = inst.world_from_model
        out.append(
            (
                inst.name,
                T[:3, :3] @ ((lo + hi) / 2) + T[:3, 3],
                T[:3, :3],
                np.maximum((hi - lo) / 2 - shrink, 0),
            )
        )
    return out


def _separated(a, b) -> bool:
    """Separating-axis test of two boxes turned about z only: z intervals, then the four
    edge normals in the floor plane."""
    (_, ca, Ra, ha), (_, cb, Rb, hb) = a, b
    if abs(ca[2] - cb[2]) >= ha[2] + hb[2]:
        return True
    d = (cb - ca)[:2]
    for ax in (Ra[:2, 0], Ra[:2, 1], Rb[:2, 0], Rb[:2, 1]):
        ax = ax / np.linalg.norm(ax)
        ra = ha[0] * abs(ax @ Ra[:2, 0]) + ha[1] * abs(ax @ Ra[:2, 1])
        rb = hb[0] * abs(ax @ Rb[:2, 0]) + hb[1] * abs(ax @ Rb[:2, 1])
        if abs(d @ ax) >= ra + rb:
            return True
    return False


def _part_boxes(scene, box, shrink):
    """The boxes of an instance's parts (its mesh's connected components), shrunk as in
    ``_boxes``: what a loaded rack's shelves and uprights are, inside its bounding box."""
    inst = next(i for i in scene.instances if i.name == box[0])
    m = scene.meshes[inst.mesh]
    import trimesh

    parts = trimesh.Trimesh(m.vertices, m.faces, process=False).split(only_watertight=False)
    T = inst.world_from_model
    out = []
    for p in parts:
        lo, hi = p.vertices.min(0), p.vertices.max(0)
        out.append(
            (
                box[0],
                T[:3, :3] @ ((lo + hi) / 2) + T[:3, 3],
                T[:3, :3],
                np.maximum((hi - lo) / 2 - shrink, 0),
            )
        )
    return out


def _clash(scene, a, b, shrink) -> bool:
    """Boxes that overlap, looked at part by part when they do (an item on a rack's shelf
    lies inside the rack's bounding box, not inside its beams)."""
    if _separated(a, b):
        return False
    pa, pb = _part_boxes(scene, a, shrink), _part_boxes(scene, b, shrink)
    return any(not _separated(x, y) for x in pa for y in pb)


@pytest.mark.parametrize("name", ["assembly_line", "storage_area", "logistics_lane"])
def test_instances_do_not_interpenetrate(name):
    import itertools

    for seed in range(2):
        layout = gg.generate_layout(name, seed=seed)
        options = {
            **layout.meta.get("scene", {}),
            "stack": True,
            "clutter": 0.5,
            "jitter": {"position_m": 0.3, "yaw_rad": 0.2},
        }
        scene = gg.build_scene(layout, seed=seed, options=options)
        boxes = _boxes(scene, shrink=0.01)  # 1 cm: stacked items touch, they must not sink in
        assert len(boxes) > 40
        clashes = [
            (a[0], b[0]) for a, b in itertools.combinations(boxes, 2) if _clash(scene, a, b, 0.01)
        ]
        assert not clashes, clashes[:5]
    # the test sees a clash when there is one: the same box moved by half its size (in its
    # own frame) overlaps it; moved by 1.5 sizes along its x it does not
    a = boxes[0]
    moved = lambda step: (a[0], a[1] + a[2] @ (step * a[3]), a[2], a[3])  # noqa: E731
    assert not _separated(a, moved(np.r_[1.0, 1.0, 0.0])) and _separated(
        a, moved(np.r_[3.0, 0.0, 0.0])
    )


def test_the_halls_meshes_are_made_once_and_are_the_librarys():
    """The floor, walls and columns of a hall are converted once per process for each size
    and shared by the scenes, like the assets' meshes: the same vertices and faces as the
    library's floor, box and column, and one object for two scenes of one strategy."""
    from genie_gl.scene.assets import library as lib
    from genie_gl.scene.model import Mesh

    layout = gg.generate_layout("assembly_line", seed=2)
    a, b = (
        gg.build_scene(layout, seed=1),
        gg.build_scene(gg.generate_layout("assembly_line", seed=3), seed=2),
    )
    x0, y0, w, h = layout.bounds
    for key, made in (
        ("floor", lib.floor(w, h)),
        ("wall_2", lib.box([0.2, h, 5.0], [0, 0, 2.5])),
        ("column", lib.column()),
    ):
        want = Mesh.from_trimesh(made)
        got = a.meshes[key]
        np.testing.assert_array_equal(got.vertices, want.vertices)
        np.testing.assert_array_equal(got.faces, want.faces)
        assert got.closed == want.closed and got.digest() == want.digest()
        assert b.meshes[key] is got  # one hall size: one mesh for both scenes


@pytest.mark.parametrize(
    "field, bad",
    [
        ("instance", 1.5),
        ("instance", "7"),
        ("instance", float("nan")),
        ("semantic", None),
        ("semantic", 2.5),
    ],
)
def test_an_id_that_is_not_a_whole_number_is_refused_by_name(field, bad):
    """Ids were cut by int() (1.5 became 1) or failed in it with a TypeError; a whole float is
    an id, anything else a ConfigError naming the id, and the scene is left as it was."""
    scene = gg.Scene()
    box = trimesh.creation.box()
    assert scene.add(box, np.eye(4), semantic=3.0, instance=np.int64(5)) == 5
    with pytest.raises(gg.errors.ConfigError, match=f"{field} id must be a whole number"):
        scene.add(box, np.eye(4), **{"semantic": 1, field: bad})
    assert [i.instance for i in scene.instances] == [5]
