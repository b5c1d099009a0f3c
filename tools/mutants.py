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
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GROUPS: dict[str, tuple[list[str], list[str], list[str]]] = {
    # group: (modules to mutate, the functions in them where a wrong number is silent
    #         (mutmut name globs), tests that must kill the mutants)
    "projection": (["genie_gl/render/projection.py"],
                   ["*.projection.x_clip_coefficients__*", "*.projection.x_rigid_inverse__*"],
                   ["tests/render/test_analytic.py", "tests/render/test_hard_cases.py"]),
    "lens": (["genie_gl/camera.py", "genie_gl/sensors/distortion.py"],
             ["*.camera.x_distort_normalized__*", "*.camera.x_fisheye_theta_d__*", "*.camera.x__pinhole_inverse__*",
              "*.camera.x__fisheye_inverse__*", "*.camera.xǁCameraǁproject__*", "*.camera.xǁCameraǁunproject__*",
              "*.distortion.x_project__*", "*.distortion.x__view__*", "*.distortion.x__lens_views__*"],
             # the lens equations against cv2 and first principles; the rendered lens tests
             # (render/test_analytic.py, test_stability.py) cost minutes per mutant
             ["tests/sensors/test_sensors.py", "tests/cloud/test_unproject_kernel.py"]),
    "unprojection": (["genie_gl/cloud/unproject.py"], ["*.unproject.x_*"],
                     ["tests/cloud/test_unproject_kernel.py", "tests/cloud/test_cloud_export.py",
                      "tests/cloud/test_frame_chunks.py"]),
    "noise": (["genie_gl/sensors/noise.py"], ["*.noise.xǁDepthNoiseǁ*", "*.noise.xǁRangeLimitsǁapply__*"],
              ["tests/sensors/test_sensors.py", "tests/sensors/test_effects.py"]),
    "labels": (["genie_gl/export/semantickitti.py", "genie_gl/export/ply.py", "genie_gl/export/pcd.py",
                "genie_gl/export/npz.py"],
               ["*.semantickitti.x_pack_labels__*", "*.semantickitti.x_write__*", "*.semantickitti.x_read__*",
                "*.semantickitti.x_encode_instances__*", "*.ply.x_*", "*.pcd.x_*", "*.npz.x_*"],
               ["tests/cloud/test_cloud_export.py", "tests/cloud/test_export_limits.py"]),
    "layout": (["genie_gl/layout/engine.py", "genie_gl/layout/generators.py", "genie_gl/layout/merge.py"],
               # the merge layer (layout/merge.py since the rewrite; engine.merge is its node-list
               # front), the grid generator and the rectangle cover of a mask
               ["*.engine.x_merge__*", "*.merge.x_*", "*.generators.xǁGridǁgenerate__*",
                "*.generators.x_rectangles__*"],
               ["tests/layout/test_merge_layer.py", "tests/layout/test_layout.py",
                "-k", "not shipped_strategies_generate"]),
    "merge": (["genie_gl/layout/merge.py"], ["*.merge.x_*"],  # the merge layer alone (a subset of "layout")
              ["tests/layout/test_merge_layer.py", "tests/layout/test_layout.py",
               "-k", "not shipped_strategies_generate"]),
    "placement": (["genie_gl/sensors/placement.py"],
                  # the coverage a placement is scored by; the GA's operators (selection, crossover,
                  # mutation rate) only change how good a search is, never a reported number: left out
                  ["*.placement.xǁCoverageProblemǁ__init____*", "*.placement.xǁCoverageProblemǁfitness*",
                   "*.placement.x_greedy_indices__*", "*.placement.x_greedy_placement__*"],
                  ["tests/sensors/test_placement_fitness.py", "tests/sensors/test_sensors.py"]),
}
# lines that only word an error or a log message: not numbers
NOT_NUMBERS = [r"raise \w+Error\(", r"^\s*f?\"[^\"]*\"\)?$", r"log\.(info|warning|debug)\(", r"warnings\.warn\("]
COPY = ["genie_gl", "tests", "layouts", "sensors", "shaders", "pyproject.toml", "README.md"]


def toml_list(items: list[str]) -> str:
    return "[" + ", ".join(f'"{i}"' for i in items) + "]"


