"""The merge layer (paper Algorithm 1, lines 4-6): identical, bordering regions become one.

After the levels before it, every pair of leaves of the same region type and orientation
that share a whole edge (so that their union is a rectangle) is joined, whatever generator
or parent made them, until no such pair is left. L-shaped unions are never made: two
leaves that border along part of an edge only stay apart, unless the strategy asks for
``"merge": {"l_shape": "strip"}``: then each is first cut where the other's edge ends, so
the bordering parts merge into one strip (the pieces of one cut leaf never rejoin).

The merged region hangs under the smallest region that holds all its parts (the lowest
common ancestor: their parent when they were siblings), so every node still lies inside its
parent; a region whose children have all merged away is removed. Everything is array code
over the layout's :class:`~.model.Tree`; only groups whose parts came from different parents
walk the tree. Each merged region is recorded for the layout's ``meta``: its node, its
parts' rectangles and its parts' former parents.
"""

from __future__ import annotations

import numpy as np

from .model import Tree

TOL_M = 1e-6  # edges at most this far apart (metres) are the same edge


def _pass(x, y, w, h, key_t, along_x: bool, tol: float, origin: np.ndarray):
    """One sweep: runs of rectangles with the same type, orientation and cross extent that
    follow each other without a gap along one axis. Returns (run id of each rectangle in the
    sorted order, that order, whether any two joined)."""
    pos, size, cpos, csize = (x, w, y, h) if along_x else (y, h, x, w)
    k1 = np.round(cpos / tol).astype(np.int64)
    k2 = np.round(csize / tol).astype(np.int64)
    order = np.lexsort((pos, k2, k1, key_t))
    same = (
        (key_t[order][1:] == key_t[order][:-1])
        & (k1[order][1:] == k1[order][:-1])
        & (k2[order][1:] == k2[order][:-1])
    )
    touch = np.abs(pos[order][:-1] + size[order][:-1] - pos[order][1:]) <= tol
    o = origin[order]
    joined = same & touch & ((o[1:] < 0) | (o[1:] != o[:-1]))  # pieces of one cut leaf never rejoin
    run = np.concatenate([[0], np.cumsum(~joined)])
    return run, order, joined.any()


def merge_leaves(x, y, w, h, key: np.ndarray, tol: float = TOL_M, origin: np.ndarray | None = None):
    """Merge rectangles of equal ``key`` sharing a whole edge until none do.

    Parameters
    ----------
    x, y, w, h : (n,) float64 rectangles; key : (n,) int64, only equal keys merge.
    origin : (n,) int64 or None, rectangles with the same origin >= 0 (pieces of one cut
        leaf) never merge with each other.

    Returns
    -------
    group : (n,) int64, for each rectangle the index of the group it ended in;
    gx, gy, gw, gh : (g,) float64, each group's rectangle.
    """
    x, y, w, h = (np.asarray(a, np.float64).copy() for a in (x, y, w, h))
    key = np.asarray(key, np.int64)
    origin = (
        np.full(len(x), -1, np.int64) if origin is None else np.asarray(origin, np.int64).copy()
    )
    group = np.arange(len(x))
    changed, along_x, idle = True, False, 0  # columns first, then rows, until neither joins
    while len(x) > 1 and idle < 2:
        run, order, changed = _pass(x, y, w, h, key, along_x, tol, origin)
        if changed:
            n = run[-1] + 1
            first = np.searchsorted(run, np.arange(n))
            last = np.r_[first[1:], len(run)] - 1
            o_first, o_last = order[first], order[last]
            if along_x:
                nx, nw = x[o_first], x[o_last] + w[o_last] - x[o_first]
                ny, nh = y[o_first], h[o_first]
            else:
                ny, nh = y[o_first], y[o_last] + h[o_last] - y[o_first]
                nx, nw = x[o_first], w[o_first]
            where = np.empty(len(x), np.int64)
            where[order] = run
            group = where[group]
            single = (last - first) == 0
            x, y, w, h, key = nx, ny, nw, nh, key[o_first]
            origin = np.where(single, origin[o_first], -1)
            idle = 0
        else:
            idle += 1
        along_x = not along_x
    return group, x, y, w, h


def _common_ancestors(
    parent: np.ndarray, depth: np.ndarray, g: np.ndarray, nodes: np.ndarray
) -> np.ndarray:
    """For each group (``g``: (m,) group labels, sorted), the deepest node that is an
    ancestor of (or one of) its ``nodes``: all groups at once, a level at a time. Returns
    one node per distinct label, in label order."""
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    size = np.diff(np.r_[starts, len(g)])
    a = nodes.astype(np.int64)
    while True:
        d = depth[a]
        dmin, dmax = np.minimum.reduceat(d, starts), np.maximum.reduceat(d, starts)
        amin, amax = np.minimum.reduceat(a, starts), np.maximum.reduceat(a, starts)
        unresolved = np.repeat(amin != amax, size)
        if not unresolved.any():
            return amin
        # lift the deepest of a group's nodes; when all are equally deep, lift them all
        lift = unresolved & ((d == np.repeat(dmax, size)) | np.repeat(dmin == dmax, size))
        a = np.where(lift, parent[a], a)


