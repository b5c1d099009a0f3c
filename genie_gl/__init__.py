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
    gg.view("out/")                                 # out/view.rrd: a Rerun recording of it

    rig   = gg.load_rig("d435_quad")                # sensors with fixed extrinsics on a body
    path  = gg.make_trajectory(layout, scene, "aisles", seed=0)   # on the free floor
    shots = gg.record(scene, rig, path, seed=0)    # (Shot, Frame) in time order

    head  = gg.load_scanner("velodyne_vlp16")      # or gg.load_scanner_rig("navvis_wearable")
    scans = gg.scan(scene, head, path, seed=0)     # one Scan per revolution, each firing from its
    pose
    gg.export_scans(scans, "out/", format="kitti") # kitti, rosbag, las, e57, pcd, ply

Names are imported lazily, so ``import genie_gl`` stays cheap and starts no GL.

``gg.render``, ``gg.capture`` and ``gg.export`` are plain functions although stage packages
of the same names exist (:mod:`genie_gl.render`, :mod:`genie_gl.capture`,
:mod:`genie_gl.export`): Python binds a package's submodules as attributes of the package
when they are imported, so this package keeps its functions in front of them. Import from a
stage with ``from genie_gl.render import Renderer``.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any

__version__ = "0.2.1"

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
    "read_usd": "genie_gl.scene.usd",
    "write_usd": "genie_gl.scene.usd",
    # sensors
    "Camera": "genie_gl.camera",
    "Sensor": "genie_gl.sensors.camera",
    "Stereo": "genie_gl.sensors.camera",
    "load_sensor": "genie_gl.effects.profile",
    "place_sensors": "genie_gl.placement.genetic",
    # cameras that move: rigs, trajectories, recordings, mobile-scan maps
    "Rig": "genie_gl.motion.rig",
    "load_rig": "genie_gl.motion.rig",
    "Trajectory": "genie_gl.motion.trajectory",
    "make_trajectory": "genie_gl.motion.paths",
    "RegistrationError": "genie_gl.motion.registration",
    "record": "genie_gl.capture.trajectory",
    "fuse": "genie_gl.cloud.fusion",
    # accuracy settings (a profile's accuracy: block, genie dataset --accuracy)
    "AccuracySettings": "genie_gl.sensors.accuracy",
    "load_accuracy": "genie_gl.sensors.accuracy",
    # render and capture
    "Frame": "genie_gl.frame",
    "Renderer": "genie_gl.render",
    "Rays": "genie_gl.render.rays",
    "RayHits": "genie_gl.render.rays",
    "cast_rays": "genie_gl.render.rays",
    "cast_bundle": "genie_gl.render.rays",
    "render": "genie_gl.capture",
    "capture": "genie_gl.capture",
    "plan": "genie_gl.capture",
    "Plan": "genie_gl.capture",
    # clouds and exports
    "PointCloud": "genie_gl.cloud",
    "to_cloud": "genie_gl.cloud",
    "export": "genie_gl.export",
    # scanners (LiDAR): profiles, rigs of heads, scans along a trajectory, their clouds and files
    "Scanner": "genie_gl.sensors.scanner",
    "load_scanner": "genie_gl.effects.scanner_profile",
    "ScannerRig": "genie_gl.motion.scanner_rig",
    "load_scanner_rig": "genie_gl.motion.scanner_rig",
    "scan": "genie_gl.capture.scanning",
    "Scan": "genie_gl.capture.scan_record",
    "scan_cloud": "genie_gl.cloud.scan_cloud",
    "scans_cloud": "genie_gl.cloud.scan_cloud",
    "export_scans": "genie_gl.export.lidar_output",
    # the sensor's report card (published measurements of the real device beside ours)
    "report_card": "genie_gl.card.report",
    # look at what was made: a Rerun recording of exported files, and its web viewer
    "view": "genie_gl.view",
}

__all__ = sorted(_EXPORTS) + ["__version__"]


# public functions named as a stage package is (the package stays in sys.modules)
_FUNCTIONS = ("render", "capture", "export", "view")


class _Package(types.ModuleType):
    """``genie_gl`` itself: importing a stage package never hides the function of its name."""

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _FUNCTIONS and isinstance(value, types.ModuleType):
            return  # the import system binding the package genie_gl.<name>: keep the function
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'genie_gl' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
