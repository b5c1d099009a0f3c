"""Regions, region types and the layout tree (DESIGN.md ``Layout``)."""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, did_you_mean
from ..outputs import atomic_write_text, check_replaceable
from ..resources import read_json

LAYOUT_FORMAT = "genie-gl layout 1"


def _is_layout_json(path: Path) -> bool:
    """True when ``path`` is a layout JSON genie-gl wrote (its ``format`` field)."""
    data = json.loads(path.read_text())
    return isinstance(data, dict) and str(data.get("format", "")).startswith("genie-gl layout")


ORIENTATIONS = ("up", "right", "down", "left")
# unit vector each orientation points to (world x, y): up = +y, right = +x
DIRECTION = {"up": (0.0, 1.0), "right": (1.0, 0.0), "down": (0.0, -1.0), "left": (-1.0, 0.0)}


@dataclass(frozen=True)
class RegionType:
    """A kind of region a strategy declares.

    Attributes
    ----------
    name : str
    final : bool, a final region is never divided further.
    color : (r, g, b) uint8, its colour in pictures.
    semantic : int or None, class id (DESIGN.md label map) of what the scene stage puts there.
    asset_group : str or None, the asset group the scene stage draws from (None: empty floor).
    fill : dict or None, how the scene stage furnishes a region of this type (validated
        :class:`~.strategy.FillSpec` as a plain dict: mode, spacing_m, count, stack_m, load);
        None: one asset.
    """

    name: str
    final: bool = False
    color: tuple[int, int, int] = (200, 200, 200)
    semantic: int | None = None
    asset_group: str | None = None
    fill: dict | None = field(default=None, hash=False)  # a dict: kept out of the hash


@dataclass(frozen=True)
class Region:
    """A rectangle in the floor plane: min corner (x, y), size (w, h) in metres."""

    x: float
    y: float
    w: float
    h: float
    type: str
    orientation: str = "up"

    @property
    def area(self) -> float:
        return self.w * self.h

    @property
    def centre(self) -> tuple[float, float]:
        return (self.x + self.w / 2, self.y + self.h / 2)

    def contains(self, other: "Region", tol: float = 1e-9) -> bool:
        return (
            other.x >= self.x - tol
            and other.y >= self.y - tol
            and other.x + other.w <= self.x + self.w + tol
            and other.y + other.h <= self.y + self.h + tol
        )

    def overlaps(self, other: "Region", tol: float = 1e-9) -> bool:
        return (
            min(self.x + self.w, other.x + other.w) - max(self.x, other.x) > tol
            and min(self.y + self.h, other.y + other.h) - max(self.y, other.y) > tol
        )


@dataclass
class Node:
    """A node of the layout tree: its region, depth (root = 0), parent index and children."""

    region: Region
    depth: int
    parent: int
    children: list[int] = field(default_factory=list)


@dataclass(frozen=True, eq=False)
class LabelRaster:
    """Leaves rasterised on a regular grid.

    labels : (H, W) int32, index into ``type_names`` (-1 = no leaf); row r, column c covers
        x ∈ [x0 + c·res, x0 + (c+1)·res), y ∈ [y0 + r·res, y0 + (r+1)·res).
    """

    labels: np.ndarray
    type_names: list[str]
    origin_xy: tuple[float, float]
    resolution_m: float


