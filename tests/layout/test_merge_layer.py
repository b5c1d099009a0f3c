"""The paper's merge layer: bordering leaves of one type and orientation merge across parents."""

import json

import numpy as np
import pytest

from genie_gl.layout import Child, Generator, Layout, generate_layout, parse_strategy, register
from genie_gl.layout.merge import merge_leaves, records


@register("test_rects")
class Rects(Generator):
    """Exact rectangles (``rects``: [[x, y, w, h], ...] relative to the parent's corner)."""

    slots = ("r",)

    def generate(self, parent, rng):
        return [Child(parent.x + x, parent.y + y, w, h, "r") for x, y, w, h in self.args["rects"]]


def _strategy(left_kids, right_kids, right_orientation="inherit", merge=True, l_shape=None):
    types = {"hall": {}, "zone_l": {}, "zone_r": {}, "a": {"final": True}, "b": {"final": True}}
    levels = [
        {
            "hall": {
                "generator": "test_rects",
                "args": {"rects": [[0, 0, 5, 4], [5, 0, 5, 4]]},
                "children": {"r": {"sequential": ["zone_l", "zone_r"]}},
            }
        },
        {
            "zone_l": {
                "generator": "test_rects",
                "args": {"rects": [r for r, _ in left_kids]},
                "children": {"r": {"sequential": [t for _, t in left_kids]}},
            },
            "zone_r": {
                "generator": "test_rects",
                "args": {"rects": [r for r, _ in right_kids]},
                "children": {"r": {"sequential": [t for _, t in right_kids]}},
                "orientation": right_orientation,
            },
        },
    ] + (["merge"] if merge else [])
    extra = {} if l_shape is None else {"merge": {"l_shape": l_shape}}
    return parse_strategy(
        {
            "name": "m",
            "root": {"width": 10, "height": 4, "type": "hall"},
            "region_types": types,
            "levels": levels,
            **extra,
        }
    )


def _leaves(layout):
    return sorted(
        (r.type, r.orientation, round(r.x, 9), round(r.y, 9), round(r.w, 9), round(r.h, 9))
        for r in layout.leaves()
    )


def _check_tree(layout: Layout):
    t = layout.tree
    assert t.parent[0] == -1 and np.all(t.parent[1:] < np.arange(1, len(t)))  # parents first
    assert np.all(np.diff(t.depth) >= 0)  # breadth-first
    assert np.all(t.depth[1:] == t.depth[t.parent[1:]] + 1)
    assert np.all(np.diff(t.parent[1:]) >= 0)  # siblings consecutive
    nodes = layout.nodes
    for n in nodes[1:]:
        assert nodes[n.parent].region.contains(n.region, tol=1e-9)


def test_leaves_under_different_parents_merge_into_the_exact_rectangle():
    left = [([0, 0, 1, 4], "b"), ([1, 0, 2, 4], "a"), ([3, 0, 2, 4], "a")]
    right = [([0, 0, 2, 4], "a"), ([2, 0, 3, 4], "a")]
    layout = generate_layout(_strategy(left, right), seed=0)
    assert _leaves(layout) == [("a", "up", 1.0, 0.0, 9.0, 4.0), ("b", "up", 0.0, 0.0, 1.0, 4.0)]
    _check_tree(layout)
    # the merged region hangs under the hall (the parts' common ancestor); zone_r, all of
    # whose children merged away, is gone; zone_l keeps its "b"
    regions = layout.regions()
    assert [r.type for r, _, _ in regions] == ["hall", "zone_l", "a", "b"]
    assert [p for _, _, p in regions] == [-1, 0, 0, 1]
    (rec,) = records(layout.meta["merges"])
    assert rec["node"] == 2 and rec["level"] == 2
    assert sorted(map(tuple, rec["parts"])) == [
        (1, 0, 2, 4),
        (3, 0, 2, 4),
        (5, 0, 2, 4),
        (7, 0, 3, 4),
    ]
    assert len(rec["parents"]) == 2
    # the record survives the JSON round trip
    assert (
        Layout.from_dict(json.loads(json.dumps(layout.to_dict()))).meta["merges"]
        == layout.meta["merges"]
    )


def test_stacked_parts_merge_both_ways():
    # the right zone's 2 x 2 block of cells, then the left zone's full-height cell
    left = [([0, 0, 3, 4], "b"), ([3, 0, 2, 4], "a")]
    right = [([0, 0, 2, 2], "a"), ([2, 0, 3, 2], "a"), ([0, 2, 2, 2], "a"), ([2, 2, 3, 2], "a")]
    layout = generate_layout(_strategy(left, right), seed=0)
    assert _leaves(layout) == [("a", "up", 3.0, 0.0, 7.0, 4.0), ("b", "up", 0.0, 0.0, 3.0, 4.0)]
    _check_tree(layout)


def test_different_types_never_merge():
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 4], "b")]
    layout = generate_layout(_strategy(left, right), seed=0)
    assert _leaves(layout) == [("a", "up", 0.0, 0.0, 5.0, 4.0), ("b", "up", 5.0, 0.0, 5.0, 4.0)]
    assert "merges" not in layout.meta


