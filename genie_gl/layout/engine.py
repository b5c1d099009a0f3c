"""The layout engine: paper Algorithm 1 (levels, merge) and Algorithm 2 (breadth-first
expansion with a generator looked up per region type), driven by one explicit Generator."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from .model import Layout, Node, Region, RegionType
from .strategy import Rule, Strategy, load_strategy

log = logging.getLogger(__name__)


def generate_layout(strategy: Strategy | str | Path, seed: int = 0, *,
                    rng: np.random.Generator | None = None) -> Layout:
    """Generate a layout tree from a strategy (object, file path or shipped name).

    The same strategy and seed give the same layout, byte for byte (``rng`` overrides seed).
    """
    strat = strategy if isinstance(strategy, Strategy) else load_strategy(strategy)
    rng = np.random.default_rng(seed) if rng is None else rng
    r = strat.root
    nodes = [Node(Region(r.x, r.y, r.width, r.height, r.type, r.orientation), 0, -1)]
    reports: list[dict] = []
    for li, level in enumerate(strat.levels):
        if level == "merge":
            nodes = merge(nodes)
            continue
        frontier = [i for i, n in enumerate(nodes) if not n.children]  # breadth-first order
        for i in frontier:
            rule = level.get(nodes[i].region.type)
            if rule is None or strat.region_types[nodes[i].region.type].final:
                continue
            _expand(nodes, i, rule, rng, strat.region_types)
            report = getattr(rule.generator, "report", None)
            if report and report.get("placed", 0) < report.get("requested", 0):
                reports.append({"level": li, "region": i, **report})
                log.info("level %d: %s placed %d of %d rooms", li, rule.generator_name,
                         report["placed"], report["requested"])
    meta = {"strategy": strat.name, "seed": int(seed), "reports": reports, "scene": strat.scene}
    return Layout(nodes, strat.region_types, meta)


def _expand(nodes: list[Node], i: int, rule: Rule, rng: np.random.Generator,
            types: dict[str, RegionType]) -> None:
    parent = nodes[i].region
    children = rule.generator.generate(parent, rng)
    by_slot: dict[str, list[int]] = {}
    for k, c in enumerate(children):
        by_slot.setdefault(c.slot, []).append(k)
    chosen: dict[int, str] = {}
    for slot, provider in rule.children.items():
        ks = by_slot.get(slot, [])
        for k, t in zip(ks, provider.choose(len(ks), rng)):
            chosen[k] = t
    kept = [k for k in range(len(children)) if k in chosen]  # slots without a provider are dropped
    regions = [Region(children[k].x, children[k].y, children[k].w, children[k].h, chosen[k]) for k in kept]
    orients = rule.orientation.choose(parent, regions, [children[k].orientation for k in kept], rng)
    for reg, o in zip(regions, orients):
        nodes[i].children.append(len(nodes))
        nodes.append(Node(Region(reg.x, reg.y, reg.w, reg.h, reg.type, o), nodes[i].depth + 1, i))


def merge(nodes: list[Node], tol: float = 1e-9) -> list[Node]:
    """Merge sibling leaves of the same type that share a whole edge into one rectangle,
    until none do; area and type coverage are preserved. Returns a re-indexed node list."""
    regions = {i: n.region for i, n in enumerate(nodes)}
    children = {i: list(n.children) for i, n in enumerate(nodes)}
    for p in range(len(nodes)):
        leaves = [c for c in children[p] if not nodes[c].children]
        changed = True
        while changed:
            changed = False
            for a_i, a in enumerate(leaves):
                ra = regions[a]
                for b in leaves[a_i + 1:]:
                    rb = regions[b]
                    m = _join(ra, rb, tol)
                    if m is not None:
                        regions[a] = m
                        leaves.remove(b)
                        children[p].remove(b)
                        changed = True
                        break
                if changed:
                    break
    # re-index breadth-first
    out: list[Node] = []
    queue, new_index = [(0, -1)], {}
    while queue:
        old, parent = queue.pop(0)
        new_index[old] = len(out)
        out.append(Node(regions[old], nodes[old].depth, parent))
        if parent >= 0:
            out[parent].children.append(new_index[old])
        queue.extend((c, new_index[old]) for c in children[old])
    return out


def _join(a: Region, b: Region, tol: float) -> Region | None:
    if a.type != b.type or a.orientation != b.orientation:
        return None
    if abs(a.y - b.y) < tol and abs(a.h - b.h) < tol and (abs(a.x + a.w - b.x) < tol or abs(b.x + b.w - a.x) < tol):
        return Region(min(a.x, b.x), a.y, a.w + b.w, a.h, a.type, a.orientation)
    if abs(a.x - b.x) < tol and abs(a.w - b.w) < tol and (abs(a.y + a.h - b.y) < tol or abs(b.y + b.h - a.y) < tol):
        return Region(a.x, min(a.y, b.y), a.w, a.h + b.h, a.type, a.orientation)
    return None
