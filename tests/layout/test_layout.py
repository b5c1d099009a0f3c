"""Layout engine: exact generator and provider results, validation messages, properties."""

import copy
import json

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

import genie_gl as gg
from genie_gl.layout import Child, Generator, generate_layout, parse_strategy, register
from genie_gl.layout.providers import TypeProvider

BASE = {
    "name": "t",
    "root": {"width": 10.0, "height": 4.0, "type": "hall"},
    "region_types": {
        "hall": {},
        "cell": {"final": True, "semantic": 1, "asset_group": "pallet"},
        "a": {"final": True},
        "b": {"final": True},
    },
    "levels": [
        {"hall": {"generator": "grid", "args": {"cell": [1.0, 1.0]}, "children": {"cell": "cell"}}}
    ],
}


def strategy(**changes):
    s = copy.deepcopy(BASE)
    s.update(changes)
    return s


def test_grid_10x4_with_1m_cells_gives_40_cells():
    layout = generate_layout(parse_strategy(BASE), seed=0)
    leaves = layout.leaves()
    assert len(leaves) == 40
    assert sum(r.area for r in leaves) == pytest.approx(40.0)
    assert all(layout.root.contains(r) for r in leaves)


def test_sequential_provider_gives_the_declared_pattern():
    s = strategy(
        levels=[
            {
                "hall": {
                    "generator": "grid",
                    "args": {"cell": [1.0, 4.0]},
                    "children": {"cell": {"sequential": ["a", "a", "b"]}},
                }
            }
        ]
    )
    types = [r.type for r in generate_layout(parse_strategy(s), seed=3).leaves()]
    assert types == (["a", "a", "b"] * 4)[:10]
    assert TypeProvider({"sequential": ["x", "y"]}, "w").choose(5, np.random.default_rng(0)) == [
        "x",
        "y",
        "x",
        "y",
        "x",
    ]


def test_stochastic_provider_follows_its_weights():
    p = TypeProvider({"stochastic": {"a": 0.95, "b": 0.05}}, "w")
    draws = p.choose(20000, np.random.default_rng(1))
    assert draws.count("b") / 20000 == pytest.approx(0.05, abs=0.006)


@pytest.mark.parametrize(
    "mutate, message",
    [
        (
            lambda s: s["levels"][0]["hall"].update(generator="gird"),
            r"\$\.levels\[0\]\.hall\.generator: unknown generator 'gird'; did you mean 'grid'\?",
        ),
        (
            lambda s: s["levels"][0]["hall"].update(children={"cell": "cel"}),
            r"region type 'cel' is not declared .*did you mean 'cell'",
        ),
        (
            lambda s: s["levels"][0].update(
                cell={"generator": "grid", "args": {"cell": [1, 1]}, "children": {"cell": "a"}}
            ),
            r"'cell' is final and cannot have a generator",
        ),
        (
            lambda s: s["levels"][0]["hall"]["args"].update(cell=[-1.0, 1.0]),
            r"args\.cell: expected \[width, height\], finite numbers > 0",
        ),
        (
            lambda s: s["levels"][0]["hall"]["args"].update(cell=[20.0, 1.0]),
            r"larger than its parent",
        ),
        (lambda s: s.update(levels=[]), r"\$\.levels: List should have at least 1 item"),
        (lambda s: s["levels"].append({}), r"\$\.levels\[1\]: empty level"),
        (lambda s: s["root"].update(width=-3), r"\$\.root\.width: Input should be greater than 0"),
    ],
)
def test_validation_errors_name_file_path_and_expectation(mutate, message):
    s = strategy()
    mutate(s)
    with pytest.raises(gg.ConfigError, match=message) as exc:
        parse_strategy(s, "plant.json")
    assert str(exc.value).startswith("plant.json: ")


def test_strategy_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    with pytest.raises(gg.ConfigError, match="bad.json: invalid JSON at line 1"):
        gg.load_strategy(bad)


def test_custom_generator_registers_with_one_line():
    @register("halves")
    class Halves(Generator):
        slots = ("half",)

        def generate(self, parent, rng):
            return [
                Child(parent.x, parent.y, parent.w / 2, parent.h, "half"),
                Child(parent.x + parent.w / 2, parent.y, parent.w / 2, parent.h, "half"),
            ]

    s = strategy(
        levels=[{"hall": {"generator": "halves", "children": {"half": {"sequential": ["a", "b"]}}}}]
    )
    leaves = generate_layout(parse_strategy(s), seed=0).leaves()
    assert [(r.x, r.w, r.type) for r in leaves] == [(0.0, 5.0, "a"), (5.0, 5.0, "b")]


