"""Measuring scripts: what a part of the pipeline costs, beside what it saves, on the benchmark
scenes of :mod:`genie_gl.bench.scenes` and on dataset scenes.

Run one with ``python -m benchmarks NAME [ARGS]`` from the repository root
(``python -m benchmarks --list`` lists them; ``python -m benchmarks NAME --help`` gives a
benchmark's arguments). Each module has ``run(...)``, which returns its rows, and
``main(argv)``, which prints them; ``tests/benchmarks/`` runs each on a small scene so a
change to the code it measures fails a test instead of a page. The figures the docs pages
quote name the command that reproduces them.

The headline benchmarks against other tools are ``genie bench ...`` (:mod:`genie_gl.bench`).
"""

#: every benchmark: module name -> what it measures
NAMES = {
    "frame_cpu": "CPU of steady GL frames of a benchmark scene and the culling kernel's share",
    "lens_frame": "a frame through the tutorial lens against the pinhole frame of the same K",
    "lens_ids": "lens resampling modes against Open3D's ray caster: ids that agree, ms a frame",
    "lod_saving": "what level of detail saves (ms a frame) and costs (depth error, ids) per raster",
    "occlusion_cost": "occlusion culling's cost and saving, the culler alone, llvmpipe's fixed "
    "cost",
    "random_rays": "gg.cast_rays on random rays beside Open3D's ray caster: seconds and agreement",
    "skip_cost": "a capture whose planner skips an effect against the same capture without it",
    "stage_cpu": "CPU seconds per stage of steady dataset scenes, as a dataset worker makes them",
    "stage_parts": "least CPU per scene of build_scene, the capture planner and the cloud stage",
}
