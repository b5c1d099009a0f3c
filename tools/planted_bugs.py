"""`make planted-bugs`: plant known bugs one at a time (the table below) and count the tests
that catch each.

Every bug is a precise textual substitution (old -> new) in a named file of a scratch copy of
the checkout under build/planted/<bug> (the worktree is never touched). The script first runs
the union of the test selections on an unplanted copy (which must pass, or a failure below
would mean nothing; it also compiles the numba kernels once, whose caches the bug copies
reuse except for the planted module), then, per bug, the bug's selection on its planted copy,
and prints the failing tests, which of them assert an independent truth, and whether the bar
"at least two failing tests, one against an independent truth" is met. A substitution whose
old text is not found exactly once stops the script (the code changed: update the bug).

    python tools/planted_bugs.py                 # every bug
    python tools/planted_bugs.py --bugs a,f1     # some
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import scratch  # noqa: E402  (the scratch copies, shared with tools/mutants.py)

ROOT = Path(__file__).resolve().parents[1]
WORK = ROOT / "build" / "planted"
PYTEST = [
    "-p",
    "no:xdist",
    "-p",
    "no:cacheprovider",
    "-p",
    "no:randomly",
    "-q",
    "-m",
    "not slow",
    "-rfE",
    "--continue-on-collection-errors",
    "-p",
    "_planted_check",
]

# a pytest plugin written into each copy: the run stops (exit 4) unless genie_gl and the tests
# are the copy's own, not the editable install's checkout; and every test's start, failure and
# end is logged to $PLANTED_LOG, so a planted bug that crashes the interpreter (a kernel writing
# past its buffer) still names its test
CHECK_PLUGIN = """
import os
import sys
from pathlib import Path
import pytest

HERE = Path(__file__).resolve().parent
LOG = os.environ["PLANTED_LOG"]


def _log(what, nodeid):
    with open(LOG, "a") as f:
        f.write(f"{what} {nodeid}\\n")
        f.flush()


def pytest_collection_finish(session):
    for name in ("genie_gl", "tests"):
        mod = sys.modules.get(name)
        if mod is None or HERE not in Path(mod.__file__).resolve().parents:
            where = getattr(mod, '__file__', None)
            pytest.exit(f"{name} imported from {where}, not from {HERE}", returncode=4)


def pytest_collectreport(report):
    if report.failed:
        _log("failed", report.nodeid)


def pytest_runtest_logstart(nodeid, location):
    _log("start", nodeid)


def pytest_runtest_logreport(report):
    if report.failed:
        _log("failed", report.nodeid)


def pytest_runtest_logfinish(nodeid, location):
    _log("end", nodeid)