def test_same_seed_same_bytes_and_json_round_trip(tmp_path):
    a = generate_layout("assembly_line", seed=7)
    b = generate_layout("assembly_line", seed=7)
    a.to_json(tmp_path / "a.json")
    b.to_json(tmp_path / "b.json")
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    assert gg.Layout.from_json(tmp_path / "a.json") == a
    assert generate_layout("assembly_line", seed=8) != a


def test_label_raster_counts_cells():
    layout = generate_layout(parse_strategy(BASE), seed=0)
    r = layout.label_raster(0.25)
    assert r.labels.shape == (16, 40)
    assert (r.labels == r.type_names.index("cell")).all()


def test_label_raster_puts_each_label_in_its_cells():
    """Row r covers y in [y0 + r·res, ...), column c x in [x0 + c·res, ...): a raster flipped
    or transposed, or a region a cell too wide, fails against the array written out here."""
    layout = hand_made(
        [(0, 0, 4, 1, "a", None), (0, 1, 1, 1, "b", None), (1, 1, 3, 1, "c", None)], root=(4.0, 2.0)
    )
    r = layout.label_raster(0.5)
    a, b, c = (r.type_names.index(t) for t in "abc")
    expected = np.array([[a] * 8, [a] * 8, [b, b] + [c] * 6, [b, b] + [c] * 6])
    np.testing.assert_array_equal(r.labels, expected)
    assert r.origin_xy == (0.0, 0.0) and r.resolution_m == 0.5


def grid_rects(args, root=(10.5, 4.3), orientation="up"):
    s = strategy(
        root={"width": root[0], "height": root[1], "type": "hall", "orientation": orientation},
        region_types={"hall": {}, "a": {"final": True}, "b": {"final": True}},
        levels=[
            {"hall": {"generator": "grid", "args": args, "children": {"cell": "a", "empty": "b"}}}
        ],
    )
    return sorted(
        (round(r.x, 9), round(r.y, 9), round(r.w, 9), round(r.h, 9), r.type)
        for r in generate_layout(parse_strategy(s), seed=0).leaves()
    )


def test_grid_cells_spacing_leftover_and_aisles_are_exact():
    """A 10.5 x 4.3 m hall in 2 x 1 m cells 0.5 m apart: 4 across (4·2 + 3·0.5 = 9.5 m), 3 rows
    (at 0, 1.5, 3), the leftover a strip 1 m wide on the right and one 0.3 m high on top; with
    'spread' the 2.5 m left over goes between the cells; an aisle of 1 m after every 2nd row
    leaves room for 2 rows; a hall facing left runs the cells' height along x."""
    cells = [(x, y, 2.0, 1.0, "a") for y in (0.0, 1.5, 3.0) for x in (0.0, 2.5, 5.0, 7.5)]
    assert grid_rects({"cell": [2, 1], "spacing": 0.5}) == sorted(
        cells + [(9.5, 0.0, 1.0, 4.3, "b"), (0.0, 4.0, 9.5, 0.3, "b")]
    )
    spread = [
        (round(i * (2 + 2.5 / 3), 9), y, 2.0, 1.0, "a") for y in (0.0, 1.5, 3.0) for i in range(4)
    ]
    assert grid_rects({"cell": [2, 1], "spacing": 0.5, "leftover": "spread"}) == sorted(spread)
    aisle = [(x, y, 2.0, 1.0, "a") for y in (0.0, 1.5) for x in (0.0, 2.5, 5.0, 7.5)]
    assert grid_rects({"cell": [2, 1], "spacing": 0.5, "aisle": 1.0, "aisle_every": 2}) == sorted(
        aisle + [(9.5, 0.0, 1.0, 4.3, "b"), (0.0, 2.5, 9.5, 1.8, "b")]
    )
    # facing left: across is y (4.3 m: one 2 m cell, 2.3 m left over), along is x (10.5 m: 7 rows
    # of 1 m, 0.5 m between, 0.5 m left over)
    left = [(x, 0.0, 1.0, 2.0, "a") for x in (0.0, 1.5, 3.0, 4.5, 6.0, 7.5, 9.0)]
    assert grid_rects({"cell": [2, 1], "spacing": 0.5}, orientation="left") == sorted(
        left + [(0.0, 2.0, 10.5, 2.3, "b"), (10.0, 0.0, 0.5, 2.0, "b")]
    )


