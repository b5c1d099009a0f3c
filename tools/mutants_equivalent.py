"""Why each mutant that survives `make mutants` cannot change a number the package reports.

Each entry: (mutant name glob, regex that the mutated line ("+ ...") must match, reason). A
survivor matching none is printed as UNCLASSIFIED: it needs a test that kills it, or an entry
here saying why no test can (it changes no output). Entries are narrow on purpose (function and
text), so a new survivor in the same function is not waved through by an old reason.
"""

from __future__ import annotations

import fnmatch
import re

NEG = r"reshape\(-2, "
EQUIVALENT: list[tuple[str, str, str]] = [
    # -- labels: export/semantickitti.py, ply.py, pcd.py, npz.py
    (
        "*.semantickitti.x_read__*",
        NEG,
        "reshape(-2, 4): numpy takes any negative size as 'the rest'",
    ),
    (
        "*.semantickitti.x_*",
        r"lut = np\.zeros\(MAX_ID16 \+ 2",
        "a spare slot in the instance table's lookup (ids go up to MAX_ID16)",
    ),
    (
        "*.semantickitti.x_write__*",
        r"\[\"\"\] \* \(frame \+ 2\)\)\[: max\(len\(old\), frame \+ 1\)\]",
        "poses.txt padded by one line more, then cut to max(len, frame + 1) lines: the same lines",
    ),
    # -- lens: camera.py
    ("*.camera.x*", NEG, "reshape with -2: numpy takes any negative size as 'the rest'"),
    ("*.camera.x*", r"\] = None$", "None stored into a float array is NaN, the value stored"),
    (
        "*.camera.x__coefficients__*",
        r"np\.asarray\(dist, (None)?\s*\)",
        "the coefficients are float64 already (Camera and the fold's frombuffer make them so)",
    ),
    (
        "*.camera.x__find_fold__*",
        r"np\.linspace\(0, (MAX_OFF_AXIS, 200002|np\.pi, 200002|61\.0, 600001|60\.0, 600002)\)",
        "the fold searched on a grid one sample finer, or for the pinhole out to r = 61 (89.06°) "
        "instead "
        "of 60 (89.05°): the fold moves by less than a grid step, ~3e-4 rad, and the tests' folds "
        "are "
        "analytic to that step",
    ),
    (
        "*.camera.x__find_fold__*",
        r"np\.diff\((r|f)\) < 0|r\[1:\] > r_fold",
        "a grid step where the map is exactly flat, or reaches the radial fold's radius exactly: a "
        "float "
        "equality of measure zero",
    ),
    (
        "*.camera.x__increasing_inverse__*",
        r"above = f\(mid\) >= target",
        "a midpoint whose image equals the target exactly: measure zero",
    ),
    (
        "*.camera.x__increasing_inverse__*",
        r"range\(61\)",
        "a 61st halving, below double precision (top / 2^60 < 3e-18)",
    ),
    (
        "*.camera.x__newton__*",
        r"range\(13\)",
        "a 13th Newton step on converged roots (residual ~1e-16)",
    ),
    ("*.camera.x__newton__*", r"step >= cap", "a step exactly as long as the cap: measure zero"),
    (
        "*.camera.x__newton__*",
        r"ok = \(res (<= 1e-9 \* \(1|< 1e-9 / \(1|< 1e-9 \* \(2) \+ np\.hypot\(xd, yd\)\)\) "
        r"& \(np\.hypot\(x, y\) < r_max\)",
        "the acceptance tolerance's form (1e-9·(1 + r) vs ·(2 + r), /(1 + r), <=): converged "
        "residuals are "
        "~1e-16, unconverged ones far above any of them",
    ),
    (
        "*.camera.x__newton__*",
        r"ok = \(res < 1e-9 \* \(1 \+ np\.hypot\(xd, yd\)\)\) & \(np\.hypot\(x, y\) <= r_max\)",
        "a root exactly on the fold: measure zero",
    ),
    (
        "*.camera.x__omni_inverse__*",
        r"~\(disc > 0\)|<= theta_max \+ 1e-12",
        "a pixel whose ray grazes the unit sphere, or lies exactly on the limit: measure zero",
    ),
    (
        "*.camera.x*",
        r"np\.where\((rd|r|td) > 0, (rd|r|td), 2\)",
        "the divisor on the axis, where what it divides multiplies 0 (ux = uy = 0, θ_d = 0, xd = "
        "yd = 0): "
        "any nonzero divisor gives the same 0",
    ),
    (
        "*.camera.x__pinhole_inverse__*",
        r"np\.zeros_like\(None\)",
        "the first estimate as a 0-d zero: the first pass's decentring shift at the origin is 0 "
        "either way",
    ),
    (
        "*.camera.x__pinhole_inverse__*",
        r"min\(r_max, 1000001\.0\)",
        "the bisection's top for a lens that never folds, 1e6 + 1 instead of 1e6 (~89.99994° off "
        "the axis)",
    ),
    (
        "*.camera.xǁCameraǁproject__*",
        r"ok &= z >= 0",
        "a point with z = 0 is 90° off the axis, already outside max_off_axis <= 89.9°",
    ),
    (
        "*.camera.xǁCameraǁproject__*",
        r"ok &= den >= 0",
        "den = cos θ + ξ is 0 only at or past the omni fold (where the sphere's projection leaps), "
        "outside max_off_axis; exactly at it within the 1e-12 tolerance: measure zero",
    ),
    (
        "*.camera.xǁCameraǁproject__*",
        r"if \(len\(self\.dist\)\) or True",
        "distort_normalized without coefficients is the identity (radial 1, no shift)",
    ),
    (
        "*.camera.xǁCameraǁproject__*",
        r"ok = theta <= self\.max_off_axis \+ 1e-12",
        "a point exactly 1e-12 rad past the limit: measure zero",
    ),
    (
        "*.camera.xǁCameraǁunproject__*",
        r"np\.asarray\(uv, (None)?\s*\)",
        "integer pixels promote to float64 in the next line's np.where with NaN: the same numbers",
    ),
    # -- lens: lens/distortion.py
    (
        "*.distortion.x__build_lens_views__*",
        r"max\(initial=None\)",
        "max(initial=None) over a non-empty image is its max",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"one = .*np\.where\(valid, x, 1\)|one = .*max\(initial=1\)|"
        r"np\.where\(valid, y, 1\)\)\.max\(initial=0\) <= MAX|np\.where\(valid, y, "
        r"0\)\)\.max\(initial=1\) <= MAX",
        "1 instead of 0 for pixels without a ray in the one-view test: MAX_SINGLE_VIEW_TAN (tan "
        "75°) > 1",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"\) < MAX_SINGLE_VIEW_TAN",
        "a ray exactly 75° off the axis: measure zero",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"np\.where\((valid|serve), [xy]v?, 1\)|zs = np\.where\(serve, .*, 1\.0\)",
        "values for pixels a view does not serve: _view reads rays and z scales only where serve",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"f, f, (1\.0, 0\.0|0\.0, 1\.0), zs\)",
        "a whole-pixel start of a face's principal point: cx = cx0 + ceil(1 - f·lo - cx0) is the "
        "same "
        "for any whole cx0",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"np\.ceil\(need \+ 1e-9\)",
        "an oversampling need within 1e-9 of a whole number: measure zero",
    ),
    (
        "*.distortion.x__build_lens_views__*",
        r"if \(factor == 1\) and False",
        "factor 1 asks the cache for the views at 1.0 again: the same views",
    ),
    (
        "*.distortion.x__scale_min__*",
        r"serve\.shape\[0\] < 2 and|serve\.shape\[1\] < 2 or serve\.shape\[1\]",
        "the guard for a one-row or one-column map: the masked loop below returns 1.0 for it as "
        "well",
    ),
    (
        "*.distortion.x__view__*",
        r"lo_x = hi_x = lo_y = hi_y = 1\.0",
        "the principal point and size of a view that serves no pixel (never rendered)",
    ),
    (
        "*.distortion.x_*",
        r"getattr\(sensor, .name., (None|.XXXX.)\)",
        "the label of a view of a bare Camera (no name): a label, no number",
    ),
    (
        "*.distortion.x_project__*",
        r"np\.asarray\(D, (None)?\s*\)",
        "D is float64 already (a calibration's coefficients)",
    ),
    (
        "*.distortion.x_project__*",
        r"if \(len\(D\)\) or True",
        "distort_normalized without coefficients is the identity",
    ),
    # -- noise: effects/noise.py
    (
        "*.noise.x*",
        r"drop\((out|frame), \((frame\.depth|z) >= 0\)",
        "the mask adds holes (depth 0) to a drop: they already have depth 0 and ids 0",
    ),
    (
        "*.noise.x*",
        r"if \((lost|bad\.any\(\))\) or True else out",
        "drop() with an empty mask returns the same frame",
    ),
    (
        "*.noise.xǁDepthNoiseǁapply__*",
        r"z = frame\.depth\.astype\(None\)",
        "σ·N (~1 mm) in float32 instead of float64 moves it by ~1e-10 m, below a float32 ulp of "
        "the "
        "depth; the exact-noise test's rounded depths were identical on every return",
    ),
    (
        "*.noise.xǁDepthNoiseǁsteep_angles__*",
        r"n = frame\.normal\[valid\]\.astype\(None\)",
        "θ from float32 normals differs by ~1e-7 rad: σ by ~1e-10 m, below a float32 ulp of the "
        "depth "
        "(identical depths in the exact-noise test)",
    ),
    (
        "*.noise.xǁDepthNoiseǁapply__*",
        r"if \(self\.needs_normals\) or True else None",
        "θ computed when the model ignores it (sigma reads θ only with incidence on)",
    ),
    (
        "*.noise.xǁDepthNoiseǁapply__*",
        r"bad = valid & ~\(noisy >= 0\)",
        "a noisy depth of exactly 0.0: measure zero",
    ),
    (
        "*.noise.xǁDepthNoiseǁsteep_angles__*",
        r"cand = \(cos (<= 0\.5 \+|< 0\.5 -) 1e-9\) & \(n != 0\)\.any\(axis=1\)",
        "which θ within 1e-9 rad of 60° count as candidates: measure zero",
    ),
    (
        "*.noise.xǁDepthNoiseǁsteep_angles__*",
        r"np\.clip\(cos\[cand\], (None, 1\.0|0\.0, None|0\.0, 2\.0)\)",
        "bounds that cannot bind: candidates have cos < 0.5, and a back face (cos < 0) gives θ >= "
        "90°, "
        "clamped to 85° by sigma either way",
    ),
    # -- placement: placement/genetic.py
    (
        "*.placement.x*",
        r"bits = None",
        "the cell-by-cell kernels instead of the bit sets: the same sums bit for bit "
        "(test_bit_sets_equal_the_cell_by_cell_kernels)",
    ),
    (
        "*.placement.x*",
        NEG + "|reshape\\(1, -2\\)",
        "reshape with -2: numpy takes any negative size as 'the rest'",
    ),
    (
        "*.placement.xǁCoverageProblemǁ__init____*",
        r"\(p[xy] >= rects|\(p[xy] <= rects",
        "a candidate exactly FREE_MARGIN_M (0.25 m) from a furnished edge: a float equality the "
        "shipped "
        "half-metre grids do not meet",
    ),
    (
        "*.placement.xǁCoverageProblemǁ__init____*",
        r"self\.cell = np\.full\(H \* W, -(1, (None)?|2, np\.int64)\s*\)",
        "the no-cell marker -1 as -2 or as float64 -1.0: the disc kernel reads only its sign and "
        "stores "
        "whole numbers into int64 indices",
    ),
    (
        "*.placement.xǁCoverageProblemǁ__init____*",
        r"self\._stamp, self\._mark = np\.zeros\(len\(self\.weight\), "
        r"((None)?\s*\), 0|np\.int64\), 1)",
        "the coverage bookkeeping (coverage.union_weights): each chromosome takes mark + 1, above "
        "every "
        "stamp so far, whether marks start at 0 or 1 and the zero stamps are int64 or float64",
    ),
    (
        "*.placement.xǁCoverageProblemǁ__init____*",
        r"or 2\.0",
        "the total weight of an empty layout: fitness 0 either way",
    ),
    (
        "*.placement.xǁCoverageProblemǁfitnesses__*",
        r"np\.ascontiguousarray\(population, (None)?\s*\)",
        "the population is an int64 array already (the GA's and the tests')",
    ),
    # -- layout: layout/generators.py, layout/merge.py
    (
        "*.generators.x_rectangles__*",
        r"mask\[r:r1, c:c1\] = None",
        "None stored into a bool array is False",
    ),
    (
        "*.generators.xǁGridǁgenerate__*",
        r"if [WH] - used_[wh] >= EPS|while y \+ ch < H \+ EPS",
        "a leftover (or a row's end) exactly EPS: a float equality of measure zero",
    ),
    (
        "*.generators.xǁGridǁgenerate__*",
        r"int\(\(W \+ sp \+ EPS\) / \(cw \+ sp\)\)",
        "int(a / b) for a // b on positive sizes: the same whole number",
    ),
    (
        "*.generators.xǁGridǁgenerate__*",
        r"^\s*r -= 1$",
        "-r % every == 0 exactly when r % every == 0",
    ),
    (
        "*.generators.xǁGridǁgenerate__*",
        r"self\.args\.get\(\"leftover\", (None|\"XXemptyXX\"|\"EMPTY\")?\s*\)",
        'the default of `leftover`: it is only compared with "spread"',
    ),
    (
        "*.merge.x*",
        r"astype\(None\)|np\.asarray\((key|origin|b|record\[\"nodes\"\]), (None)?\s*\)|"
        r"np\.array\(\[e\[0\] for e in extra\], (None)?\s*\)|np\.full\((len\(\w+\)|\w+), -1, "
        r"(None)?\s*\)|"
        r"np\.bincount\([^)]*, \)",
        "a dtype or minlength dropped where numpy infers the same (integer input, int64 defaults) "
        "or the "
        "result is only compared and sorted (rounded tolerance quanta: whole numbers, exact in "
        "float64), "
        "and bincount without minlength where every group has a part",
    ),
    (
        "*.merge.x*",
        r"np\.full\((len\(\w+\)|\w+), -2, np\.int64\)|np\.where\(single, origin\[o_first\], -2\)",
        "-2 for the -1 'not a piece' marker: only its sign is read",
    ),
    (
        "*.merge.x__endpoints_inside__*",
        r"cmin \+ 2$|emin \+ 4$",
        "a wider stride in the cut finder's line and interval codes: still one block per line",
    ),
    (
        "*.merge.x__endpoints_inside__*",
        r"np\.argsort\(ek, (kind=None|kind=\"STABLE\")?\s*\)",
        "the endpoint table's sort kind: equal codes lie all inside or all outside a search range, "
        "and "
        "the cuts become sets",
    ),
    (
        "*.merge.x__endpoints_inside__*",
        r"np\.searchsorted\(ek, mine \* Q \+ c0 - emin \+ 1, \)",
        "searchsorted's default side ('left') on codes that cannot equal the bound",
    ),
    (
        "*.merge.x_merge_leaves__*",
        r"changed, along_x, idle = False, False, 0",
        "the first value of `changed` is never read",
    ),
    (
        "*.merge.x_merge_leaves__*",
        r"while len\(x\) >= 1 and idle < 2|idle <= 2|idle < 3",
        "the loop entered with one rectangle (joins nothing) or a third idle pass (repeats the "
        "first, "
        "which joined nothing)",
    ),
    (
        "*.merge.x_merge_tree__*",
        r"l_shape: str = \"(XXkeepXX|KEEP)\"",
        'a default l_shape other than "keep": only "strip" is tested for',
    ),
    (
        "*.merge.x_merge_tree__*",
        r"\* 5 \+ tree\.orient",
        "type * 5 + orient: orientations are < 4, so the same keys' order, one key per type and "
        "orientation",
    ),
    (
        "*.merge.x_merge_tree__*",
        r"if n0 (<= 2|< 3):",
        "a root with one leaf: the same tree, no record and the identity either way",
    ),
    (
        "*.merge.x_merge_tree__*",
        r"(empty\[0\]|keep\[absorbed\]) = None",
        "None stored into a bool array is False",
    ),
    (
        "*.merge.x_merge_tree__*",
        r"range\(int\(depth\[keep\]\.max\(\)\) \+ 2\)",
        "one more, empty depth in the re-indexing",
    ),
    (
        "*.merge.x_merge_tree__*",
        r"if d (>= 0|> 1):",
        "sorting depth 0 (the root alone) or not sorting depth 1 (every node there is a child of "
        "the root)",
    ),
    # -- unprojection: cloud/unproject.py
    (
        "*.unproject.x__colour_source__*",
        r"writeable=None\)",
        "None is falsy: as_strided makes the view read-only all the same",
    ),
    (
        "*.unproject.x_unproject__*",
        r"np\.asarray\(origin, (None)?\s*\)",
        "origin enters only M[:, 3] -= origin (float64, in place) and PointCloud, which holds it "
        "as float64",
    ),
    (
        "*.unproject.x_unproject__*",
        r"xyz = np\.empty\(\(n \+ 3, 3\)|np\.empty\(n \+ 2, np\.uint(16|32)\)"
        r"|np\.empty\(\(n \+ 2, 3\), np\.uint8\)",
        "more spare room than the kernel's branch-free compaction needs; the outputs are cut to "
        "[:n]",
    ),
    (
        "*.unproject.x_unproject__*",
        r"unproject_into\(frame, origin, xyz, sem, inst, rgb, (n=None)?\s*\)",
        "unproject_into counts the same n itself",
    ),
    (
        "*.unproject.x_unproject_into__*",
        r"if \(n is None\) or True else n",
        "counting again gives the n every caller passes (the documented contract)",
    ),
    (
        "*.unproject.x_unproject_into__*",
        r"rgb\.shape\[0\] if colour else n \+ 2\)",
        "without a colour output this term cannot decide room < n + 1",
    ),
    (
        "*.x__write_cloud__*",
        r'name: str = "(XXcloudXX|CLOUD)"',
        "the default file name of _write_cloud: its one caller, export(), always passes name=",
    ),
]