def test_different_orientations_never_merge():
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 2, 4], "a"), ([2, 0, 3, 4], "a")]
    layout = generate_layout(_strategy(left, right, right_orientation="right"), seed=0)
    # the two right-facing cells merge with each other, not with the up-facing one
    assert _leaves(layout) == [("a", "right", 5.0, 0.0, 5.0, 4.0), ("a", "up", 0.0, 0.0, 5.0, 4.0)]
    _check_tree(layout)


def test_an_l_shaped_union_is_not_made():
    # a 5 x 4 "a" beside a 5 x 2 "a": they border along half an edge only
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 2], "a"), ([0, 2, 5, 2], "b")]
    layout = generate_layout(_strategy(left, right), seed=0)
    assert _leaves(layout) == [
        ("a", "up", 0.0, 0.0, 5.0, 4.0),
        ("a", "up", 5.0, 0.0, 5.0, 2.0),
        ("b", "up", 5.0, 2.0, 5.0, 2.0),
    ]


def test_an_l_shaped_union_is_not_made_whichever_side_is_shorter():
    """Neighbours that share their bottom edge's line but not their height never merge, the
    short one on the left or on the right (the pass sorts by height, so only one of the two
    orders reaches the equal-height check), side by side or stacked (equal width)."""
    left = [([0, 0, 5, 2], "a"), ([0, 2, 5, 2], "b")]
    right = [([0, 0, 5, 4], "a")]
    layout = generate_layout(_strategy(left, right), seed=0)
    assert _leaves(layout) == [
        ("a", "up", 0.0, 0.0, 5.0, 2.0),
        ("a", "up", 5.0, 0.0, 5.0, 4.0),
        ("b", "up", 0.0, 2.0, 5.0, 2.0),
    ]
    assert "merges" not in layout.meta
    for x, y, w, h in (
        ([0, 1], [0, 0], [1, 1], [1, 2]),
        ([0, 1], [0, 0], [1, 1], [2, 1]),  # side by side
        ([0, 0], [0, 1], [1, 2], [1, 1]),
        ([0, 0], [0, 1], [2, 1], [1, 1]),
    ):  # stacked
        group, gx, gy, gw, gh = merge_leaves(
            np.array(x, float),
            np.array(y, float),
            np.array(w, float),
            np.array(h, float),
            np.zeros(2, np.int64),
        )
        assert group.tolist() == [0, 1] or group.tolist() == [1, 0]
        assert sorted(zip(gx, gy, gw, gh)) == sorted(zip(x, y, w, h))
    # equal heights (widths) do merge, into the exact rectangle
    group, gx, gy, gw, gh = merge_leaves(
        np.array([1.0, 0.0]),
        np.zeros(2),
        np.array([2.0, 1.0]),
        np.full(2, 3.0),
        np.zeros(2, np.int64),
    )
    assert group.tolist() == [0, 0] and (gx.tolist(), gy.tolist(), gw.tolist(), gh.tolist()) == (
        [0],
        [0],
        [3],
        [3],
    )


def test_strip_cuts_an_l_so_the_bordering_parts_merge():
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 2], "a"), ([0, 2, 5, 2], "b")]
    layout = generate_layout(_strategy(left, right, l_shape="strip"), seed=0)
    assert _leaves(layout) == [
        ("a", "up", 0.0, 0.0, 10.0, 2.0),
        ("a", "up", 0.0, 2.0, 5.0, 2.0),
        ("b", "up", 5.0, 2.0, 5.0, 2.0),
    ]
    _check_tree(layout)
    (rec,) = records(layout.meta["merges"])
    assert sorted(map(tuple, rec["parts"])) == [(0, 0, 5, 2), (5, 0, 5, 2)]
    # "keep" (the default) leaves the L apart
    assert len(generate_layout(_strategy(left, right, l_shape="keep"), seed=0).leaves()) == 3


def test_strip_handles_a_t_and_the_transposed_l():
    # a T: the right cell borders the middle of the left one, which is cut in three
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 1], "b"), ([0, 1, 5, 2], "a"), ([0, 3, 5, 1], "b")]
    layout = generate_layout(_strategy(left, right, l_shape="strip"), seed=0)
    assert _leaves(layout) == [
        ("a", "up", 0.0, 0.0, 5.0, 1.0),
        ("a", "up", 0.0, 1.0, 10.0, 2.0),
        ("a", "up", 0.0, 3.0, 5.0, 1.0),
        ("b", "up", 5.0, 0.0, 5.0, 1.0),
        ("b", "up", 5.0, 3.0, 5.0, 1.0),
    ]
    _check_tree(layout)
    # one above the other: a 3 m wide cell on a 5 m wide one is cut across x
    left = [([0, 0, 5, 2], "a"), ([0, 2, 3, 2], "a"), ([3, 2, 2, 2], "b")]
    right = [([0, 0, 5, 4], "b")]
    layout = generate_layout(_strategy(left, right, l_shape="strip"), seed=0)
    leaves = [r for r in _leaves(layout) if r[0] == "a"]
    assert leaves == [("a", "up", 0.0, 0.0, 3.0, 4.0), ("a", "up", 3.0, 0.0, 2.0, 2.0)]
    _check_tree(layout)


