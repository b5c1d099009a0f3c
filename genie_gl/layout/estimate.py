"""How large a layout of a strategy can get, before any of it is made.

:func:`layout_estimate` bounds the regions (and the work) of every layout a strategy can
make, from each generator's own bound (:meth:`Generator.max_children`,
:meth:`Generator.work`, :meth:`Generator.child_cost`, :meth:`Generator.always_splits`), so
that ``generate_layout``, ``genie layout`` and ``genie dataset`` refuse a strategy that
cannot fit (:func:`genie_gl.limits.check_regions`) instead of running out of memory or time.

The bound holds for any seed. It follows, level by level, an upper bound of the leaves of
each region type: a level's rule for type ``t`` expands only the leaves of type ``t`` (at most
``leaves[t]`` regions, each at most the root's size, together at most its area: leaves are
disjoint and inside the root); its children can be of any type its slots' providers name,
so each such type gains at most all of them; a parent stays a leaf of its type unless its
generator always gives it a child (:meth:`Generator.always_splits`). A type no level makes
costs nothing however deep the strategy, so a deep chain of small steps is bounded by what it
makes, not by the product of its levels. ``"merge"`` levels join regions (the default) and
are not counted.

The work counts a region made by a generator's array code (``generate_batch``) as 1, one
made by the per-region loop (``generate``) as :data:`~.generators.LOOP_COST` (the measured
ratio of their times, ``genie bench layout``), plus each generator's own work (overlap
tests, walk steps).
"""

from __future__ import annotations

from .strategy import Strategy

CAP = 1e18


def layout_estimate(strategy: Strategy) -> tuple[int, int]:
    """(regions, work): upper bounds of the regions a layout of ``strategy`` holds and of the
    work of making it (regions plus each generator's own work, in regions' worth)."""
    W, H = float(strategy.root.width), float(strategy.root.height)
    area = W * H
    leaves = {strategy.root.type: 1.0}
    nodes, work = 1.0, 1.0
    for level in strategy.levels:
        if not isinstance(level, dict):  # "merge" only joins regions
            continue
        gained: dict[str, float] = {}
        split: set[str] = set()
        for tname, rule in level.items():
            parents = leaves.get(tname, 0.0)
            if parents <= 0 or strategy.region_types[tname].final:
                continue
            gen = rule.generator
            made = min(gen.max_children(W, H, parents, min(area, parents * area)), CAP)
            work += gen.work(W, H, parents) + made * gen.child_cost()
            nodes += made
            for t in {t for provider in rule.children.values() for t in provider.types()}:
                gained[t] = gained.get(t, 0.0) + made
            if gen.always_splits(set(rule.children)):
                split.add(tname)
        for t in split:  # every parent of these types got a child: none is a leaf any more
            leaves[t] = 0.0
        for t, n in gained.items():
            leaves[t] = min(leaves.get(t, 0.0) + n, nodes)
        nodes, work = min(nodes, CAP), min(work, CAP)
    return int(nodes), int(work)
