"""Strategies at the edges of the layout estimate and of JSON numbers: a 1 cm grid that the
per-region loop would take minutes and gigabytes to make is refused at once; a deep chain of
small steps that makes a few thousand regions is accepted; the estimate stays an upper bound
of what random deep strategies make; ``Infinity`` and ``NaN`` are refused at parsing, in one
line naming the JSON path, by every command that reads a strategy."""

import json
import time

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.layout import parse_strategy
from genie_gl.layout.estimate import layout_estimate
from genie_gl.limits import MAX_REGIONS
from genie_gl.resources import data_dir

from .common import cli, cli_proc, fault, refused


def cm_grid(side: float = 14.0) -> dict:
    """A hall of ``side`` x ``side`` m cut into 1 cm cells: ~2 M regions, each made by the
    grid's per-region loop."""
    return {
        "name": "cm",
        "root": {"width": side, "height": side, "type": "hall"},
        "region_types": {
            "hall": {},
            "cell": {"final": True, "semantic": 1, "asset_group": "pallet"},
            "empty": {"final": True},
        },
        "levels": [
            {
                "hall": {
                    "generator": "grid",
                    "args": {"cell": [0.01, 0.01]},
                    "children": {"cell": "cell", "empty": "empty"},
                }
            },
            "merge",
        ],
    }


def deep_chain(levels: int = 1000) -> dict:
    """Four rooms, then ``levels`` levels that each put one room inside every room: ~4,000
    regions, made in seconds."""
    room = {
        "generator": "random_rooms",
        "args": {"count": 1, "width": [1, 9], "height": [1, 9]},
        "children": {"room": "a"},
    }
    return {
        "name": "deep",
        "root": {"width": 20, "height": 20, "type": "hall"},
        "region_types": {"hall": {}, "a": {}},
        "levels": [
            {
                "hall": {
                    "generator": "grid",
                    "args": {"cell": [10, 10]},
                    "children": {"cell": "a", "empty": "a"},
                }
            }
        ]
        + [{"a": room}] * levels,
    }


@fault("huge input", "hang")
@pytest.mark.parametrize("command", ["layout", "dataset"])
def test_a_1cm_grid_is_refused_at_once(command, tmp_path):
    """Under the old bound it passed (1.96 M regions < 2 M) and ran for minutes at >3 GB."""
    p = tmp_path / "cm.json"
    p.write_text(json.dumps(cm_grid()))
    assert layout_estimate(parse_strategy(cm_grid(), "cm.json"))[1] > MAX_REGIONS
    run = cli_proc(command, p, "--out", tmp_path / "o", timeout=60, memory_gb=3.0)
    refused(run, "cm.json: a layout of this strategy can make up to", "--max-nodes")
    assert not (tmp_path / "o").exists()


@fault("huge input", "wrong")
def test_a_deep_chain_of_small_steps_is_accepted(tmp_path):
    """1,000 levels of one room in each room: the old bound doubled at every level and refused
    it as "up to 1e+18 regions"."""
    nodes, work = layout_estimate(parse_strategy(deep_chain(), "deep.json"))
    assert work <= MAX_REGIONS and nodes < 10_000, (nodes, work)
    t = time.perf_counter()
    layout = gg.generate_layout(deep_chain(), seed=0)
    assert 4_000 <= len(layout) <= nodes
    assert time.perf_counter() - t < 60