def test_without_the_merge_level_nothing_merges():
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 4], "a")]
    assert len(generate_layout(_strategy(left, right, merge=False), seed=0).leaves()) == 2
    assert len(generate_layout(_strategy(left, right), seed=0).leaves()) == 1


def test_random_grids_keep_area_per_type_and_the_same_seed_gives_the_same_tree():
    s = {
        "name": "g",
        "root": {"width": 12, "height": 9, "type": "hall"},
        "region_types": {"hall": {}, "zone": {}, "a": {"final": True}, "b": {"final": True}},
        "levels": [
            {"hall": {"generator": "grid", "args": {"cell": [3, 3]}, "children": {"cell": "zone"}}},
            {
                "zone": {
                    "generator": "grid",
                    "args": {"cell": [1, 1]},
                    "children": {"cell": {"random": ["a", "b"]}},
                    "orientation": {"random": ["up", "left"]},
                }
            },
            "merge",
        ],
    }
    strat = parse_strategy(s)
    before = parse_strategy({**s, "levels": s["levels"][:2]})
    for seed in range(4):
        a, b = generate_layout(strat, seed=seed), generate_layout(strat, seed=seed)
        assert json.dumps(a.to_dict()) == json.dumps(b.to_dict())
        raw = generate_layout(before, seed=seed)
        assert len(a.leaves()) < len(raw.leaves())
        _check_tree(a)
        for key in {(r.type, r.orientation) for r in raw.leaves()}:
            area = lambda lay: sum(r.area for r in lay.leaves() if (r.type, r.orientation) == key)  # noqa: E731
            assert area(a) == pytest.approx(area(raw))
        # some merges joined cells of different 3 x 3 zones
        assert any(len(m["parents"]) > 1 for m in records(a.meta["merges"]))
        # every merged region is exactly tiled by its parts, all of its own type (area sums)
        leaves = a.tree
        for m in records(a.meta["merges"]):
            i = m["node"]
            assert sum(w * h for _, _, w, h in m["parts"]) == pytest.approx(
                leaves.w[i] * leaves.h[i]
            )


def test_merge_leaves_arrays():
    # a row of three touching unit squares, a gap, then one more; and a key that differs
    x = np.array([0.0, 1.0, 2.0, 3.5, 1.0])
    y = np.zeros(5)
    w = np.ones(5)
    h = np.ones(5)
    key = np.array([0, 0, 0, 0, 1])
    group, gx, gy, gw, gh = merge_leaves(x, y, w, h, key)
    assert group[0] == group[1] == group[2] and len({group[0], group[3], group[4]}) == 3
    rects = sorted(zip(gx.tolist(), gw.tolist()))
    assert rects == [(0.0, 3.0), (1.0, 1.0), (3.5, 1.0)]


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=30, deadline=None)
@given(
    w=st.floats(4, 30),
    h=st.floats(4, 30),
    c1=st.floats(1.5, 8),
    c2=st.floats(0.4, 3),
    sp=st.sampled_from([0.0, 0.3]),
    gen=st.sampled_from(["grid", "assembly_line", "random_rooms"]),
    seed=st.integers(0, 2**16),
    l_shape=st.sampled_from(["keep", "strip"]),
)
def test_two_levels_then_merge_keep_the_tree_sound(w, h, c1, c2, sp, gen, seed, l_shape):
    args = {
        "grid": {"cell": [c1, c1]},
        "assembly_line": {"line_width": c1, "paths": [0, 2], "path_width": c2},
        "random_rooms": {"count": [1, 5], "width": [c1, c1 + 2], "height": [c1, c1 + 2]},
    }[gen]
    slots = {"grid": ["cell"], "assembly_line": ["line", "path", "rest"], "random_rooms": ["room"]}[
        gen
    ]
    s = {
        "name": "p",
        "root": {"width": w, "height": h, "type": "hall"},
        "region_types": {"hall": {}, "zone": {}, "a": {"final": True}, "b": {"final": True}},
        "levels": [
            {
                "hall": {
                    "generator": gen,
                    "args": args,
                    "children": {k: {"random": ["zone", "a"]} for k in slots},
                }
            },
            {
                "zone": {
                    "generator": "grid",
                    "args": {"cell": [c2, c2], "spacing": sp},
                    "children": {"cell": {"random": ["a", "b"]}},
                    "orientation": {"random": ["up", "left"]},
                }
            },
            "merge",
        ],
        "merge": {"l_shape": l_shape},
    }
    try:
        strat = parse_strategy(s)
    except Exception:
        return  # a parent too small for its generator is refused; other tests check the message
    raw = generate_layout(parse_strategy({**s, "levels": s["levels"][:2]}), seed=seed)
    if l_shape == "keep":  # no leaf of the result is a piece of a cut one
        assert len(generate_layout(strat, seed=seed).leaves()) <= len(raw.leaves())
    layout = generate_layout(strat, seed=seed)
    _check_tree(layout)
    leaves = layout.leaves()
    assert not any(a.overlaps(b, tol=1e-6) for i, a in enumerate(leaves) for b in leaves[i + 1 :])
    for key in {(r.type, r.orientation) for r in raw.leaves()}:
        area = lambda lay: sum(r.area for r in lay.leaves() if (r.type, r.orientation) == key)  # noqa: E731
        assert area(layout) == pytest.approx(area(raw), rel=1e-9, abs=1e-9)
    for m in records(layout.meta.get("merges", [])):
        i = m["node"]
        assert sum(pw * ph for _, _, pw, ph in m["parts"]) == pytest.approx(
            layout.tree.w[i] * layout.tree.h[i]
        )