def test_grid_exact_fit_two_across_facing_left_and_lone_aisle_arguments():
    cells = [(x, y, 2.0, 1.0, "a") for y in (0.0, 1.5, 3.0) for x in (0.0, 2.5, 5.0, 7.5)]
    assert grid_rects({"cell": [2, 1], "spacing": 0.5}, root=(9.5, 4.0)) == sorted(
        cells
    )  # no leftover
    for lone in ({"aisle": 1.0}, {"aisle_every": 1}):  # an aisle needs both: alone, nothing changes
        assert grid_rects({"cell": [2, 1], "spacing": 0.5, **lone}, root=(9.5, 4.0)) == sorted(
            cells
        )
    assert grid_rects({"cell": [2, 1], "spacing": 0.5, "leftover": "spread"}, root=(5.0, 1.0)) == [
        (0.0, 0.0, 2.0, 1.0, "a"),
        (3.0, 0.0, 2.0, 1.0, "a"),
    ]
    left = [(x, y, 1.0, 2.0, "a") for x in (0.0, 1.5, 3.0, 4.5, 6.0, 7.5, 9.0) for y in (0.0, 2.5)]
    assert grid_rects(
        {"cell": [2, 1], "spacing": 0.5}, root=(10.5, 5.0), orientation="left"
    ) == sorted(left + [(0.0, 4.5, 10.5, 0.5, "b"), (10.0, 0.0, 0.5, 4.5, "b")])


def test_rectangles_cover_a_mask_exactly():
    from genie_gl.layout.generators import rectangles

    rng = np.random.default_rng(2)
    for _ in range(20):
        mask = rng.random((7, 9)) < 0.6
        mask[2:5, 3:8] = True
        cover = np.zeros(mask.shape, int)
        for r0, r1, c0, c1 in rectangles(mask):
            assert r0 < r1 and c0 < c1
            cover[r0:r1, c0:c1] += 1
        np.testing.assert_array_equal(cover, mask.astype(int))  # every cell once, nothing else
    assert rectangles(np.ones((3, 4), bool)) == [(0, 3, 0, 4)]
    assert rectangles(np.array([[1, 1, 0, 1], [1, 1, 0, 1]], bool)) == [(0, 2, 0, 2), (0, 2, 3, 4)]


def test_random_rooms_places_what_fits_and_reports_it():
    s = strategy(
        levels=[
            {
                "hall": {
                    "generator": "random_rooms",
                    "args": {"count": [30, 30], "width": [3, 3], "height": [3, 3], "attempts": 20},
                    "children": {"room": "a"},
                }
            }
        ]
    )
    layout = generate_layout(parse_strategy(s), seed=0)
    rooms = layout.leaves()
    assert 1 <= len(rooms) <= 3  # at most three 3 x 3 m rooms fit in 10 x 4 m
    assert layout.meta["reports"][0]["requested"] == 30
    assert not any(a.overlaps(b) for i, a in enumerate(rooms) for b in rooms[i + 1 :])


def test_merge_joins_siblings_and_preserves_area():
    s = strategy(
        levels=[
            {
                "hall": {
                    "generator": "grid",
                    "args": {"cell": [1.0, 1.0]},
                    "children": {"cell": {"sequential": ["a", "a", "a", "a", "a", "b"] * 2}},
                }
            },
            "merge",
        ]
    )
    before = generate_layout(parse_strategy(strategy(levels=s["levels"][:1])), seed=0)
    after = generate_layout(parse_strategy(s), seed=0)
    assert len(after.leaves()) < len(before.leaves())
    for t in ("a", "b"):
        assert sum(r.area for r in after.leaves() if r.type == t) == pytest.approx(
            sum(r.area for r in before.leaves() if r.type == t)
        )
    assert_merge_keeps_the_ground(before, after)


@register("hand_made")
class HandMade(Generator):
    """Children given as (x, y, w, h, slot, orientation) relative to the parent."""

    slots = ("a", "b", "c")

    def generate(self, parent, rng):
        return [
            Child(parent.x + x, parent.y + y, w, h, slot, o)
            for x, y, w, h, slot, o in self.args["cells"]
        ]


