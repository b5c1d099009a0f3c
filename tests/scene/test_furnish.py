"""Furnished regions: rows, grids, stacks and loaded racks, each item its own instance."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import genie_gl as gg
from genie_gl.layout import Layout, Region, RegionType, parse_strategy
from genie_gl.scene.assets import library as lib


def _scene(rtype: RegionType, w: float, h: float, seed: int = 0, orientation: str = "up"):
    layout = Layout.from_regions(
        [Region(0.0, 0.0, w, h, rtype.name, orientation)], {rtype.name: rtype}, (0.0, 0.0, w, h)
    )
    return gg.build_scene(layout, seed=seed, options={})


def _placed(scene, cls):
    out = []
    for inst in scene.instances:
        if inst.semantic != lib.SEMANTIC[cls] or inst.mesh.split("_")[0] != cls:
            continue
        m = scene.meshes[inst.mesh]
        lo, hi = m.vertices.min(0), m.vertices.max(0)
        corners = np.array(
            [[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        w = corners @ inst.world_from_model.T
        out.append((inst, w[:, :3].min(0), w[:, :3].max(0)))
    return out


@pytest.mark.parametrize("seed", range(3))
def test_a_row_runs_along_the_long_side_with_the_clearance(seed):
    t = RegionType(
        "racks", final=True, semantic=2, asset_group="rack", fill={"mode": "row", "spacing_m": 0.1}
    )
    racks = _placed(_scene(t, 10.0, 1.3, seed), "rack")
    width = racks[0][2][0] - racks[0][1][0]  # every rack of a row is the same variant
    assert len(racks) == int((10.0 + 0.1 + 1e-9) // (width + 0.1))
    xs = sorted((lo[0], hi[0]) for _, lo, hi in racks)
    gaps = [b[0] - a[1] for a, b in zip(xs, xs[1:])]
    np.testing.assert_allclose(gaps, 0.1, atol=1e-6)  # float32 vertices
    assert xs[0][0] >= -1e-6 and xs[-1][1] <= 10.0 + 1e-6
    # a row along y when the region is tall
    tall = _placed(_scene(t, 1.3, 10.0, seed), "rack")
    assert len(tall) == len(racks)
    assert np.ptp([(lo[0] + hi[0]) / 2 for _, lo, hi in tall]) < 1e-6


def test_count_caps_a_row_and_grid_fills_both_ways():
    lane = RegionType(
        "lane",
        final=True,
        semantic=8,
        asset_group="forklift",
        fill={"mode": "row", "count": [2, 2], "spacing_m": 3.0},
    )
    assert len(_placed(_scene(lane, 40.0, 3.0), "forklift")) == 2
    capped = RegionType(
        "pallets",
        final=True,
        semantic=1,
        asset_group="pallet",
        fill={"mode": "grid", "spacing_m": 0.2, "count": 5},
    )
    assert len(_placed(_scene(capped, 4.0, 4.0, seed=1), "pallet")) == 5  # of 12 that fit
    grid = RegionType(
        "pallets",
        final=True,
        semantic=1,
        asset_group="pallet",
        fill={"mode": "grid", "spacing_m": 0.2},
    )
    pallets = _placed(_scene(grid, 4.0, 4.0, seed=1), "pallet")
    w, d = pallets[0][2][:2] - pallets[0][1][:2]
    assert len(pallets) == int((4.2 + 1e-6) // (w + 0.2)) * int((4.2 + 1e-6) // (d + 0.2))
    lows = [lo for _, lo, _ in pallets]
    assert len({round(p[0], 6) for p in lows}) > 1 and len({round(p[1], 6) for p in lows}) > 1


def test_stack_goes_up_to_the_height():
    t = RegionType(
        "klts", final=True, semantic=9, asset_group="klt", fill={"mode": "stack", "stack_m": 1.0}
    )
    klts = _placed(_scene(t, 1.0, 1.0), "klt")
    h = klts[0][2][2] - klts[0][1][2]
    assert len(klts) == int(1.0 // (h + 0.001)) >= 3
    np.testing.assert_allclose(
        sorted(lo[2] for _, lo, _ in klts), np.arange(len(klts)) * (h + 0.001), atol=1e-9
    )


def test_loaded_racks_carry_their_own_instances_on_the_shelves():
    t = RegionType(
        "racks",
        final=True,
        semantic=2,
        asset_group="rack",
        fill={"mode": "row", "spacing_m": 0.1, "load": {"pallet": 1, "stillage": 1, "klt": 1}},
    )
    loaded = 0
    for seed in range(3):
        scene = _scene(t, 12.0, 1.3, seed)
        racks = _placed(scene, "rack")
        variant = racks[0][0].mesh.split("_", 1)[1]
        decks = [z for z, *_ in lib.SHELVES["rack"][variant]]
        for cls in ("pallet", "stillage", "klt"):
            for inst, lo, hi in _placed(scene, cls):
                loaded += 1
                assert inst.semantic == lib.SEMANTIC[cls]
                # on a deck (a KLT may stand on a pallet or another KLT), inside one rack's
                # footprint
                on = [
                    r
                    for r in racks
                    if np.all(lo[:2] >= r[1][:2] - 1e-6) and np.all(hi[:2] <= r[2][:2] + 1e-6)
                ]
                assert len(on) == 1
                assert min(abs(lo[2] - z) for z in decks) < 1e-6 or cls == "klt"
        ids = [i.instance for i in scene.instances]
        assert len(ids) == len(set(ids))
    assert loaded > 10


def test_same_seed_same_furnishing():
    t = RegionType(
        "racks",
        final=True,
        semantic=2,
        asset_group="rack",
        fill={
            "mode": "row",
            "spacing_m": [0.05, 0.3],
            "count": [1, 5],
            "load": {"pallet": 1, "empty": 1},
        },
    )
    a, b = _scene(t, 12.0, 1.3, 5), _scene(t, 12.0, 1.3, 5)
    assert [(i.mesh, i.world_from_model.tobytes()) for i in a.instances] == [
        (i.mesh, i.world_from_model.tobytes()) for i in b.instances
    ]


def test_bad_fill_is_refused_with_its_path():
    s = {
        "name": "f",
        "root": {"width": 4, "height": 4, "type": "hall"},
        "region_types": {
            "hall": {},
            "r": {"final": True, "asset_group": "rack", "fill": {"mode": "rows"}},
        },
        "levels": [
            {"hall": {"generator": "grid", "args": {"cell": [2, 2]}, "children": {"cell": "r"}}}
        ],
    }
    with pytest.raises(gg.ConfigError, match=r"region_types\.r\.fill\.mode"):
        parse_strategy(s)
    s["region_types"]["r"]["fill"] = {"mode": "row", "count": [3, 1]}
    with pytest.raises(gg.ConfigError, match=r"fill\.count"):
        parse_strategy(s)
    t = RegionType("r", final=True, asset_group="rack", fill={"mode": "row", "load": {"palet": 1}})
    with pytest.raises(gg.ConfigError, match="did you mean 'pallet'"):
        _scene(t, 4.0, 2.0)


def test_the_assembly_line_runs_both_ways():
    directions = set()
    for seed in range(8):
        line = next(
            r
            for r in gg.generate_layout("assembly_line", seed=seed).regions()
            if r[0].type == "line"
        )[0]
        directions.add("horizontal" if line.w > line.h else "vertical")
    assert directions == {"horizontal", "vertical"}


@settings(max_examples=25, deadline=None)
@given(
    w=st.floats(1.5, 9.0),
    h=st.floats(1.3, 6.0),
    cls=st.sampled_from(["rack", "stillage", "pallet", "klt", "cabinet", "forklift", "dolly"]),
    mode=st.sampled_from(["one", "row", "grid", "stack"]),
    spacing=st.floats(0.0, 0.5),
    count=st.one_of(st.none(), st.integers(1, 6)),
    stack=st.one_of(st.none(), st.floats(0.2, 2.5)),
    jitter=st.booleans(),
    seed=st.integers(0, 2**16),
    orientation=st.sampled_from(["up", "right", "down", "left"]),
)
def test_furnished_items_never_interpenetrate_and_stay_inside(
    w, h, cls, mode, spacing, count, stack, jitter, seed, orientation
):
    import itertools

    from tests.scene.test_scene import _boxes, _clash

    fill = {
        "mode": mode,
        "spacing_m": spacing,
        "count": count,
        "stack_m": stack,
        "load": {"pallet": 1, "stillage": 1, "klt": 1, "empty": 1} if cls == "rack" else None,
    }
    t = RegionType("r", final=True, semantic=1, asset_group=cls, fill=fill)
    layout = Layout.from_regions(
        [Region(0.0, 0.0, w, h, "r", orientation)], {"r": t}, (0.0, 0.0, w, h)
    )
    options = {"jitter": {"position_m": 0.3, "yaw_rad": 0.2}} if jitter else {}
    scene = gg.build_scene(layout, seed=seed, options=options)
    boxes = _boxes(scene, shrink=0.01)
    assert not [
        (a[0], b[0]) for a, b in itertools.combinations(boxes, 2) if _clash(scene, a, b, 0.01)
    ]
    for inst in scene.instances[1:]:  # the floor first, then the items
        v = scene.meshes[inst.mesh].vertices.astype(np.float64)
        xy = (np.c_[v, np.ones(len(v))] @ inst.world_from_model.T)[:, :2]
        assert xy.min() >= -1e-6 and xy[:, 0].max() <= w + 1e-6 and xy[:, 1].max() <= h + 1e-6
