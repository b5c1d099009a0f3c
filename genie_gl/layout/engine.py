"""The layout engine: paper Algorithm 1 (levels, merge) and Algorithm 2 (breadth-first
expansion with a generator looked up per region type), driven by one explicit Generator."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from .generators import Children, Parents
from .merge import merge_tree, renumber
from .model import ORIENTATIONS, Layout, Node, Region, RegionType, Tree
from ..validation.arguments import check_seed, describe, whole_number
from ..errors import ConfigError
from ..limits import MAX_REGIONS, check_regions
from .estimate import layout_estimate
from .strategy import Rule, Strategy, load_strategy, parse_strategy

log = logging.getLogger(__name__)


def generate_layout(
    strategy: Strategy | str | Path | dict,
    seed: int = 0,
    *,
    rng: np.random.Generator | None = None,
    max_regions: int = MAX_REGIONS,
) -> Layout:
    """Generate a layout tree from a strategy (object, file path or shipped name).

    Algorithm 2 a level at a time: the leaves of each region type that the level has a rule
    for are expanded together (one ``generate_batch`` call), their children's types and
    orientations chosen in arrays, and the new nodes appended grouped by parent, so the tree
    stays breadth-first. The same strategy and seed give the same layout, byte for byte
    (``rng`` overrides seed).

    A strategy whose layouts can hold more than ``max_regions`` regions (or cost as much work,
    :func:`~genie_gl.layout.estimate.layout_estimate`) is refused before any work
    (:class:`~genie_gl.errors.LimitError`).
    """
    strat = as_strategy(strategy)
    seed = check_seed(seed)
    max_regions = whole_number(max_regions, "generate_layout: max_regions", 1)
    check_regions(
        layout_estimate(strat)[1],
        max_regions,
        str(strat.source),
        option="--max-nodes (max_regions= in the API)",
    )
    rng = np.random.default_rng(seed) if rng is None else rng
    names = tuple(strat.region_types)
    r = strat.root
    tree = Tree(
        *(np.array([v], np.float64) for v in (r.x, r.y, r.width, r.height)),
        np.array([names.index(r.type)], np.int32),
        np.array([ORIENTATIONS.index(r.orientation)], np.int8),
        np.zeros(1, np.int32),
        np.full(1, -1, np.int32),
        names,
    )
    reports: list[dict] = []
    merges: list[dict] = []
    for li, level in enumerate(strat.levels):
        if level == "merge":
            tree, record, mapping = merge_tree(tree, l_shape=strat.l_shape, level=li)
            merges = [renumber(m, mapping) for m in merges] + ([record] if record else [])
            continue
        tree = _expand_level(tree, level, strat.region_types, li, reports, rng=rng)
    meta = {"strategy": strat.name, "seed": int(seed), "reports": reports, "scene": strat.scene}
    if merges:
        meta["merges"] = merges
    return Layout(tree, strat.region_types, meta)


def as_strategy(strategy: Strategy | str | Path | dict) -> Strategy:
    """A :class:`Strategy` from itself, a file path, a shipped name or parsed JSON (a dict)."""
    if isinstance(strategy, Strategy):
        return strategy
    if isinstance(strategy, dict):
        return parse_strategy(strategy, "strategy (dict)")
    if isinstance(strategy, (str, Path)):
        return load_strategy(strategy)
    raise ConfigError(
        f"strategy: expected a Strategy, a strategy file, a shipped name or its JSON as a dict, "
        f"got {describe(strategy)}"
    )


def _expand_level(
    tree: Tree,
    level: dict[str, Rule],
    types: dict[str, RegionType],
    li: int,
    reports: list[dict],
    *,
    rng: np.random.Generator,
) -> Tree:
    names = tree.type_names
    leaves = np.flatnonzero(tree.n_children() == 0)
    parts = []
    for tname, rule in level.items():
        if types[tname].final:
            continue
        sel = leaves[tree.type[leaves] == names.index(tname)]
        if len(sel) == 0:
            continue
        kids = rule.generator.generate_batch(
            Parents(tree.x[sel], tree.y[sel], tree.w[sel], tree.h[sel], tree.orient[sel], tname),
            rng=rng,
        )
        for k, rep in kids.reports:
            if rep.get("placed", 0) < rep.get("requested", 0):
                reports.append({"level": li, "region": int(sel[k]), **rep})
                log.info(
                    "level %d: %s placed %d of %d rooms",
                    li,
                    rule.generator_name,
                    rep["placed"],
                    rep["requested"],
                )
        parts.append(_assign(tree, sel, kids, rule, rng=rng))
    if not parts:
        return tree
    new = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    order = np.argsort(new["parent"], kind="stable")  # children grouped by parent: breadth-first
    new = {k: v[order] for k, v in new.items()}
    return Tree(
        *(
            np.concatenate([getattr(tree, k), new[k]])
            for k in ("x", "y", "w", "h", "type", "orient")
        ),
        np.concatenate([tree.depth, tree.depth[new["parent"]] + 1]),
        np.concatenate([tree.parent, new["parent"].astype(np.int32)]),
        names,
    )


def _assign(
    tree: Tree, sel: np.ndarray, kids: Children, rule: Rule, *, rng: np.random.Generator
) -> dict[str, np.ndarray]:
    """Region types and orientations of a batch's children; children whose slot has no type
    provider are dropped."""
    names = tree.type_names
    slots = rule.generator.slots
    t = np.full(len(kids), -1, np.int32)
    for slot, provider in rule.children.items():
        m = np.flatnonzero(kids.slot == slots.index(slot))
        p = kids.parent[m]
        starts = np.flatnonzero(np.r_[True, p[1:] != p[:-1]]) if len(p) else np.zeros(0, np.int64)
        rank = np.arange(len(m)) - np.repeat(starts, np.diff(np.r_[starts, len(m)]))
        lut = np.array([names.index(v) for v in provider.values], np.int32)
        t[m] = lut[provider.choose_index(rank, rng)]
    keep = np.flatnonzero(t >= 0)
    parent = sel[kids.parent[keep]]
    x, y, w, h, t = kids.x[keep], kids.y[keep], kids.w[keep], kids.h[keep], t[keep]
    suggested = kids.orient[keep]
    orient = rule.orientation.choose_index(tree.orient[parent], suggested, rng)
    if orient is None:  # per parent (face a neighbour)
        orient = np.empty(len(keep), np.int8)
        bounds = np.flatnonzero(np.r_[True, parent[1:] != parent[:-1], True]) if len(keep) else [0]
        for a, b in zip(bounds[:-1], bounds[1:]):
            regs = [Region(x[k], y[k], w[k], h[k], names[t[k]]) for k in range(a, b)]
            sug = [None if s < 0 else ORIENTATIONS[s] for s in suggested[a:b]]
            got = rule.orientation.choose(tree.region(int(parent[a])), regs, sug, rng)
            orient[a:b] = [ORIENTATIONS.index(o) for o in got]
    return {"parent": parent, "x": x, "y": y, "w": w, "h": h, "type": t, "orient": orient}


def merge(nodes: list[Node], tol: float = 1e-9) -> list[Node]:
    """The merge layer on a node list (see :mod:`.merge`): leaves of the same type and
    orientation sharing a whole edge become one rectangle, whatever their parents, until
    none do; area and type coverage are preserved. Returns a re-indexed node list."""
    names = tuple(dict.fromkeys(n.region.type for n in nodes))
    tree, _, _ = merge_tree(Tree.from_nodes(nodes, names), tol=max(tol, 1e-9))
    return tree.to_nodes()
