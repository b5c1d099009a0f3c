"""Procedural layout generation: region layout trees from a JSON strategy (paper §3.1–3.2)."""

from .engine import generate_layout, merge
from .generators import GENERATORS, Child, Generator, register
from .model import ORIENTATIONS, LabelRaster, Layout, Node, Region, RegionType
from .picture import layout_image, save_layout_png
from .strategy import Strategy, json_schema, load_strategy, parse_strategy

__all__ = [
    "GENERATORS",
    "ORIENTATIONS",
    "Child",
    "Generator",
    "LabelRaster",
    "Layout",
    "Node",
    "Region",
    "RegionType",
    "Strategy",
    "generate_layout",
    "json_schema",
    "layout_image",
    "load_strategy",
    "merge",
    "parse_strategy",
    "register",
    "save_layout_png",
]