def _endpoints_inside(lo, size, clo, csize, key, tol: float) -> tuple[list[int], list[float]]:
    """Where rectangles of one key meet on a line (one's far edge on the other's near edge),
    the ends of each one's neighbours' intervals that fall strictly inside its own interval:
    (rectangle, coordinate) pairs. Sorted searches over all lines at once."""
    q = lambda v: np.round(v / tol).astype(np.int64)  # noqa: E731
    near, far, c0, c1 = q(lo), q(lo + size), q(clo), q(clo + csize)
    cmin = min(near.min(), far.min())
    span = max(near.max(), far.max()) - cmin + 1
    _, rank = np.unique(
        np.r_[key * span + near - cmin, key * span + far - cmin], return_inverse=True
    )
    rank_near, rank_far = rank[: len(lo)], rank[len(lo) :]
    emin = c0.min()
    Q = c1.max() - emin + 3
    out_i, out_c = [], []
    for mine, theirs in ((rank_far, rank_near), (rank_near, rank_far)):
        ek = np.r_[theirs * Q + c0 - emin, theirs * Q + c1 - emin]
        ev = np.r_[clo, clo + csize]
        order = np.argsort(ek, kind="stable")
        ek, ev = ek[order], ev[order]
        a = np.searchsorted(ek, mine * Q + c0 - emin + 1, "left")
        b = np.searchsorted(ek, mine * Q + c1 - emin - 1, "right")
        n = np.maximum(b - a, 0)
        if n.sum() == 0:
            continue
        who = np.repeat(np.arange(len(lo)), n)
        pos = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + np.repeat(a, n)
        out_i += who.tolist()
        out_c += ev[pos].tolist()
    return out_i, out_c


def _strip_cuts(
    tree: Tree, leaves: np.ndarray, key: np.ndarray, tol: float
) -> tuple[Tree, np.ndarray]:
    """``l_shape: strip``: every leaf that borders a leaf of its key along part of an edge is
    cut where the other's edge ends. Returns the tree with the pieces (a cut leaf keeps its
    first piece; the others are appended as its siblings) and each node's origin (the cut
    leaf's index for its pieces, -1 elsewhere)."""
    x, y, w, h = (a[leaves] for a in (tree.x, tree.y, tree.w, tree.h))
    cuts: dict[int, tuple[set, set]] = {}
    for axis, (lo, size, clo, csize) in ((1, (x, w, y, h)), (0, (y, h, x, w))):
        # side by side along x: cut across y (axis 1); one above the other: across x (axis 0)
        for i, c in zip(*_endpoints_inside(lo, size, clo, csize, key, tol)):
            cuts.setdefault(i, (set(), set()))[axis].add(c)
    origin = np.full(len(tree), -1, np.int64)
    extra: list[tuple] = []
    rect = {k: getattr(tree, k).copy() for k in ("x", "y", "w", "h")}
    for i, (cx, cy) in sorted(cuts.items()):
        node = int(leaves[i])
        xs = [x[i], *sorted(cx), x[i] + w[i]]
        ys = [y[i], *sorted(cy), y[i] + h[i]]
        pieces = [
            (x0, y0, x1 - x0, y1 - y0) for y0, y1 in zip(ys, ys[1:]) for x0, x1 in zip(xs, xs[1:])
        ]
        origin[node] = node
        rect["x"][node], rect["y"][node], rect["w"][node], rect["h"][node] = pieces[0]
        extra += [(node, *p) for p in pieces[1:]]
    if not extra:
        return tree, origin
    src = np.array([e[0] for e in extra], np.int64)
    cat = lambda a, b: np.concatenate([a, np.asarray(b, a.dtype)])  # noqa: E731
    out = Tree(
        *(cat(rect[k], [e[1 + c] for e in extra]) for c, k in enumerate(("x", "y", "w", "h"))),
        cat(tree.type, tree.type[src]),
        cat(tree.orient, tree.orient[src]),
        cat(tree.depth, tree.depth[src]),
        cat(tree.parent, tree.parent[src]),
        tree.type_names,
    )
    return out, np.concatenate([origin, src])


