"""``genie bench lidar`` runs end to end on the smallest benchmark scene, and its second walk
is the first without the footprint: the same beams, one ray each."""

import json

import numpy as np

from genie_gl.bench.lidar import without_footprint
from genie_gl.cli import main
from genie_gl.motion.scanner_rig import load_scanner_rig


def test_without_the_footprint_every_other_effect_stays():
    rig = load_scanner_rig("navvis_wearable")
    bare = without_footprint(rig)
    for h, b in zip(rig.heads, bare.heads):
        names = [e.name for e in h.scanner.effects]
        assert "beam_divergence" in names
        assert [e.name for e in b.scanner.effects] == [n for n in names if n != "beam_divergence"]
        np.testing.assert_array_equal(b.body_from_scanner, h.body_from_scanner)


def test_the_bench_writes_its_casts_and_both_walks(tmp_path):
    argv = "bench lidar --scenes 100k --scanners velodyne_vlp16 --repeats 1 --walk 0.2"
    assert main(argv.split() + ["--out", str(tmp_path)]) == 0
    out = json.loads((tmp_path / "lidar.json").read_text())
    (cast,) = out["casts"]
    assert cast["beams"] == 28_944 and cast["agreement"]["id_agree"] >= 0.9999
    walk, bare = out["walk"], out["walk_beams_only"]
    assert walk["footprint"] and not bare["footprint"]
    assert walk["scans"] == bare["scans"] == 4  # two heads, two revolutions of 0.1 s each
    assert 0 < bare["points"] and 0 < walk["points"]