@fault("huge input", "wrong")
@pytest.mark.parametrize("seed", range(8))
def test_the_estimate_bounds_random_deep_strategies(seed):
    """Random chains of 8 levels over three region types, each level's rule feeding types the
    next ones expand (and some never made): the bound holds at several seeds."""
    rng = np.random.default_rng(100 + seed)
    types = ["a", "b", "c"]

    def children(slots):
        return {
            s: (
                str(rng.choice(types))
                if rng.random() < 0.6
                else {"random": sorted(set(rng.choice(types, 2).tolist()))}
            )
            for s in slots
        }

    def rule():
        kind = rng.choice(["grid", "random_rooms", "drunkard_walk", "assembly_line"])
        if kind == "grid":
            slots = ["cell", "empty"] if rng.random() < 0.7 else ["cell"]
            return {
                "generator": "grid",
                "args": {"cell": rng.uniform(0.5, 4, 2).round(2).tolist()},
                "children": children(slots),
            }
        if kind == "random_rooms":
            return {
                "generator": "random_rooms",
                "args": {
                    "count": [1, int(rng.integers(1, 4))],
                    "width": [0.5, 3.0],
                    "height": [0.5, 3.0],
                },
                "children": children(["room"]),
            }
        if kind == "drunkard_walk":
            return {
                "generator": "drunkard_walk",
                "args": {"steps": int(rng.integers(1, 60)), "block": 0.7},
                "children": children(["room"]),
            }
        return {
            "generator": "assembly_line",
            "args": {"paths": [0, 2], "line_width": 0.6, "path_width": 0.5},
            "children": children(["line", "rest"] if rng.random() < 0.7 else ["line", "path"]),
        }

    levels = [{"hall": rule()}]
    for _ in range(7):
        levels.append(
            {t: rule() for t in rng.choice(types, int(rng.integers(1, 3)), replace=False).tolist()}
        )
    s = {
        "name": "chain",
        "root": {
            "width": float(rng.uniform(6, 20)),
            "height": float(rng.uniform(6, 20)),
            "type": "hall",
        },
        "region_types": {"hall": {}, "a": {}, "b": {}, "c": {}},
        "levels": levels,
    }
    strategy = parse_strategy(s, "chain.json")
    nodes, work = layout_estimate(strategy)
    if nodes > 100_000:  # too large to make here: the bound is what the test checks, not the limit
        pytest.skip(f"estimate {nodes:,}")
    made = max(len(gg.generate_layout(strategy, seed=k, max_regions=10**9)) for k in range(3))
    assert made <= nodes <= work, (made, nodes, work)


def _storage(edit) -> dict:
    s = json.loads((data_dir("layouts") / "storage_area.json").read_text())
    edit(s)
    return s


NON_FINITE = {
    "root width Infinity": (
        lambda s: s["root"].__setitem__("width", float("inf")),
        "$.root.width: inf",
    ),
    "root x -Infinity": (lambda s: s["root"].__setitem__("x", float("-inf")), "$.root.x: -inf"),
    "generator arg NaN": (
        lambda s: s["levels"][1]["box_room"]["args"].__setitem__("spacing", float("nan")),
        "$.levels[1].box_room.args.spacing: nan",
    ),
    "scene option Infinity": (
        lambda s: s["scene"]["jitter"].__setitem__("position_m", float("inf")),
        "$.scene.jitter.position_m: inf",
    ),
    "fill range NaN": (
        lambda s: s["region_types"]["pallet"]["fill"].__setitem__("stack_m", [0.15, float("nan")]),
        "$.region_types.pallet.fill.stack_m[1]: nan",
    ),
}


@fault("bad file", "traceback")
@pytest.mark.parametrize("command", ["layout", "dataset"])
@pytest.mark.parametrize("name", list(NON_FINITE))
def test_a_number_that_is_not_finite_is_refused_at_parsing(name, command, tmp_path):
    edit, needle = NON_FINITE[name]
    p = tmp_path / "s.json"
    p.write_text(json.dumps(_storage(edit)))  # json writes Infinity / NaN as JavaScript does
    run = cli(command, p, "--out", tmp_path / "o", timeout=60)
    refused(run, f"s.json: {needle} is not a finite number")
    assert not (tmp_path / "o").exists()


@fault("bad API call", "traceback")
def test_the_api_refuses_a_number_that_is_not_finite():
    with pytest.raises(ConfigError, match=r"\$\.root\.width: inf is not a finite number"):
        gg.generate_layout(_storage(NON_FINITE["root width Infinity"][0]), seed=0)
