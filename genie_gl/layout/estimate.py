"""How large a layout of a strategy can get, before any of it is made.

:func:`layout_estimate` bounds the regions (and the work) of every layout a strategy can
make, from each generator's own bound (:meth:`Generator.max_children` and
:meth:`Generator.work`), so that ``generate_layout``, ``genie layout`` and ``genie dataset``
refuse a strategy that cannot fit (:func:`genie_gl.limits.check_regions`) instead of running
out of memory or time. The bound holds for any seed: a level expands leaves, which are
disjoint and inside the root, so each level's parents are at most every region made so far,
each at most the root's size, together at most its area; the rules of a level are summed
(each parent has one type, so one rule expands it).
"""
from __future__ import annotations

from .strategy import Strategy

CAP = 1e18


def layout_estimate(strategy: Strategy) -> tuple[int, int]:
    """(regions, work): upper bounds of the regions a layout of ``strategy`` holds and of the
    work of making it (regions plus each generator's own work, in regions' worth)."""
    W, H = float(strategy.root.width), float(strategy.root.height)
    area = W * H
    nodes, work = 1.0, 1.0
    for level in strategy.levels:
        if not isinstance(level, dict):   # "merge" only joins regions
            continue
        made = 0.0
        for rule in level.values():
            made += rule.generator.max_children(W, H, nodes, area)
            work += rule.generator.work(W, H, nodes)
        nodes = min(nodes + made, CAP)
        work = min(work + made, CAP)
    return int(nodes), int(work)