def hand_made(cells, merge=False, root=(6.0, 2.0)):
    s = strategy(
        root={"width": root[0], "height": root[1], "type": "hall"},
        region_types={"hall": {}, "a": {"final": True}, "b": {"final": True}, "c": {"final": True}},
        levels=[
            {
                "hall": {
                    "generator": "hand_made",
                    "args": {"cells": [list(c) for c in cells]},
                    "children": {k: k for k in "abc"},
                    "orientation": "suggested",
                }
            }
        ]
        + (["merge"] if merge else []),
    )
    return generate_layout(parse_strategy(s), seed=0)


def rects(layout):
    return sorted(
        (round(r.x, 9), round(r.y, 9), round(r.w, 9), round(r.h, 9), r.type, r.orientation)
        for r in layout.leaves()
    )


def assert_merge_keeps_the_ground(before, after):
    """Whatever merges, the floor is covered by the same types as before: same area per type,
    the same label raster cell for cell, no two leaves overlapping."""
    for t in {(r.type, r.orientation) for r in before.leaves()}:
        assert sum(r.area for r in after.leaves() if (r.type, r.orientation) == t) == pytest.approx(
            sum(r.area for r in before.leaves() if (r.type, r.orientation) == t), abs=1e-9
        )
    np.testing.assert_array_equal(after.label_raster(0.25).labels, before.label_raster(0.25).labels)
    leaves = after.leaves()
    assert not any(p.overlaps(q, tol=1e-9) for i, p in enumerate(leaves) for q in leaves[i + 1 :])


@pytest.mark.parametrize(
    "cells, merged",
    [
        # a row: runs of a type that border with the same height join; b splits them
        (
            [
                (0, 0, 1, 2, "a", "up"),
                (1, 0, 1, 2, "a", "up"),
                (2, 0, 1, 2, "a", "up"),
                (3, 0, 1, 2, "b", "up"),
                (4, 0, 1, 2, "a", "up"),
                (5, 0, 1, 2, "a", "up"),
            ],
            [(0, 0, 3, 2, "a", "up"), (3, 0, 1, 2, "b", "up"), (4, 0, 2, 2, "a", "up")],
        ),
        # the same row listed right to left, and a column listed top to bottom
        (
            [
                (5, 0, 1, 2, "a", "up"),
                (4, 0, 1, 2, "a", "up"),
                (3, 0, 1, 2, "a", "up"),
                (2, 0, 1, 1, "b", "up"),
                (2, 1, 1, 1, "b", "up"),
                (1, 1, 1, 1, "b", "up"),
            ],
            [(1, 1, 1, 1, "b", "up"), (2, 0, 1, 2, "b", "up"), (3, 0, 3, 2, "a", "up")],
        ),
        # a column: same x and width, bordering in y
        (
            [(0, 0, 2, 0.5, "a", "up"), (0, 0.5, 2, 1.5, "a", "up"), (2, 0, 4, 2, "b", "up")],
            [(0, 0, 2, 2, "a", "up"), (2, 0, 4, 2, "b", "up")],
        ),
        # a 2 x 2 block of one type becomes one rectangle, whatever the order of the joins
        (
            [
                (0, 0, 1, 1, "a", "up"),
                (1, 0, 1, 1, "a", "up"),
                (0, 1, 1, 1, "a", "up"),
                (1, 1, 1, 1, "a", "up"),
            ],
            [(0, 0, 2, 2, "a", "up")],
        ),
        # bordering but of unequal height: the union is no rectangle, nothing joins
        (
            [(0, 0, 1, 2, "a", "up"), (1, 0, 1, 1, "a", "up"), (1, 1, 1, 1, "b", "up")],
            [(0, 0, 1, 2, "a", "up"), (1, 0, 1, 1, "a", "up"), (1, 1, 1, 1, "b", "up")],
        ),
        # same height but shifted in y: they share only part of an edge
        (
            [(0, 0, 1, 1, "a", "up"), (1, 0.5, 1, 1, "a", "up")],
            [(0, 0, 1, 1, "a", "up"), (1, 0.5, 1, 1, "a", "up")],
        ),
        # different types or orientations never join
        (
            [
                (0, 0, 1, 2, "a", "up"),
                (1, 0, 1, 2, "b", "up"),
                (2, 0, 1, 2, "a", "up"),
                (3, 0, 1, 2, "a", "left"),
            ],
            [
                (0, 0, 1, 2, "a", "up"),
                (1, 0, 1, 2, "b", "up"),
                (2, 0, 1, 2, "a", "up"),
                (3, 0, 1, 2, "a", "left"),
            ],
        ),
        # a column facing left keeps its orientation
        (
            [(0, 0, 1, 1, "a", "left"), (0, 1, 1, 1, "a", "left"), (1, 0, 1, 2, "b", "left")],
            [(0, 0, 1, 2, "a", "left"), (1, 0, 1, 2, "b", "left")],
        ),
        # same type and size, not bordering (a gap of 0.5 m)
        (
            [(0, 0, 1, 2, "a", "up"), (1.5, 0, 1, 2, "a", "up")],
            [(0, 0, 1, 2, "a", "up"), (1.5, 0, 1, 2, "a", "up")],
        ),
    ],
)
def test_merge_on_hand_made_layouts_gives_the_exact_rectangles(cells, merged):
    before = hand_made(cells)
    after = hand_made(cells, merge=True)
    assert rects(before) == sorted(
        (float(x), float(y), float(w), float(h), t, o) for x, y, w, h, t, o in cells
    )
    assert rects(after) == sorted(
        (float(x), float(y), float(w), float(h), t, o) for x, y, w, h, t, o in merged
    )
    assert_merge_keeps_the_ground(before, after)