def classify(name: str, diff: list[str]) -> str | None:
    """The reason ``name`` (its diff lines, "-" old and "+" new) is equivalent, or None."""
    added = "\n".join(line[1:] for line in diff if line.startswith("+"))
    for glob, pattern, reason in EQUIVALENT:
        if fnmatch.fnmatch(name, glob) and re.search(pattern, added):
            return reason
    return None


def main(argv: list[str]) -> int:
    """Classify the survivors of a saved `make mutants` report: python tools/mutants_equivalent.py
    REPORT"""
    import sys

    text = open(argv[0]).read().splitlines() if argv else sys.stdin.read().splitlines()
    survivors: list[tuple[str, list[str]]] = []
    for line in text:
        m = re.match(r"\s*survived: (\S+)", line)
        if m:
            survivors.append((m.group(1), []))
        elif survivors and re.match(r"\s{4}[+-]", line):
            survivors[-1][1].append(line.strip())
    open_ = 0
    for name, diff in survivors:
        reason = classify(name, diff)
        open_ += reason is None
        print(
            f"{name}\n    "
            + "\n    ".join(diff)
            + f"\n    {'equivalent: ' + reason if reason else 'UNCLASSIFIED'}"
        )
    print(
        f"{len(survivors)} survivors, {len(survivors) - open_} classified equivalent, {open_} "
        "unclassified"
    )
    return 1 if open_ else 0


if __name__ == "__main__":
    import sys

    sys.exit(main(sys.argv[1:]))
