"""genie-gl: labelled synthetic 3D point clouds of industrial scenes, rendered headless.

The public API, one name per pipeline stage (DESIGN.md)::

    import genie_gl as gg
    layout = gg.generate_layout("layouts/assembly_line.json", seed=0)
    scene  = gg.build_scene(layout, seed=0)
    sensor = gg.load_sensor("sensors/realsense_d435.yaml")
    poses  = gg.place_sensors(layout, sensor, n=40, seed=0)
    plan   = gg.plan(scene, sensor, poses)      # what will run where, and why
    frames = gg.capture(scene, sensor, poses, seed=0)
    cloud  = gg.to_cloud(frames)
    gg.export(cloud, "out/", format="semantickitti")

    rig   = gg.load_rig("d435_quad")                # sensors with fixed extrinsics on a body
    path  = gg.make_trajectory(layout, scene, "aisles", seed=0)   # on the free floor
    shots = gg.record(scene, rig, path, seed=0)    # (Shot, Frame) in time order

Names are imported lazily, so ``import genie_gl`` stays cheap and starts no GL.
"""
from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

# public name -> module that defines it
_EXPORTS: dict[str, str] = {
    # errors
    "GenieError": "genie_gl.errors",
    "ConfigError": "genie_gl.errors",
    "BackendUnavailableError": "genie_gl.errors",
    "ShaderError": "genie_gl.errors",
    "RenderError": "genie_gl.errors",
    # layout
    "generate_layout": "genie_gl.layout",
    "load_strategy": "genie_gl.layout",
    "Layout": "genie_gl.layout",
    "Region": "genie_gl.layout",
    # scene
    "Scene": "genie_gl.scene.model",
    "Mesh": "genie_gl.scene.model",
    "Instance": "genie_gl.scene.model",
    "Material": "genie_gl.scene.model",
    "build_scene": "genie_gl.scene",
    "register_asset": "genie_gl.scene",
    # sensors
    "Camera": "genie_gl.camera",
    "Sensor": "genie_gl.sensors.camera",
    "load_sensor": "genie_gl.sensors",
    "place_sensors": "genie_gl.sensors",
    # cameras that move: rigs, trajectories, recordings, mobile-scan maps
    "Rig": "genie_gl.sensors.rig",
    "load_rig": "genie_gl.sensors.rig",
    "Trajectory": "genie_gl.sensors.trajectory",
    "make_trajectory": "genie_gl.sensors.paths",
    "RegistrationError": "genie_gl.sensors.registration",
    "record": "genie_gl.capture.trajectory",
    "fuse": "genie_gl.cloud.fusion",
    # render
    "Frame": "genie_gl.frame",
    "Renderer": "genie_gl.render",
    "render": "genie_gl.render",
    "capture": "genie_gl.render",
    # accuracy settings (the accuracy: block)
    "AccuracySettings": "genie_gl.accuracy",
    "load_accuracy": "genie_gl.accuracy",
    # planning
    "plan": "genie_gl.plan",
    "Plan": "genie_gl.plan",
    # clouds and exports
    "PointCloud": "genie_gl.cloud",
    "to_cloud": "genie_gl.cloud",
    "export": "genie_gl.export",
}

__all__ = sorted(_EXPORTS) + ["__version__"]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'genie_gl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
