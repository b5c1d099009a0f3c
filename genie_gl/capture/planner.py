"""What will run where, and why: the per-frame plan ``capture`` follows.

``plan(scene, sensor, poses)`` looks at every view before anything is rendered: which
instances can be seen (inside the frustum, nearer than the far plane), how deep they lie,
what they are made of and whether they are convex; then asks each of the sensor's effects
whether the view calls for it (:meth:`~genie_gl.effects.base.Effect.plan`). An effect the
view cannot call for is skipped with its reason; one that depends on what the frame shows is
decided again on the rendered frame (:meth:`~genie_gl.effects.base.Effect.check`), where a
skip is taken only when running would change nothing (same bytes, same RNG stream).

The far plane is the farthest depth any effect can still use (``range``'s max, the wrap reach
of ``ambiguity``) plus a margin; instances wholly beyond it are culled (not drawn: they could
only ever give returns the range drops, and hide nothing nearer). Instances nearer than the
minimum range are *not* culled: they still hide what lies behind them (the near plane, and
what a real sensor reports there, belong to the camera model).

Costs are estimates in milliseconds: the render from the scene's triangles and the image
size, each effect from its ``cost_ms_per_mpx``; a dataset run's predicted time sums them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..validation.arguments import capture_arguments
from ..scene.convexity import is_convex
from ..scene.materials import MaterialTable
from ..scene.model import Mesh, Scene
from ..sensors.camera import Sensor
from ..lens.distortion import lens_views
from ..effects.base import Decision, View

# render cost model (llvmpipe, this class of host): fixed + per megapixel + per million triangles
RENDER_MS_FIXED, RENDER_MS_PER_MPX, RENDER_MS_PER_MTRI = 2.0, 25.0, 60.0
MARGIN_REL, MARGIN_M = 0.05, 0.1  # far plane margin beyond the effects' reach


@dataclass(frozen=True)
class EffectPlan:
    """One effect's decision for one frame. ``run`` None: decided on the rendered frame."""

    name: str
    run: bool | None
    reason: str
    cost_ms: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "run": self.run,
            "reason": self.reason,
            "cost_ms": round(self.cost_ms, 2),
        }


@dataclass(frozen=True, eq=False)
class FramePlan:
    """The plan of one frame: what is drawn, what is culled, each effect's decision."""

    index: int
    effects: list[EffectPlan]
    drawn: np.ndarray  # instance ids to draw (not culled by range)
    culled_range: np.ndarray  # ids wholly beyond the far plane
    culled_frustum: np.ndarray  # ids outside the view (the renderer culls these itself)
    far_m: float
    render_ms: float
    reason: str = ""  # why the frame is empty, when it is

    @property
    def empty(self) -> bool:
        """True when nothing lies in range and in view."""
        return bool(self.reason)

    @property
    def decisions(self) -> list[Decision | None]:
        """Per effect of the sensor, in order: the plan's decision, or None (decide on the
        frame)."""
        return [
            None if e.run is None else Decision(e.run, e.reason, e.cost_ms) for e in self.effects
        ]

    @property
    def cost_ms(self) -> float:
        return self.render_ms + sum(e.cost_ms for e in self.effects if e.run is not False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "frame": self.index,
            "far_m": round(self.far_m, 3),
            "empty": self.empty,
            "reason": self.reason,
            "drawn": len(self.drawn),
            "culled_range": self.culled_range.tolist(),
            "culled_frustum": self.culled_frustum.tolist(),
            "render_ms": round(self.render_ms, 2),
            "cost_ms": round(self.cost_ms, 2),
            "effects": [e.to_dict() for e in self.effects],
        }


