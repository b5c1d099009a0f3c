"""CPU time per steady scene of the parts of a dataset scene cut in the second round of the
pipeline work, each beside the way it was done before, in one process, the two taking turns
(the least of the repeats, which a loaded machine blurs least). Six assembly-line scenes of
40 cameras, ideal pinhole, as ``genie bench pipeline --dataset-only`` makes them.

* cloud: ``frame_chunks`` (both passes, the draws and the label gathers) with pass 2 walking
  pass 1's runs, against pass 2 computing every pixel's tile again (no room for runs);
* pose checks: ``check_pose`` of a plainly rigid pose in plain floats, against the array
  tests alone (a capture checks each of its 40 poses three times);
* look_at: numpy's cross products written out, against ``np.cross`` (40 cameras);
* placement: the genetic search's generations compiled, against numpy's array steps.

    python docs/pipeline_cuts.py
"""
import os
import time

import numpy as np

import genie_gl as gg
import genie_gl.checks as checks
import genie_gl.cloud.tally as tally
from genie_gl.cloud import frame_chunks
from genie_gl.dataset.streams import SceneStreams
from genie_gl.layout.engine import generate_layout
from genie_gl.layout.strategy import load_strategy
from genie_gl.sensors import pose
from genie_gl.sensors.placement import (CoverageProblem, genetic_placement, greedy_indices, layout_ceiling,
                                       mount_for)

sensor = gg.load_sensor("ideal_pinhole")
layouts = [generate_layout(load_strategy("assembly_line"), rng=SceneStreams(0, i).rng("layout")) for i in range(6)]
scenes = [gg.build_scene(lay, rng=SceneStreams(0, i).rng("scene")) for i, lay in enumerate(layouts)]
poses = [gg.place_sensors(lay, sensor, n=40, seed=i) for i, lay in enumerate(layouts)]
frames = [gg.capture(s, sensor, p, seed=1, depth_only=True) for s, p in zip(scenes[:2], poses[:2])]


def least(fn, repeats: int = 7) -> float:
    best = np.inf
    for _ in range(repeats):
        c = time.process_time()
        fn()
        best = min(best, time.process_time() - c)
    return best


def turns(before, after, repeats: int = 7) -> tuple[float, float]:
    """(before, after): the least CPU seconds of ``repeats`` calls each, in turns."""
    b = a = np.inf
    for _ in range(repeats):
        b, a = min(b, least(before, 1)), min(a, least(after, 1))
    return b, a


def cloud(room: int):
    def run():
        tally.RUN_ROOM = room
        for fr in frames:
            frame_chunks(fr, 12.0, max_points=25000, rng=np.random.default_rng(5))
        tally.RUN_ROOM = 4
    return run


def checks_of(fast: bool):
    real = checks._plainly_rigid

    def run():
        if not fast:
            checks._plainly_rigid = lambda T: False
        for p in poses:
            for _ in range(3):
                for T in p:
                    checks.check_pose(T)
        checks._plainly_rigid = real
    return run


def look_at_of(fast: bool):
    cross = pose._cross

    def run():
        if not fast:
            pose._cross = np.cross
        for p in poses:
            for T in p:
                pose.look_at(T[:3, 3], T[:3, 3] + T[:3, 2])
        pose._cross = cross
    return run


def numpy_genetic(problem, n, rng, population=32, generations=150, mutation=0.05):
    m = len(problem.candidates)
    pop = rng.integers(0, m, (population, n))
    pop[0] = greedy_indices(problem, n)
    fit = problem.fitnesses(pop)
    for _ in range(generations):
        elite = pop[fit.argmax()].copy()
        a, b = rng.integers(0, population, (2, population))
        parents = np.where((fit[a] >= fit[b])[:, None], pop[a], pop[b])
        mates = parents[rng.permutation(population)]
        child = np.where(rng.random((population, n)) < 0.5, parents, mates)
        mut = rng.random((population, n)) < mutation
        child[mut] = rng.integers(0, m, int(mut.sum()))
        child[0] = elite
        pop, fit = child, problem.fitnesses(child)
    return pop[fit.argmax()]


problems = [CoverageProblem(lay, mount_for(sensor, ceiling_m=layout_ceiling(lay)).radius_m) for lay in layouts]
print(f"load average (1 min) {os.getloadavg()[0]:.1f}; least CPU ms per scene, before -> after:")
for name, (before, after), per in (
        ("cloud (frame_chunks)", turns(cloud(10**9), cloud(4)), len(frames)),
        ("pose checks (3 x 40)", turns(checks_of(False), checks_of(True)), len(poses)),
        ("look_at (40 cameras)", turns(look_at_of(False), look_at_of(True)), len(poses)),
        ("genetic placement", turns(lambda: [numpy_genetic(p, 40, np.random.default_rng(i)) for i, p in enumerate(problems)],
                                    lambda: [genetic_placement(p, 40, rng=np.random.default_rng(i))
                                             for i, p in enumerate(problems)]), len(problems))):
    print(f"  {name:24s} {before / per * 1e3:7.2f} -> {after / per * 1e3:7.2f}  (saved {(before - after) / per * 1e3:.2f})")
