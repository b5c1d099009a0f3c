"""The timing run behind the "what accuracy buys" table: its output's shape, a planned-away
effect shown as skipped (never as a cost), and the accuracy table reading it."""

import json
import re

import pytest

from genie_gl.studies.costs import cost_text, costs_markdown, time_effects


def _result():
    return {
        "profile": "p",
        "strategy": "s",
        "seed": 0,
        "frames": 4,
        "repeats": 3,
        "date": "2026-11-29 06:00 UTC",
        "load_before": 1.2,
        "load_after": 1.4,
        "seconds": 9.0,
        "(ideal render)": 20.0,
        "(full profile)": 31.0,
        "effects": {
            "range": {
                "ran_frames": 0,
                "skipped_frames": 4,
                "median_ms_when_run": None,
                "ms_per_frame": 0.0,
                "skip_reasons": ["everything in view lies within 0.17-6 m"],
            },
            "depth_noise": {
                "ran_frames": 4,
                "skipped_frames": 0,
                "median_ms_when_run": 2.5,
                "ms_per_frame": 2.5,
                "skip_reasons": [],
            },
            "stereo_shadow": {
                "ran_frames": 3,
                "skipped_frames": 1,
                "median_ms_when_run": 8.0,
                "ms_per_frame": 6.0,
                "skip_reasons": ["nothing in range or view"],
            },
        },
    }


def test_a_skipped_effect_reads_as_skipped_and_a_partly_skipped_one_says_so():
    r = _result()
    assert (
        cost_text(r["effects"]["range"])
        == "skipped (planned away on 4 of 4 frames: everything in view lies within 0.17-6 m)"
    )
    assert cost_text(r["effects"]["depth_noise"]) == "2.5"
    assert cost_text(r["effects"]["stereo_shadow"]) == "6.0 (skipped on 1 of 4 frames)"
    assert cost_text(None) == "—"
    md = costs_markdown(r, "genie eval --study costs --out o --yes")
    assert (
        "load average 1.2 before and 1.4 after" in md
        and "`genie eval --study costs --out o --yes`" in md
    )
    assert "| range | 0 | 4 | — | skipped (planned away" in md
    assert "Ideal render 20.0 ms per frame, the full profile 31.0 ms" in md


@pytest.mark.slow
@pytest.mark.gl
def test_time_effects_times_each_effect_of_the_profile_on_real_frames():
    r = time_effects("realsense_d435", "assembly_line", frames=2, repeats=2)
    assert list(r["effects"]) == ["range", "stereo_shadow", "specular_loss", "depth_noise"]
    for e in r["effects"].values():
        assert e["ran_frames"] + e["skipped_frames"] == 2
        assert (e["median_ms_when_run"] is None) == (e["ran_frames"] == 0)
        assert e["ms_per_frame"] >= 0 and (e["ran_frames"] == 0 or e["median_ms_when_run"] > 0)
    assert r["effects"]["depth_noise"]["ran_frames"] == 2  # noise runs wherever there is a return
    assert r["(full profile)"] > r["(ideal render)"] > 0
    assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", r["date"]) and r["load_before"] >= 0
    json.dumps(r)