def _hand_nodes(gap):
    from genie_gl.layout.model import Node, Region

    return [
        Node(Region(0, 0, 10, 4, "hall"), 0, -1, [1, 2]),
        Node(Region(0, 0, 5, 4, "zone"), 1, 0, [3]),
        Node(Region(5, 0, 5, 4, "zone"), 1, 0, [4, 5]),
        Node(Region(0, 1, 5, 2, "a"), 2, 1),
        Node(Region(5 + gap, 1, 5 - gap, 2, "a"), 2, 2),
        Node(Region(5, 3, 5, 1, "b", "left"), 2, 2),
    ]


def test_merge_tree_mapping_and_record_by_hand():
    """merge_tree on the hand-made tree: each old node's new index (-1 for the emptied zone,
    the merged region's for both halves), the record's parts and former parents; the record
    renumbered by a later mapping; records() split per region (counts by hand)."""
    from genie_gl.layout.merge import merge_tree, renumber
    from genie_gl.layout.model import Tree

    tree = Tree.from_nodes(_hand_nodes(0.0), ("hall", "zone", "a", "b"))
    out, rec, mapping = merge_tree(tree, level=3)
    assert mapping.tolist() == [0, -1, 1, 2, 2, 3]
    assert out.parent.tolist() == [-1, 0, 0, 1] and out.depth.tolist() == [0, 1, 1, 2]
    assert out.depth.dtype == np.int32
    assert rec == {
        "level": 3,
        "nodes": [2],
        "part_counts": [2],
        "parts": [0, 1, 5, 2, 5, 1, 5, 2],
        "parent_counts": [2],
        "parents": [1, 2],
    }
    assert renumber(rec, np.array([9, 8, 7, 6]))["nodes"] == [7]
    assert renumber({"level": 0, "nodes": [1, 3]}, np.array([0, -1, 5, 2])) == {
        "level": 0,
        "nodes": [-1, 2],
    }
    two = {
        "level": 1,
        "nodes": [4, 9],
        "part_counts": [2, 3],
        "parts": list(range(20)),
        "parent_counts": [1, 2],
        "parents": [7, 8, 9],
    }
    assert records([two]) == [
        {"level": 1, "node": 4, "parts": [[0, 1, 2, 3], [4, 5, 6, 7]], "parents": [7]},
        {
            "level": 1,
            "node": 9,
            "parts": [[8, 9, 10, 11], [12, 13, 14, 15], [16, 17, 18, 19]],
            "parents": [8, 9],
        },
    ]
    # nothing to join (a gap): the same tree back, no record, the identity mapping
    same, none, ident = merge_tree(Tree.from_nodes(_hand_nodes(0.5), ("hall", "zone", "a", "b")))
    assert none is None and ident.tolist() == list(range(6)) and len(same) == 6


def test_merge_on_a_node_list_by_hand():
    """``layout.merge(nodes)``: the two ``a`` halves under different zones become one region
    under the hall (their common ancestor), the zone left empty goes, and the result is
    re-indexed breadth-first; a gap wider than ``tol`` keeps them apart."""
    from genie_gl.layout import merge

    nodes = _hand_nodes

    out = merge(nodes(0.0))
    got = [
        (
            n.region.type,
            n.region.orientation,
            n.region.x,
            n.region.y,
            n.region.w,
            n.region.h,
            n.depth,
            n.parent,
        )
        for n in out
    ]
    assert got == [
        ("hall", "up", 0, 0, 10, 4, 0, -1),
        ("zone", "up", 5, 0, 5, 4, 1, 0),
        ("a", "up", 0, 1, 10, 2, 1, 0),
        ("b", "left", 5, 3, 5, 1, 2, 1),
    ]
    assert [n.children for n in out] == [[1, 2], [3], [], []]
    assert len(merge(nodes(1e-7))) == 6  # the default tol (1e-9): apart
    assert len(merge(nodes(1e-7), tol=1e-6)) == 4  # a wider tol: joined


# ---- the merge layer's functions on hand-made arrays (expected rectangles worked out by hand) ----

NAMES = ("hall", "zone", "a", "b")


