"""A worker's one-time start-up, done before its first scene and timed apart from it.

The first scene a process makes would otherwise also pay for what every later scene reuses:
the imports of the stages, numba loading its cached kernels (tens of milliseconds each), the
GL context, the shader builds and llvmpipe's compilation of their variants. :func:`warm_up`
pays these once by running every stage of the run's configuration on a throw-away scene (its
own fixed seed, two cameras, nothing written), so that scene times measure scenes and the
warm-up is reported on its own (``warmup_s`` per worker in the manifest's run record and in
``genie bench pipeline``).

The throw-away scene draws from its own generators and fills only caches that the scenes
fill anyway (the GL context, shaders, kernels, ray tables, tessellated assets): every scene
still depends only on (seed, index), byte for byte.
"""
from __future__ import annotations

import time

import numpy as np

from ..capture import capture, segments_option
from ..cloud import frame_chunks, keep_cloud
from ..export import get_format
from ..layout import generate_layout, load_strategy
from ..render import shared_context
from ..render.memory import prefault
from ..scene import build_scene
from ..sensors import load_sensor, place_sensors
from .config import DatasetConfig, settings_of

WARM_SEED = 20_26_11_23  # the throw-away scene's seed (any fixed value)
WARM_CAMERAS = 2


def warm_up(cfg: DatasetConfig) -> float:
    """Run every stage of ``cfg`` once on a throw-away scene in this process; returns seconds."""
    t0 = time.perf_counter()
    rng = {n: np.random.default_rng(np.random.SeedSequence([WARM_SEED, k]))
           for k, n in enumerate(("layout", "scene", "cloud"))}
    fmt = get_format(cfg.format)
    layout = generate_layout(load_strategy(cfg.strategy), rng=rng["layout"], max_regions=cfg.max_nodes)
    accuracy = settings_of(cfg.accuracy)
    scene = build_scene(layout, rng=rng["scene"], **segments_option(accuracy))
    sensor = load_sensor(cfg.sensor)
    poses = place_sensors(layout, sensor, n=min(WARM_CAMERAS, cfg.cameras), seed=WARM_SEED,
                          mount_height_m=cfg.mount_m)
    # (the culling kernels load only if a view of this scene draws enough faces to cull: the
    # assembly line's views never do, so its scenes never load them)
    frames = capture(scene, sensor, poses, seed=WARM_SEED, workers=1, depth_only=not fmt.colour,
                     accuracy=accuracy, context=shared_context())
    if frames:  # every frame of a scene is held until its clouds are made: map their memory now
        f = frames[0]
        prefault(*f.depth.shape, f.rgb is not None, f.normal is not None, cfg.cameras)
    if fmt.chunks and frames:
        tiles, _ = frame_chunks(frames, cfg.chunk_m, max_points=cfg.points, rng=rng["cloud"])
        for _, tile in tiles[:1]:
            keep_cloud(tile, min_points=cfg.min_points, min_labelled_share=cfg.min_labelled_share)
    return time.perf_counter() - t0