def merge_tree(
    tree: Tree, tol: float = TOL_M, l_shape: str = "keep", level: int = -1
) -> tuple[Tree, dict | None, np.ndarray]:
    """The merge layer over a whole tree: returns the new tree (breadth-first, siblings
    consecutive), the level's record (None when nothing merged; see :func:`records`), and
    each old node's new index (a part's is its merged region's; -1 for a removed region).
    ``l_shape``: "keep" or "strip" (see :class:`~.strategy.MergeSpec`)."""
    n0 = len(tree)
    if n0 < 2:
        return tree, None, np.arange(n0)
    leaves = np.flatnonzero(tree.n_children() == 0)
    key = tree.type[leaves].astype(np.int64) * 4 + tree.orient[leaves]
    origin = np.full(n0, -1, np.int64)
    if l_shape == "strip":
        tree, origin = _strip_cuts(tree, leaves, key, tol)
        leaves = np.flatnonzero(tree.n_children() == 0)
        key = tree.type[leaves].astype(np.int64) * 4 + tree.orient[leaves]
    n = len(tree)
    group, gx, gy, gw, gh = merge_leaves(
        tree.x[leaves], tree.y[leaves], tree.w[leaves], tree.h[leaves], key, tol, origin[leaves]
    )
    sizes = np.bincount(group, minlength=len(gx))
    if np.all(sizes == 1) and n == n0:
        return tree, None, np.arange(n)
    x, y, w, h = tree.x.copy(), tree.y.copy(), tree.w.copy(), tree.h.copy()
    parent, depth = tree.parent.copy(), tree.depth.copy()
    keep = np.ones(n, bool)
    # representative of each group: its first part in breadth-first order
    order = np.lexsort((leaves, group))
    starts = np.searchsorted(group[order], np.arange(len(gx)))
    rep = leaves[order[starts]]
    multi = np.flatnonzero(sizes > 1)
    x[rep[multi]], y[rep[multi]], w[rep[multi]], h[rep[multi]] = (
        gx[multi],
        gy[multi],
        gw[multi],
        gh[multi],
    )
    absorbed = leaves[rep[group] != leaves]
    keep[absorbed] = False
    lp = parent[leaves][order]  # by group
    pmin, pmax = np.minimum.reduceat(lp, starts), np.maximum.reduceat(lp, starts)
    cross = np.flatnonzero(pmin != pmax)
    if len(cross):  # parts from several parents: hang the region under their common ancestor
        sel = np.isin(group[order], cross)
        common = _common_ancestors(tree.parent, tree.depth, group[order][sel], lp[sel])
        parent[rep[cross]], depth[rep[cross]] = common, tree.depth[common] + 1
    # the record, in flat columns (tens of thousands of merges stay cheap): each merged
    # region's parts (breadth-first) and their former parents
    in_multi = sizes[group[order]] > 1
    m_nodes, m_groups = leaves[order][in_multi], group[order][in_multi]
    pk = np.unique(
        m_groups.astype(np.int64) * (n + 1) + tree.parent[m_nodes]
    )  # (group, parent) pairs
    pairs = np.stack([pk // (n + 1), pk % (n + 1)], 1)
    # regions whose children all merged away go too (their area is in the merged regions)
    had_kids = tree.n_children() > 0
    while True:
        kids = np.bincount(parent[1:][keep[1:]], minlength=n)
        empty = keep & had_kids & (kids == 0)
        empty[0] = False
        if not empty.any():
            break
        keep &= ~empty
    # breadth-first order again: by depth, then parent's new position, then old position
    new_index = np.full(n, -1, np.int64)
    pos = 0
    for d in range(int(depth[keep].max()) + 1):
        idx = np.flatnonzero(keep & (depth == d))
        if d > 0:
            idx = idx[np.lexsort((idx, new_index[parent[idx]]))]
        new_index[idx] = np.arange(pos, pos + len(idx))
        pos += len(idx)
    old = np.empty(pos, np.int64)
    old[new_index[keep]] = np.flatnonzero(keep)
    new_parent = np.where(old == 0, -1, new_index[parent[old]]).astype(np.int32)
    out = Tree(
        x[old],
        y[old],
        w[old],
        h[old],
        tree.type[old],
        tree.orient[old],
        depth[old].astype(np.int32),
        new_parent,
        tree.type_names,
    )
    record = {
        "level": level,
        "nodes": new_index[rep[multi]].tolist(),
        "part_counts": sizes[multi].tolist(),
        "parts": np.stack([tree.x[m_nodes], tree.y[m_nodes], tree.w[m_nodes], tree.h[m_nodes]], 1)
        .ravel()
        .tolist(),
        "parent_counts": np.bincount(pairs[:, 0], minlength=len(gx))[multi].tolist(),
        "parents": pairs[:, 1].tolist(),
    }
    new_index[absorbed] = new_index[rep[group[np.searchsorted(leaves, absorbed)]]]
    return out, record, new_index[:n0]


def renumber(record: dict, mapping: np.ndarray) -> dict:
    """An earlier level's record with its nodes moved to a later merge's numbering
    (``mapping``: old index -> new index; -1: the region was removed since)."""
    return {**record, "nodes": mapping[np.asarray(record["nodes"], np.int64)].tolist()}


def records(merges: list[dict]) -> list[dict]:
    """The merge records of ``layout.meta["merges"]`` one merged region at a time:
    ``{"level", "node", "parts": [[x, y, w, h], ...], "parents": [...]}`` (parents: node
    indices of the tree before that merge level)."""
    out = []
    for m in merges:
        p, q = 0, 0
        for node, k, j in zip(m["nodes"], m["part_counts"], m["parent_counts"]):
            out.append(
                {
                    "level": m["level"],
                    "node": node,
                    "parts": [m["parts"][4 * i : 4 * i + 4] for i in range(p, p + k)],
                    "parents": m["parents"][q : q + j],
                }
            )
            p, q = p + k, q + j
    return out