"""


@dataclass(frozen=True)
class Bug:
    name: str
    what: str
    file: str
    old: str
    new: str
    tests: tuple[str, ...]


RENDER = (
    "tests/render/test_analytic.py",
    "tests/render/test_hard_cases.py",
    "tests/render/test_reference.py",
    "tests/render/test_readback.py",
    "tests/capture/test_supersample.py",
)
CLOUD = (
    "tests/cloud/test_unproject_kernel.py",
    "tests/export/test_cloud_export.py",
    "tests/cloud/test_frame_chunks.py",
)
LENS = (
    "tests/sensors/test_sensors.py",
    "tests/lens/test_lens_truths.py",
    "tests/bench/test_stability.py",
    "tests/render/test_analytic.py::test_distorted_render_puts_points_where_cv2_projects_them",
)
NOISE = (
    "tests/sensors/test_sensors.py",
    "tests/effects/test_effects.py",
    "tests/effects/test_fused_kernels.py",
)
LABELS = (
    "tests/export/test_cloud_export.py",
    "tests/export/test_export_limits.py",
    "tests/test_field_readers.py",
)
LAYOUT = ("tests/layout",)

BUGS = [
    Bug(
        "a",
        "principal point off by half a pixel in the projection from K (x only)",
        "genie_gl/render/projection.py",
        "2 * (cx + 0.5) / width - 1",
        "2 * cx / width - 1",
        RENDER,
    ),
    Bug(
        "b",
        "NaN depth counted as valid in the unprojection kernel's per-pixel path",
        "genie_gl/cloud/kernels.py",
        "n += uint64(d[p + k] > 0)",
        "n += uint64(not d[p + k] <= 0)",
        CLOUD,
    ),
    Bug(
        "c",
        "wide pinhole view behind a lens: its height computed from fx instead of fy",
        "genie_gl/lens/distortion.py",
        "h = int(math.ceil(fy * hi_y + cy)) + 3",
        "h = int(math.ceil(fx * hi_y + cy)) + 3",
        LENS,
    ),
    Bug(
        "d1",
        "stereo sigma grows with z instead of z^2 (the model's sigma(), noise.py)",
        "genie_gl/effects/noise.py",
        "return z * z * self.sigma_d_px(sensor)",
        "return z * self.sigma_d_px(sensor)",
        NOISE,
    ),
    Bug(
        "d2",
        "stereo sigma grows with z instead of z^2 (the compiled pass that applies it)",
        "genie_gl/effects/kernels.py",
        "noisy = z + draws[u] * (z * z * sigma_d / fb)",
        "noisy = z + draws[u] * (z * sigma_d / fb)",
        NOISE,
    ),
    Bug(
        "e",
        "SemanticKITTI instance packed with << 15 instead of << 16",
        "genie_gl/export/semantickitti.py",
        "instance.astype(np.uint32) << 16 |",
        "instance.astype(np.uint32) << 15 |",
        LABELS,
    ),
    Bug(
        "f1",
        "merge: the equal-extent (equal height along the shared edge) check dropped",
        "genie_gl/layout/merge.py",
        "& (k2[order][1:] == k2[order][:-1])",
        "& True",
        LAYOUT,
    ),
    Bug(
        "f2",
        "merge: the touch test's tolerance comparison flipped (<= tol -> > tol)",
        "genie_gl/layout/merge.py",
        "- pos[order][1:]) <= tol",
        "- pos[order][1:]) > tol",
        LAYOUT,
    ),
    Bug(
        "f3",
        "merge: the touch test takes the next sibling's length instead of its own",
        "genie_gl/layout/merge.py",
        "pos[order][:-1] + size[order][:-1] - pos[order][1:]",
        "pos[order][:-1] + size[order][1:] - pos[order][1:]",
        LAYOUT,
    ),
    Bug(
        "f4",
        "merge: the merged rectangle's far edge from the first part's length (wrong corner)",
        "genie_gl/layout/merge.py",
        "y[o_last] + h[o_last] - y[o_first]",
        "y[o_last] + h[o_first] - y[o_first]",
        LAYOUT,
    ),
    Bug(
        "f5",
        "merge: the absolute value dropped from the touch test (a gap between two regions joins "
        "them)",
        "genie_gl/layout/merge.py",
        "touch = np.abs(pos[order][:-1] + size[order][:-1] - pos[order][1:]) <= tol",
        "touch = (pos[order][:-1] + size[order][:-1] - pos[order][1:]) <= tol",
        LAYOUT,
    ),
    # from the weak tests: a stride bug in the voxel key (voxels collide, few are kept)
    Bug(
        "g",
        "voxel down-sampling: a wrong stride in the voxel key (distinct voxels collide)",
        "genie_gl/cloud/process.py",
        "flat = (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]",
        "flat = keys[:, 0] * dims[1] + keys[:, 1] * dims[2] + keys[:, 2]",
        ("tests/export/test_cloud_export.py",),
    ),
    # from the weak tests: a label raster flipped upside down (one label everywhere passes)
    Bug(
        "h",
        "layout label raster flipped (row 0 at the top instead of y0)",
        "genie_gl/layout/model.py",
        "return LabelRaster(labels, names",
        "return LabelRaster(labels[::-1], names",
        (
            "tests/layout/test_layout.py",
            "tests/placement/test_placement_fitness.py",
            "tests/placement/test_placement_free_floor.py",
        ),
    ),
]

# Failing test functions that assert a truth computed independently of the code under test
# (analytic values, cv2, another renderer or reader, values written out by hand), by function
# name. A failing test not listed here compares the code with itself (two paths, two runs) or
# checks an invariant: it still counts as catching the bug, not as an independent truth.
INDEPENDENT = {
    # rendering (render/projection.py)
    "test_tilted_plane_depth_is_exact": "analytic depth of a tilted plane",
    "test_sphere_depth_matches_closed_form": "closed-form ray-sphere depth",
    "test_boxes_depth_and_ids_match_exact_ray_casting": "exact ray caster (float64 slab test)",
    "test_projected_point_lands_where_cv2_puts_it": "cv2.projectPoints of a marker",
    "test_distorted_render_puts_points_where_cv2_projects_them": "cv2.projectPoints of markers through the lens",  # noqa: E501
    "test_camera_inside_a_closed_mesh_sees_its_inner_walls": "exact ray caster",
    "test_scene_far_from_origin_renders_to_the_millimetre": "exact ray caster",
    "test_planes_1mm_apart_at_50m_with_far_near_ratio_1e5": "analytic plane depth",
    "test_grazing_incidence_85_degrees": "analytic plane depth",
    "test_agrees_with_pyrender_seg_mode": "pyrender (an independent renderer)",
    "test_a_tilted_plane_keeps_its_exact_depth_at_every_supersampling": "analytic plane depth",
    "test_capture_is_independent_of_worker_count": "exact ray caster (besides 1 vs 2 workers)",
    "test_osmesa_fallback_renders_the_same_depth": "exact ray caster (besides EGL)",
    # unprojection (cloud/kernels.py)
    "test_kernel_writes_exactly_the_reference_points": "float64 first principles, NaN/negative "
    "depth no return",
    "test_unprojection_matches_first_principles_for_every_lens": "K^-1 / cv2.undistortPoints in float64",  # noqa: E501
    "test_unprojection_drops_nan_depth_in_every_path": "holes counted by hand, points in float64 "
    "along each ray",
    "test_merge_counts_and_normals_agree_with_the_kernel_on_invalid_depths": "numpy's count of depth > 0",  # noqa: E501
    # lens views (lens/distortion.py)
    "test_the_wide_view_holds_every_ray_one_pixel_inside_its_border": "cv2.undistortPoints rays, K from fx/fy",  # noqa: E501
    "test_distortion_maps_stay_inside_the_wide_render": "cv2.undistortPoints rays inside the view",
    "test_distortion_maps_put_rays_where_cv2_projects_them": "cv2.projectPoints",
    # noise (effects/noise.py, effects/kernels.py)
    "test_sigma_models_against_the_papers_at_several_depths": "the papers' sigma(z) at 0.2-6 m, written out",  # noqa: E501
    "test_noise_sigma_on_a_flat_wall_matches_the_model": "the papers' sigma(z) at 0.5, 1, 2, 4 m, "
    "written out",
    "test_stereo_noise_grows_with_the_square_of_depth": "sigma(4 m) / sigma(1 m) = 16",
    "test_sigma_d_and_baseline_come_from_the_calibration_unless_the_profile_sets_them": "z^2 sigma_d / (f b) at 2 m from the calibration, written out",  # noqa: E501
    "test_nguyen_incidence_term_only_past_60_degrees_clamped_at_85_and_only_when_asked": "Nguyen's terms and the stereo sigma at 2 m, written out",  # noqa: E501
    "test_shipped_profiles_load": "the Zivid datasheet's 60 um at 0.7 m",
    "test_depth_noise_drops_what_it_pushes_behind_the_camera_and_keeps_holes": "Gaussian tail Phi(-z/sigma)",  # noqa: E501
    # SemanticKITTI labels (export/semantickitti.py)
    "test_semantickitti_label_words_are_the_documented_bits": "label words written by hand",
    "test_label_words_at_the_16_bit_limits": "label words and bytes written by hand",
    "test_the_table_file_and_reading_through_it": "label words written by hand",
    "test_semantickitti_reads_back_as_its_api_does": "label & 0xFFFF / >> 16 as SemanticKITTI's "
    "API reads them",
    "test_semantic_kitti_api_loads_and_evaluates_the_dataset": "semantic-kitti-api's own LaserScan / iouEval",  # noqa: E501
    "test_instance_ids_beyond_16_bits_are_renumbered_or_refused": "semantic-kitti-api's reader",
    # layout merge (layout/merge.py): rectangles, trees and records worked out by hand
    **{
        name: "rectangles / trees worked out by hand"
        for name in (
            "test_leaves_under_different_parents_merge_into_the_exact_rectangle",
            "test_stacked_parts_merge_both_ways",
            "test_different_types_never_merge",
            "test_different_orientations_never_merge",
            "test_an_l_shaped_union_is_not_made",
            "test_strip_cuts_an_l_so_the_bordering_parts_merge",
            "test_strip_handles_a_t_and_the_transposed_l",
            "test_without_the_merge_level_nothing_merges",
            "test_merge_leaves_arrays",
            "test_merge_tree_mapping_and_record_by_hand",
            "test_merge_on_a_node_list_by_hand",
            "test_merge_leaves_joins_columns_first_then_rows",
            "test_merge_leaves_keeps_the_pieces_of_one_cut_leaf_apart",
            "test_a_piece_that_joined_a_neighbour_is_no_longer_a_piece",
            "test_merge_leaves_tolerance_is_inclusive",
            "test_merge_leaves_small_inputs_and_dtypes",
            "test_merge_tree_of_one_and_two_nodes",
            "test_regions_emptied_by_a_merge_go_all_the_way_up",
            "test_a_merged_region_hangs_under_the_lowest_common_ancestor",
            "test_a_join_elsewhere_keeps_the_pieces_marked",
            "test_strip_cuts_by_hand_anywhere_in_the_plane",
            "test_the_record_of_several_merges_by_hand",
            "test_merge_on_hand_made_layouts_gives_the_exact_rectangles",
            "test_an_l_shaped_union_is_not_made_whichever_side_is_shorter",
        )
    },
    # layout label raster (layout/model.py)
    "test_label_raster_puts_each_label_in_its_cells": "the label array written out by hand",
    "test_fitness_is_the_covered_weight_share_counted_cell_by_cell": "coverage counted cell by cell from the leaves",  # noqa: E501
    "test_greedy_takes_the_disc_with_most_new_weight_each_time": "greedy gains counted cell by cell from the leaves",  # noqa: E501
    # voxel down-sampling (cloud/process.py)
    "test_sampling_and_cleaning": "the first point of each voxel, found one point at a time",
    "test_voxel_downsample_keeps_the_first_point_of_each_voxel_by_hand": "kept indices written by hand",  # noqa: E501
}


def independent(test: str) -> str | None:
    return INDEPENDENT.get(test.split("::")[-1].split("[")[0])


def copy_checkout(dst: Path, src: Path = ROOT, caches: bool = False) -> None:
    """A scratch copy (tools/scratch.py) with this script's pytest plugin in it."""
    scratch.copy_checkout(dst, src, caches=caches, extra=("_planted_check.py",) if caches else ())
    (dst / "_planted_check.py").write_text(CHECK_PLUGIN)