@dataclass(frozen=True, eq=False)
class Plan:
    """Per-frame plans of one capture, JSON-able with :meth:`to_dict`."""

    sensor: str
    frames: list[FramePlan]
    materials: MaterialTable = field(repr=False)

    @property
    def predicted_s(self) -> float:
        """Predicted seconds to capture every frame (render and effects)."""
        return sum(f.cost_ms for f in self.frames) / 1e3

    @property
    def empty_frames(self) -> list[int]:
        return [f.index for f in self.frames if f.empty]

    def to_dict(self) -> dict[str, Any]:
        return {
            "sensor": self.sensor,
            "frames": [f.to_dict() for f in self.frames],
            "predicted_s": round(self.predicted_s, 3),
            "empty_frames": self.empty_frames,
        }

    def summary(self) -> str:
        """A table: one row per effect with how many frames run it, skip it, or decide on the
        frame."""
        lines = [
            f"plan for {self.sensor}: {len(self.frames)} frames, "
            f"{len(self.empty_frames)} with nothing in range; predicted {self.predicted_s:.2f} s"
        ]
        names = [e.name for e in self.frames[0].effects] if self.frames else []
        for k, name in enumerate(names):
            runs = sum(f.effects[k].run is True for f in self.frames)
            skips = [f.effects[k] for f in self.frames if f.effects[k].run is False]
            later = sum(f.effects[k].run is None for f in self.frames)
            why = f"  (skip: {skips[0].reason})" if skips else ""
            lines.append(
                f"  {name:<18} run {runs:>4}  skip {len(skips):>4}  on frame {later:>4}{why}"
            )
        return "\n".join(lines)


def _spheres(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World bounding spheres of the instances: ids (N,), centres (N, 3), radii (N,).

    A mesh's sphere is found once; the instances' transforms are applied all at once, with the
    per-instance arithmetic's operations in its order (``T[:3, :3] @ c + T[:3, 3]``, the
    largest column norm of ``T[:3, :3]`` times the radius)."""
    spheres: dict[str, tuple[np.ndarray, float]] = {}
    for key in {inst.mesh for inst in scene.instances}:
        v = scene.meshes[key].vertices.astype(np.float64)
        if len(v) == 0:
            spheres[key] = (np.zeros(3), -1.0)
        else:
            c = (v.min(0) + v.max(0)) / 2
            spheres[key] = (c, float(np.linalg.norm(v - c, axis=1).max()))
    n = len(scene.instances)
    ids = np.fromiter((inst.instance for inst in scene.instances), np.uint32, n)
    if n == 0:
        return ids, np.zeros((0, 3)), np.zeros(0)
    T = np.stack([inst.world_from_model for inst in scene.instances]).astype(np.float64, copy=False)
    c = np.array([spheres[inst.mesh][0] for inst in scene.instances])
    r = np.array([spheres[inst.mesh][1] for inst in scene.instances])
    R = T[:, :3, :3]
    centres = (R[:, :, 0] * c[:, :1] + R[:, :, 1] * c[:, 1:2]) + R[:, :, 2] * c[:, 2:] + T[:, :3, 3]
    radii = r * np.sqrt(np.add.reduce(R * R, axis=1)).max(axis=1)
    return ids, centres, radii


def _is_convex(mesh: Mesh) -> bool:
    """True for a closed convex mesh, or a single triangle (no surface of it faces another);
    decided once per mesh (:func:`genie_gl.scene.convexity.is_convex`)."""
    return is_convex(mesh)


def far_plane(sensor: Sensor) -> float:
    """The far plane the effects need: the largest reach of any effect plus a margin, or the
    sensor's own far plane when no effect bounds it."""
    reach = [r for e in sensor.effects if (r := e.reach_m(sensor)) is not None]
    if not reach or any(not np.isfinite(r) for r in reach):
        return float(sensor.far_m)
    far = max(reach)
    b = 0.0 if sensor.stereo is None else float(sensor.stereo.baseline_m)
    return float(min(sensor.far_m, far * (1 + MARGIN_REL) + MARGIN_M + b))