def _tree(rows):
    """A Tree from (parent, x, y, w, h, type[, orientation index]) rows in breadth-first order."""
    from genie_gl.layout.model import Tree

    parent = np.array([r[0] for r in rows], np.int32)
    depth = np.zeros(len(rows), np.int32)
    for i in range(1, len(rows)):
        depth[i] = depth[parent[i]] + 1
    col = lambda k: np.array([r[k] for r in rows], np.float64)  # noqa: E731
    return Tree(
        col(1),
        col(2),
        col(3),
        col(4),
        np.array([NAMES.index(r[5]) for r in rows], np.int32),
        np.array([r[6] if len(r) > 6 else 0 for r in rows], np.int8),
        depth,
        parent,
        NAMES,
    )


def _rows(tree):
    return [
        (
            int(tree.parent[i]),
            int(tree.depth[i]),
            tree.type_names[tree.type[i]],
            int(tree.orient[i]),
            float(tree.x[i]),
            float(tree.y[i]),
            float(tree.w[i]),
            float(tree.h[i]),
        )
        for i in range(len(tree))
    ]


def _merge(rects, key, **kw):
    """merge_leaves on (x, y, w, h) rows: (group of each input, merged rectangles in group
    order)."""
    r = np.array(rects, np.float64).T
    group, gx, gy, gw, gh = merge_leaves(r[0], r[1], r[2], r[3], np.array(key, np.int64), **kw)
    return group.tolist(), np.stack([gx, gy, gw, gh], 1).tolist()


def test_merge_leaves_joins_columns_first_then_rows():
    # three unit squares in an L: bottom-left, bottom-right, top-left. The first pass joins
    # along y (columns): bottom-left + top-left = (0, 0, 1, 2); the bottom-right square then
    # shares only half an edge with that column and stays. (Rows first would give (0, 0, 2, 1).)
    assert _merge([(0, 0, 1, 1), (1, 0, 1, 1), (0, 1, 1, 1)], [0, 0, 0]) == (
        [0, 1, 0],
        [[0.0, 0.0, 1.0, 2.0], [1.0, 0.0, 1.0, 1.0]],
    )
    # the same L mirrored (bottom-left, top-left, top-right): column (0, 0, 1, 2), square (1, 1, 1,
    # 1)
    assert _merge([(0, 0, 1, 1), (0, 1, 1, 1), (1, 1, 1, 1)], [3, 3, 3]) == (
        [0, 0, 1],
        [[0.0, 0.0, 1.0, 2.0], [1.0, 1.0, 1.0, 1.0]],
    )


def test_merge_leaves_keeps_the_pieces_of_one_cut_leaf_apart():
    # a 5 x 4 leaf (key 1) cut at y = 1 into two pieces (same origin), beside a 5 x 1 leaf of
    # its key at x = 5, and an unrelated key-0 square that sorts first. The pieces share a whole
    # edge but must not rejoin; the lower piece joins its neighbour into the strip (0, 0, 10, 1).
    rects = [(0, 0, 1, 1), (0, 0, 5, 1), (0, 1, 5, 3), (5, 0, 5, 1)]
    expected = ([0, 1, 2, 1], [[0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 10.0, 1.0], [0.0, 1.0, 5.0, 3.0]])
    for origin in (7, 0):  # any origin >= 0 marks a piece, 0 included
        assert _merge(rects, [0, 1, 1, 1], origin=np.array([-1, origin, origin, -1])) == expected
    # without origins the pieces are plain rectangles: they rejoin (columns first) into 5 x 4
    assert _merge(rects, [0, 1, 1, 1]) == (
        [0, 1, 1, 2],
        [[0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 5.0, 4.0], [5.0, 0.0, 5.0, 1.0]],
    )
    # two pieces of different leaves do join
    assert _merge(rects, [0, 1, 1, 1], origin=np.array([-1, 4, 5, -1]))[1] == [
        [0.0, 0.0, 1.0, 1.0],
        [0.0, 0.0, 5.0, 4.0],
        [5.0, 0.0, 5.0, 1.0],
    ]


def test_a_piece_that_joined_a_neighbour_is_no_longer_a_piece():
    # pieces p1 = (0, 0, 1, 1) and p2 = (0, 1, 1, 1) of one cut leaf, a free square B on top.
    # Pass 1 (columns): p1 | p2 + B, the pair p1-p2 being refused. Pass 2 (rows): nothing.
    # Pass 3 (columns again): p1 and the merged (0, 1, 1, 2), which is no piece: one 1 x 3
    # column. A merge that stopped after one idle pass would leave two rectangles.
    assert _merge(
        [(0, 0, 1, 1), (0, 1, 1, 1), (0, 2, 1, 1)], [0, 0, 0], origin=np.array([5, 5, -1])
    ) == ([0, 0, 0], [[0.0, 0.0, 1.0, 3.0]])


def test_merge_leaves_tolerance_is_inclusive():
    # tol = 0.25 (exact in binary): a gap of exactly tol is the same edge, twice tol is not;
    # the joined rectangle spans from the first's near edge to the second's far edge
    assert _merge([(0, 0, 1, 1), (1.25, 0, 1, 1), (2.75, 0, 1, 1)], [0, 0, 0], tol=0.25) == (
        [0, 0, 1],
        [[0.0, 0.0, 2.25, 1.0], [2.75, 0.0, 1.0, 1.0]],
    )
    # cross extents equal to within tol: y 0 vs 0.1 and h 1 vs 1.1 round to the same quarter
    assert _merge([(0, 0, 1, 1), (1, 0.1, 1, 1.1)], [0, 0], tol=0.25) == (
        [0, 0],
        [[0.0, 0.0, 2.0, 1.0]],
    )
    assert _merge([(0, 0, 1, 1), (1, 0.1, 1, 1.1)], [0, 0]) == (
        [0, 1],
        [[0.0, 0.0, 1.0, 1.0], [1.0, 0.1, 1.0, 1.1]],
    )


