"""Materials: per-class ranges, USD round trip, foreign UsdPreviewSurface inputs, implicit
gprims."""

from __future__ import annotations

import numpy as np
import pytest
from pxr import Usd, UsdShade

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.scene.materials import CLASS_KIND, KINDS, MaterialTable
from genie_gl.scene.model import DEFAULT_MATERIAL, Material
from genie_gl.scene.usd import read_usd

FOREIGN = """#usda 1.0
(
    upAxis = "Z"
    metersPerUnit = 1
)
def Xform "World"
{
    def Mesh "plate" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        rel material:binding = </World/Looks/steel>
    }
    def Sphere "ball"
    {
        double radius = 0.5
        double3 xformOp:translate = (3, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def Cylinder "pipe" (prepend apiSchemas = ["MaterialBindingAPI"])
    {
        double radius = 0.1
        double height = 2
        uniform token axis = "X"
        rel material:binding = </World/Looks/partial>
    }
    def Scope "Looks"
    {
        def Material "steel"
        {
            token outputs:surface.connect = </World/Looks/steel/pbr.outputs:surface>
            def Shader "pbr"
            {
                uniform token info:id = "UsdPreviewSurface"
                color3f inputs:diffuseColor = (0.25, 0.5, 0.75)
                float inputs:metallic = 1
                float inputs:roughness = 0.125
                float inputs:opacity = 0.875
                float inputs:ior = 2.5
                token outputs:surface
            }
        }
        def Material "partial"
        {
            token outputs:surface.connect = </World/Looks/partial/pbr.outputs:surface>
            def Shader "pbr"
            {
                uniform token info:id = "UsdPreviewSurface"
                float inputs:roughness = 0.25
                token outputs:surface
            }
        }
    }
}
"""


@pytest.fixture(scope="module")
def built():
    layout = gg.generate_layout("layouts/storage_area.json", seed=3)
    return gg.build_scene(layout, seed=3)


def test_every_instance_gets_its_class_material(built):
    assert all(i.material is not None for i in built.instances)
    floor = next(i for i in built.instances if i.name == "floor")
    assert KINDS[CLASS_KIND["floor"]].roughness[0] <= floor.material.roughness
    sem_kinds = {1: "wood", 2: "painted_steel", 5: "galvanised", 9: "plastic"}
    seen = set()
    for inst in built.instances:
        kind = sem_kinds.get(inst.semantic)
        if kind:
            k = KINDS[kind]
            assert k.roughness[0] - 1e-6 <= inst.material.roughness <= k.roughness[1] + 1e-6, (
                kind,
                inst.material,
            )
            assert k.metallic[0] - 1e-6 <= inst.material.metallic <= k.metallic[1] + 1e-6
            seen.add(kind)
    assert seen, "the storage area holds pallets, stillages or KLTs"
    # drawn within the range, not fixed: two instances of one class differ
    pallets = [i.material for i in built.instances if i.semantic in (1, 5, 9)]
    assert len(set(pallets)) == len(pallets) > 1


def test_materials_are_seeded():
    layout = gg.generate_layout("layouts/storage_area.json", seed=3)
    a, b = gg.build_scene(layout, seed=5), gg.build_scene(layout, seed=5)
    c = gg.build_scene(layout, seed=6)
    assert [i.material for i in a.instances] == [i.material for i in b.instances]
    assert [i.material for i in a.instances] != [i.material for i in c.instances]


def test_round_trip_keeps_every_input(built, tmp_path):
    path = gg.write_usd(built, tmp_path / "s.usda")
    back = gg.read_usd(path)
    want = {i.instance: i.material for i in built.instances}
    got = {i.instance: i.material for i in back.instances}
    assert got == want
    assert back.metadata["prims_without_material"] == 0
    # an independent reader (pxr alone) sees the bound UsdPreviewSurface inputs
    stage = Usd.Stage.Open(str(path))
    inst = built.instances[-1]
    prim = next(
        p
        for p in stage.Traverse()
        if p.HasAttribute("genie:instanceId")
        and p.GetAttribute("genie:instanceId").Get() == inst.instance
    )
    mat, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
    shader, _, _ = mat.ComputeSurfaceSource()
    assert shader.GetIdAttr().Get() == "UsdPreviewSurface"
    assert shader.GetInput("roughness").Get() == pytest.approx(inst.material.roughness, abs=0)
    assert tuple(shader.GetInput("diffuseColor").Get()) == pytest.approx(
        inst.material.diffuse_color, abs=0
    )