@dataclass(frozen=True, eq=False)
class Tree:
    """The layout tree as arrays, one entry per node in breadth-first order (node 0 is the
    root; a parent comes before its children; the engine keeps siblings consecutive).

    x, y, w, h : float64; type : int32 index into ``type_names``; orient : int8 index into
    ORIENTATIONS; depth : int32 (root 0); parent : int32 (root -1).
    """

    x: np.ndarray
    y: np.ndarray
    w: np.ndarray
    h: np.ndarray
    type: np.ndarray
    orient: np.ndarray
    depth: np.ndarray
    parent: np.ndarray
    type_names: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.x)

    @staticmethod
    def from_nodes(nodes: list[Node], type_names: tuple[str, ...]) -> "Tree":
        index = {t: i for i, t in enumerate(type_names)}
        f = lambda k, dt: np.array([getattr(n.region, k) for n in nodes], dt)  # noqa: E731
        return Tree(
            f("x", np.float64),
            f("y", np.float64),
            f("w", np.float64),
            f("h", np.float64),
            np.array([index[n.region.type] for n in nodes], np.int32),
            np.array([ORIENTATIONS.index(n.region.orientation) for n in nodes], np.int8),
            np.array([n.depth for n in nodes], np.int32),
            np.array([n.parent for n in nodes], np.int32),
            type_names,
        )

    def n_children(self) -> np.ndarray:
        return (
            np.bincount(self.parent[1:], minlength=len(self))
            if len(self) > 1
            else np.zeros(len(self), np.int64)
        )

    def region(self, i: int) -> Region:
        return Region(
            float(self.x[i]),
            float(self.y[i]),
            float(self.w[i]),
            float(self.h[i]),
            self.type_names[self.type[i]],
            ORIENTATIONS[self.orient[i]],
        )

    def to_nodes(self) -> list[Node]:
        nodes = [
            Node(self.region(i), int(self.depth[i]), int(self.parent[i])) for i in range(len(self))
        ]
        for i, p in enumerate(self.parent.tolist()):
            if p >= 0:
                nodes[p].children.append(i)
        return nodes


