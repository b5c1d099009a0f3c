"""From a pose to a realistic frame: decide the renders a sensor needs, then apply its effects.

``simulate(sensor, pose, render=..., rng=...)`` is what ``genie_gl.capture`` calls for each
camera. ``render(sensor, pose, *, depth_only=False, normals=False[, only=ids]) -> Frame``
renders an ideal pinhole frame of a pinhole camera, as :meth:`Renderer.render` does. A
distorted sensor is rendered through its lens (:func:`.distortion.render_through_lens`:
pinhole views, resampled with ``resample`` / ``oversample``); then the sensor's effects run
in order. Effects that declare ``needs_normals`` get
the frame rendered with normals (the normals are dropped from the result again); effects that
declare ``needs_render`` also get ``render_depth(sensor, pose) -> (H, W) float32``, a
depth-only render from any pose, and ``render_frame(sensor, pose, exclude=ids) -> Frame``;
effects that declare ``needs_materials`` get ``materials=`` (a
:class:`~genie_gl.scene.materials.MaterialTable`). With no effects and no distortion the
result is ``render(sensor, pose)`` itself, bit for bit, and no RNG draw is made.

With a frame plan (:mod:`genie_gl.capture.planner`) the frame follows it: only the instances it
draws
are drawn, the far plane is its ``far_m``, an effect it skips is skipped. Every effect not
skipped by the plan is asked again on the frame (:meth:`Effect.check`); a skip never changes
the output or the RNG stream (:meth:`Effect.skip` draws what a run would have). Each frame's
``meta["effects"]`` records, per effect: ``name``, ``run``, ``reason``, ``ms`` and
``changed`` (pixels whose depth or instance id the effect changed: what the effect recorded
as ``meta[name]["changed"]`` when it counts them itself, else a comparison of the frames).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from ..scene.materials import MaterialTable
from ..sensors.camera import Sensor
from ..lens.distortion import draws_lenses, render_through_lens
from .kernels import changed

RenderFn = Callable[..., Frame]
DepthRenderFn = Callable[[Sensor, np.ndarray], np.ndarray]


def _changed(a: Frame, b: Frame) -> int:
    if a is b or (a.depth is b.depth and a.instance is b.instance):
        return 0
    if a.depth.shape != b.depth.shape:
        return int(b.depth.size)
    return int(changed(a.depth, b.depth, a.instance, b.instance))


def simulate(
    sensor: Sensor,
    pose: np.ndarray,
    *,
    render: RenderFn,
    rng: np.random.Generator | None,
    resample: str = "exact",
    oversample: float | None = None,
    materials: Any = None,
    plan: Any = None,
    decide: bool = True,
) -> Frame:
    """Render ``sensor`` at ``pose`` (world_from_camera) and apply its effects in order,
    each drawing from ``rng`` (None only for a sensor without effects).

    ``resample`` and ``oversample``: how a distorted sensor's image is made from its pinhole
    views (see :mod:`.distortion`; ignored for a pinhole sensor). ``materials``: the scene's
    MaterialTable (effects that need it get it); ``plan``: this frame's
    :class:`~genie_gl.capture.FramePlan` (None: every effect is decided on the frame);
    ``decide`` False: no effect is asked whether the frame calls for it, every one runs (the
    same output: the pipeline before the planner, for comparison).
    """
    only = None if plan is None else plan.drawn
    far = None if plan is None else plan.far_m

    def restricted(fn: Callable[..., Frame]) -> Callable[..., Frame]:
        """``fn`` drawing only what the plan draws, no farther than its far plane."""

        def draw(
            view: Sensor, view_pose: np.ndarray, exclude: Sequence[int] = (), **kw: Any
        ) -> Frame:
            ids = only
            if len(exclude):
                ids = np.setdiff1d(
                    materials.ids if ids is None else ids, np.asarray(exclude, np.uint32)
                )
            if ids is not None:
                kw["only"] = ids
            if far is not None and far < view.far_m:
                return fn(dataclasses.replace(view, far_m=far), view_pose, **kw).replace(
                    sensor=view
                )
            return fn(view, view_pose, **kw)

        return draw

    draw = restricted(render)
    draw.draws_lenses = draws_lenses(render)  # type: ignore[attr-defined]
    if hasattr(
        render, "lens"
    ):  # a supersampled render: the exact lens mode supersamples through the lens
        draw.lens = restricted(render.lens)

    normals = any(eff.needs_normals for eff in sensor.effects)
    kw = {"normals": True} if normals else {}
    if sensor.is_pinhole:
        frame = draw(sensor, pose, **kw)
    else:
        frame = render_through_lens(
            draw, sensor, pose, resample=resample, oversample=oversample, **kw
        )
    if not sensor.effects:
        return frame
    if rng is None:
        raise ConfigError(
            f"simulate: sensor {sensor.name!r} has effects: they need an rng "
            "(numpy.random.Generator)"
        )

    def render_depth(view: Sensor, view_pose: np.ndarray) -> np.ndarray:
        return draw(view, view_pose, depth_only=True).depth

    def render_frame(view: Sensor, view_pose: np.ndarray, exclude: Sequence[int] = ()) -> Frame:
        return draw(view, view_pose, exclude=exclude, depth_only=True)

    decisions = [None] * len(sensor.effects) if plan is None else plan.decisions
    log = []
    for eff, decided in zip(sensor.effects, decisions):
        t0 = time.perf_counter()
        needs: dict[str, Any] = {}
        if eff.needs_render:
            needs.update(render_depth=render_depth, render_frame=render_frame)
        if eff.needs_materials:
            if materials is None:  # no scene table: every surface is the default material
                materials = MaterialTable.empty()
            needs["materials"] = materials
        reason = decided.reason if decided is not None else None
        run = decided.run if decided is not None else True
        if run and decide:
            why = eff.check(frame, **needs)
            if why is not None:
                run, reason = False, why
        if run:
            before = frame
            mine = (frame.meta or {}).get(eff.name)
            frame = eff.apply(frame, rng=rng, **needs) if needs else eff.apply(frame, rng=rng)
            rec = (frame.meta or {}).get(eff.name)
            if isinstance(rec, dict) and rec is not mine and "changed" in rec:
                changed = int(rec["changed"])  # the effect counted what it changed
            else:
                changed = _changed(before, frame)
        else:
            eff.skip(frame, rng)
            changed = 0
        log.append(
            {
                "name": eff.name,
                "run": bool(run),
                "reason": reason or "",
                "changed": changed,
                "ms": round(1e3 * (time.perf_counter() - t0), 3),
            }
        )
    meta = {**(frame.meta or {}), "effects": log}
    if plan is not None and plan.empty:
        meta["empty"] = plan.reason
    return frame.replace(meta=meta, normal=None if normals else frame.normal)
