"""Trajectories asked for more than their route gives, or through points that are no points:
the duration asked for is the duration made (the route walked back and forth), and NaN
waypoints are named, not counted."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.motion.floor import free_floor
from genie_gl.motion.paths import make_trajectory

from .common import fault

WRONG = fault("bad option", "wrong")
BAD = fault("bad file", "wrong")


@pytest.fixture(scope="module")
def hall():
    layout = gg.generate_layout("assembly_line", seed=0)
    scene = gg.build_scene(layout, seed=0)
    return layout, scene, free_floor(layout, scene)


def two_points(floor, apart_m=4.0) -> np.ndarray:
    """Two free points about ``apart_m`` apart (a route of a few seconds)."""
    rows, cols = np.nonzero(floor.free)
    xy = floor.centres(rows, cols)
    a = xy[len(xy) // 2]
    d = np.linalg.norm(xy - a, axis=1)
    return np.stack([a, xy[int(np.argmin(abs(d - apart_m)))]])


@WRONG
@pytest.mark.parametrize("path", ["waypoints", "random"])
def test_a_duration_longer_than_the_route_is_what_is_made(hall, path, tmp_path):
    layout, scene, floor = hall
    kw = {"waypoints": two_points(floor)} if path == "waypoints" else {"length_m": 5.0}
    once = make_trajectory(layout, scene, path, seed=1, floor=floor, **kw)
    asked = 4 * once.duration_s + 1.0
    tr = make_trajectory(layout, scene, path, seed=1, floor=floor, duration_s=asked, **kw)
    assert tr.duration_s == pytest.approx(asked, abs=1e-9)  # not once.duration_s
    assert tr.meta["laps"] >= 5 and tr.meta["cropped_s"] == asked
    assert floor.is_free(tr.positions[:, :2]).all()  # back and forth on free floor only
    assert np.linalg.norm(np.diff(tr.positions, axis=0), axis=1).max() < 0.5  # no jump between laps
    # the first lap is the route itself, sample for sample
    n = np.searchsorted(tr.times_s, once.end_s)
    np.testing.assert_allclose(tr.positions[: n - 1], once.positions[: n - 1], atol=1e-9)


def test_a_shorter_duration_still_crops(hall):
    layout, scene, floor = hall
    once = make_trajectory(layout, scene, "waypoints", waypoints=two_points(floor), floor=floor)
    tr = make_trajectory(
        layout,
        scene,
        "waypoints",
        waypoints=two_points(floor),
        floor=floor,
        duration_s=once.duration_s / 2,
    )
    assert tr.duration_s == pytest.approx(once.duration_s / 2) and "laps" not in tr.meta


@BAD
@pytest.mark.parametrize(
    "text, needle",
    [
        (
            "1 2\nnan 3\n4 5\n",
            r"waypoint 2 \(nan, 3\) is not a finite point; expected x y in metres \(1 of the 3",
        ),
        ("[[1, 2], [Infinity, 3]]", r"waypoint 2 \(inf, 3\) is not a finite point"),
        ("[[1, 2], [NaN, NaN]]", r"waypoint 2 \(nan, nan\) is not a finite point; .*\(1 of the 2"),
        ("1 2\n", r"expected at least two waypoints \(x y in metres\), got 1"),
    ],
)
def test_a_nan_waypoint_is_named(hall, tmp_path, text, needle):
    layout, scene, floor = hall
    f = tmp_path / "w.txt"
    f.write_text(text)
    with pytest.raises(gg.ConfigError, match=rf"{f}: {needle}") as e:
        make_trajectory(layout, scene, "waypoints", waypoints=f, floor=floor)
    assert "got 2" not in str(e.value) and "\n" not in str(e.value)


@BAD
def test_nan_waypoints_given_as_an_array_are_named(hall):
    layout, scene, floor = hall
    with pytest.raises(
        gg.ConfigError, match=r"waypoints: waypoint 1 \(nan, 0\) is not a finite point"
    ):
        make_trajectory(
            layout, scene, "waypoints", waypoints=np.array([[np.nan, 0], [1, 1]]), floor=floor
        )
    with pytest.raises(gg.ConfigError, match=r"waypoints: expected an \(n, 2\) array"):
        make_trajectory(layout, scene, "waypoints", waypoints=[[1, 2], "x"], floor=floor)
