"""``genie bench deskew`` end to end on a short walk: the four KISS-ICP runs, the perfect
deskew of the ``true poses`` run, and its seeds refused when they are not seeds."""

import json
from dataclasses import replace

import numpy as np
import pytest

from genie_gl.bench.deskew import MODES, at_scan_end, fast_walk
from genie_gl.capture.scanning import scan
from genie_gl.cli import main
from genie_gl.effects.scanner_profile import load_scanner
from genie_gl.layout import generate_layout
from genie_gl.motion.paths import make_trajectory
from genie_gl.motion.scanner_rig import ScannerRig
from genie_gl.scene import build_scene


def test_a_perfect_deskew_puts_each_scan_in_the_heads_frame_at_its_end():
    """Moved by the head's true pose at the scan's end, the ``true poses`` points are the
    exact hits in the world, to 1e-9 m; the raw points, skewed by the walk, are not."""
    layout = generate_layout("assembly_line", seed=5)
    scene = build_scene(layout, seed=5)
    path = make_trajectory(layout, scene, "random", seed=5, motion=fast_walk(60.0), duration_s=0.6)
    head = replace(load_scanner("velodyne_vlp16"), effects=())
    scans = scan(scene, ScannerRig.single(head), path, seed=5)
    for s, pts in zip(scans, at_scan_end(scans, path, head.scan_period_s)):
        end = path.at(np.array([min(s.start_s + head.scan_period_s, path.end_s)]))[0]
        world = pts @ end[:3, :3].T + end[:3, 3]
        np.testing.assert_allclose(world, s.world_xyz, atol=1e-9)
        raw = s.sensor_xyz @ end[:3, :3].T + end[:3, 3]
        if (
            s.start_s > 0.15
        ):  # moving (1.5 m/s² from rest): the first points lie a scan's motion back
            assert np.linalg.norm(raw - s.world_xyz, axis=1).max() > 0.02


def test_the_bench_writes_four_runs_per_walk_and_their_summary(tmp_path):
    argv = "bench deskew --duration-s 1.5 --seeds 5"
    assert main(argv.split() + ["--out", str(tmp_path)]) == 0
    out = json.loads((tmp_path / "deskew.json").read_text())
    (walk,) = out["walks"]
    assert walk["seed"] == 5 and walk["scans"] == 15
    assert walk["own_time_pose_max_error_m"] <= 1e-9
    assert set(walk["modes"]) == set(MODES) == set(out["summary"])
    ate = {m: walk["modes"][m]["ate_rmse_m"] for m in MODES}
    # the skew of a 1.8 m/s walk costs KISS-ICP: undone by the true poses, the error shrinks
    assert ate["true poses"] < 0.8 * ate["deskew off"], ate
    # KISS-ICP's own deskewing from the time field undoes most of it; shuffled times do not
    assert ate["deskew on"] < 0.8 * ate["deskew off"], ate
    assert ate["time shuffled"] > 1.2 * ate["deskew on"], ate
    assert all(walk["modes"][m]["rpe_t_rmse_m"] > 0 for m in MODES)
    summary = out["summary"]
    assert summary["deskew off"]["ate_rmse_m"]["walks_better_than_off"] == 0
    assert summary["true poses"]["ate_rmse_m"]["mean"] == ate["true poses"]


@pytest.mark.parametrize("seeds", ["-1", "0,x", ""])
def test_seeds_that_are_not_seeds_are_refused(seeds, tmp_path, capsys):
    assert main(["bench", "deskew", "--seeds", seeds, "--out", str(tmp_path)]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
