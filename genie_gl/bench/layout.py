"""``genie bench layout``: the paper's Table 7 — a dummy generator of branching factor R over
L levels; time, nodes, nodes/s, a least-squares fit of time ∝ N, a plot, and a shipped
strategy end to end."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ..layout import Child, Generator, generate_layout, parse_strategy, register
from ..layout.generators import Children


def _strategy(R: int, L: int, generator: str = "strips") -> dict:
    return {
        "name": f"dummy_R{R}_L{L}",
        "root": {"width": 1000.0, "height": 1000.0, "type": "n"},
        "region_types": {"n": {}, "leaf": {"final": True}},
        "levels": [
            {
                "n": {
                    "generator": generator,
                    "args": {"n": R},
                    "children": {"strip": "n" if lvl < L - 1 else "leaf"},
                }
            }
            for lvl in range(L)
        ],
    }


def _register() -> None:
    @register("strips")
    class Strips(Generator):
        """Dummy generator of branching factor n: n equal strips across the parent."""

        slots = ("strip",)

        def generate(self, parent, *, rng):
            n = int(self.args["n"])
            w = parent.w / n
            return [Child(parent.x + i * w, parent.y, w, parent.h, "strip") for i in range(n)]

        def max_children(self, w, h, parents, area):  # the limits' bound: n strips per parent
            return parents * int(self.args["n"])

        def generate_batch(self, parents, *, rng):  # every parent at once
            n, m = int(self.args["n"]), len(parents)
            w = np.repeat(parents.w / n, n)
            x = np.repeat(parents.x, n) + np.tile(np.arange(n), m) * w
            return Children(
                np.repeat(np.arange(m), n),
                x,
                np.repeat(parents.y, n),
                w,
                np.repeat(parents.h, n),
                np.zeros(n * m, np.int32),
                np.full(n * m, -1, np.int8),
                [],
            )

    @register("strips_per_region")
    class StripsPerRegion(Strips):
        """The same generator without array code: the engine calls ``generate`` per region."""

        generate_batch = Generator.generate_batch


def _merge_cost(repeats: int) -> dict:
    """The merge layer's cost beside the expansion it follows, measured side by side: R=10,
    L=5 (100 000 leaves) typed leaf, leaf, leaf2, ... so that neighbours merge, within a
    parent and across parents."""
    s = _strategy(10, 5)
    s["region_types"]["leaf2"] = {"final": True}
    s["levels"][-1]["n"]["children"]["strip"] = {"sequential": ["leaf", "leaf", "leaf2"]}
    without, with_merge = (
        parse_strategy(s),
        parse_strategy({**s, "levels": s["levels"] + ["merge"]}),
    )
    t_without = t_with = np.inf
    for _ in range(repeats):
        for strat in (without, with_merge):
            t = time.perf_counter()
            layout = generate_layout(strat, seed=0)
            dt = time.perf_counter() - t
            if strat is without:
                t_without, before = min(t_without, dt), len(layout.leaf_indices())
            else:
                t_with, after = min(t_with, dt), len(layout.leaf_indices())
    print(
        f"merge layer, R=10 L=5 ({before:,} leaves -> {after:,}): {1e3 * t_with:.0f} ms with it, "
        f"{1e3 * t_without:.0f} ms without (x{t_with / t_without:.2f})"
    )
    return {
        "leaves_before": before,
        "leaves_after": after,
        "ms_with": 1e3 * t_with,
        "ms_without": 1e3 * t_without,
    }


def run(args: argparse.Namespace) -> int:
    _register()
    rows = []
    cases = [(R, 4) for R in range(10, 21, 2)] + [(5, L) for L in range(3, 8)]
    print(f"{'R':>3} {'L':>2} {'nodes':>9} {'time ms':>9} {'nodes/s':>11}")
    for R, L in cases:
        strat = parse_strategy(_strategy(R, L))
        best = np.inf
        for _ in range(args.repeats):
            t = time.perf_counter()
            layout = generate_layout(strat, seed=0)
            best = min(best, time.perf_counter() - t)
        rows.append(
            {
                "R": R,
                "L": L,
                "nodes": len(layout),
                "ms": 1e3 * best,
                "nodes_per_s": len(layout) / best,
            }
        )
        print(f"{R:>3} {L:>2} {len(layout):>9,} {1e3 * best:>9.1f} {len(layout) / best:>11,.0f}")
    n = np.array([r["nodes"] for r in rows], float)
    t = np.array([r["ms"] for r in rows])
    k = float((n @ t) / (n @ n))
    r2 = 1 - ((t - k * n) ** 2).sum() / ((t - t.mean()) ** 2).sum()
    print(
        f"fit: time = {k * 1e3:.3f} us x N (R^2 = {r2:.4f}); paper: 122 k nodes/s (R=20, L=4: 1313 "
        "ms)"
    )
    t0 = time.perf_counter()
    slow = generate_layout(parse_strategy(_strategy(20, 4, "strips_per_region")), seed=0)
    loop_s = time.perf_counter() - t0
    print(
        f"R=20, L=4 with a per-region generator (no array code): {1e3 * loop_s:.0f} ms, "
        f"{len(slow) / loop_s:,.0f} nodes/s"
    )
    merge = _merge_cost(args.repeats)
    t0 = time.perf_counter()
    for _ in range(5):
        generate_layout("assembly_line", seed=0)
    real_ms = 1e3 * (time.perf_counter() - t0) / 5
    print(f"shipped assembly_line strategy: {real_ms:.1f} ms per layout")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "layout.json").write_text(
        json.dumps(
            {
                "rows": rows,
                "us_per_node": k * 1e3,
                "r2": r2,
                "assembly_line_ms": real_ms,
                "merge_layer": merge,
                "per_region_nodes_per_s": len(slow) / loop_s,
            },
            indent=1,
        )
    )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(n, t, "o", label="measured")
    xs = np.linspace(0, n.max(), 50)
    ax.plot(xs, k * xs, "-", label=f"fit {k * 1e3:.2f} us/node")
    ax.set_xlabel("nodes N")
    ax.set_ylabel("time (ms)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "layout.png", dpi=100)
    print(f"wrote {out / 'layout.json'} and {out / 'layout.png'}")
    return 0