def prepare(group: str, work: Path) -> None:
    modules, _, tests = GROUPS[group]
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    for name in COPY:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, work / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        elif src.exists():
            shutil.copy2(src, work / name)
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
""")


def results(work: Path, env: dict) -> dict[str, str]:
    out = subprocess.run([sys.executable, "-P", "-m", "mutmut", "results", "--all", "true"], cwd=work, env=env,
                         capture_output=True, text=True).stdout
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


def recheck(work: Path, env: dict, status: dict[str, str], tests: list[str], budget: float) -> None:
    """Run the group's tests once more, plainly, against each survivor: mutmut attributes tests
    to functions from one stats run, and a test it failed to attribute (seen on the merged
    sensors and cloud tests) leaves a mutant 'survived' that a test does kill. Bounded."""
    t = time.perf_counter()
    for name in sorted(k for k, v in status.items() if v == "survived"):
        if time.perf_counter() - t > budget:
            break
        run_env = dict(env, MUTANT_UNDER_TEST=name)
        try:
            r = subprocess.run([sys.executable, "-P", "-m", "pytest", "-p", "no:xdist", "-p", "no:cacheprovider",
                                "-x", "-q", "-m", "not slow", *tests], cwd=work / "mutants", env=run_env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=300)
            if r.returncode == 1:       # a test failed (not a usage or collection error)
                status[name] = "killed"
        except subprocess.TimeoutExpired:
            status[name] = "timeout"


def run_group(group: str, timeout: float, children: int, recheck_s: float = 600,
              report_only: bool = False) -> list[tuple[str, int, int, list[str]]]:
    modules, functions, _ = GROUPS[group]
    work = ROOT / "build" / "mutants" / group
    if report_only:     # the results of the last run in build/mutants/<group>, rechecked
        timeout = 0
    else:
        prepare(group, work)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    env["PYTHONPATH"] = str(work / "mutants")
    env["HYPOTHESIS_PROFILE"] = "mutants"   # fixed examples, no deadline (mutmut's tracing slows code)
    t = time.perf_counter()
    finished = False
    for attempt in range(3):  # a first run can fail its setup (see below): again
        left = timeout - (time.perf_counter() - t)
        if left <= 0:
            break
        with open(work / f"mutmut-run-{attempt}.log", "w") as log:
            # its own session: on the time bound, mutmut and every mutant it forked stop together
            # -P: keep the scratch root (its unmutated genie_gl/ and tests/ packages) off sys.path
            proc = subprocess.Popen([sys.executable, "-P", "-m", "mutmut", "run", "--max-children", str(children),
                                     *functions], cwd=work, env=env, stdin=subprocess.DEVNULL, stdout=log,
                                    stderr=subprocess.STDOUT, start_new_session=True)
            try:
                proc.wait(timeout=left)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                break
        r = proc
        log_text = (work / f"mutmut-run-{attempt}.log").read_text()
        # a first run over a fresh copy can fail its stats run (pytest usage error while numba
        # fills its cache) or see no test hit any mutant (the run that generated the mutants):
        # a second run over the generated mutants collects the stats properly
        if not any(s in log_text for s in ("BadTestExecutionCommandsException", "failed to collect stats",
                                           "could not find any test case for any mutant")):
            finished = r.returncode == 0
            break
        # the failed run's partial test-to-function stats would hide tests from the retry
        for stale in (work / "mutants").glob("mutmut-stats*.json"):
            stale.unlink()
    status = {k: v for k, v in results(work, env).items()
              if any(fnmatch.fnmatch(k, f) for f in functions)}
    recheck(work, env, status, GROUPS[group][2], budget=recheck_s)
    rows = []
    for mod in modules:
        mine = {k: v for k, v in status.items() if module_of(k, modules) == mod}
        tested = {k: v for k, v in mine.items() if v not in ("not checked", "skipped")}
        killed = [k for k, v in tested.items() if v in ("killed", "timeout", "caught by type check")]
        survived = sorted(k for k, v in tested.items() if v not in ("killed", "timeout", "caught by type check"))
        rows.append((mod, len(killed), len(tested), survived, len(mine) - len(tested)))
    print(f"[{group}] {'done' if finished else f'stopped at the {timeout:.0f} s bound'} "
          f"in {time.perf_counter() - t:.0f} s", flush=True)
    for mod, k, n, surv, unchecked in rows:
        rate = f"{100 * k / n:5.1f} %" if n else "   - "
        print(f"  {mod:40s} {k:4d} / {n:4d} killed  {rate}" + (f"  ({unchecked} not run)" if unchecked else ""))
    for mod, k, n, surv, _ in rows:
        for name in surv:
            print(f"  survived: {name} ({status[name]})")
            diff = subprocess.run([sys.executable, "-P", "-m", "mutmut", "show", name], cwd=work, env=env,
                                  capture_output=True, text=True).stdout
            print("    " + "\n    ".join(line for line in diff.splitlines() if line[:1] in "+-" and line[:3] not in ("+++", "---")))
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--modules", default="all", help=f"comma-separated groups: {', '.join(GROUPS)} (or all)")
    p.add_argument("--timeout", type=float, default=1200, help="seconds per group (the machine is shared)")
    p.add_argument("--children", type=int, default=2, help="mutants run side by side")
    p.add_argument("--report-only", action="store_true", help="no new run: report (and recheck) the last one")
    p.add_argument("--recheck", type=float, default=600, help="seconds per group to rerun the tests on survivors")
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
