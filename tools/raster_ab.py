"""The exact raster of the work tree against that of a git revision, side by side in one
process: both versions' kernels (the modules of ``render/cpu/`` as one module each,
:mod:`kernel_source`, loaded from temporary files; a revision's kernel must take the work
tree's arguments) draw a benchmark scene's 40 poses in turns, pose by
pose, the order flipping each round; a pose's time is its least over the rounds (process CPU
time with one thread, wall time with more), and the ratio is of the sums.

    python tools/raster_ab.py 1M 2 5 HEAD~1      # scene, threads, rounds, revision
    python tools/raster_ab.py dataset 1 5        # a dataset scene and its 40 cameras
    python tools/raster_ab.py 100k 1 5 HEAD~1 --lens   # through the tutorial lens

``--lens``: the frames through the OpenCV tutorial lens of ``benchmarks/lens_ids.py`` instead
of the pinhole sensor, each version's rays binned by its own
:func:`genie_gl.render.cpu.bins.lens_samples`; a revision that held the binned rays as (N, 2)
rows gets them so.
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

import genie_gl as gg

from genie_gl.bench.render import sensor_640
from genie_gl.bench.scenes import bench_spec, to_scene
from genie_gl.render import Renderer
from genie_gl.render.cpu import raster
from genie_gl.render.cpu import renderer as cpu_renderer
from kernel_source import joined, load
from raster_profile import dataset_scene

ROOT = Path(__file__).resolve().parent.parent


def kernel(read, where: Path, name: str):
    """The frame kernel of one version (``read(module name)``: its source) and its binning of a
    lens's rays (:func:`genie_gl.render.cpu.bins.lens_samples`, None before it existed; kept in
    the lens maps' cache under ``name``, apart from the other version's)."""
    mod = load(joined(read), where, name)
    own = getattr(mod, "lens_samples", None)
    if own is None:
        return mod._raster, None

    def lens_samples(maps):
        got = maps.cache.get(name)
        if got is None:
            kept = maps.cache.pop("lens_samples", None)
            got = maps.cache[name] = own(maps)
            maps.cache.pop("lens_samples", None)
            if kept is not None:
                maps.cache["lens_samples"] = kept
        return got

    return mod._raster, lens_samples


def at(rev: str, name: str) -> str | None:
    got = subprocess.run(
        ["git", "-C", str(ROOT), "show", f"{rev}:genie_gl/render/cpu/{name}"],
        capture_output=True,
        text=True,
    )
    if got.returncode:
        if name in ("coverage.py", "raster.py"):
            sys.exit(
                f"raster_ab.py: revision {rev!r}: no genie_gl/render/cpu/{name} there "
                f"({got.stderr.strip()})"
            )
        return None  # a module the revision did not have yet
    return got.stdout


def rows_of_rays(base, rev: str):
    """``base`` (a revision's frame kernel and binning) with the binned rays as (N, 2) rows when
    that revision held them so (the work tree holds a row per coordinate, (2, N))."""
    if "np.stack([rx[order], ry[order]], 1)" not in (at(rev, "bins.py") or ""):
        return base
    rows = {}
    f, bins = base

    def kernel(geo, inst, view, samples, *rest):
        if len(samples.cell0) > 1:
            xy = rows.setdefault(id(samples.xy), np.ascontiguousarray(samples.xy.T))
            samples = samples._replace(xy=xy)
        return f(geo, inst, view, samples, *rest)

    return kernel, bins


def main() -> None:
    lens = "--lens" in sys.argv
    if lens:
        sys.argv.remove("--lens")
    try:
        size, threads, rounds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    except (IndexError, ValueError):
        sys.exit(
            "usage: python tools/raster_ab.py SCENE THREADS ROUNDS [REVISION]   (e.g. 1M 2 5 "
            "HEAD~1)"
        )
    rev = sys.argv[4] if len(sys.argv) > 4 else "HEAD"
    numba.set_num_threads(threads)
    clock = time.process_time if threads == 1 else time.perf_counter
    if size == "dataset":
        scene, poses = dataset_scene()
        sensor = gg.load_sensor("ideal_pinhole")
    else:
        spec = bench_spec(size)
        scene, poses, sensor = to_scene(spec), spec.poses, sensor_640()
    if lens:
        sys.path.insert(0, str(ROOT))
        from benchmarks.lens_frame import LENS
        from benchmarks.lens_ids import LENSES

        sensor = LENSES[LENS]
    r = Renderer(scene, raster="cpu")
    own, own_bins = raster._raster, cpu_renderer.lens_samples
    with tempfile.TemporaryDirectory() as tmp:
        kernels = {
            rev: rows_of_rays(kernel(lambda name: at(rev, name), Path(tmp), "ab_base"), rev),
            "work tree": kernel(None, Path(tmp), "ab_new"),
        }
        best = {k: np.full(len(poses), np.inf) for k in kernels}
        try:
            for f, bins in kernels.values():  # compile
                raster._raster, cpu_renderer.lens_samples = f, bins or own_bins
                r.render(sensor, poses[0], depth_only=True)
            for k in range(rounds):
                for i, p in enumerate(poses):
                    for name, (f, bins) in kernels.items() if k % 2 else reversed(kernels.items()):
                        raster._raster, cpu_renderer.lens_samples = f, bins or own_bins
                        t = clock()
                        r.render(sensor, p, depth_only=True)
                        best[name][i] = min(best[name][i], clock() - t)
        finally:
            raster._raster, cpu_renderer.lens_samples = own, own_bins
    base, new = (1e3 * best[k].mean() for k in kernels)
    print(
        f"{size}{' through the lens' if lens else ''}, {threads} thread(s), {rounds} rounds: "
        f"{rev} {base:.2f} ms, work tree {new:.2f} "
        "ms a frame; "
        f"work tree / {rev} {new / base:.3f}"
    )


if __name__ == "__main__":
    main()