def guillotine(rng, x, y, w, h, depth):
    """A random mosaic: rectangles split in x or y at quarter-metre steps, typed a or b."""
    if depth == 0 or (w < 1 and h < 1) or (depth < 5 and rng.random() < 0.15):
        return [(x, y, w, h, "ab"[rng.integers(2)], ["up", "left"][int(rng.random() < 0.2)])]
    if w >= h:
        k = 0.25 * rng.integers(1, round(w / 0.25))
        return guillotine(rng, x, y, k, h, depth - 1) + guillotine(
            rng, x + k, y, w - k, h, depth - 1
        )
    k = 0.25 * rng.integers(1, round(h / 0.25))
    return guillotine(rng, x, y, w, k, depth - 1) + guillotine(rng, x, y + k, w, h - k, depth - 1)


@pytest.mark.parametrize("seed", range(6))
def test_merge_of_random_mosaics_keeps_the_ground_and_joins_what_it_can(seed):
    """Random mosaics of bordering cells of unequal sizes: the merged floor is the same, and
    no two leaves left are still joinable (same type and orientation, one shared whole edge)."""
    cells = guillotine(np.random.default_rng(seed), 0.0, 0.0, 6.0, 2.0, 6)[:: 1 if seed % 2 else -1]
    before, after = hand_made(cells), hand_made(cells, merge=True)
    assert len(before.leaves()) == len(cells) >= 8
    assert_merge_keeps_the_ground(before, after)
    leaves = after.leaves()
    for i, p in enumerate(leaves):
        for q in leaves[i + 1 :]:
            if (p.type, p.orientation) != (q.type, q.orientation):
                continue
            side = (
                np.isclose(p.y, q.y)
                and np.isclose(p.h, q.h)
                and (np.isclose(p.x + p.w, q.x) or np.isclose(q.x + q.w, p.x))
            )
            stacked = (
                np.isclose(p.x, q.x)
                and np.isclose(p.w, q.w)
                and (np.isclose(p.y + p.h, q.y) or np.isclose(q.y + q.h, p.y))
            )
            assert not (side or stacked), (p, q)


def test_merge_keeps_the_ground_of_every_shipped_strategy():
    from pathlib import Path

    for name in ("assembly_line", "storage_area", "logistics_lane"):
        s = json.loads((Path(__file__).parents[2] / "layouts" / f"{name}.json").read_text())
        s["levels"] = [lv for lv in s["levels"] if lv != "merge"]
        before = generate_layout(parse_strategy(s), seed=1)
        after = generate_layout(parse_strategy({**s, "levels": s["levels"] + ["merge"]}), seed=1)
        assert_merge_keeps_the_ground(before, after)


sizes = st.floats(0.5, 6.0)