def test_foreign_stage_materials_and_gprims(tmp_path):
    path = tmp_path / "foreign.usda"
    path.write_text(FOREIGN)
    scene = read_usd(path, segments=24)
    by_name = {i.name: i for i in scene.instances}
    assert set(by_name) == {"plate", "ball", "pipe"}
    assert by_name["plate"].material == Material((0.25, 0.5, 0.75), 1.0, 0.125, 0.875, 2.5)
    assert by_name["ball"].material is None  # no binding: read as the default
    assert by_name["pipe"].material == Material(roughness=0.25)  # the rest: USD's defaults
    assert scene.metadata["prims_without_material"] == 1
    ball = scene.meshes[by_name["ball"].mesh]
    r = np.linalg.norm(ball.vertices, axis=1)
    np.testing.assert_allclose(r, 0.5, atol=1e-6)  # vertices on the sphere
    np.testing.assert_allclose(by_name["ball"].world_from_model[:3, 3], [3, 0, 0])
    pipe = scene.meshes[by_name["pipe"].mesh]
    np.testing.assert_allclose(
        pipe.vertices.min(0), [-1, -0.1, -0.1], atol=1e-6
    )  # axis X, height 2
    np.testing.assert_allclose(pipe.vertices.max(0), [1, 0.1, 0.1], atol=1e-6)
    table = MaterialTable.from_scene(scene)
    ids = np.array([[by_name["plate"].instance, by_name["ball"].instance, 0]], np.uint32)
    np.testing.assert_allclose(
        table.metallic[table.rows(ids)], [[1.0, DEFAULT_MATERIAL.metallic, 0.0]]
    )
    assert table.reflective(ids).tolist() == [[True, False, False]]


def test_segments_is_an_accuracy_knob():
    from genie_gl.scene.gprims import tessellate

    for seg in (8, 64):
        m = tessellate("Cylinder", seg, radius=1.0, height=1.0)
        v = m.vertices.astype(np.float64)
        # facet midpoints of the rim lie r·cos(π/segments) from the axis
        ring = v[np.abs(v[:, 2] - 0.5) < 1e-6]
        ring = ring[np.linalg.norm(ring[:, :2], axis=1) > 0.5]
        ang = np.sort(np.arctan2(ring[:, 1], ring[:, 0]))
        assert len(ang) == seg
        mid = np.cos(np.pi / seg)
        assert 1 - mid == pytest.approx(1 - np.cos(np.diff(ang).max() / 2), rel=1e-5)
    with pytest.raises(ConfigError, match="segments"):
        tessellate("Sphere", 2)


def test_bad_material_is_refused():
    with pytest.raises(ConfigError, match="roughness"):
        Material(roughness=1.5)
    with pytest.raises(ConfigError, match="diffuse_color"):
        Material(diffuse_color=(2.0, 0, 0))


def test_material_inputs_are_held_as_float32_whatever_their_type():
    """Every input is its float32 value (as USD stores it): random values, the ends of the
    ranges, values that round onto an end, numpy scalars and text; out of range is refused."""
    rng = np.random.default_rng(7)
    f32 = lambda x: float(np.float32(x))  # noqa: E731
    for _ in range(300):
        c, (m, r, o), ior = rng.random(3), rng.random(3), 1.0 + 4.0 * rng.random()
        got = Material(tuple(c), m, r, o, ior)
        assert got.diffuse_color == tuple(f32(x) for x in c)
        assert (got.metallic, got.roughness, got.opacity, got.ior) == (
            f32(m),
            f32(r),
            f32(o),
            f32(ior),
        )
    edge = Material((0.0, 1.0, 1.0 + 1e-12), np.float64(1.0), np.float32(0.25), "0.5", 5.0)
    assert edge.diffuse_color == (0.0, 1.0, 1.0) and (
        edge.metallic,
        edge.roughness,
        edge.opacity,
    ) == (1.0, 0.25, 0.5)
    assert edge.ior == 5.0
    for bad, field in (
        ({"metallic": 1.001}, "metallic"),
        ({"opacity": float("nan")}, "opacity"),
        ({"diffuse_color": (0.5, 0.5)}, "diffuse_color"),
        ({"roughness": 1e300}, "roughness"),
        ({"ior": 0.5}, "ior"),
        ({"diffuse_color": (0.1, -0.2, 0.3)}, "diffuse_color"),
    ):
        with pytest.raises(ConfigError, match=field):
            Material(**bad)


def test_instance_colours_are_numpys_uniform_gain_and_normal_noise():
    """Each instance's colour: its class's base colour times a gain drawn uniformly from
    [0.75, 1.15) plus N(0, 12) noise per channel, clipped to 0..255 and truncated, drawn
    as numpy's ``uniform`` and ``normal`` draw them (the same values, the generator left in
    the same state)."""
    from genie_gl.scene.build import BASE_COLOR, SceneBuilder
    from genie_gl.scene.assets.catalogue import ASSETS
    from genie_gl.scene_options import scene_options

    layout = gg.generate_layout("assembly_line", seed=1)
    builder = SceneBuilder(
        layout, scene_options({"color": True}, "test"), ASSETS, rng=np.random.default_rng(21)
    )
    ref = np.random.default_rng(21)
    ref.spawn(1)  # the builder's material stream
    for cls in ("pallet", "rack", "car", "klt", "forklift") * 40:
        gain, noise = ref.uniform(0.75, 1.15), ref.normal(0, 12, 3)
        want = tuple(int(c) for c in np.clip(np.array(BASE_COLOR[cls]) * gain + noise, 0, 255))
        assert builder.color(cls) == want
    assert builder.rng.random() == ref.random()