class Layout:
    """A tree of regions; leaves are what the scene stage fills.

    The tree is held as arrays (:class:`Tree`): the engine builds and extends it a level at a
    time without a Python object per node; ``nodes``, ``leaves()`` and ``regions()`` give
    object views on demand.

    Parameters
    ----------
    nodes : list of Node (node 0 is the root, parents before children), or a Tree.
    region_types : dict name -> RegionType.
    meta : dict (strategy name, seed, reports from generators).
    """

    def __init__(
        self,
        nodes: "list[Node] | Tree",
        region_types: dict[str, RegionType],
        meta: dict | None = None,
    ):
        if len(nodes) == 0:
            raise ConfigError("a layout needs a root region")
        self.region_types = dict(region_types)
        self.meta = dict(meta or {})
        if isinstance(nodes, Tree):
            self.tree = nodes
        else:
            names = tuple(self.region_types) + tuple(
                sorted({n.region.type for n in nodes} - set(self.region_types))
            )
            self.tree = Tree.from_nodes(nodes, names)
        self._nodes: list[Node] | None = None

    # -- views ----------------------------------------------------------------------------
    @property
    def nodes(self) -> list[Node]:
        """The tree as Node objects (built on first use)."""
        if self._nodes is None:
            self._nodes = self.tree.to_nodes()
        return self._nodes

    @property
    def root(self) -> Region:
        return self.tree.region(0)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        t = self.tree
        return (float(t.x[0]), float(t.y[0]), float(t.w[0]), float(t.h[0]))

    def leaf_indices(self) -> np.ndarray:
        """Indices of the nodes without children, in breadth-first order."""
        return np.flatnonzero(self.tree.n_children() == 0)

    def leaves(self) -> list[Region]:
        """Regions of the nodes without children, in breadth-first order."""
        return [self.tree.region(i) for i in self.leaf_indices().tolist()]

    def regions(self) -> list[tuple[Region, int, int]]:
        """Every node as (region, depth, parent index) — the root's parent is -1."""
        t = self.tree
        return [(t.region(i), int(t.depth[i]), int(t.parent[i])) for i in range(len(t))]

    def __len__(self) -> int:
        return len(self.tree)

    @classmethod
    def from_regions(
        cls,
        regions: list[Region],
        region_types: dict[str, RegionType],
        bounds: tuple[float, float, float, float],
        root_type: str = "root",
    ) -> "Layout":
        """A flat layout: a root covering ``bounds`` with ``regions`` as its children."""
        types = dict(region_types)
        types.setdefault(root_type, RegionType(root_type))
        nodes = [Node(Region(*bounds, type=root_type), 0, -1)]
        for r in regions:
            nodes[0].children.append(len(nodes))
            nodes.append(Node(r, 1, 0))
        return cls(nodes, types)

    # -- rasters ---------------------------------------------------------------------------
    def label_raster(self, resolution_m: float) -> LabelRaster:
        """Rasterise the leaves (later leaves over earlier ones where they touch)."""
        if resolution_m <= 0:
            raise ConfigError(f"label raster: resolution_m must be > 0, got {resolution_m}")
        x0, y0, w, h = self.bounds
        W, H = (
            max(1, int(np.ceil(w / resolution_m - 1e-9))),
            max(1, int(np.ceil(h / resolution_m - 1e-9))),
        )
        names = sorted(self.region_types)
        index = {n: i for i, n in enumerate(names)}
        labels = np.full((H, W), -1, np.int32)
        for r in self.leaves():
            # a cell belongs to a region when its centre lies inside it
            c0 = int(np.ceil((r.x - x0) / resolution_m - 0.5 - 1e-9))
            c1 = int(np.ceil((r.x + r.w - x0) / resolution_m - 0.5 - 1e-9))
            r0 = int(np.ceil((r.y - y0) / resolution_m - 0.5 - 1e-9))
            r1 = int(np.ceil((r.y + r.h - y0) / resolution_m - 0.5 - 1e-9))
            labels[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = index[r.type]
        return LabelRaster(labels, names, (x0, y0), float(resolution_m))

    # -- JSON -----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "format": LAYOUT_FORMAT,
            "meta": self.meta,
            "region_types": {
                k: {**asdict(v), "color": list(v.color)}
                for k, v in sorted(self.region_types.items())
            },
            "nodes": [
                {
                    "region": asdict(n.region),
                    "depth": n.depth,
                    "parent": n.parent,
                    "children": n.children,
                }
                for n in self.nodes
            ],
        }

    def to_json(self, path: str | os.PathLike) -> None:
        """Write the layout as JSON (temporary file, then rename). An existing file is replaced
        only when it is a genie-gl layout; anything else is refused (:mod:`genie_gl.outputs`)."""
        path = check_replaceable(path, _is_layout_json, what="layout JSON")
        atomic_write_text(path, json.dumps(self.to_dict(), indent=1, sort_keys=True))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> "Layout":
        """A layout from its JSON data (:meth:`to_dict`), every field checked: unknown keys
        (with the nearest known one), undeclared region types, parents that do not come
        before their children, children lists that disagree with the parents, sizes that
        are not finite and positive are refused in one line naming the JSON path."""
        types, nodes, meta = _parse_layout(data, source)
        return cls(nodes, types, meta)

    @classmethod
    def from_json(cls, path: str | os.PathLike) -> "Layout":
        return cls.from_dict(read_json(path, "layout JSON"), str(path))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Layout) and self.to_dict() == other.to_dict()


_LAYOUT_KEYS = ("format", "meta", "region_types", "nodes")
_NODE_KEYS = ("region", "depth", "parent", "children")
_REGION_KEYS = ("x", "y", "w", "h", "type", "orientation")
_TYPE_KEYS = ("name", "final", "color", "semantic", "asset_group", "fill")


def _known(d: Any, keys: tuple[str, ...], where: str, what: str) -> dict:
    if not isinstance(d, dict):
        raise ConfigError(f"{where}: expected {what} (a JSON object), got {type(d).__name__}")
    for k in d:
        if k not in keys:
            raise ConfigError(
                f"{where}.{k}: not a field of {what}{did_you_mean(k, keys)} (fields: "
                f"{', '.join(keys)})"
            )
    return d