@given(
    w=st.floats(5, 60),
    h=st.floats(5, 60),
    cw=sizes,
    ch=sizes,
    sp=st.floats(0, 1),
    seed=st.integers(0, 2**16),
    gen=st.sampled_from(["grid", "random_rooms", "assembly_line", "drunkard_walk"]),
    do_merge=st.booleans(),
)
def test_properties_of_random_strategies(w, h, cw, ch, sp, seed, gen, do_merge):
    # bounded work per example (the CI profile has a deadline): at most ~150 grid cells
    assume((w // (cw + sp)) * (h // (ch + sp)) <= 150)
    args = {
        "grid": {"cell": [cw, ch], "spacing": sp},
        "random_rooms": {"count": [1, 6], "width": [cw, cw + 1], "height": [ch, ch + 1]},
        "assembly_line": {"line_width": [cw, cw + 1], "paths": [0, 2], "path_width": [1, 2]},
        "drunkard_walk": {"block": cw / 2, "steps": 30},
    }[gen]
    slots = {
        "grid": ["cell"],
        "random_rooms": ["room"],
        "assembly_line": ["line", "path", "rest"],
        "drunkard_walk": ["room"],
    }[gen]
    s = strategy(
        root={"width": w, "height": h, "type": "hall"},
        levels=[
            {
                "hall": {
                    "generator": gen,
                    "args": args,
                    "children": {k: {"random": ["a", "b"]} for k in slots},
                }
            }
        ]
        + (["merge"] if do_merge else []),
    )
    try:
        strat = parse_strategy(s)
    except gg.ConfigError:
        return  # an impossible size is rejected with a message, which other tests check
    layout = generate_layout(strat, seed=seed)
    nodes = layout.nodes
    for n in nodes[1:]:
        assert nodes[n.parent].region.contains(n.region, tol=1e-6)
    kids = [nodes[c].region for c in nodes[0].children]
    if gen in ("grid", "random_rooms", "assembly_line", "drunkard_walk"):
        assert not any(a.overlaps(b, tol=1e-6) for i, a in enumerate(kids) for b in kids[i + 1 :])
    for leaf in layout.leaves():
        assert layout.region_types[leaf.type].final or leaf.type == "hall"
    again = generate_layout(strat, seed=seed)
    assert json.dumps(again.to_dict()) == json.dumps(layout.to_dict())


@pytest.mark.parametrize("name", ["assembly_line", "storage_area", "logistics_lane"])
def test_shipped_strategies_generate_and_fill_scenes(name):
    layout = generate_layout(name, seed=0)
    groups = [r for r in layout.leaves() if layout.region_types[r.type].asset_group]
    assert len(groups) >= 20
    scene = gg.build_scene(layout, seed=0)
    assert len(scene.instances) >= len(groups) * 0.8


def test_array_generators_grow_the_same_tree_as_per_region_ones():
    from tests.scenes import register_strips, strips_strategy

    register_strips()
    fast = generate_layout(parse_strategy(strips_strategy(6, 3)), seed=0)
    slow = generate_layout(parse_strategy(strips_strategy(6, 3, "test_strips_per_region")), seed=0)
    assert len(fast) == 1 + 6 + 36 + 216
    assert json.dumps(fast.to_dict()) == json.dumps(slow.to_dict())
    t = fast.tree
    assert (np.diff(t.depth) >= 0).all()  # breadth-first
    assert (np.diff(t.parent[1:]) >= 0).all()  # siblings consecutive
    np.testing.assert_allclose(
        np.bincount(t.parent[1:], weights=t.w[1:], minlength=len(t))[t.n_children() > 0],
        t.w[t.n_children() > 0],
    )  # strips tile their parent
    assert len(fast.leaves()) == 216 and all(r.type == "leaf" for r in fast.leaves())
    again = gg.Layout.from_dict(fast.to_dict())
    assert again == fast and np.array_equal(again.tree.parent, t.parent)


def test_grid_in_a_parent_smaller_than_one_cell_leaves_it_empty():
    """No cell fits (across, along, or both): one ``empty`` child, exactly the parent, with
    the parent's orientation."""
    from genie_gl.layout.generators import Grid
    from genie_gl.layout.model import Region

    for w, h in ((2.0, 9.0), (9.0, 2.0), (2.0, 2.5)):
        parent = Region(1.5, -2.0, w, h, "zone", "left")
        kids = Grid(cell=[3, 3]).generate(parent, rng=np.random.default_rng(0))
        assert [(c.x, c.y, c.w, c.h, c.slot, c.orientation) for c in kids] == [
            (1.5, -2.0, w, h, "empty", "left")
        ]
