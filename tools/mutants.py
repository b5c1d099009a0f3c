"""`make mutants`: mutation testing of the numerical core with mutmut.

Each group below names the modules where a wrong number is silent and the tests that must
catch it. For every group a scratch copy of the checkout is made under build/mutants/<group>
(the worktree is never touched), mutmut mutates only that group's modules, runs only that
group's tests against each mutant (stopping at the first failure), and this script prints
the kill rate per module and every surviving mutant with its diff.

mutmut leaves decorated functions alone: the numba kernels (``@njit``) are not mutated, only
the Python around them (ray tables, poses, counts, buffers). Their own truths are the kernel
tests (tests/cloud/test_unproject_kernel.py: first principles in float64, NaN holes).

    python tools/mutants.py --modules layout,labels --timeout 900
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mutants_equivalent import classify  # noqa: E402  (why each known survivor cannot change a number)
from scratch import copy_checkout  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
GROUPS: dict[str, tuple[list[str], list[str], list[str]]] = {
    # group: (modules to mutate, the functions in them where a wrong number is silent
    #         (mutmut name globs), tests that must kill the mutants)
    "projection": (
        ["genie_gl/render/projection.py"],
        ["*.projection.x_clip_coefficients__*", "*.projection.x_rigid_inverse__*"],
        ["tests/render/test_analytic.py", "tests/render/test_hard_cases.py"],
    ),
    "lens": (
        ["genie_gl/camera.py", "genie_gl/lens/distortion.py"],
        [
            "*.camera.x_tilt_matrix__*",
            "*.camera.x_distort_normalized__*",
            "*.camera.x__coefficients__*",
            "*.camera.x__radial__*",
            "*.camera.x__decentring__*",
            "*.camera.x_fisheye_theta_d__*",
            "*.camera.x__find_fold__*",
            "*.camera.x__max_off_axis__*",
            "*.camera.xǁCameraǁproject__*",
            "*.camera.xǁCameraǁunproject__*",
            "*.camera.xǁCameraǁdirections__*",
            "*.camera.xǁCameraǁrays__*",
            "*.camera.x__pinhole_inverse__*",
            "*.camera.x__newton__*",
            "*.camera.x__untilt__*",
            "*.camera.x__homography__*",
            "*.camera.x__increasing_inverse__*",
            "*.camera.x__fisheye_inverse__*",
            "*.camera.x__omni_inverse__*",
            "*.camera.x__pixel_directions__*",
            "*.camera.x__pixel_rays__*",
            "*.distortion.x_project__*",
            "*.distortion.x__view__*",
            "*.distortion.x__scale_min__*",
            "*.distortion.x__build_lens_views__*",
            "*.distortion.x_lens_views__*",
            "*.distortion.x_distortion_maps__*",
        ],
        # the lens equations against cv2 and first principles, no GL: a few seconds in all
        # (the rendered lens tests cost minutes per mutant). The lens caches (_fold,
        # _directions, _rays, _lens_views) wrap undecorated bodies so that mutmut reaches them
        [
            "tests/lens/test_lens_truths.py",
            "tests/lens/test_lens_inverse_hard.py",
            *(
                f"tests/sensors/test_sensors.py::{t}"
                for t in (
                    "test_distortion_maps_put_rays_where_cv2_projects_them",
                    "test_distortion_maps_stay_inside_the_wide_render",
                    "test_numpy_lens_projection_equals_cv2",
                    "test_strong_barrel_distortion_drops_what_the_model_folds",
                    "test_project_without_distortion_is_the_pinhole_k",
                )
            ),
            # (its hypothesis tests of the same lens maps against cv2 cost ~4 s per mutant)
            *(
                f"tests/bench/test_stability.py::{t}"
                for t in (
                    "test_lens_folds_are_dropped_not_wrapped",
                    "test_cube_faces_for_a_wide_fisheye_and_one_view_for_a_narrow_lens",
                    "test_automatic_oversampling_gives_every_lens_pixel_its_own_view_pixel",
                )
            ),
        ],
    ),
    "unprojection": (
        ["genie_gl/cloud/unproject.py"],
        ["*.unproject.x_*"],
        [
            "tests/cloud/test_unproject_kernel.py",
            "tests/export/test_cloud_export.py",
            "tests/cloud/test_frame_chunks.py",
            "tests/cloud/test_unproject_contract.py",
        ],
    ),
    # the noise models' numbers (DepthNoise's cost_per_mpx is left out: an estimate the planner
    # ranks effects by, measured by `genie bench planning`, never a number in the data)
    "noise": (
        ["genie_gl/effects/noise.py"],
        ["*.noise.xǁDepthNoiseǁ[!c]*", "*.noise.xǁRangeLimitsǁapply__*"],
        [
            "tests/sensors/test_sensors.py",
            "tests/effects/test_effects.py",
            "tests/effects/test_fused_kernels.py",
        ],
    ),
    "labels": (
        [
            "genie_gl/export/semantickitti.py",
            "genie_gl/export/ply.py",
            "genie_gl/export/pcd.py",
            "genie_gl/export/npz.py",
        ],
        [
            "*.semantickitti.x_pack_labels__*",
            "*.semantickitti.x_write__*",
            "*.semantickitti.x_read__*",
            "*.semantickitti.x_encode_instances__*",
            "*.ply.x_*",
            "*.pcd.x_*",
            "*.npz.x_*",
        ],
        ["tests/export/test_cloud_export.py", "tests/export/test_export_limits.py"],
    ),
    "layout": (
        ["genie_gl/layout/engine.py", "genie_gl/layout/generators.py", "genie_gl/layout/merge.py"],
        # the merge layer (layout/merge.py since the rewrite; engine.merge is its node-list
        # front), the grid generator and the rectangle cover of a mask
        [
            "*.engine.x_merge__*",
            "*.merge.x_*",
            "*.generators.xǁGridǁgenerate__*",
            "*.generators.x_rectangles__*",
        ],
        [
            "tests/layout/test_merge_layer.py",
            "tests/layout/test_layout.py",
            "-k",
            "not shipped_strategies_generate",
        ],
    ),
    "merge": (
        ["genie_gl/layout/merge.py"],
        ["*.merge.x_*"],  # the merge layer alone (a subset of "layout")
        [
            "tests/layout/test_merge_layer.py",
            "tests/layout/test_layout.py",
            "-k",
            "not shipped_strategies_generate",
        ],
    ),
    "placement": (
        ["genie_gl/placement/genetic.py"],
        # the coverage a placement is scored by; the GA's operators (selection, crossover,
        # mutation rate) only change how good a search is, never a reported number: left out
        [
            "*.placement.xǁCoverageProblemǁ__init____*",
            "*.placement.xǁCoverageProblemǁfitness*",
            "*.placement.x_greedy_indices__*",
            "*.placement.x_greedy_placement__*",
        ],
        # (the bit sets against the cell-by-cell kernels, which fractional weights take; the
        # free-floor rule for low mounts)
        [
            "tests/placement/test_placement_fitness.py",
            "tests/placement/test_placement_bits.py",
            "tests/placement/test_placement_free_floor.py",
            "tests/sensors/test_sensors.py",
        ],
    ),
}
# lines that only word an error or a log message: not numbers
NOT_NUMBERS = [
    r"raise \w+Error\(",
    r"^\s*f?\"[^\"]*\"\)?$",
    r"log\.(info|warning|debug)\(",
    r"warnings\.warn\(",
]


def toml_list(items: list[str]) -> str:
    return "[" + ", ".join(f'"{i}"' for i in items) + "]"


# seconds added to a mutant's expected test time before mutmut's CPU limit (x 8; its wall-clock
# limit is half that) applies. The unprojection group's mutants can hand the numba kernel an
# array of another layout or type, which compiles a new specialisation in the mutant's child;
# with mutmut's default 1 s such a mutant could be stopped mid-compile (a "timeout", counted as
# killed without a test failing). Its renders need genie_gl.render.context's fork rule: mutmut
# forks every mutant from the process that ran the clean tests through EGL, and a forked child's
# EGL read-back waited for the parent's driver threads forever (the timeouts of earlier runs)
TIMEOUT_CONSTANT = {"unprojection": 30.0}


def prepare(group: str, work: Path) -> None:
    modules, _, tests = GROUPS[group]
    copy_checkout(work)
    # mutmut writes the mutated copy to work/mutants, which PYTHONPATH names; it must exist
    # before mutmut starts: Python caches a missing sys.path entry as "no finder" for the life of
    # the process, so the stats run imported genie_gl and tests from the editable install's
    # checkout (/work/main on sys.path through its .pth) instead: no trampoline was hit ("could
    # not find any test case"), or tests that only this copy has failed to import
    (work / "mutants").mkdir()
    with open(work / "pyproject.toml", "a") as f:
        f.write(f"""
