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
        {"hall": {"generator": "test_rects", "args": {"rects": [[0, 0, 5, 4], [5, 0, 5, 4]]},
                  "children": {"r": {"sequential": ["zone_l", "zone_r"]}}}},
        {"zone_l": {"generator": "test_rects", "args": {"rects": [r for r, _ in left_kids]},
                    "children": {"r": {"sequential": [t for _, t in left_kids]}}},
         "zone_r": {"generator": "test_rects", "args": {"rects": [r for r, _ in right_kids]},
                    "children": {"r": {"sequential": [t for _, t in right_kids]}},
                    "orientation": right_orientation}},
    ] + (["merge"] if merge else [])
    extra = {} if l_shape is None else {"merge": {"l_shape": l_shape}}
    return parse_strategy({"name": "m", "root": {"width": 10, "height": 4, "type": "hall"},
                           "region_types": types, "levels": levels, **extra})


def _leaves(layout):
    return sorted((r.type, r.orientation, round(r.x, 9), round(r.y, 9), round(r.w, 9), round(r.h, 9))
                  for r in layout.leaves())


def _check_tree(layout: Layout):
    t = layout.tree
    assert t.parent[0] == -1 and np.all(t.parent[1:] < np.arange(1, len(t)))      # parents first
    assert np.all(np.diff(t.depth) >= 0)                                         # breadth-first
    assert np.all(t.depth[1:] == t.depth[t.parent[1:]] + 1)
    assert np.all(np.diff(t.parent[1:]) >= 0)                                    # siblings consecutive
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
    assert sorted(map(tuple, rec["parts"])) == [(1, 0, 2, 4), (3, 0, 2, 4), (5, 0, 2, 4), (7, 0, 3, 4)]
    assert len(rec["parents"]) == 2
    # the record survives the JSON round trip
    assert Layout.from_dict(json.loads(json.dumps(layout.to_dict()))).meta["merges"] == layout.meta["merges"]


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
    assert _leaves(layout) == [("a", "up", 0.0, 0.0, 5.0, 4.0), ("a", "up", 5.0, 0.0, 5.0, 2.0),
                               ("b", "up", 5.0, 2.0, 5.0, 2.0)]


def test_strip_cuts_an_l_so_the_bordering_parts_merge():
    left = [([0, 0, 5, 4], "a")]
    right = [([0, 0, 5, 2], "a"), ([0, 2, 5, 2], "b")]
    layout = generate_layout(_strategy(left, right, l_shape="strip"), seed=0)
    assert _leaves(layout) == [("a", "up", 0.0, 0.0, 10.0, 2.0), ("a", "up", 0.0, 2.0, 5.0, 2.0),
                               ("b", "up", 5.0, 2.0, 5.0, 2.0)]
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
    assert _leaves(layout) == [("a", "up", 0.0, 0.0, 5.0, 1.0), ("a", "up", 0.0, 1.0, 10.0, 2.0),
                               ("a", "up", 0.0, 3.0, 5.0, 1.0), ("b", "up", 5.0, 0.0, 5.0, 1.0),
                               ("b", "up", 5.0, 3.0, 5.0, 1.0)]
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
    s = {"name": "g", "root": {"width": 12, "height": 9, "type": "hall"},
         "region_types": {"hall": {}, "zone": {}, "a": {"final": True}, "b": {"final": True}},
         "levels": [{"hall": {"generator": "grid", "args": {"cell": [3, 3]}, "children": {"cell": "zone"}}},
                    {"zone": {"generator": "grid", "args": {"cell": [1, 1]},
                              "children": {"cell": {"random": ["a", "b"]}},
                              "orientation": {"random": ["up", "left"]}}},
                    "merge"]}
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
            assert sum(w * h for _, _, w, h in m["parts"]) == pytest.approx(leaves.w[i] * leaves.h[i])


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
@given(w=st.floats(4, 30), h=st.floats(4, 30), c1=st.floats(1.5, 8), c2=st.floats(0.4, 3), sp=st.sampled_from([0.0, 0.3]),
       gen=st.sampled_from(["grid", "assembly_line", "random_rooms"]), seed=st.integers(0, 2**16),
       l_shape=st.sampled_from(["keep", "strip"]))
