"""Scenes: the industrial asset library, scene building and USD in and out (paper §3.3)."""

from .assets.catalogue import ASSETS, Catalogue, load_asset, register_asset
from .build import GROUPS, build_scene
from .model import Instance, Mesh, Scene

__all__ = [
    "ASSETS",
    "GROUPS",
    "Catalogue",
    "Instance",
    "Mesh",
    "Scene",
    "build_scene",
    "load_asset",
    "register_asset",
]
