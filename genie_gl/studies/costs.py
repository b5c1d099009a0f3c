"""What each effect of a sensor profile costs per frame, timed alone on fixed frames: the cost
column of the "what accuracy buys" table (``genie eval --study costs``).

The frames are those of one scene of the study's strategy (its training seed), the cameras
placed for the profile as a dataset places them. For each effect of the profile, the profile
with that effect alone is planned (:func:`genie_gl.plan`) and captured frame by frame through
the same renderer, ``repeats`` times; the effect's own milliseconds (``simulate``'s log) are
taken per frame, the median over the repeats. A frame whose plan (or whose rendered frame)
leaves the effect out is counted as *skipped*, never as a cost: the effect's cost per frame is
the sum of its medians over the frames it ran on divided by all the frames, and an effect the
plan leaves out of every frame is *skipped*, with the planner's reason. The ideal render (no
effect) and the full profile are timed the same way, turn about with the effects. The machine's
load average is recorded before and after (timings are only comparable at a similar load).
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import time
from typing import Any

import numpy as np

import genie_gl as gg

from ..capture import plan as make_plan
from ..capture import through_lens
from ..render import Renderer
from ..resources import resolve
from ..effects.simulate import simulate


def _variants(sensor: Any) -> dict[str, Any]:
    """The ideal sensor, each effect alone, and the full profile, by name."""
    out = {"(ideal render)": dataclasses.replace(sensor, effects=())}
    for e in sensor.effects:
        out[e.name] = dataclasses.replace(sensor, effects=(e,))
    out["(full profile)"] = sensor
    return out


def time_effects(
    profile: str = "realsense_d435",
    strategy: str = "assembly_line",
    *,
    frames: int = 8,
    repeats: int = 5,
    seed: int = 0,
) -> dict:
    """Per effect of ``profile``: frames run and skipped, the median ms of a run, the ms per
    frame (skips count 0), the skip reasons; the ideal render's and the full profile's ms per
    frame; the load average before and after. See the module's docstring."""
    if frames < 1 or repeats < 1:
        raise gg.ConfigError(f"costs: frames and repeats must be >= 1, got {frames}, {repeats}")
    load0 = os.getloadavg()
    sensor = gg.load_sensor(profile)
    layout = gg.generate_layout(resolve(strategy, "layouts", (".json",)), seed=seed)
    scene = gg.build_scene(layout, seed=seed)
    poses = list(gg.place_sensors(layout, sensor, n=frames, seed=seed))
    variants = _variants(sensor)
    plans = {k: make_plan(scene, s, poses) for k, s in variants.items()}
    # per variant, per frame: a list over repeats of (total ms, {effect: ms or None when skipped},
    # reasons)
    runs: dict[str, list[list[tuple[float, dict, dict]]]] = {
        k: [[] for _ in poses] for k in variants
    }
    t_start = time.perf_counter()
    with Renderer(scene) as r:
        lens_render = through_lens(r.render)
        for k, pose in enumerate(poses):  # warm: compiled kernels, GL objects
            simulate(
                sensor,
                pose,
                render=lens_render,
                rng=np.random.default_rng(k),
                materials=plans["(full profile)"].materials,
                plan=plans["(full profile)"].frames[k],
            )
        for _ in range(repeats):
            for k, pose in enumerate(poses):
                for name, s in variants.items():  # turn about, frame by frame
                    p = plans[name]
                    t = time.perf_counter()
                    f = simulate(
                        s,
                        pose,
                        render=lens_render,
                        rng=np.random.default_rng(k) if s.effects else None,
                        materials=p.materials,
                        plan=p.frames[k],
                    )
                    total = 1e3 * (time.perf_counter() - t)
                    log = (f.meta or {}).get("effects", [])
                    runs[name][k].append(
                        (
                            total,
                            {e["name"]: (e["ms"] if e["run"] else None) for e in log},
                            {e["name"]: e["reason"] for e in log if not e["run"]},
                        )
                    )
    out: dict = {
        "profile": profile,
        "strategy": strategy,
        "seed": seed,
        "frames": len(poses),
        "repeats": repeats,
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "load_before": round(load0[0], 2),
        "load_after": round(os.getloadavg()[0], 2),
        "seconds": round(time.perf_counter() - t_start, 1),
        "effects": {},
    }
    for name in ("(ideal render)", "(full profile)"):
        out[name] = round(
            statistics.fmean(statistics.median(r[0] for r in per) for per in runs[name]), 2
        )
    for e in sensor.effects:
        ran, skipped, medians, reasons = 0, 0, [], {}
        for per in runs[e.name]:
            ms = [r[1].get(e.name) for r in per]
            if any(m is None for m in ms):  # a frame the plan or the frame leaves the effect out of
                skipped += 1
                for r in per:
                    if e.name in r[2]:
                        reasons[r[2][e.name]] = reasons.get(r[2][e.name], 0) + 1
                continue
            ran += 1
            medians.append(statistics.median(ms))
        out["effects"][e.name] = {
            "ran_frames": ran,
            "skipped_frames": skipped,
            "median_ms_when_run": round(statistics.median(medians), 3) if medians else None,
            "ms_per_frame": round(sum(medians) / len(poses), 3),
            "skip_reasons": sorted(reasons, key=lambda k: -reasons[k]),
        }
    return out


def cost_text(entry: dict | None) -> str:
    """One effect's cost cell: ``3.1`` ms per frame, ``skipped (planned away on 8 of 8
    frames: reason)``, or ``3.1 (skipped on 2 of 8 frames)``; — without a timing."""
    if entry is None:
        return "—"
    n = entry["ran_frames"] + entry["skipped_frames"]
    if entry["ran_frames"] == 0:
        why = f": {entry['skip_reasons'][0]}" if entry["skip_reasons"] else ""
        return f"skipped (planned away on {n} of {n} frames{why})"
    text = f"{entry['ms_per_frame']:.1f}"
    if entry["skipped_frames"]:
        text += f" (skipped on {entry['skipped_frames']} of {n} frames)"
    return text


def costs_markdown(result: dict, command: str) -> str:
    """The timing run as a table, with its date, load and command."""
    rows = [
        "| effect | frames run | frames skipped | median ms when run | ms per frame (skips count "
        "0) |",
        "| --- | ---: | ---: | ---: | --- |",
    ]
    for name, e in result["effects"].items():
        med = f"{e['median_ms_when_run']:.2f}" if e["median_ms_when_run"] is not None else "—"
        rows.append(
            f"| {name} | {e['ran_frames']} | {e['skipped_frames']} | {med} | {cost_text(e)} |"
        )
    return (
        f"## What each {result['profile']} effect costs, timed alone\n\nMeasured {result['date']}, "
        "load average "
        f"{result['load_before']:.1f} before and {result['load_after']:.1f} after (2 cores); "
        f"{result['frames']} "
        f"frames of one {result['strategy']} scene (seed {result['seed']}), each variant "
        f"{result['repeats']} times "
        f"turn about, the median per frame. Ideal render {result['(ideal render)']:.1f} ms per "
        "frame, the full "
        f"profile {result['(full profile)']:.1f} ms. Reproduce: `{command}`.\n\n"
        + "\n".join(rows)
        + "\n"
    )