[tool.mutmut]
source_paths = ["genie_gl"]
only_mutate = {toml_list(modules)}
also_copy = ["layouts", "sensors", "shaders", "README.md"]
pytest_add_cli_args = ["-p", "no:xdist", "-p", "no:cacheprovider", "-x", "-q", "-m", "not slow"]
pytest_add_cli_args_test_selection = {toml_list(tests)}
do_not_mutate_patterns = [{", ".join("'" + p + "'" for p in NOT_NUMBERS)}]
use_git_change_detection = false
timeout_multiplier = 4.0
timeout_constant = {TIMEOUT_CONSTANT.get(group, 1.0)}
""")


def results(work: Path, env: dict) -> dict[str, str]:
    out = subprocess.run(
        [sys.executable, "-P", "-m", "mutmut", "results", "--all", "true"],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
    ).stdout
    status = {}
    for line in out.splitlines():
        m = re.match(r"\s*([\w.]+__mutmut_\d+): (.+)$", line)
        if m:
            status[m.group(1)] = m.group(2).strip()
    return status


def module_of(mutant: str, modules: list[str]) -> str:
    for mod in modules:
        dotted = mod[:-3].replace("/", ".")
        if mutant.startswith(dotted + "."):
            return mod
    return "?"


# The recheck's worker: imports pytest and the package once (collecting the group's tests, so
# every import is paid for), then forks one child per mutant that activates it the way mutmut
# does (MUTANT_UNDER_TEST) and runs the tests plainly; prints "name exit-code" per mutant.
RECHECK_WORKER = r"""
import json, os, signal, sys
import pytest
job = json.load(open(sys.argv[1]))
args = ["--rootdir=.", "-p", "no:xdist", "-p", "no:cacheprovider", "-p", "no:randomly", "-q",
        "-m", "not slow"]
