"""Reference files: the shipped ones load and agree with their profiles; bad files are refused
with the file and the key named; the judging of each kind of bound."""

import math

import pytest
import yaml

import genie_gl as gg
from genie_gl.card.references import METRICS, load_references, parse_references, reference_path
from genie_gl.card.measurements import Measurement
from genie_gl.card.report import judge
from genie_gl.errors import ConfigError
from genie_gl.resources import data_dir

SHIPPED = sorted(
    p.name[: -len(".reference.yml")] for p in data_dir("sensors").glob("*.reference.yml")
)


def test_every_shipped_profile_but_the_ideal_one_has_a_reference_file():
    profiles = sorted(
        p.stem for p in data_dir("sensors").glob("*.yaml")
    )  # profiles only (.calib.yml, .reference.yml)
    assert SHIPPED == [
        p for p in profiles if gg.load_sensor(p).effects
    ]  # the ideal ones have nothing to judge


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_reference_files_load_and_name_their_profile(name):
    refs = load_references(name)
    assert refs.sensor == gg.load_sensor(name).name == name
    for f in refs.figures:
        assert f.metric in METRICS and f.source.key in refs.sources
        assert f.quote.strip() and f.source.citation.strip()
        if f.bound == "value":
            assert f.tolerance is not None and f.tolerance_from
    # a figure read in its source is counted; one quoted by others or not read is not
    assert all(f.counted == (f.source.verification == "read") for f in refs.figures)


def _good():
    return {
        "sensor": "x",
        "sources": {
            "s": {
                "citation": "A. Author, Title, Venue 2020",
                "where": "Table 1",
                "verification": "read",
            }
        },
        "figures": [
            {
                "metric": "temporal_noise_mm",
                "distance_m": 1.0,
                "bound": "max",
                "value": 2.0,
                "source": "s",
                "quote": "sigma <= 2 mm",
            }
        ],
    }


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda d: d["figures"][0].update(colour="red"),
            r"\$\.figures\[0\]\.colour: Extra inputs are not permitted",
        ),
        (
            lambda d: d["figures"][0].update(metric="temporal_nosie_mm"),
            "did you mean 'temporal_noise_mm'",
        ),
        (
            lambda d: d["figures"][0].update(source="t"),
            r"\$\.figures\[0\]\.source: 't' is not in \$\.sources",
        ),
        (lambda d: d["figures"][0].update(bound="value"), "needs tolerance and tolerance_from"),
        (lambda d: d["figures"][0].update(bound="below"), r"\$\.figures\[0\]\.bound"),
        (
            lambda d: d["figures"][0].update(distance_range_m=[1, 2]),
            "exactly one of distance_m or distance_range_m",
        ),
        (lambda d: d["sources"]["s"].update(verification="maybe"), r"\$\.sources\.s\.verification"),
        (lambda d: d["figures"][0].update(metric="panel_fill_pct"), "needs the part"),
        (lambda d: d.update(figures=[]), r"\$\.figures"),
    ],
)
def test_bad_reference_data_is_refused_naming_the_key(change, message):
    data = _good()
    parse_references(data, "ref.yaml")  # the good one passes
    change(data)
    with pytest.raises(ConfigError, match=message) as e:
        parse_references(data, "ref.yaml")
    assert str(e.value).startswith("ref.yaml: ") and "\n" not in str(e.value)


def test_a_bad_file_is_one_line_naming_it(tmp_path):
    p = tmp_path / "r.yaml"
    p.write_text("sensor: [unclosed\n")
    with pytest.raises(ConfigError, match="r.yaml: not valid YAML"):
        load_references(p)
    with pytest.raises(ConfigError, match="did you mean 'kinect_v2'"):
        load_references("kinect_v3")
    p.write_text(yaml.safe_dump(_good()))
    assert load_references(p).figures[0].metric == "temporal_noise_mm"
    assert reference_path("kinect_v2").is_file()


def _fig(**kw):
    d = _good()
    d["figures"][0].update(kw)
    return parse_references(d).figures[0]


def _m(value, d=1.0, metric="temporal_noise_mm", angle=0.0):
    return Measurement(metric, METRICS[metric][0], d, angle, None, value, 4)


def test_judging_each_bound():
    assert judge(_fig(), [_m(1.9)]).verdict == "pass"
    j = judge(_fig(), [_m(2.1)])
    assert (j.verdict, j.ours, j.limit, j.distance_m) == ("differs", 2.1, 2.0, 1.0)
    assert judge(_fig(bound="min"), [_m(2.1)]).verdict == "pass"
    assert judge(_fig(bound="max_abs"), [_m(-1.5)]).verdict == "pass"
    assert judge(_fig(bound="max_abs"), [_m(-2.5)]).verdict == "differs"
    v = dict(bound="value", tolerance=0.5, tolerance_from="the source's sd")
    assert (
        judge(_fig(**v), [_m(2.4)]).verdict == "pass"
        and judge(_fig(**v), [_m(2.6)]).verdict == "differs"
    )
    # nothing under the figure: another distance, angle or metric
    assert (
        judge(_fig(), [_m(1.0, d=2.0), _m(1.0, angle=30.0), _m(1.0, metric="bias_mm")]).verdict
        == "not measured"
    )
    assert judge(_fig(), [_m(math.nan)]).verdict == "not measured"


def test_a_range_figure_growing_with_distance_reports_its_worst_case():
    f = _fig(distance_m=None, distance_range_m=[0.5, 3.0], bound="max_abs", value=11.0, per_m=1.0)
    ms = [
        _m(-11.0, d=0.5),
        _m(11.8, d=1.0),
        _m(13.9, d=3.0),
        _m(99.0, d=4.0),
    ]  # 4 m is outside the range
    j = judge(f, ms)
    assert j.verdict == "pass" and j.distance_m == 3.0 and j.limit == pytest.approx(14.0)
    j = judge(f, ms + [_m(12.6, d=1.5)])  # limit 12.5 at 1.5 m
    assert (j.verdict, j.distance_m) == ("differs", 1.5)


def test_the_metrics_module_starts_no_gl():
    import subprocess
    import sys

    code = (
        "import sys, genie_gl.card.metrics; sys.exit(int(any(m in sys.modules for m in "
        "('moderngl', 'OpenGL'))))"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_a_reference_file_of_another_sensor_is_refused(tmp_path):
    from genie_gl.card.report import report_card

    p = tmp_path / "r.yml"
    p.write_text(yaml.safe_dump(_good()))  # sensor: x
    with pytest.raises(
        ConfigError, match=r"r.yml: \$\.sensor is 'x', but the profile is 'ideal_pinhole'"
    ):
        report_card("ideal_pinhole", references=str(p))


def test_only_figures_read_in_their_source_are_counted():
    from genie_gl.card.report import Comparison, ReportCard
    from genie_gl.card.measurements import CardSettings

    figs = []
    for how in ("read", "secondary", "unverified"):
        d = _good()
        d["sources"]["s"]["verification"] = how
        figs.append(parse_references(d).figures[0])
    assert [f.counted for f in figs] == [True, False, False]
    comps = tuple(Comparison(f, judge(f, [_m(1.0)])) for f in figs)  # all three pass
    card = ReportCard("x", "x.yaml", CardSettings(), (), "ref.yaml", comps)
    assert card.counts() == {
        "pass": 1,
        "differs": 0,
        "not measured": 0,
        "by construction": 0,
        "not modelled": 0,
    }
