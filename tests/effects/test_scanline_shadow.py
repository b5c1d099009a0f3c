"""The stereo shadow of a rectified pair drawn row by row from the depth image (method
"scanline"): analytic strip widths, a post narrower than its shadow, the second view on
either side, and agreement with the rendered second view (method "render")."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.render import Renderer
from genie_gl.effects import kernels
from genie_gl.effects.simulate import simulate
from genie_gl.sensors.camera import Stereo
from genie_gl.effects.base import drop
from genie_gl.effects.shadow import StereoShadow

pytestmark = pytest.mark.gl

F, B = 500.0, 0.075
Z_POST, Z_WALL = 1.0, 2.0


def wall_and(*boxes):
    """A wall whose face is at Z_WALL and boxes ((size), (centre)) before it."""
    scene = gg.Scene()
    scene.add(trimesh.creation.box((6, 6, 0.02)), [0, 0, Z_WALL + 0.01])
    for size, centre in boxes:
        scene.add(trimesh.creation.box(size), centre)
    return scene


def shadows(scene, baseline=B, **kw):
    """{method: (ideal frame, returns dropped by the shadow, the effect's record)}."""
    s = gg.Sensor.pinhole(320, 240, F)
    out = {}
    with Renderer(scene) as r:
        ideal = r.render(s, np.eye(4))
        for method, scale in (("scanline", 0.5), ("render", 1.0)):
            eff = StereoShadow(baseline_m=baseline, method=method, scale=scale, **kw)
            sensor = gg.Sensor.pinhole(320, 240, F, effects=(eff,))
            f = simulate(sensor, np.eye(4), render=r.render, rng=np.random.default_rng(0))
            out[method] = (ideal, (ideal.depth > 0) & (f.depth == 0), f.meta["stereo_shadow"])
    return out


def test_a_box_casts_a_strip_of_the_analytic_width_and_matches_the_render():
    # a box whose face is at 1 m, 2 m before the wall: f·b·(1/z_box − 1/z_wall) = 18.75 px
    scene = wall_and(((0.4, 0.6, 0.2), (0, 0, Z_POST + 0.1)))
    res = shadows(scene)
    ideal, gone, rec = res["scanline"]
    assert rec["method"] == "scanline" and rec["second_view"] is False
    strip, band = F * B * (1 / Z_POST - 1 / Z_WALL), F * B / Z_WALL
    rows = np.flatnonzero((ideal.depth == np.float32(Z_POST)).any(1))[5:-5]
    for v in rows:
        left = np.flatnonzero(ideal.depth[v] == np.float32(Z_POST))[0]
        assert abs(gone[v, left - 40 : left].sum() - strip) <= 1.0
        assert abs(gone[v, :40].sum() - band) <= 1.0  # outside the second view
        assert not gone[v, left:].any()  # the box and the wall right of it
    assert rec["occluded"] + rec["outside"] == gone.sum() == rec["changed"]
    assert np.array_equal(gone, res["render"][1])  # the rendered second view agrees


def test_a_post_narrower_than_its_shadow_hides_only_its_own_width():
    """A 20 mm post at 1 m (10 px) casts a 18.75 px shift: the second view sees the wall
    between the post's image and the strip it hides, which is 10 px wide, not 18.75. (The post
    is 2 mm deep: the side a deeper one turns to the second view, which the first view cannot
    see, widens the rendered strip by a fraction of a pixel; the scanline knows only what the
    first view sees.)"""
    scene = wall_and(((0.02, 0.6, 0.002), (0.0013, 0, Z_POST + 0.001)))  # no edge on a pixel centre
    res = shadows(scene)
    ideal, gone, _ = res["scanline"]
    shift = F * B * (1 / Z_POST - 1 / Z_WALL)
    rows = np.flatnonzero((ideal.depth == np.float32(Z_POST)).any(1))[5:-5]
    for v in rows:
        post = np.flatnonzero(ideal.depth[v] == np.float32(Z_POST))
        hidden = np.flatnonzero(gone[v, 40:]) + 40
        assert abs(len(hidden) - len(post)) <= 1
        assert abs(post[0] - hidden[0] - shift) <= 1.0  # the strip lies one shift left
        assert hidden[-1] < post[0] - 1  # and wall is seen between
    assert np.array_equal(gone, res["render"][1])


def test_the_second_view_on_the_left_hides_the_strip_right_of_an_edge():
    # the mirror image of the +x case, where a tie (an edge on a column centre) breaks the
    # other way: a baseline whose shifts are no multiple of half a pixel keeps ties out
    b = 0.0731
    scene = wall_and(((0.4, 0.6, 0.2), (0, 0, Z_POST + 0.1)))
    res = shadows(scene, baseline=b, axis=(-1.0, 0.0, 0.0))
    ideal, gone, _ = res["scanline"]
    strip = F * b * (1 / Z_POST - 1 / Z_WALL)
    for v in np.flatnonzero((ideal.depth == np.float32(Z_POST)).any(1))[5:-5]:
        right = np.flatnonzero(ideal.depth[v] == np.float32(Z_POST))[-1]
        assert abs(gone[v, right + 1 : right + 41].sum() - strip) <= 1.0
        assert not gone[v, : right + 1][40:].any()
    assert np.array_equal(gone, res["render"][1])


def test_scanline_agrees_with_the_rendered_second_view_on_a_cluttered_scene():
    """Thirty boxes, some thinner than a pixel, some rotated: the two methods agree on
    >= 99.5 % of the returns; the scanline is at least as close to the full-resolution render
    as the default half-resolution render is."""
    rng = np.random.default_rng(3)
    scene = gg.Scene()
    scene.add(trimesh.creation.box((8, 8, 0.02)), [0, 0, 4.0])
    for _ in range(30):
        T = trimesh.transformations.random_rotation_matrix(rng.random(3))
        T[:3, 3] = [*rng.uniform(-1, 1, 2), rng.uniform(1.0, 3.5)]
        scene.add(trimesh.creation.box(rng.uniform(0.005, 0.3, 3)), T)
    s = gg.Sensor.pinhole(320, 240, 250.0)
    gone = {}
    with Renderer(scene) as r:
        ideal = r.render(s, np.eye(4))
        for method, scale in (("scanline", 0.5), ("render", 1.0), ("render", 0.5)):
            eff = StereoShadow(baseline_m=0.05, method=method, scale=scale)
            f = eff.apply(
                ideal, rng=None, render_depth=lambda v, p: r.render(v, p, depth_only=True).depth
            )
            gone[method, scale] = (ideal.depth > 0) & (f.depth == 0)
    valid = (ideal.depth > 0).sum()
    differ = (gone["scanline", 0.5] != gone["render", 1.0]).sum()
    assert gone["render", 1.0].sum() > 1000 and differ <= 0.005 * valid
    assert differ <= (gone["render", 0.5] != gone["render", 1.0]).sum()


def test_the_fused_drop_equals_the_mask_then_drop():
    d = np.full((40, 60), 2.0, np.float32)
    d[10:30, 30:40] = 1.0
    d[0, :] = 0
    s = gg.Sensor.pinhole(60, 40, 100.0)
    inst = np.where(d > 0, np.where(d < 1.5, 2, 1), 0).astype(np.uint32)
    normal = np.zeros((40, 60, 3), np.float32)
    normal[..., 2] = -1
    f = gg.Frame(d, inst, inst.astype(np.uint16), None, s, np.eye(4), normal)
    eff = StereoShadow(baseline_m=0.1)
    out = eff.apply(f, rng=None)  # no renderer needed
    gone, occluded, outside = kernels.scanline_shadow(
        d, -100.0 * 0.1, eff.tolerance_m, eff.tolerance_rel
    )
    ref = drop(f, gone)
    # 5 px hidden left of the block (100·0.1·(1/1 − 1/2)) in its 20 rows; a 5 px band outside
    assert occluded == 20 * 5 and outside == 39 * 5
    for a, b in (
        (out.depth, ref.depth),
        (out.instance, ref.instance),
        (out.semantic, ref.semantic),
        (out.normal, ref.normal),
    ):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert out.meta["stereo_shadow"] == {
        "occluded": occluded,
        "outside": outside,
        "second_view": False,
        "method": "scanline",
        "changed": occluded + outside,
    }


def test_the_method_follows_the_pair_and_the_lens():
    pinhole = gg.Sensor.pinhole(64, 48, 50.0, stereo=Stereo(0.05))
    assert StereoShadow().resolved_method(pinhole) == "scanline"
    assert StereoShadow(method="render").resolved_method(pinhole) == "render"
    # a calibration with a rotation or a vertical offset: not rectified, so rendered
    for R, T in (
        (np.diag([1.0, 1.0, 1.0]) + np.eye(3, k=1) * 1e-3, [-0.05, 0, 0]),
        (np.eye(3), [-0.05, 0.001, 0]),
    ):
        tilted = gg.Sensor.pinhole(64, 48, 50.0, stereo=Stereo.from_extrinsics(R, T))
        assert StereoShadow().resolved_method(tilted) == "render"
        with pytest.raises(gg.ConfigError, match="scanline needs a rectified pair"):
            StereoShadow(method="scanline").resolved_method(tilted)
    distorted = gg.Sensor(64, 48, pinhole.K, np.array([0.1, 0, 0, 0, 0]), stereo=Stereo(0.05))
    assert StereoShadow().resolved_method(distorted) == "render"
    with pytest.raises(gg.ConfigError, match="stereo_shadow.method"):
        StereoShadow(method="fast")