out, err = os.dup(1), os.dup(2)
null = os.open(os.devnull, os.O_WRONLY)
os.dup2(null, 1); os.dup2(null, 2)
pytest.main(["--collect-only", "-qqq", *args, *job["selection"]])
for name, tests in job["mutants"]:
    pid = os.fork()
    if pid == 0:
        os.environ["MUTANT_UNDER_TEST"] = name
        signal.alarm(int(job["timeout"]))
        os._exit(int(pytest.main(["-x", *args, *(tests or job["selection"])])))
    _, status = os.waitpid(pid, 0)
    code = os.waitstatus_to_exitcode(status)
    os.write(out, f"{name} {code}\n".encode())
"""


def recheck(work: Path, env: dict, status: dict[str, str], tests: list[str], budget: float) -> None:
    """Run the tests once more, plainly, against each survivor, each in a fresh fork of one
    process that has imported pytest and the package but run no test (about a second a mutant,
    not the ten of a new interpreter). A safety net for mutmut's attribution: it runs only the
    tests its stats run saw reach the mutated function, and forks each mutant from the process
    that ran the clean tests (tests/conftest.py empties the package's caches for this; a cache
    it does not know would hide a mutant again). The recheck runs the tests mutmut attributed
    to the function, or the group's whole selection where it attributed none ("no tests").
    Bounded by ``budget`` seconds."""
    import json

    stats_file = work / "mutants" / "mutmut-stats.json"
    by_function = (
        json.loads(stats_file.read_text())["tests_by_mangled_function_name"]
        if stats_file.exists()
        else {}
    )
    todo = []
    # a "timeout" too: mutmut's wall-clock limit is 4x the clean tests' time, which a busy
    # machine can reach without any mutant hanging; rerun plainly, it stays a timeout only if
    # the tests run past the recheck's own alarm (300 s) again
    # and a "segfault" or "suspicious": a crash of the test process (pytest printing a mutant's
    # bad array can crash) says nothing about whether a test fails
    for name in sorted(
        k
        for k, v in status.items()
        if v in ("survived", "no tests", "timeout", "segfault", "suspicious")
    ):
        attributed = sorted(by_function.get(name.rsplit("__mutmut_", 1)[0], []))
        todo.append((name, attributed))
    if not todo or budget <= 0:
        return
    job = work / "recheck.json"
    job.write_text(json.dumps({"mutants": todo, "selection": tests, "timeout": 300}))
    proc = subprocess.Popen(
        [sys.executable, "-P", "-c", RECHECK_WORKER, str(job)],
        cwd=work / "mutants",
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    t = time.perf_counter()
    try:
        for line in proc.stdout:
            name, code = line.split()
            if int(code) in (1, 3):  # a test failed (not a usage or collection error)
                status[name] = "killed"
            elif int(code) in (-14, -9, 142):  # SIGALRM: the mutant hangs the tests
                status[name] = "timeout"
            elif int(code) == 0:  # every test passed: it survives
                status[name] = "survived"
            if time.perf_counter() - t > budget:
                break
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def run_group(
    group: str, timeout: float, children: int, recheck_s: float = 600, report_only: bool = False
) -> list[tuple[str, int, int, list[str]]]:
    modules, functions, _ = GROUPS[group]
    work = ROOT / "build" / "mutants" / group
    if report_only:  # the results of the last run in build/mutants/<group>, rechecked
        timeout = 0
    else:
        prepare(group, work)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    env["PYTHONPATH"] = str(work / "mutants")
    env["HYPOTHESIS_PROFILE"] = (
        "mutants"  # fixed examples, no deadline (mutmut's tracing slows code)
    )
    t = time.perf_counter()
    finished = False
    for attempt in range(3):  # a first run can fail its setup (see below): again
        left = timeout - (time.perf_counter() - t)
        if left <= 0:
            break
        with open(work / f"mutmut-run-{attempt}.log", "w") as log:
            # its own session: on the time bound, mutmut and every mutant it forked stop together
            # -P: keep the scratch root (its unmutated genie_gl/ and tests/ packages) off sys.path
            proc = subprocess.Popen(
                [
                    sys.executable,
                    "-P",
                    "-m",
                    "mutmut",
                    "run",
                    "--max-children",
                    str(children),
                    *functions,
                ],
                cwd=work,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
            try:
                proc.wait(timeout=left)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                break
        r = proc
        log_text = (work / f"mutmut-run-{attempt}.log").read_text()
        # a first run over a fresh copy could fail its stats run or see no test hit any mutant
        # (it imported the installed checkout: see prepare(), which now prevents it); kept as a
        # fallback: a second run over the generated mutants collects the stats properly
        if not any(
            s in log_text
            for s in (
                "BadTestExecutionCommandsException",
                "failed to collect stats",
                "could not find any test case for any mutant",
            )
        ):
            finished = r.returncode == 0
            break
        # the failed run's partial test-to-function stats would hide tests from the retry
        for stale in (work / "mutants").glob("mutmut-stats*.json"):
            stale.unlink()
    status = {
        k: v for k, v in results(work, env).items() if any(fnmatch.fnmatch(k, f) for f in functions)
    }
    recheck(work, env, status, GROUPS[group][2], budget=recheck_s)
    rows = []
    for mod in modules:
        mine = {k: v for k, v in status.items() if module_of(k, modules) == mod}
        tested = {k: v for k, v in mine.items() if v not in ("not checked", "skipped")}
        killed = [
            k for k, v in tested.items() if v in ("killed", "timeout", "caught by type check")
        ]
        survived = sorted(
            k for k, v in tested.items() if v not in ("killed", "timeout", "caught by type check")
        )
        rows.append((mod, len(killed), len(tested), survived, len(mine) - len(tested)))
    print(
        f"[{group}] {'done' if finished else f'stopped at the {timeout:.0f} s bound'} "
        f"in {time.perf_counter() - t:.0f} s",
        flush=True,
    )
    for mod, k, n, surv, unchecked in rows:
        rate = f"{100 * k / n:5.1f} %" if n else "   - "
        print(
            f"  {mod:40s} {k:4d} / {n:4d} killed  {rate}"
            + (f"  ({unchecked} not run)" if unchecked else "")
        )
    unclassified = 0
    for mod, k, n, surv, _ in rows:
        for name in surv:
            print(f"  survived: {name} ({status[name]})")
            diff = subprocess.run(
                [sys.executable, "-P", "-m", "mutmut", "show", name],
                cwd=work,
                env=env,
                capture_output=True,
                text=True,
            ).stdout
            lines = [
                line
                for line in diff.splitlines()
                if line[:1] in "+-" and line[:3] not in ("+++", "---")
            ]
            print("    " + "\n    ".join(lines))
            reason = classify(name, lines)
            unclassified += reason is None
            print(
                f"    equivalent: {reason}"
                if reason
                else "    UNCLASSIFIED: a test should kill it, or a reason "
                "added to tools/mutants_equivalent.py"
            )
    if unclassified:
        print(f"  {unclassified} survivor(s) unclassified")
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--modules", default="all", help=f"comma-separated groups: {', '.join(GROUPS)} (or all)"
    )
    p.add_argument(
        "--timeout", type=float, default=1200, help="seconds per group (the machine is shared)"
    )
    p.add_argument("--children", type=int, default=2, help="mutants run side by side")
    p.add_argument(
        "--report-only", action="store_true", help="no new run: report (and recheck) the last one"
    )
    p.add_argument(
        "--recheck",
        type=float,
        default=600,
        help="seconds per group to rerun the tests on survivors",
    )
    a = p.parse_args(argv)
    groups = list(GROUPS) if a.modules == "all" else a.modules.split(",")
    unknown = [g for g in groups if g not in GROUPS]
    if unknown:
        p.error(f"unknown group(s) {unknown}; expected {', '.join(GROUPS)}")
    total_k = total_n = 0
    for g in groups:
        for _, k, n, _, _ in run_group(g, a.timeout, a.children, a.recheck, a.report_only):
            total_k, total_n = total_k + k, total_n + n
    if total_n:
        print(f"all groups: {total_k} / {total_n} killed ({100 * total_k / total_n:.1f} %)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