def _side_planes(view: Sensor) -> np.ndarray:
    """(4, 3) inward unit normals of a pinhole view's side planes through its centre (a pixel
    of margin, skew included)."""
    K = view.K
    x0, x1 = (-1.5 - K[0, 2]) / K[0, 0], (view.width + 0.5 - K[0, 2]) / K[0, 0]
    y0, y1 = (-1.5 - K[1, 2]) / K[1, 1], (view.height + 0.5 - K[1, 2]) / K[1, 1]
    skew = abs(K[0, 1]) * max(abs(y0), abs(y1)) / K[0, 0]
    x0, x1 = x0 - skew, x1 + skew
    n = np.array([[1.0, 0, -x0], [-1.0, 0, x1], [0, 1.0, -y0], [0, -1.0, y1]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _frustum(sensor: Sensor) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pinhole views a frame is rendered from (one for a pinhole or a narrow lens, cube
    faces for a fisheye): per view, (camera_from_view rotation, side planes in the view)."""
    if sensor.is_pinhole:
        return [(np.eye(3), _side_planes(sensor))]
    return [(m.rotation, _side_planes(m.render_sensor)) for m in lens_views(sensor)]


def plan(
    scene: Scene,
    sensor: Sensor,
    poses: Sequence[np.ndarray],
    *,
    materials: MaterialTable | None = None,
) -> Plan:
    """Decide, per pose (world_from_camera), what is drawn and which effects run, and why."""
    scene, sensor, poses, _ = capture_arguments(scene, sensor, poses, 0, Scene, Sensor, "plan")
    ids, centres, radii = _spheres(scene)
    table = MaterialTable.from_scene(scene) if materials is None else materials
    mesh_of = np.array([i.mesh for i in scene.instances])
    # convexity decides only views of a single object (multipath): computed for those alone
    wants_convex = any(e.needs_convexity for e in sensor.effects)
    convex_mesh: dict[str, bool] = {}
    rows = table.rows(ids)
    reflective = table.reflective(ids)
    transparent = table.opacity[rows] < 0.5
    albedo = table.albedo[rows]
    far = far_plane(sensor)
    views = _frustum(sensor)
    near = float(sensor.near_m)
    tri = {k: len(m.faces) for k, m in scene.meshes.items()}
    tri_of = np.array([tri[m] for m in mesh_of], np.float64)
    mpx = sensor.width * sensor.height / 1e6
    frames = []
    for k, pose in enumerate(poses):
        pose = np.asarray(pose, dtype=np.float64)
        R, t = pose[:3, :3], pose[:3, 3]
        c = (centres - t) @ R  # camera-frame centres
        ok = radii >= 0
        in_front = (c[:, 2] + radii >= near) if len(views) == 1 else np.ones(len(c), bool)
        sides = np.zeros(len(c), bool)
        for rot, normals in views:  # in view when inside any of the lens's pinhole views
            cv = c @ rot  # view-frame centres (camera_from_view = rot)
            sides |= (cv @ normals.T >= -radii[:, None]).all(axis=1) & (cv[:, 2] + radii > 0)
        beyond = ok & (c[:, 2] - radii > far)
        seen = ok & in_front & sides & ~beyond
        z_lo = np.maximum(c[seen, 2] - radii[seen], near)
        z_hi = np.minimum(c[seen, 2] + radii[seen], far)
        r_hi = np.linalg.norm(c[seen], axis=1) + radii[seen]
        convex = np.zeros(int(seen.sum()), bool)  # unknown (False) unless one object is seen
        if wants_convex and len(convex) == 1:
            key = str(mesh_of[seen][0])
            if key not in convex_mesh:
                convex_mesh[key] = _is_convex(scene.meshes[key])
            convex[0] = convex_mesh[key]
        view = View(
            sensor,
            pose,
            ids[seen],
            float(z_lo.min()) if seen.any() else 0.0,
            float(z_hi.max()) if seen.any() else 0.0,
            float(r_hi.max()) if seen.any() else 0.0,
            convex,
            reflective[seen],
            transparent[seen],
            albedo[seen],
        )
        effects = []
        for eff in sensor.effects:
            d = eff.plan(view)
            cost = eff.cost_per_mpx(sensor) * mpx
            if d is None:
                effects.append(EffectPlan(eff.name, None, "decided on the rendered frame", cost))
            else:
                effects.append(EffectPlan(eff.name, d.run, d.reason, cost if d.run else 0.0))
        reason = (
            ""
            if seen.any()
            else (
                f"nothing within {far:.2f} m in view"
                if (ok & in_front & sides).any()
                else "nothing in view"
            )
        )
        render_ms = (
            RENDER_MS_FIXED
            + RENDER_MS_PER_MPX * mpx
            + RENDER_MS_PER_MTRI * tri_of[seen].sum() / 1e6
        )
        frames.append(
            FramePlan(
                k,
                effects,
                ids[ok & ~beyond],
                ids[beyond],
                ids[ok & ~beyond & ~(in_front & sides)],
                far,
                render_ms,
                reason,
            )
        )
    return Plan(sensor.name, frames, table)