def test_merge_leaves_small_inputs_and_dtypes():
    # integer input: float64 out (the documented dtypes)
    group, gx, gy, gw, gh = merge_leaves([0, 1], [0, 0], [1, 2], [3, 3], [2, 2])
    assert group.tolist() == [0, 0] and [gx.tolist(), gy.tolist(), gw.tolist(), gh.tolist()] == [
        [0],
        [0],
        [3],
        [3],
    ]
    assert {a.dtype for a in (gx, gy, gw, gh)} == {np.dtype(np.float64)} and group.dtype == np.int64
    # exactly two rectangles that join (stacked), one alone, none
    assert _merge([(2, 1, 3, 1), (2, 2, 3, 0.5)], [9, 9]) == ([0, 0], [[2.0, 1.0, 3.0, 1.5]])
    assert _merge([(2, 1, 3, 1)], [9]) == ([0], [[2.0, 1.0, 3.0, 1.0]])
    group, *out = merge_leaves(*np.zeros((4, 0)), np.zeros(0, np.int64))
    assert len(group) == 0 and all(len(a) == 0 for a in out)


def test_merge_tree_of_one_and_two_nodes():
    from genie_gl.layout.merge import merge_tree

    one = _tree([(-1, 0, 0, 10, 4, "hall")])
    out, rec, mapping = merge_tree(one)
    assert out is one and rec is None and mapping.tolist() == [0]
    two = _tree([(-1, 0, 0, 10, 4, "hall"), (0, 0, 0, 10, 4, "a")])
    out, rec, mapping = merge_tree(two, l_shape="strip")
    assert out is two and rec is None and mapping.tolist() == [0, 1]
    # a root and two halves that border: one region, the record by hand
    out, rec, mapping = merge_tree(
        _tree([(-1, 0, 0, 10, 4, "hall"), (0, 0, 0, 4, 4, "a"), (0, 4, 0, 6, 4, "a")]), level=5
    )
    assert _rows(out) == [
        (-1, 0, "hall", 0, 0.0, 0.0, 10.0, 4.0),
        (0, 1, "a", 0, 0.0, 0.0, 10.0, 4.0),
    ]
    assert mapping.tolist() == [0, 1, 1]
    assert rec == {
        "level": 5,
        "nodes": [1],
        "part_counts": [2],
        "parts": [0, 0, 4, 4, 4, 0, 6, 4],
        "parent_counts": [1],
        "parents": [0],
    }


def test_regions_emptied_by_a_merge_go_all_the_way_up():
    # hall -> zone 1 -> a (0, 0, 5, 4); hall -> zone 2 -> zone 3 -> a (5, 0, 5, 4). The halves
    # merge under the hall (their lowest common ancestor); zone 3 loses its only child, then
    # zone 2 its only one, and zone 1 its "a": all three go.
    from genie_gl.layout.merge import merge_tree

    tree = _tree(
        [
            (-1, 0, 0, 10, 4, "hall"),
            (0, 0, 0, 5, 4, "zone"),
            (0, 5, 0, 5, 4, "zone"),
            (1, 0, 0, 5, 4, "a"),
            (2, 5, 0, 5, 4, "zone"),
            (4, 5, 0, 5, 4, "a"),
        ]
    )
    out, rec, mapping = merge_tree(tree)
    assert _rows(out) == [
        (-1, 0, "hall", 0, 0.0, 0.0, 10.0, 4.0),
        (0, 1, "a", 0, 0.0, 0.0, 10.0, 4.0),
    ]
    assert mapping.tolist() == [0, -1, -1, 1, -1, 1]
    assert rec == {
        "level": -1,
        "nodes": [1],
        "part_counts": [2],
        "parts": [0, 0, 5, 4, 5, 0, 5, 4],
        "parent_counts": [2],
        "parents": [1, 4],
    }


def test_a_merged_region_hangs_under_the_lowest_common_ancestor():
    # hall -> zone Z (0, 0, 10, 4) and b (0, 4, 10, 2); Z -> zone 1 -> a; Z -> zone 2 -> zone 3 ->
    # a.
    # The parts sit at depths 3 and 4; their common ancestor is Z (depth 1), not the hall.
    from genie_gl.layout.merge import merge_tree

    tree = _tree(
        [
            (-1, 0, 0, 10, 6, "hall"),
            (0, 0, 0, 10, 4, "zone"),
            (0, 0, 4, 10, 2, "b"),
            (1, 0, 0, 5, 4, "zone"),
            (1, 5, 0, 5, 4, "zone"),
            (3, 0, 0, 5, 4, "a"),
            (4, 5, 0, 5, 4, "zone"),
            (6, 5, 0, 5, 4, "a"),
        ]
    )
    out, rec, mapping = merge_tree(tree)
    assert _rows(out) == [
        (-1, 0, "hall", 0, 0.0, 0.0, 10.0, 6.0),
        (0, 1, "zone", 0, 0.0, 0.0, 10.0, 4.0),
        (0, 1, "b", 0, 0.0, 4.0, 10.0, 2.0),
        (1, 2, "a", 0, 0.0, 0.0, 10.0, 4.0),
    ]
    assert mapping.tolist() == [0, 1, 2, -1, -1, 3, -1, 3]
    assert rec["nodes"] == [3] and rec["parents"] == [3, 6] and rec["parent_counts"] == [2]


