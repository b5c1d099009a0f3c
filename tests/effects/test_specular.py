"""specular_loss on a synthetic frame of four materials: bare metal loses every return, a
shiny painted surface only within the glare cone around the mirror direction (analytic),
glass all (``transparent: drop``), matte none; with rendered normals and with normals from
the depth image; the one compiled pass equals the per-pixel codes it looks up."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.scene.materials import MaterialTable
from genie_gl.scene.model import Material
from genie_gl.effects import kernels
from genie_gl.effects.geometry import pixel_rays_xy
from genie_gl.effects.specular import SpecularLoss

W, H, F = 120, 90, 60.0
MATERIALS = (
    Material((0.5, 0.5, 0.5), 0.0, 0.9),  # 1 matte
    Material((0.5, 0.5, 0.5), 0.0, 0.2),  # 2 shiny paint: glare only
    Material((0.6, 0.6, 0.6), 1.0, 0.1),  # 3 bare metal below 0.25 roughness
    Material((0.9, 0.9, 0.9), 0.0, 0.1, 0.2),
)  # 4 clear


def quadrants(normals=True):
    """A wall at 2 m facing the camera; the instance of each pixel by quadrant (1-4)."""
    s = gg.Sensor.pinhole(W, H, F)
    d = np.full((H, W), 2.0, np.float32)
    inst = np.ones((H, W), np.uint32)
    inst[:, W // 2 :] = 2
    inst[H // 2 :, : W // 2] = 3
    inst[H // 2 :, W // 2 :] = 4
    inst[:8, :8] = 2  # a shiny patch off axis: no glare there
    n = np.zeros((H, W, 3), np.float32)
    n[..., 2] = -1
    return gg.Frame(d, inst, inst.astype(np.uint16), None, s, np.eye(4), n if normals else None)


@pytest.fixture(scope="module")
def table():
    scene = gg.Scene()
    for m in MATERIALS:
        scene.add(trimesh.creation.box((1, 1, 1)), material=m)
    return MaterialTable.from_scene(scene)


@pytest.mark.parametrize("normals", [True, False])
def test_each_material_loses_what_its_physics_says(table, normals):
    f = quadrants(normals)
    eff = SpecularLoss(glare_deg=8.0, metal_min_roughness=0.25, transparent="drop")
    out = eff.apply(f, rng=np.random.default_rng(0), materials=table)
    lost = (f.depth > 0) & (out.depth == 0)
    u, v = np.meshgrid(np.arange(W) - (W - 1) / 2, np.arange(H) - (H - 1) / 2)
    theta = np.degrees(np.arctan(np.hypot(u, v) / F))  # angle between ray and normal
    inside = np.ones((H, W), bool)
    if not normals:  # from the depth image: none on the border (no central difference)
        inside[[0, -1], :] = inside[:, [0, -1]] = False
    away = np.abs(theta - 8.0) > 0.05  # off the cone's edge
    shiny = (f.instance == 2) & inside & away
    assert not lost[f.instance == 1].any()  # matte: nothing
    np.testing.assert_array_equal(lost[shiny], theta[shiny] < 8.0)  # shiny: the glare cone
    assert lost[shiny].sum() > 50 and not lost[:8, :8].any()
    assert lost[f.instance == 3].all() and lost[f.instance == 4].all()  # bare metal, glass
    assert not out.instance[lost].any() and not out.semantic[lost].any()
    rec = out.meta["specular_loss"]
    assert rec["dropped"] == rec["changed"] == lost.sum()


def test_the_one_pass_looks_up_the_codes_pixel_codes_gives(table):
    f = quadrants()
    f.depth[10:20, 30:90] = 0  # holes look nothing up
    eff = SpecularLoss()
    by_id = eff._codes(table)
    kind, n = kernels.pixel_codes(f.depth, f.instance, by_id)
    assert n == int(((f.depth > 0) & (f.instance != 1)).sum())
    assert kernels.any_code(f.depth, f.instance, by_id)
    matte = np.where(f.depth > 0, 1, 7).astype(np.uint32)  # ids beyond the table read its last
    assert not kernels.any_code(f.depth, matte, by_id[:2].copy())
    lost, n_lost, n_clear = kernels.specular_lost(
        f.depth,
        f.instance,
        by_id,
        *pixel_rays_xy(f.sensor),
        f.normal,
        float(np.cos(np.radians(8.0))),
        True,
    )
    assert n_clear == int((kind & 4).astype(bool).sum()) and n_lost == lost.sum()
    assert lost[(kind & 2).astype(bool)].all() and not lost[kind == 0].any()
