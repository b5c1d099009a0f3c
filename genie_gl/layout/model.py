"""Regions, region types and the layout tree (DESIGN.md ``Layout``)."""
from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError

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
    """

    name: str
    final: bool = False
    color: tuple[int, int, int] = (200, 200, 200)
    semantic: int | None = None
    asset_group: str | None = None


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
        return (other.x >= self.x - tol and other.y >= self.y - tol
                and other.x + other.w <= self.x + self.w + tol and other.y + other.h <= self.y + self.h + tol)

    def overlaps(self, other: "Region", tol: float = 1e-9) -> bool:
        return (min(self.x + self.w, other.x + other.w) - max(self.x, other.x) > tol
                and min(self.y + self.h, other.y + other.h) - max(self.y, other.y) > tol)


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


class Layout:
    """A tree of regions; leaves are what the scene stage fills.

    Parameters
    ----------
    nodes : list of Node, node 0 is the root.
    region_types : dict name -> RegionType.
    meta : dict (strategy name, seed, reports from generators).
    """

    def __init__(self, nodes: list[Node], region_types: dict[str, RegionType], meta: dict | None = None):
        if not nodes:
            raise ConfigError("a layout needs a root region")
        self.nodes = nodes
        self.region_types = dict(region_types)
        self.meta = dict(meta or {})

    # -- views ----------------------------------------------------------------------------
    @property
    def root(self) -> Region:
        return self.nodes[0].region

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        r = self.root
        return (r.x, r.y, r.w, r.h)

    def leaves(self) -> list[Region]:
        """Regions of the nodes without children, in breadth-first order."""
        return [n.region for n in self.nodes if not n.children]

    def regions(self) -> list[tuple[Region, int, int]]:
        """Every node as (region, depth, parent index) — the root's parent is -1."""
        return [(n.region, n.depth, n.parent) for n in self.nodes]

    def __len__(self) -> int:
        return len(self.nodes)

    @classmethod
    def from_regions(cls, regions: list[Region], region_types: dict[str, RegionType],
                     bounds: tuple[float, float, float, float], root_type: str = "root") -> "Layout":
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
        W, H = max(1, int(np.ceil(w / resolution_m - 1e-9))), max(1, int(np.ceil(h / resolution_m - 1e-9)))
        names = sorted(self.region_types)
        index = {n: i for i, n in enumerate(names)}
        labels = np.full((H, W), -1, np.int32)
        for r in self.leaves():
            # a cell belongs to a region when its centre lies inside it
            c0 = int(np.ceil((r.x - x0) / resolution_m - 0.5 - 1e-9))
            c1 = int(np.ceil((r.x + r.w - x0) / resolution_m - 0.5 - 1e-9))
            r0 = int(np.ceil((r.y - y0) / resolution_m - 0.5 - 1e-9))
            r1 = int(np.ceil((r.y + r.h - y0) / resolution_m - 0.5 - 1e-9))
            labels[max(r0, 0):max(r1, 0), max(c0, 0):max(c1, 0)] = index[r.type]
        return LabelRaster(labels, names, (x0, y0), float(resolution_m))

    # -- JSON -----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "format": "genie-gl layout 1",
            "meta": self.meta,
            "region_types": {k: {**asdict(v), "color": list(v.color)} for k, v in sorted(self.region_types.items())},
            "nodes": [{"region": asdict(n.region), "depth": n.depth, "parent": n.parent,
                       "children": n.children} for n in self.nodes],
        }

    def to_json(self, path: str | os.PathLike) -> None:
        """Write the layout as JSON (temporary file, then rename)."""
        path = Path(path)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(json.dumps(self.to_dict(), indent=1, sort_keys=True))
        tmp.replace(path)

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> "Layout":
        try:
            types = {k: RegionType(**{**v, "color": tuple(v["color"])}) for k, v in data["region_types"].items()}
            nodes = [Node(Region(**n["region"]), n["depth"], n["parent"], list(n["children"])) for n in data["nodes"]]
        except (KeyError, TypeError) as exc:
            raise ConfigError(f"{source}: not a genie-gl layout JSON ({exc})") from exc
        return cls(nodes, types, data.get("meta", {}))

    @classmethod
    def from_json(cls, path: str | os.PathLike) -> "Layout":
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read layout JSON ({exc})") from exc
        return cls.from_dict(data, str(path))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Layout) and self.to_dict() == other.to_dict()