def test_a_join_elsewhere_keeps_the_pieces_marked():
    # pieces p1 = (0, 0, 2, 1) and p2 = (0, 1, 2, 1) of one cut leaf; C = (3, 0, 1, 1) and
    # D = (3, 1, 1, 1) free. Pass 1 (columns) joins C + D and refuses p1-p2; the pieces stay
    # single groups and keep their mark, so no later pass joins them: three rectangles.
    rects = [(0, 0, 2, 1), (0, 1, 2, 1), (3, 0, 1, 1), (3, 1, 1, 1)]
    assert _merge(rects, [0, 0, 0, 0], origin=np.array([5, 5, -1, -1])) == (
        [0, 1, 2, 2],
        [[0.0, 0.0, 2.0, 1.0], [0.0, 1.0, 2.0, 1.0], [3.0, 0.0, 1.0, 2.0]],
    )


def _leaf_rects(tree):
    leaves = np.flatnonzero(tree.n_children() == 0)
    return sorted(
        (
            tree.type_names[tree.type[i]],
            float(tree.x[i]),
            float(tree.y[i]),
            float(tree.w[i]),
            float(tree.h[i]),
        )
        for i in leaves
    )


# strip cuts by hand, in a 10 x 4 hall: (leaves as (type, x, y, w, h)) -> merged leaves
STRIP_CASES = [
    # an L, the bordering half on top: the 4 x 4 "a" is cut at y = 2, its upper piece joins
    (
        [("a", 0, 0, 4, 4), ("b", 4, 0, 6, 2), ("a", 4, 2, 6, 2)],
        [("a", 0, 0, 4, 2), ("a", 0, 2, 10, 2), ("b", 4, 0, 6, 2)],
        [[(0, 2, 4, 2), (4, 2, 6, 2)]],
    ),
    # the mirrored L: the cut falls on the right-hand leaf (the one whose near edge borders)
    (
        [("a", 0, 0, 4, 2), ("b", 0, 2, 4, 2), ("a", 4, 0, 6, 4)],
        [("a", 0, 0, 10, 2), ("a", 4, 2, 6, 2), ("b", 0, 2, 4, 2)],
        [[(0, 0, 4, 2), (4, 0, 6, 2)]],
    ),
    # staggered: A = y 0..3 and B = y 1..4 cut each other (A at 1, B at 3); the middles join
    (
        [("a", 0, 0, 4, 3), ("b", 0, 3, 4, 1), ("a", 4, 1, 6, 3), ("b", 4, 0, 6, 1)],
        [
            ("a", 0, 0, 4, 1),
            ("a", 0, 1, 10, 2),
            ("a", 4, 3, 6, 1),
            ("b", 0, 3, 4, 1),
            ("b", 4, 0, 6, 1),
        ],
        [[(0, 1, 4, 2), (4, 1, 6, 2)]],
    ),
    # one above the other: a 6 m wide "a" on a 10 m wide one, the lower one cut at x = 6
    (
        [("a", 0, 0, 10, 2), ("a", 0, 2, 6, 2), ("b", 6, 2, 4, 2)],
        [("a", 0, 0, 6, 4), ("a", 6, 0, 4, 2), ("b", 6, 2, 4, 2)],
        [[(0, 0, 6, 2), (0, 2, 6, 2)]],
    ),
    # nothing to cut: strip mode merges whole edges like "keep"
    ([("a", 0, 0, 4, 4), ("a", 4, 0, 6, 4)], [("a", 0, 0, 10, 4)], [[(0, 0, 4, 4), (4, 0, 6, 4)]]),
]


@pytest.mark.parametrize("dx, dy", [(0, 0), (3, 2), (-7, -4.5)])
@pytest.mark.parametrize("leaves, merged, parts", STRIP_CASES)
def test_strip_cuts_by_hand_anywhere_in_the_plane(leaves, merged, parts, dx, dy):
    from genie_gl.layout.merge import merge_tree

    tree = _tree(
        [(-1, dx, dy, 10, 4, "hall")] + [(0, x + dx, y + dy, w, h, t) for t, x, y, w, h in leaves]
    )
    out, rec, _ = merge_tree(tree, l_shape="strip")
    assert _leaf_rects(out) == sorted(
        (t, x + dx, y + dy, float(w), float(h)) for t, x, y, w, h in merged
    )
    got = [sorted((x - dx, y - dy, w, h) for x, y, w, h in m["parts"]) for m in records([rec])]
    assert got == [sorted(map(tuple, p)) for p in parts]
    _check_tree(Layout(out, {t: None for t in NAMES}))