def _parse_layout(data: Any, source: str) -> tuple[dict[str, RegionType], list[Node], dict]:
    """(region types, nodes, meta) of layout JSON data, checked (see :meth:`Layout.from_dict`)."""
    _known(data, _LAYOUT_KEYS, f"{source}: $", "a genie-gl layout")
    if not str(data.get("format", LAYOUT_FORMAT)).startswith("genie-gl layout"):
        raise ConfigError(f"{source}: $.format: {data['format']!r}, expected {LAYOUT_FORMAT!r}")
    for k in ("region_types", "nodes"):
        if k not in data:
            raise ConfigError(
                f"{source}: $.{k}: missing; not a genie-gl layout JSON (genie layout writes one)"
            )
    types: dict[str, RegionType] = {}
    if not isinstance(data["region_types"], dict) or not data["region_types"]:
        raise ConfigError(f"{source}: $.region_types: expected a JSON object of region types")
    for name, v in data["region_types"].items():
        where = f"{source}: $.region_types.{name}"
        v = _known(v, _TYPE_KEYS, where, "a region type")
        color = v.get("color", (200, 200, 200))
        if not (
            isinstance(color, list)
            and len(color) == 3
            and all(isinstance(c, int) and 0 <= c <= 255 for c in color)
        ):
            raise ConfigError(f"{where}.color: expected [r, g, b] (0-255), got {color!r:.40}")
        try:
            types[name] = RegionType(**{**v, "name": name, "color": tuple(color)})
        except TypeError as exc:
            raise ConfigError(f"{where}: {exc}") from None
    raw = data["nodes"]
    if not isinstance(raw, list) or not raw:
        raise ConfigError(
            f"{source}: $.nodes: expected a non-empty list of nodes, got {type(raw).__name__}"
        )
    nodes: list[Node] = []
    kids: list[list[int]] = [[] for _ in raw]
    for i, n in enumerate(raw):
        where = f"{source}: $.nodes[{i}]"
        n = _known(n, _NODE_KEYS, where, "a layout node")
        r = _known(n.get("region"), _REGION_KEYS, f"{where}.region", "a region")
        for k in ("x", "y", "w", "h"):
            v = r.get(k)
            if (
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not np.isfinite(v)
                or (k in ("w", "h") and v <= 0)
                or abs(v) > 1e9
            ):
                raise ConfigError(
                    f"{where}.region.{k}: expected a finite number{' > 0' if k in 'wh' else ''} "
                    f"(metres), got {v!r:.40}"
                )
        t = r.get("type")
        if t not in types:
            raise ConfigError(
                f"{where}.region.type: {t!r} is not declared in $.region_types"
                f"{did_you_mean(str(t), types)}"
            )
        o = r.get("orientation", "up")
        if o not in ORIENTATIONS:
            raise ConfigError(
                f"{where}.region.orientation: {o!r}, expected one of {', '.join(ORIENTATIONS)}"
                f"{did_you_mean(str(o), ORIENTATIONS)}"
            )
        p = n.get("parent")
        if (
            isinstance(p, bool)
            or not isinstance(p, int)
            or (i == 0 and p != -1)
            or (i > 0 and not 0 <= p < i)
        ):
            raise ConfigError(
                f"{where}.parent: {p!r}; expected "
                + (
                    "-1 (node 0 is the root)"
                    if i == 0
                    else f"the index of an earlier node (0..{i - 1}): parents come before their "
                    "children"
                )
            )
        depth = 0 if i == 0 else nodes[p].depth + 1
        if n.get("depth", depth) != depth:
            raise ConfigError(
                f"{where}.depth: {n['depth']!r}, expected {depth} (its parent's depth + 1)"
            )
        if p >= 0:
            kids[p].append(i)
        nodes.append(
            Node(Region(float(r["x"]), float(r["y"]), float(r["w"]), float(r["h"]), t, o), depth, p)
        )
    for i, n in enumerate(raw):
        if "children" in n and n["children"] != kids[i]:
            raise ConfigError(
                f"{source}: $.nodes[{i}].children: {n['children']!r:.60} disagrees with the nodes "
                "whose "
                f"parent is {i} ({kids[i]!r:.60})"
            )
        nodes[i].children = kids[i]
    meta = data.get("meta", {})
    if not isinstance(meta, dict):
        raise ConfigError(f"{source}: $.meta: expected a JSON object, got {type(meta).__name__}")
    return types, nodes, meta
