"""``genie bench planning``: what a full sensor frame costs before and after planning, as
multiples of the ideal render of the same view, measured side by side in one run.

For each profile (the full RealSense D435 and the full Azure Kinect NFOV, multipath included)
on a generated scene (the assembly line, cameras placed for the sensor's range):

* ideal — the frame through the lens, no effect (what ``gg.render`` gives);
* before — every effect of the profile run on every frame, nothing culled, the stereo second
  view always rendered (the pipeline before the planner: ``simulate(plan=None, decide=False)``
  with the shadow's ``second_view="always"``);
* planned — ``capture``'s path: the plan's culling and far plane, effects skipped where the
  view or the frame cannot call for them (same output as running them);
* reference — the planned path with the effects' reference computations where a fused one
  replaced them (their ``fused=False``: noise drawn by numpy's ``rng.standard_normal(n)``
  before the compiled pass; the shadow mask, then ``drop``): the same bytes, checked on every
  view before timing. Every column runs the effects' own code: nothing is copied here;
* shadow rendered — the planned path with the stereo shadow's second view rendered (method
  "render", the default before the scanline method: what this column was before it); where
  the scanline method is the default, how often it agrees with a full-resolution render of
  the second view (and how often the render method's half-resolution one does);

One more row: the Azure profile on a matte convex sphere, where the planner skips multipath
(goal: within 5 % of the ideal render). Methods take turns frame by frame (the machine is
noisy); the median of the per-frame ratios to the ideal is quoted, of wall time and of the
process's CPU time (all renderer threads included: steadier where other work shares the
cores, since a busy machine stretches a single-threaded effect's wall time more than a
render spread over every core). Goals: D435 at <= 2x the ideal render, Azure with
multipath at <= 3x.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import trimesh

import genie_gl as gg

from ..capture import plan as make_plan
from ..capture import through_lens
from ..render import Renderer
from ..sensors.pose import look_at
from ..resources import resolve
from ..scene.model import Material
from ..effects.registry import DepthNoise
from ..effects.shadow import StereoShadow
from ..effects.simulate import simulate


def _before(sensor):
    """``sensor`` as the pipeline ran before planning: the stereo shadow's second view rendered
    on every frame (method "render", ``second_view="always"``); with ``simulate(plan=None,
    decide=False)``: every effect on every frame, nothing culled."""
    effects = tuple(
        dataclasses.replace(e, method="render", second_view="always")
        if isinstance(e, StereoShadow)
        else e
        for e in sensor.effects
    )
    return dataclasses.replace(sensor, effects=effects)


def _reference(sensor):
    """``sensor`` with its fused effects computing the reference way (``fused=False``: numpy's
    draws before the compiled noise pass; the shadow's mask, then ``drop``): the same bytes."""
    effects = tuple(
        dataclasses.replace(e, fused=False) if isinstance(e, (DepthNoise, StereoShadow)) else e
        for e in sensor.effects
    )
    return dataclasses.replace(sensor, effects=effects)


def _rendered_shadow(sensor):
    """``sensor`` with its stereo shadow's second view rendered (method "render": the default
    before the scanline method)."""
    effects = tuple(
        dataclasses.replace(e, method="render") if isinstance(e, StereoShadow) else e
        for e in sensor.effects
    )
    return dataclasses.replace(sensor, effects=effects)


def _shadow_agreement(sensor, poses, r) -> dict | None:
    """Where the sensor's stereo shadow is drawn by scanline: the share of returns on which it
    agrees with a full-resolution render of the second view, and on which the render method's
    default half-resolution second view does (lowest and highest over the views, %)."""
    eff = next((e for e in sensor.effects if isinstance(e, StereoShadow)), None)
    if eff is None or eff.resolved_method(sensor) != "scanline":
        return None
    ideal = dataclasses.replace(sensor, effects=())

    lens_render = through_lens(r.render)

    def depth2(view, view_pose):
        return lens_render(view, view_pose, depth_only=True).depth

    scan, half = [], []
    for pose in poses:
        f = lens_render(ideal, pose).replace(sensor=sensor)
        valid = f.depth > 0
        gone = {
            m: valid
            & (
                dataclasses.replace(eff, method=m, scale=sc)
                .apply(f, rng=None, render_depth=depth2)
                .depth
                == 0
            )
            for m, sc in (("scanline", 1.0), ("render", 1.0))
        }
        gone["half"] = valid & (
            dataclasses.replace(eff, method="render", scale=0.5)
            .apply(f, rng=None, render_depth=depth2)
            .depth
            == 0
        )
        n = max(int(valid.sum()), 1)
        scan.append(100.0 * (1 - (gone["scanline"] != gone["render"]).sum() / n))
        half.append(100.0 * (1 - (gone["half"] != gone["render"]).sum() / n))
    return {
        "scanline_vs_full_render_pct": [round(min(scan), 2), round(max(scan), 2)],
        "half_render_vs_full_render_pct": [round(min(half), 2), round(max(half), 2)],
    }


def _time(fn) -> tuple[float, float, object]:
    """(wall ms, CPU ms of the whole process: every renderer thread included, fn's result)."""
    t, c = time.perf_counter(), time.process_time()
    out = fn()
    return 1e3 * (time.perf_counter() - t), 1e3 * (time.process_time() - c), out


def _rows(label, scene, sensor, poses, rounds):
    p = make_plan(scene, sensor, poses)
    ideal_sensor = dataclasses.replace(sensor, effects=())
    before = _before(sensor)
    reference = _reference(sensor)
    rendered = _rendered_shadow(sensor)
    ms = {"ideal": [], "before": [], "reference": [], "rendered": [], "planned": []}
    cpu = {key: [] for key in ms}
    effect_ms: dict = {}
    with Renderer(scene) as r:
        lens_render = through_lens(r.render)
        for k, pose in enumerate(poses):  # warm: compiled kernels, caches, GL objects
            a, b = (
                simulate(
                    s,
                    pose,
                    render=lens_render,
                    rng=np.random.default_rng(k),
                    materials=p.materials,
                    plan=p.frames[k],
                )
                for s in (sensor, reference)
            )
            if any(
                getattr(a, n).tobytes() != getattr(b, n).tobytes()
                for n in ("depth", "instance", "semantic")
            ):
                raise AssertionError(
                    f"{label}: the fused effects differ from their reference on view {k}"
                )
            simulate(
                before,
                pose,
                render=lens_render,
                rng=np.random.default_rng(k),
                materials=p.materials,
                decide=False,
            )
        for _ in range(rounds):
            for k, pose in enumerate(poses):
                _add(
                    ms,
                    cpu,
                    "ideal",
                    _time(
                        lambda: simulate(
                            ideal_sensor, pose, render=lens_render, rng=np.random.default_rng(k)
                        )
                    ),
                )
                _add(
                    ms,
                    cpu,
                    "before",
                    _time(
                        lambda: simulate(
                            before,
                            pose,
                            render=lens_render,
                            rng=np.random.default_rng(k),
                            materials=p.materials,
                            decide=False,
                        )
                    ),
                )
                _add(
                    ms,
                    cpu,
                    "reference",
                    _time(
                        lambda: simulate(
                            reference,
                            pose,
                            render=lens_render,
                            rng=np.random.default_rng(k),
                            materials=p.materials,
                            plan=p.frames[k],
                        )
                    ),
                )
                _add(
                    ms,
                    cpu,
                    "rendered",
                    _time(
                        lambda: simulate(
                            rendered,
                            pose,
                            render=lens_render,
                            rng=np.random.default_rng(k),
                            materials=p.materials,
                            plan=p.frames[k],
                        )
                    ),
                    effect_ms,
                )
                _add(
                    ms,
                    cpu,
                    "planned",
                    _time(
                        lambda: simulate(
                            sensor,
                            pose,
                            render=lens_render,
                            rng=np.random.default_rng(k),
                            materials=p.materials,
                            plan=p.frames[k],
                        )
                    ),
                    effect_ms,
                )
        agreement = _shadow_agreement(sensor, poses, r)
        last = simulate(
            sensor,
            poses[0],
            render=lens_render,
            rng=np.random.default_rng(0),
            materials=p.materials,
            plan=p.frames[0],
        )
    ideal, ideal_cpu = np.array(ms["ideal"]), np.array(cpu["ideal"])
    row = {
        "case": label,
        "ideal_ms": round(float(np.median(ideal)), 1),
        "ideal_cpu_ms": round(float(np.median(ideal_cpu)), 1),
    }
    # what a skipped effect costs, as a share of the ideal render (goal: under 5 %)
    row["skipped_share"] = {
        e["name"]: round(e["ms"] / float(np.median(ideal)), 4)
        for e in last.meta["effects"]
        if not e["run"]
    }
    if agreement is not None:
        row["shadow_agreement"] = agreement
    row["effect_ms"] = {
        key: {name: round(float(np.median(v)), 2) for name, v in per.items()}
        for key, per in effect_ms.items()
    }
    for key in ("before", "reference", "rendered", "planned"):
        row[f"{key}_ms"] = round(float(np.median(ms[key])), 1)
        row[f"{key}_x"] = round(float(np.median(np.array(ms[key]) / ideal)), 2)
        row[f"{key}_cpu_x"] = round(float(np.median(np.array(cpu[key]) / ideal_cpu)), 2)
    return row


def _add(ms, cpu, key, timed, effects=None) -> None:
    ms[key].append(timed[0])
    cpu[key].append(timed[1])
    meta = getattr(timed[2], "meta", None) or {}
    if effects is not None:
        for e in meta.get("effects", []):  # what simulate recorded per effect
            effects.setdefault(key, {}).setdefault(e["name"], []).append(e["ms"])


def run(args: argparse.Namespace) -> int:
    layout = gg.generate_layout(resolve("assembly_line", "layouts", (".json",)), seed=0)
    scene = gg.build_scene(layout, seed=0)
    rows = []
    for name in ("realsense_d435", "azure_kinect_nfov"):
        sensor = gg.load_sensor(resolve(name, "sensors", (".yaml",)))
        poses = gg.place_sensors(layout, sensor, n=args.cameras, seed=0)
        rows.append(_rows(f"{name}, assembly line", scene, sensor, poses, args.rounds))
        print(rows[-1], flush=True)
    sphere = gg.Scene()
    sphere.add(
        trimesh.creation.icosphere(subdivisions=4, radius=0.5),
        np.eye(4),
        semantic=1,
        material=Material((0.5, 0.5, 0.5), 0.0, 0.9),
    )
    azure = gg.load_sensor(resolve("azure_kinect_nfov", "sensors", (".yaml",)))
    pose = look_at([0.0, 0.0, 2.0], [0.0, 0.0, 0.0], up=(0, 1, 0))
    rows.append(
        _rows("azure_kinect_nfov, matte convex sphere", sphere, azure, [pose] * 2, args.rounds)
    )
    print(rows[-1], flush=True)
    print(
        f"\n{'case':<42} {'ideal ms':>9} {'before':>14} {'planned, ref.':>14} "
        f"{'shadow rendered':>16}"
        f" {'planned':>14}   skipped effects (share of the render)"
    )
    for r in rows:
        skipped = ", ".join(f"{k} {100 * v:.1f} %" for k, v in r["skipped_share"].items()) or "-"
        print(
            f"{r['case']:<42} {r['ideal_ms']:>9.1f} {r['before_ms']:>7.1f} ({r['before_x']:>4.2f}x)"
            f" {r['reference_ms']:>7.1f} ({r['reference_x']:>4.2f}x)"
            f" {r['rendered_ms']:>9.1f} ({r['rendered_x']:>4.2f}x)"
            f" {r['planned_ms']:>7.1f} ({r['planned_x']:>4.2f}x)   {skipped}"
        )
    print("\nms per effect where it ran or was checked (median), planned vs shadow rendered:")
    for r in rows:
        per = r["effect_ms"]
        print(
            f"{r['case']:<42} "
            + ", ".join(
                f"{n} {per['planned'][n]:.2f} vs {per['rendered'].get(n, 0.0):.2f}"
                for n in per.get("planned", {})
            )
        )
    for r in rows:
        a = r.get("shadow_agreement")
        if a:
            lo, hi = a["scanline_vs_full_render_pct"]
            lo2, hi2 = a["half_render_vs_full_render_pct"]
            print(
                f"{r['case']:<42} stereo shadow, share of returns agreeing with a full-resolution "
                "second view:"
                f" scanline {lo:.2f}-{hi:.2f} %, half-resolution render (the render method's "
                "default)"
                f" {lo2:.2f}-{hi2:.2f} %"
            )
    print(
        "\nCPU time of the process (every renderer thread included), as multiples of the ideal's:"
    )
    for r in rows:
        print(
            f"{r['case']:<42} {r['ideal_cpu_ms']:>6.1f} ms {r['before_cpu_x']:>13.2f}x "
            f"{r['reference_cpu_x']:>13.2f}x"
            f" {r['rendered_cpu_x']:>15.2f}x {r['planned_cpu_x']:>13.2f}x"
        )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "planning.json").write_text(
        json.dumps(
            {"rows": rows, "goals": {"realsense_d435": 2.0, "azure_kinect_nfov": 3.0}}, indent=1
        )
    )
    return 0
