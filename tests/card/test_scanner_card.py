"""A scanner's report card: the point rate measured from the firings equals the VLP-16's
published 289,344 points/s (single return, 10 Hz), and the range noise measured on a flat wall
is the profile's sigma."""

import pytest

from genie_gl.card.scanner_card import measure, published_point_rate, noise_sigma, scanner_card
from genie_gl.cli import main
from genie_gl.effects.scanner_profile import load_scanner


def test_vlp16_card_point_rate_and_range_noise():
    vlp = load_scanner("velodyne_vlp16")
    m = measure(vlp, seed=3)
    # the datasheet's figure, from the model: 16 lasers x the whole firings of 55.296 us in a second
    assert published_point_rate(vlp) == 289_344
    assert m["point_rate_per_s"] == published_point_rate(vlp)
    assert (
        m["points_returned_per_s"] >= 0.99 * m["point_rate_per_s"]
    )  # a closed room: every beam hits
    # sigma 15 mm with 2 mm steps on ~9,600 wall points: within 4 % (the standard error is ~0.7 %)
    assert m["wall_points"] > 5000
    assert m["range_noise_sigma_m"] == pytest.approx(noise_sigma(vlp), rel=0.04)
    assert m["elevation_span_deg"] == pytest.approx([-15.0, 15.0], abs=1e-6)
    assert m["azimuth_covered_deg"] == 360.0 and m["max_returns_per_beam"] == 2


def test_a_card_without_noise_measures_none_and_the_cli_prints_it(capsys):
    from dataclasses import replace

    quiet = replace(load_scanner("ouster_os1_64"), effects=())
    assert measure(quiet)["range_noise_sigma_m"] < 1e-9  # the wall's exact range, to rounding
    assert main(["report-card", "--sensor", "ouster_os1_64"]) == 0
    out = capsys.readouterr().out
    assert "| point rate, single return (pts/s) | 655360 | 655360 |" in out
    assert scanner_card(load_scanner("ouster_os1_64"))["rows"][0][1] == 64 * 1024 * 10