def test_the_record_of_several_merges_by_hand():
    # hall -> zone 1 (left half), zone 2 (right half). Zone 1: a facing up (0, 0, 5, 2) and a
    # facing left (0, 2, 5, 2); zone 2: a up (5, 0, 5, 2) and zone 3 -> a left (5, 2, 5, 2).
    # Two merged regions (the up-facing pair, then the left-facing one: keys by type and
    # orientation), both under the hall; all three zones emptied.
    from genie_gl.layout.merge import merge_tree

    tree = _tree(
        [
            (-1, 0, 0, 10, 4, "hall"),
            (0, 0, 0, 5, 4, "zone"),
            (0, 5, 0, 5, 4, "zone"),
            (1, 0, 0, 5, 2, "a", 0),
            (1, 0, 2, 5, 2, "a", 3),
            (2, 5, 0, 5, 2, "a", 0),
            (2, 5, 2, 5, 2, "zone"),
            (6, 5, 2, 5, 2, "a", 3),
        ]
    )
    out, rec, mapping = merge_tree(tree, level=1)
    assert _rows(out) == [
        (-1, 0, "hall", 0, 0.0, 0.0, 10.0, 4.0),
        (0, 1, "a", 0, 0.0, 0.0, 10.0, 2.0),
        (0, 1, "a", 3, 0.0, 2.0, 10.0, 2.0),
    ]
    assert mapping.tolist() == [0, -1, -1, 1, 2, 1, -1, 2]
    assert rec == {
        "level": 1,
        "nodes": [1, 2],
        "part_counts": [2, 2],
        "parts": [0, 0, 5, 2, 5, 0, 5, 2, 0, 2, 5, 2, 5, 2, 5, 2],
        "parent_counts": [2, 2],
        "parents": [1, 2, 1, 6],
    }
    # the same four cells straight under the hall: the second region's one former parent is
    # the hall (node 0), listed once per region; strip mode (nothing to cut) records the same
    flat = _tree(
        [
            (-1, 0, 0, 10, 4, "hall"),
            (0, 0, 0, 5, 2, "a", 0),
            (0, 0, 2, 5, 2, "a", 3),
            (0, 5, 0, 5, 2, "a", 0),
            (0, 5, 2, 5, 2, "a", 3),
        ]
    )
    for l_shape in ("keep", "strip"):
        out, rec, mapping = merge_tree(flat, l_shape=l_shape)
        assert _rows(out) == [
            (-1, 0, "hall", 0, 0.0, 0.0, 10.0, 4.0),
            (0, 1, "a", 0, 0.0, 0.0, 10.0, 2.0),
            (0, 1, "a", 3, 0.0, 2.0, 10.0, 2.0),
        ]
        assert mapping.tolist() == [0, 1, 2, 1, 2]
        assert (
            rec["nodes"] == [1, 2]
            and rec["part_counts"] == [2, 2]
            and rec["parent_counts"] == [1, 1]
        )
        assert rec["parts"] == [0, 0, 5, 2, 5, 0, 5, 2, 0, 2, 5, 2, 5, 2, 5, 2] and rec[
            "parents"
        ] == [0, 0]


def _endpoints_by_brute_force(lo, size, clo, csize, key, tol):
    """Pair by pair: where i's far edge lies on j's near edge (or i's near on j's far) and
    both have one key, the ends of j's cross interval strictly inside i's."""
    q = lambda v: round(v / tol)  # noqa: E731
    out = []
    for i in range(len(lo)):
        for j in range(len(lo)):
            meet = q(lo[i] + size[i]) == q(lo[j]) or q(lo[i]) == q(lo[j] + size[j])
            if i != j and key[i] == key[j] and meet:
                out += [
                    (i, e)
                    for e in (clo[j], clo[j] + csize[j])
                    if q(clo[i]) < q(e) < q(clo[i] + csize[i])
                ]
    return sorted(out)


@pytest.mark.parametrize("seed", range(4))
def test_endpoints_inside_against_brute_force(seed):
    """The sorted-search cut finder of ``l_shape: strip`` against the pair-by-pair definition,
    on random rectangles of three keys on a coarse grid (lines and ends often coincide),
    placed around the origin (negative coordinates too)."""
    from genie_gl.layout.merge import _endpoints_inside

    rng = np.random.default_rng(seed)
    n, tol = 60, 0.25
    lo, clo = rng.integers(-10, 10, n) * tol, rng.integers(-10, 10, n) * tol
    size, csize = rng.integers(1, 6, n) * tol, rng.integers(1, 9, n) * tol
    key = rng.choice([0, 1, 5], n)
    who, where = _endpoints_inside(lo, size, clo, csize, key, tol)
    got = sorted(zip(who, where))
    assert got == _endpoints_by_brute_force(lo, size, clo, csize, key, tol)
    assert len(got) >= 20  # the draws do meet (25-29 cuts per seed)
