"""Scenes: the industrial asset library, scene building and USD in and out (paper §3.3)."""
from .build import GROUPS, build_scene
from .model import Instance, Mesh, Scene

__all__ = ["GROUPS", "Instance", "Mesh", "Scene", "build_scene"]