def plant(work: Path, bug: Bug) -> None:
    path = work / bug.file
    text = path.read_text()
    n = text.count(bug.old)
    if n != 1:
        raise SystemExit(
            f"bug {bug.name}: {bug.file} holds {n} copies of {bug.old!r}, expected exactly 1: "
            "the code changed; update the bug in tools/planted_bugs.py"
        )
    path.write_text(text.replace(bug.old, bug.new))
    # numba's on-disk caches of the planted module go (the others are the base copy's, still valid)
    for stale in (path.parent / "__pycache__").glob(path.stem + ".*"):
        stale.unlink()


def run_tests(
    work: Path, tests: tuple[str, ...] | list[str]
) -> tuple[int, list[str], list[str], str]:
    """Run ``tests`` in ``work``; returns (exit code, failing test ids, crashing test ids, output).
    A test that kills the interpreter is noted as crashing and the run goes on without it."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTEST_ADDOPTS")}
    env["PYTHONPATH"] = str(work)
    env.setdefault("HYPOTHESIS_PROFILE", "ci")
    log = work / "planted.log"
    env["PLANTED_LOG"] = str(log)
    failed: set[str] = set()
    crashed: list[str] = []
    out = ""
    for _ in range(20):
        log.write_text("")
        # -P: the copy's root is on sys.path only through PYTHONPATH, ahead of the editable
        # install's checkout (its .pth); _planted_check stops the run if that ever fails
        r = subprocess.run(
            [
                sys.executable,
                "-P",
                "-m",
                "pytest",
                *PYTEST,
                *tests,
                *(a for c in crashed for a in ("--deselect", c)),
            ],
            cwd=work,
            env=env,
            capture_output=True,
            text=True,
        )
        out = r.stdout + r.stderr
        started, ended = [], set()
        for line in log.read_text().splitlines():
            what, _, nodeid = line.partition(" ")
            if what == "failed":
                failed.add(nodeid)
            elif what == "start":
                started.append(nodeid)
            elif what == "end":
                ended.add(nodeid)
        if r.returncode in (0, 1, 4, 5):
            return r.returncode, sorted(failed), crashed, out
        open_ = [t for t in started if t not in ended]
        if (
            not open_
        ):  # every test ran; the interpreter died after them (a corrupted heap freed at exit)
            return r.returncode, sorted(failed), crashed, out
        crashed.append(open_[-1])
    raise SystemExit(f"pytest in {work} kept crashing: {crashed}")


def function_of(test: str) -> str:
    """tests/x.py::test_name[param] -> tests/x.py::test_name"""
    return test.split("[", 1)[0]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--bugs", default="all", help=f"comma-separated: {', '.join(b.name for b in BUGS)} (or all)"
    )
    p.add_argument(
        "--skip-unplanted",
        action="store_true",
        help="no run of the unplanted copy first (while working on a bug; its failures then mean "
        "less)",
    )
    a = p.parse_args(argv)
    bugs = BUGS if a.bugs == "all" else [b for b in BUGS if b.name in a.bugs.split(",")]
    if not bugs:
        p.error("no such bug")
    # every substitution is checked against the current code before anything runs
    for bug in bugs:
        n = (ROOT / bug.file).read_text().count(bug.old)
        if n != 1:
            raise SystemExit(
                f"bug {bug.name}: {bug.file} holds {n} copies of {bug.old!r}, expected exactly 1: "
                "the code changed; update the bug in tools/planted_bugs.py"
            )
    t0 = time.perf_counter()
    base = WORK / "_unplanted"
    copy_checkout(base)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(base)
    where = subprocess.run(
        [sys.executable, "-P", "-c", "import genie_gl; print(genie_gl.__file__)"],
        cwd="/",
        env=env,
        capture_output=True,
        text=True,
    ).stdout.strip()
    if not where.startswith(str(base) + os.sep):
        raise SystemExit(f"the scratch copy is not what gets imported: genie_gl from {where!r}")
    selection = sorted({t for b in bugs for t in b.tests})
    t = time.perf_counter()
    code, failed, crashed, out = (
        (0, [], [], "skipped\n") if a.skip_unplanted else run_tests(base, selection)
    )
    summary = out.strip().splitlines()[-1] if out.strip() else ""
    print(
        f"unplanted copy (genie_gl from {where}): {summary} [{time.perf_counter() - t:.0f} s]",
        flush=True,
    )
    if code != 0 or failed or crashed:
        print(out[-4000:])
        raise SystemExit(
            "the unplanted copy fails its own selection: planted failures would mean nothing"
        )
    rows, ok_all = [], True
    for bug in bugs:
        work = WORK / bug.name
        copy_checkout(work, base, caches=True)
        plant(work, bug)
        t = time.perf_counter()
        code, failed, crashed, out = run_tests(work, bug.tests)
        if code == 4:
            print(out[-2000:])
            raise SystemExit(f"bug {bug.name}: the run did not import the planted copy")
        caught = sorted(set(failed) | set(crashed))
        functions = sorted({function_of(f) for f in caught})
        truths = {f: independent(f) for f in functions}
        n_ind = sum(1 for v in truths.values() if v)
        ok = len(functions) >= 2 and n_ind >= 1
        ok_all &= ok
        print(
            f"\n[{bug.name}] {bug.what}\n    {bug.file}: {bug.old!r} -> {bug.new!r}\n"
            f"    {len(caught)} failing test ids in {len(functions)} test functions, {n_ind} of "
            "them against an "
            f"independent truth [{time.perf_counter() - t:.0f} s]: {'PASS' if ok else 'FAIL'}",
            flush=True,
        )
        for f in functions:
            ids = [c for c in caught if function_of(c) == f]
            note = (
                f" ({len(ids)} id{'s' if len(ids) > 1 else ''})"
                if len(ids) > 1 or ids[0] != f
                else ""
            )
            note += " CRASHED the interpreter" if any(c in crashed for c in ids) else ""
            print(f"      {f}{note}" + (f"\n          truth: {truths[f]}" if truths[f] else ""))
        rows.append((bug.name, len(caught), len(functions), n_ind, ok))
    print(
        "\nbar: a bug is caught by >= 2 test functions, >= 1 of them against an independent truth"
    )
    print("bug  ids  functions  independent  bar")
    for name, n, nf, ni, ok in rows:
        print(f"{name:4s} {n:4d}  {nf:9d}  {ni:11d}  {'PASS' if ok else 'FAIL'}")
    print(f"total {time.perf_counter() - t0:.0f} s")
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
