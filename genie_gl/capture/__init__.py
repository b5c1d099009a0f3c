"""Capture: the composer of the stages below it.

The renderer (:mod:`genie_gl.render`) draws pinhole views; here they meet the sensor's lens
(:mod:`.lens`), the plan of what to draw and which effects to run (:mod:`.planner`), the
accuracy settings (:mod:`.settings`, :mod:`.supersample`) and the sensor's effects
(:func:`~genie_gl.effects.simulate.simulate`): :func:`render` makes one frame through the
lens, :func:`capture` many, with their effects, on all cores. Cameras that move:
:mod:`.trajectory` records a rig along a trajectory (its shots in time order, planned per
sensor), :mod:`.mobile_map` gives those frames a mobile scanner's registration error.
"""

from .costs import add_totals, effect_totals, frame_cost, frame_costs
from .frames import capture, render
from .lens import silhouettes, through_lens
from .planner import EffectPlan, FramePlan, Plan, far_plane, plan
from .serial import pose_rng
from .settings import apply_to_sensor, settings_for
from .supersample import supersampled

__all__ = [
    "EffectPlan",
    "FramePlan",
    "Plan",
    "add_totals",
    "apply_to_sensor",
    "capture",
    "effect_totals",
    "far_plane",
    "frame_cost",
    "frame_costs",
    "plan",
    "pose_rng",
    "render",
    "settings_for",
    "silhouettes",
    "supersampled",
    "through_lens",
]
