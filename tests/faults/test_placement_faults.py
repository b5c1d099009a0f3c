"""Camera placement on stages where every candidate covers everything (a floorless stage of
small cubes, a tiny hall): two cameras never share a pose, and the coverage of the distinct
positions is never less than that of the repeats they replace."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.layout.model import Layout, Region, RegionType
from genie_gl.placement.genetic import CoverageProblem, distinct, scene_poses

from .common import fault


def _cubes() -> gg.Scene:
    """A floorless stage: 4 x 4 cubes of 10 cm, one mesh instanced 16 times."""
    s = gg.Scene()
    cube = trimesh.creation.box((0.1, 0.1, 0.1))
    for i in range(4):
        for j in range(4):
            s.add(cube, [i * 0.3, j * 0.3, 0.05], semantic=9)
    return s


def _distinct_poses(poses) -> int:
    return len(np.unique(np.round(np.array(poses).reshape(len(poses), -1), 9), axis=0))


@fault("bad file", "wrong")
@pytest.mark.parametrize("n", [2, 3, 8, 20])
def test_cameras_on_a_stage_of_small_cubes_never_share_a_pose(n):
    """Every candidate's disc covers the whole stage: the search kept one candidate n times
    (``--cameras 2`` gave two cameras on the identical pose). 20 is more cameras than the
    stage has candidate positions (16): the repeats are turned apart."""
    poses = scene_poses(_cubes(), gg.load_sensor("realsense_d435"), n, seed=0)
    assert len(poses) == n
    assert _distinct_poses(poses) == n
    if n <= 16:  # distinct positions, not only distinct turns
        assert len(np.unique(np.round([p[:2, 3] for p in poses], 9), axis=0)) == n


@fault("bad API call", "wrong")
@pytest.mark.parametrize("method", ["genetic", "greedy", "random"])
def test_place_sensors_over_a_tiny_hall_never_repeats_a_pose(method):
    hall = Region(0.0, 0.0, 3.0, 3.0, type="cell")
    layout = Layout.from_regions(
        [hall], {"cell": RegionType("cell", asset_group="pallet")}, (0.0, 0.0, 3.0, 3.0)
    )
    poses = gg.place_sensors(layout, gg.load_sensor("realsense_d435"), n=6, seed=1, method=method)
    assert _distinct_poses(poses) == 6


@fault("bad API call", "wrong")
def test_replacing_repeats_never_lowers_the_coverage():
    hall = Region(0.0, 0.0, 12.0, 4.0, type="cell")
    layout = Layout.from_regions(
        [hall], {"cell": RegionType("cell", asset_group="pallet")}, (0.0, 0.0, 12.0, 4.0)
    )
    problem = CoverageProblem(layout, 2.0)
    chosen = np.array([0, 0, 0, 5])
    out = distinct(problem, chosen)
    assert len(set(out.tolist())) == 4 and out[0] == 0 and out[3] == 5
    assert problem.fitness(out) >= problem.fitness(chosen)
