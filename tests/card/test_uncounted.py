"""Figures the profile could not have failed are shown, not counted: a bound whose figure the
profile took from the bound's own sentence (``by construction``), and a systematic error the
profile has no effect for (``not modelled``). No rendering: the judgements are made on given
measurements."""

import pytest

import genie_gl as gg
from genie_gl.card.measurements import CardSettings, Measurement
from genie_gl.card.references import load_references, parse_references
from genie_gl.card.report import Comparison, ReportCard, judge, qualify
from genie_gl.errors import ConfigError


def _m(metric, value, d=1.0):
    return Measurement(metric, "wall", d, 0.0, None, value, 8)


def _refs(sensor, **fig):
    f = {
        "metric": "subpixel_rms_px",
        "distance_m": 1.0,
        "bound": "min",
        "value": 0.032,
        "source": "s",
        "quote": "as low as 0.032 but it is best to use about 0.08",
    }
    f.update(fig)
    return parse_references(
        {
            "sensor": sensor,
            "sources": {
                "s": {
                    "citation": "A. Author, a note, 2019",
                    "where": "a comment",
                    "verification": "read",
                }
            },
            "figures": [f],
        },
        "ref.yml",
    )


def test_the_shipped_d435_card_counts_neither_its_own_subpixel_nor_a_bias_it_does_not_model():
    sensor = gg.load_sensor("realsense_d435")
    refs = load_references("realsense_d435")
    measured = (
        [_m("subpixel_rms_px", 0.0775, d) for d in (0.3, 1.0, 2.0)]
        + [_m("bias_mm", 0.07, d) for d in (0.3, 1.0)]
        + [_m("plane_fit_rms_mm", 3.6)]
    )
    comps = tuple(Comparison(f, qualify(f, judge(f, measured), sensor)) for f in refs.figures)
    by = {(c.figure.metric, c.figure.bound, c.figure.source.key): c.sim for c in comps}
    sub = by[("subpixel_rms_px", "min", "intel_grunnet_3904")]
    assert sub.verdict == "by construction" and "depth_noise.subpixel = 0.08" in sub.why
    assert (
        sensor.effects[-1].subpixel == 0.08
    )  # the profile's figure is the sentence's "about 0.08"
    assert by[("bias_mm", "max_abs", "ieee_access_2025")].verdict == "not modelled"
    assert (
        by[("plane_fit_rms_mm", "value", "intel_support_7806")].verdict == "pass"
    )  # a figure it could fail
    card = ReportCard("realsense_d435", "p", CardSettings(), (), refs.path, comps)
    n = card.counts()
    assert (n["by construction"], n["not modelled"]) == (1, 1)
    assert n["pass"] + n["differs"] + n["not measured"] == sum(f.counted for f in refs.figures) - 2


def test_a_bias_is_judged_where_the_profile_models_one():
    azure = gg.load_sensor("azure_kinect_nfov")  # ToF multipath moves the mean depth
    f = _refs("azure_kinect_nfov", metric="bias_mm", bound="max_abs", value=11.0).figures[0]
    assert qualify(f, judge(f, [_m("bias_mm", 3.0)]), azure).verdict == "pass"
    assert qualify(f, judge(f, [_m("bias_mm", 30.0)]), azure).verdict == "differs"
    d435 = gg.load_sensor("realsense_d435")
    f2 = _refs("realsense_d435", metric="bias_mm", bound="max_abs", value=11.0).figures[0]
    assert qualify(f2, judge(f2, [_m("bias_mm", 30.0)]), d435).verdict == "not modelled"


def test_a_profile_parameter_the_profile_lacks_is_refused():
    f = _refs("realsense_d435", profile_parameter="depth_noise.sigma").figures[0]
    with pytest.raises(
        ConfigError, match=r"ref.yml: profile_parameter 'depth_noise.sigma'.*its effects: range"
    ):
        qualify(
            f, judge(f, [_m("subpixel_rms_px", 0.07)]), gg.load_sensor("realsense_d435"), "ref.yml"
        )
    with pytest.raises(ConfigError, match=r"profile_parameter"):
        _refs("realsense_d435", profile_parameter="subpixel")  # effect.parameter expected


def test_the_card_shows_the_uncounted_verdicts_with_their_reason():
    from genie_gl.card.pages import card_markdown

    sensor = gg.load_sensor("realsense_d435")
    refs = load_references("realsense_d435")
    measured = [
        _m("subpixel_rms_px", 0.0775, 1.0),
        _m("bias_mm", 0.07, 1.0),
        _m("plane_fit_rms_mm", 3.6),
    ]
    comps = tuple(Comparison(f, qualify(f, judge(f, measured), sensor)) for f in refs.figures)
    md = card_markdown(ReportCard("realsense_d435", "p", CardSettings(), (), refs.path, comps))
    row = next(
        x
        for x in md.splitlines()
        if x.startswith("| subpixel_rms_px") and "intel_grunnet_3904" in x
    )
    assert "**by construction** (the profile's depth_noise.subpixel = 0.08" in row
    assert "**not modelled** (no effect of the profile moves the mean depth" in md
    assert "so are 1 read by construction and 1 not modelled" in md
