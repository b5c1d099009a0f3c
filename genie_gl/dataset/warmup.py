"""A worker's one-time start-up, done before its first scene and timed apart from it.

The first scene a process makes would otherwise also pay for what every later scene reuses:
the imports of the stages, numba loading its cached kernels (tens of milliseconds each), the
GL context, the shader builds and llvmpipe's compilation of their variants. :func:`warm_up`
pays these once by making a throw-away scene with the run's own recipe
(:mod:`.recipe`: every stage, the run's strategy, sensor and settings; its own fixed seed,
two cameras, nothing written), so that scene times measure scenes and the warm-up is
reported on its own (``warmup_s`` per worker in the manifest's run record and in
``genie bench pipeline``).

:func:`compile_kernels` runs the same warm-up once, outside any run, so that numba compiles
the kernels of a recipe into its cache (beside the package's modules, or the user's cache
when the install cannot be written): ``make setup`` does it for the demo's recipe, so the
first ``make demo`` loads the kernels instead of compiling them in every worker at once.

The throw-away scene draws from its own streams and fills only caches that the scenes fill
anyway (the GL context, shaders, kernels, ray tables, tessellated assets): every scene still
depends only on (seed, index), byte for byte.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from ..export import get_format
from ..render.memory import prefault
from ..scene.assets.catalogue import ASSETS
from .config import DatasetConfig
from .previews import write_previews
from .recipe import RunInputs, chunk, load_inputs, make
from .streams import SceneStreams

WARM_SEED = 20_26_11_23  # the throw-away scene's seed (any fixed value)
WARM_CAMERAS = 2


def warm_up(cfg: DatasetConfig, inputs: RunInputs) -> float:
    """Make a throw-away scene of ``cfg`` with ``inputs`` in this process; returns seconds."""
    t0 = time.perf_counter()
    _throw_away(cfg, inputs)
    return time.perf_counter() - t0


def _throw_away(cfg: DatasetConfig, inputs: RunInputs):
    """The throw-away scene (:data:`WARM_SEED`): made, its frames chunked; returns it."""
    fmt = get_format(cfg.format)
    segments = inputs.accuracy.tessellation
    (ASSETS if segments is None else ASSETS.copy(segments=segments)).build_builtins()
    streams = SceneStreams(WARM_SEED, 0)
    # (the culling kernels load only if a view of this scene draws enough faces to cull: the
    # assembly line's views never do, so its scenes never load them)
    made = make(
        inputs,
        streams,
        cameras=min(WARM_CAMERAS, cfg.cameras),
        depth_only=not fmt.colour,
        chunk_m=cfg.chunk_m if fmt.chunks else None,
    )
    frames = made.frames
    if frames:  # every frame of a scene is held until its clouds are made: map their memory now
        f = frames[0]
        prefault(*f.depth.shape, f.rgb is not None, f.normal is not None, cfg.cameras)
    chunk(cfg, frames, streams, chunks=fmt.chunks, tally=made.tally)
    return made


def compile_kernels(
    strategy: str = "assembly_line", sensor: str = "realsense_d435", format: str = "semantickitti"
) -> float:
    """Compile and cache the kernels a dataset run of this recipe loads: the warm-up, and the
    previews of its throw-away scene drawn into a temporary folder (removed), in this process;
    nothing else written but numba's cache. Returns seconds."""
    t0 = time.perf_counter()
    cfg = DatasetConfig.parse(
        {
            "strategy": strategy,
            "sensor": sensor,
            "format": format,
            "out": ".",
            "scenes": 1,
            "cameras": WARM_CAMERAS,
        }
    )
    made = _throw_away(cfg, load_inputs(cfg))
    with tempfile.TemporaryDirectory() as tmp:
        write_previews(Path(tmp), 0, made.layout, made.frames, made.scene)
    return time.perf_counter() - t0