def test_two_levels_then_merge_keep_the_tree_sound(w, h, c1, c2, sp, gen, seed, l_shape):
    args = {"grid": {"cell": [c1, c1]}, "assembly_line": {"line_width": c1, "paths": [0, 2], "path_width": c2},
            "random_rooms": {"count": [1, 5], "width": [c1, c1 + 2], "height": [c1, c1 + 2]}}[gen]
    slots = {"grid": ["cell"], "assembly_line": ["line", "path", "rest"], "random_rooms": ["room"]}[gen]
    s = {"name": "p", "root": {"width": w, "height": h, "type": "hall"},
         "region_types": {"hall": {}, "zone": {}, "a": {"final": True}, "b": {"final": True}},
         "levels": [{"hall": {"generator": gen, "args": args, "children": {k: {"random": ["zone", "a"]} for k in slots}}},
                    {"zone": {"generator": "grid", "args": {"cell": [c2, c2], "spacing": sp},
                              "children": {"cell": {"random": ["a", "b"]}}, "orientation": {"random": ["up", "left"]}}},
                    "merge"], "merge": {"l_shape": l_shape}}
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
    assert not any(a.overlaps(b, tol=1e-6) for i, a in enumerate(leaves) for b in leaves[i + 1:])
    for key in {(r.type, r.orientation) for r in raw.leaves()}:
        area = lambda lay: sum(r.area for r in lay.leaves() if (r.type, r.orientation) == key)  # noqa: E731
        assert area(layout) == pytest.approx(area(raw), rel=1e-9, abs=1e-9)
    for m in records(layout.meta.get("merges", [])):
        i = m["node"]
        assert sum(pw * ph for _, _, pw, ph in m["parts"]) == pytest.approx(layout.tree.w[i] * layout.tree.h[i])


def _hand_nodes(gap):
    from genie_gl.layout.model import Node, Region
    return [Node(Region(0, 0, 10, 4, "hall"), 0, -1, [1, 2]),
            Node(Region(0, 0, 5, 4, "zone"), 1, 0, [3]),
            Node(Region(5, 0, 5, 4, "zone"), 1, 0, [4, 5]),
            Node(Region(0, 1, 5, 2, "a"), 2, 1),
            Node(Region(5 + gap, 1, 5 - gap, 2, "a"), 2, 2),
            Node(Region(5, 3, 5, 1, "b", "left"), 2, 2)]


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
    assert rec == {"level": 3, "nodes": [2], "part_counts": [2], "parts": [0, 1, 5, 2, 5, 1, 5, 2],
                   "parent_counts": [2], "parents": [1, 2]}
    assert renumber(rec, np.array([9, 8, 7, 6]))["nodes"] == [7]
    assert renumber({"level": 0, "nodes": [1, 3]}, np.array([0, -1, 5, 2])) == {"level": 0, "nodes": [-1, 2]}
    two = {"level": 1, "nodes": [4, 9], "part_counts": [2, 3], "parts": list(range(20)),
           "parent_counts": [1, 2], "parents": [7, 8, 9]}
    assert records([two]) == [
        {"level": 1, "node": 4, "parts": [[0, 1, 2, 3], [4, 5, 6, 7]], "parents": [7]},
        {"level": 1, "node": 9, "parts": [[8, 9, 10, 11], [12, 13, 14, 15], [16, 17, 18, 19]], "parents": [8, 9]}]
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
    got = [(n.region.type, n.region.orientation, n.region.x, n.region.y, n.region.w, n.region.h, n.depth, n.parent)
           for n in out]
    assert got == [("hall", "up", 0, 0, 10, 4, 0, -1), ("zone", "up", 5, 0, 5, 4, 1, 0),
                   ("a", "up", 0, 1, 10, 2, 1, 0), ("b", "left", 5, 3, 5, 1, 2, 1)]
    assert [n.children for n in out] == [[1, 2], [3], [], []]
    assert len(merge(nodes(1e-7))) == 6                    # the default tol (1e-9): apart
    assert len(merge(nodes(1e-7), tol=1e-6)) == 4          # a wider tol: joined
