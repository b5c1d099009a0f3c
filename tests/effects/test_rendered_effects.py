"""Effects that need the scene (stereo shadowing, normals) and visibility placement, rendered
on llvmpipe through EGL."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.layout.model import Layout, Region, RegionType
from genie_gl.render import Renderer
from genie_gl.sensors.camera import Stereo
from genie_gl.effects.simulate import simulate
from genie_gl.effects.registry import DepthNoise
from genie_gl.placement.genetic import VisibilityProblem
from genie_gl.effects.shadow import StereoShadow
from genie_gl.effects.surface import IncidenceDropout

pytestmark = pytest.mark.gl

F, B = 500.0, 0.075
Z_BOX, Z_WALL = 1.0, 2.0


@pytest.fixture(scope="module")
def box_and_wall():
    scene = gg.Scene()
    scene.add(trimesh.creation.box((6, 6, 0.02)), [0, 0, Z_WALL + 0.01])  # wall face at z = 2
    scene.add(trimesh.creation.box((0.4, 0.6, 0.2)), [0, 0, Z_BOX + 0.1])  # box face at z = 1
    with Renderer(scene) as r:
        yield r


def shadowed(r, effect, stereo=None):
    s = gg.Sensor.pinhole(320, 240, F, effects=(effect,), stereo=stereo)
    ideal = r.render(s, np.eye(4))
    out = simulate(s, np.eye(4), render=r.render, rng=np.random.default_rng(0))
    return ideal, out


@pytest.mark.parametrize("method", ["render", "scanline"])
def test_stereo_shadow_strip_has_the_analytic_width(box_and_wall, method):
    ideal, out = shadowed(
        box_and_wall, StereoShadow(baseline_m=B, method=method)
    )  # second view at +x
    gone = (ideal.depth > 0) & (out.depth == 0)
    assert not out.instance[gone].any() and not out.semantic[gone].any()
    assert out.normal is None and np.isfinite(out.depth).all()
    strip = F * B * (1 / Z_BOX - 1 / Z_WALL)  # 18.75 px of wall hidden left of the box
    band = F * B / Z_WALL  # 18.75 px at the left border: outside view 2
    box_rows = np.flatnonzero((ideal.depth == np.float32(Z_BOX)).any(1))
    widths, bands = [], []
    for v in box_rows[5:-5]:
        left_edge = np.flatnonzero(ideal.depth[v] == np.float32(Z_BOX))[0]
        row = gone[v]
        widths.append(row[left_edge - 40 : left_edge].sum())
        bands.append(row[:40].sum())
        assert not row[left_edge:].any()  # nothing hidden on the box or right of it
    assert np.abs(np.array(widths) - strip).max() <= 1.5
    assert np.abs(np.array(bands) - band).max() <= 1.0
    # the same pair from a stereo calibration (X2 = X1 + T, T = (-b, 0, 0)) gives the same frame
    stereo = Stereo.from_extrinsics(np.eye(3), [-B, 0, 0])
    _, calibrated = shadowed(box_and_wall, StereoShadow(method=method), stereo)
    assert calibrated.depth.tobytes() == out.depth.tobytes()


def test_stereo_shadow_compiled_drop_equals_mask_then_drop(box_and_wall):
    """apply() (render method) drops shadow_mask's returns in one compiled pass; the reference
    is the same mask handed to drop(), normals included."""
    from genie_gl.effects import kernels
    from genie_gl.effects.base import drop
    from genie_gl.effects.geometry import pixel_rays

    eff = StereoShadow(baseline_m=B, method="render")
    s = gg.Sensor.pinhole(320, 240, F)
    f = box_and_wall.render(s, np.eye(4), normals=True)
    second, view = eff.second_from_first(s), eff.view_sensor(s)
    depth2 = box_and_wall.render(view, np.linalg.inv(second), depth_only=True).depth
    out = eff.apply(
        f,
        rng=np.random.default_rng(0),
        render_depth=lambda v, p: box_and_wall.render(v, p, depth_only=True).depth,
    )
    gone, occluded, outside = kernels.shadow_mask(
        f.depth,
        pixel_rays(s),
        np.ascontiguousarray(second[:3, :3]),
        np.ascontiguousarray(second[:3, 3]),
        view.K,
        view.width,
        view.height,
        float(view.near_m),
        depth2,
        True,
        eff.tolerance_m,
        eff.tolerance_rel,
    )
    ref = drop(f, gone)
    assert occluded > 1000 and outside > 1000
    assert (
        out.meta["stereo_shadow"]["occluded"] == occluded
        and out.meta["stereo_shadow"]["outside"] == outside
    )
    for a, b in (
        (out.depth, ref.depth),
        (out.instance, ref.instance),
        (out.semantic, ref.semantic),
        (out.normal, ref.normal),
    ):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert f.depth[gone].all()  # the input frame is left as it was


def test_stereo_shadow_without_baseline_or_renderer_is_a_clear_error(box_and_wall):
    with pytest.raises(gg.ConfigError, match="no baseline"):
        shadowed(box_and_wall, StereoShadow())
    f = box_and_wall.render(gg.Sensor.pinhole(32, 24, 30.0), np.eye(4))
    with pytest.raises(gg.ConfigError, match="needs a renderer"):
        StereoShadow(baseline_m=0.05, method="render").apply(f, rng=np.random.default_rng(0))


def test_rendered_normals_drive_incidence_effects():
    a = np.radians(50.0)  # a plane turned 50° about y, 3 m away
    scene = gg.Scene()
    plane = trimesh.creation.box((8, 8, 0.01))
    T = np.eye(4)
    T[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    T[:3, 3] = [0, 0, 3.0]
    scene.add(plane, T)
    s = gg.Sensor.pinhole(160, 120, 100.0, effects=(IncidenceDropout(max_angle_deg=55.0),))
    noisy_sensor = gg.Sensor.pinhole(160, 120, 100.0, effects=(DepthNoise(),))
    with Renderer(scene) as r:
        ideal = r.render(s, np.eye(4))
        out = simulate(s, np.eye(4), render=r.render, rng=np.random.default_rng(0))
        noisy = simulate(noisy_sensor, np.eye(4), render=r.render, rng=np.random.default_rng(1))
    n = -T[:3, 2]  # the face towards the camera
    u, v = np.meshgrid(np.arange(160) - 79.5, np.arange(120) - 59.5)
    rays = np.stack([u / 100.0, v / 100.0, np.ones_like(u)], -1)
    theta = np.degrees(np.arccos(np.abs(rays @ n) / np.linalg.norm(rays, axis=-1)))
    hit = ideal.depth > 0
    clear = hit & (np.abs(theta - 55.0) > 0.05)
    np.testing.assert_array_equal((out.depth == 0)[clear], (theta > 55.0)[clear])
    assert 0.2 < (out.depth[hit] == 0).mean() < 0.8 and out.normal is None
    # Nguyen's angle term raises the noise on the steep side only
    err = noisy.depth.astype(np.float64) - ideal.depth
    steep, mild = hit & (theta > 65), hit & (theta < 55)
    assert np.std(err[steep]) > 1.5 * np.std(err[mild])


def test_structured_light_profile_end_to_end():
    s = gg.load_sensor("zivid2_m70")
    scene = gg.Scene()
    scene.add(trimesh.creation.box((3, 3, 0.02)), [0, 0, 0.91])  # wall face at 0.9 m
    scene.add(trimesh.creation.box((0.1, 0.1, 0.1)), [0, 0, 0.65])  # a cube 0.3 m before it
    ideal_sensor = gg.Sensor(s.width, s.height, s.K, s.dist)
    with Renderer(scene) as r:
        out = simulate(s, np.eye(4), render=r.render, rng=np.random.default_rng(0))
        ideal = simulate(ideal_sensor, np.eye(4), render=r.render, rng=np.random.default_rng(0))
    wall = (ideal.depth > 0.85) & (out.depth > 0)
    assert wall.sum() > 10_000 and np.isfinite(out.depth).all()
    expected = 0.9**2 * 0.0122 / (s.fx * s.stereo.baseline_m)  # 0.1 mm
    assert np.std(out.depth[wall].astype(np.float64) - ideal.depth[wall]) == pytest.approx(
        expected, rel=0.05
    )
    # the projector, 112 mm to the right, cannot light a strip left of the cube
    assert out.meta["stereo_shadow"]["occluded"] > 0 and out.meta["stereo_shadow"]["outside"] > 0


def test_a_wall_lowers_visibility_coverage_below_circle_coverage():
    types = {"work": RegionType("work", final=True, asset_group="pallets")}
    layout = Layout.from_regions([Region(7, 1, 4, 4, "work")], types, (0, 0, 12, 6))
    fits = {}
    for wall in (False, True):
        scene = gg.Scene()
        scene.add(trimesh.creation.box((12, 6, 0.1)), [6, 3, -0.05])
        if wall:  # 3 m high, between x = 5.9 and 6.1
            scene.add(trimesh.creation.box((0.2, 6, 3.0)), [6.0, 3, 1.5])
        with Renderer(scene) as r:
            problem = VisibilityProblem(layout, 6.0, render=r.render)
            (pose,) = gg.place_sensors(
                layout, None, n=1, method="greedy", fitness="visibility", render=r.render
            )
        assert pose[0, 3] > 6.1 or not wall  # behind the wall it sees nothing
        k = np.array([int(np.argmin(((problem.candidates - [3.5, 3.5]) ** 2).sum(1)))])
        circle = float(problem.weight[problem.disc[k].any(0)].sum()) / problem.total
        fits[wall] = (circle, problem.fitness(k))
    (circle, open_vis), (circle_w, walled_vis) = fits[False], fits[True]
    assert circle == circle_w and circle > 0.5  # the disc reaches into the region
    assert open_vis > 0.9 * circle  # seen from 3.5 m with nothing in the way
    assert walled_vis < 0.1 * circle  # the wall hides it
    with Renderer(gg.Scene()) as r:
        with pytest.raises(gg.ConfigError, match="did you mean 'visibility'"):
            gg.place_sensors(layout, None, n=1, fitness="visibilty", render=r.render)
