"""The base of every sensor effect, and what the planner and ``simulate`` ask of one.

This module knows no effect; each topic module (noise, edges, shadow, surface, tof, ...)
subclasses :class:`Effect` from here, and :mod:`.effects` is the one place that lists them
all (a dict, name -> class): the list imports the modules, the modules import only this base.

An effect answers three questions:

* :meth:`Effect.plan` — before anything is rendered, from what the planner knows of a view
  (:class:`View`: the instances in range and view, their depth span, materials and
  convexity): does it run, and why? ``None`` leaves the decision to the frame.
* :meth:`Effect.check` — after the render, from the frame itself: a reason to skip, or None.
  A skip must give exactly the frame that running would (same bytes): a check only says
  "skip" where the effect provably changes nothing.
* :meth:`Effect.skip` — what a skipped effect still does so the RNG stream stays that of a
  run (draws of fixed size, e.g. calibration_error's four normals); by default nothing, which
  is right for effects whose draws scale with the pixels they touch (none when none).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ..frame import Frame
from . import kernels


@dataclass(frozen=True)
class Decision:
    """Whether an effect runs on a frame, why (one sentence), and its estimated cost in ms."""

    run: bool
    reason: str
    cost_ms: float = 0.0


@dataclass(frozen=True, eq=False)
class View:
    """What the planner knows of one camera view before it is rendered.

    Attributes
    ----------
    sensor : the Sensor; pose : (4, 4) world_from_camera.
    ids : (N,) uint32, instances that can be seen (in the frustum and in range).
    z_min, z_max : depth span (m) of those instances' bounding spheres (clipped to the
        frustum's near plane); 0, 0 when ``ids`` is empty.
    r_max : the farthest range (distance from the camera centre) of those spheres.
    convex : (N,) bool, each instance's mesh is convex (computed only when N == 1 and an
        effect asks; False = not known to be convex).
    reflective, transparent : (N,) bool, from the instances' materials (metallic >= 0.5 or
        roughness <= 0.3; opacity < 0.5).
    albedo : (N,) float64, mean diffuse albedo of each instance's material.
    """

    sensor: Any
    pose: np.ndarray
    ids: np.ndarray
    z_min: float
    z_max: float
    r_max: float = 0.0
    convex: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    reflective: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    transparent: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    albedo: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def empty(self) -> bool:
        return len(self.ids) == 0


class Effect:
    """Base class: ``apply(frame, *, rng, **needs)`` returns the frame the sensor would report.

    Class flags ask ``simulate`` for more than the ideal frame: ``needs_normals`` (rendered
    normals), ``needs_render`` (``render_depth=``, a depth render from any pose),
    ``needs_materials`` (``materials=``, the scene's
    :class:`~genie_gl.scene.materials.MaterialTable`); and the planner: ``needs_convexity``
    (whether each instance's mesh is convex, in :class:`View`, when one object is in view).
    ``cost_ms_per_mpx`` is the planner's estimate of the effect's time per million pixels on
    this machine class (llvmpipe host). ``accuracy_knobs`` maps the fields of
    :class:`~genie_gl.sensors.accuracy.AccuracySettings` that set one of the effect's
    parameters to that parameter (the capture applies them; ``genie bench accuracy`` turns
    them); :meth:`knob_unused` says when one changes nothing. ``systematic_error``: the effect
    moves the mean depth of a flat surface (a bias the report card can judge), not only its spread.
    """

    name: ClassVar[str] = ""
    draws: ClassVar[bool] = False
    needs_normals: ClassVar[bool] = False
    needs_render: ClassVar[bool] = False
    needs_materials: ClassVar[bool] = False
    needs_convexity: ClassVar[bool] = False
    cost_ms_per_mpx: ClassVar[float] = 10.0
    systematic_error: ClassVar[bool] = False
    accuracy_knobs: ClassVar[Mapping[str, str]] = {}

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        raise NotImplementedError

    def plan(self, view: View) -> Decision | None:
        """Before rendering: a decision, or None to decide on the frame (:meth:`check`)."""
        if view.empty:
            return Decision(False, "nothing in range or view")
        return None

    def check(self, frame: Frame, **needs: Any) -> str | None:
        """After rendering: a reason to skip (the effect would change nothing), or None."""
        if not (frame.depth > 0).any():
            return "no return in the frame"
        return None

    def skip(self, frame: Frame, rng: np.random.Generator) -> None:
        """Consume what a run would draw from ``rng`` when that does not depend on the frame."""

    def cost_per_mpx(self, sensor: Any) -> float:
        """The planner's estimate (ms per million pixels) for ``sensor``: ``cost_ms_per_mpx``
        unless the effect's method depends on the sensor."""
        return float(self.cost_ms_per_mpx)

    def knob_unused(self, knob: str, sensor: Any) -> str | None:
        """Why the accuracy knob ``knob`` (a key of ``accuracy_knobs``) changes nothing on
        ``sensor`` (one sentence), or None when it acts."""
        return None

    def range_m(self) -> tuple[float, float] | None:
        """The (min, max) range in metres of the returns this effect lets through, when it
        bounds them to a finite interval (the placement mounts cameras for it); else None."""
        return None

    def reach_m(self, sensor: Any) -> float | None:
        """The farthest depth (m) whose surfaces can still change this effect's output, or
        None (no bound of its own). The planner's far plane is the largest reach."""
        return None


def record(frame: Frame, name: str, **values: Any) -> Frame:
    """A copy of ``frame`` whose ``meta[name]`` holds ``values`` (what an effect drew or did)."""
    return frame.replace(meta={**(frame.meta or {}), name: values})


def drop(frame: Frame, mask: np.ndarray, depth: np.ndarray | None = None) -> Frame:
    """``frame`` with no return where ``mask``: depth 0, ids 0 (and normal 0); ``depth``, when
    given, replaces the frame's depth first."""
    d = (frame.depth if depth is None else depth).copy()
    d[mask] = 0
    inst, sem = frame.instance.copy(), frame.semantic.copy()
    inst[mask], sem[mask] = 0, 0
    normal = frame.normal
    if normal is not None and mask.any():
        normal = normal.copy()
        normal[mask] = 0
    return frame.replace(
        depth=d.astype(np.float32, copy=False), instance=inst, semantic=sem, normal=normal
    )


def drop_compiled(frame: Frame, mask: np.ndarray) -> Frame:
    """:func:`drop` in one compiled pass over the frame (the same bytes), for effects that
    drop on most frames (stereo shadow, specular loss)."""
    depth, inst, sem = kernels.drop_where(frame.depth, frame.instance, frame.semantic, mask)
    normal = frame.normal
    if normal is not None:
        normal = normal.copy()
        normal[mask] = 0
    return frame.replace(depth=depth, instance=inst, semantic=sem, normal=normal)
