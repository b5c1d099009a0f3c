"""Level of detail: off, the frames are the exact ones; on, small-looking instances are drawn
from a simplified copy (fewer triangles) and depth moves by about the decimation's error."""

import numpy as np
import pytest
import trimesh

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.render import LevelOfDetail, Renderer
from genie_gl.sensors.pose import look_at

pytestmark = pytest.mark.gl


RADIUS = 0.5


def balls():
    """A row of 20,480-face spheres of radius 0.5 m, 3 to 30 m from the camera."""
    scene = gg.Scene()
    ball = trimesh.creation.icosphere(5, radius=RADIUS)
    for k, x in enumerate(np.linspace(3.0, 30.0, 10)):
        scene.add(ball, [x, 1.5 * (k % 3 - 1), 0.0], semantic=1)
    return scene, look_at([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def sphere_depth_error(frame, scene, pose):
    """(id, |depth - analytic sphere depth|) per pixel of each ball whose ray passes within
    0.9 radius of the ball's centre (away from silhouettes, where the depth is steep)."""
    K = frame.sensor.K
    h, w = frame.depth.shape
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    d_cam = np.stack(
        [(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1
    )  # z = 1
    d_world = d_cam @ pose[:3, :3].T
    origin = pose[:3, 3]
    ids, errs = [], []
    for inst in scene.instances:
        c = inst.world_from_model[:3, 3] - origin
        # |t d - c| = r with d of z = 1: t is the depth itself
        a = (d_world * d_world).sum(-1)
        b = d_world @ c
        miss2 = (c @ c) - b * b / a  # squared distance of the ray from the centre
        pix = (frame.instance == inst.instance) & (miss2 < (0.9 * RADIUS) ** 2)
        t = (b - np.sqrt(np.maximum(b * b - a * ((c @ c) - RADIUS**2), 0.0))) / a
        ids.append(np.full(int(pix.sum()), inst.instance))
        errs.append(np.abs(frame.depth[pix].astype(np.float64) - t[pix]))
    return np.concatenate(ids), np.concatenate(errs)


def test_lod_off_draws_every_face_and_the_full_meshes_depth(glctx):
    scene, pose = balls()
    sensor = gg.Sensor.pinhole(320, 240, 260.0)
    with (
        Renderer(scene, context=glctx) as off,
        Renderer(scene, context=glctx, lod=LevelOfDetail(below_px=60.0, keep=0.1)) as on,
    ):
        f_off, f_on = off.render(sensor, pose), on.render(sensor, pose)
        s_off, s_on = dict(off.stats), dict(on.stats)
    # off (the default): no instance simplified
    assert s_off["instances_simplified"] == 0
    # the full mesh lies within its chord sag of the true sphere: a face of icosphere(5) spans
    # ~2.2 degrees, sag 0.5 m (1 - cos 1.25 deg) = 0.12 mm, x 2.3 at 0.9 radius off centre
    ids, err = sphere_depth_error(f_off, scene, pose)
    assert len(err) > 2000 and err.max() < 5e-4
    # on: the nine far balls drawn from a tenth of the faces, ten times the sag: the bound above
    # tells the two apart
    assert s_on["instances_simplified"] == 9 and s_on["triangles_drawn"] < s_off["triangles_drawn"]
    ids, err = sphere_depth_error(f_on, scene, pose)
    assert err.max() > 5e-4


def test_lod_draws_far_instances_simplified_with_a_small_depth_error(glctx):
    scene, pose = balls()
    sensor = gg.Sensor.pinhole(320, 240, 260.0)
    lod = LevelOfDetail(below_px=60.0, keep=0.1)
    with Renderer(scene, context=glctx) as exact, Renderer(scene, context=glctx, lod=lod) as r:
        fe, fl = (
            exact.render(sensor, pose, depth_only=True),
            r.render(sensor, pose, depth_only=True),
        )
        n_exact, n_lod = exact.stats["triangles_drawn"], r.stats["triangles_drawn"]
        simplified = r.stats["instances_simplified"]
    # spheres 2 f r / z < 60 px across: z > 260 * 1 / 60 = 4.3 m, all but the nearest
    assert simplified == 9
    assert n_lod < n_exact
    both = (fe.instance > 0) & (fl.instance == fe.instance)
    assert both.sum() > 0.97 * (fe.instance > 0).sum()
    dz = np.abs(fl.depth[both] - fe.depth[both])
    # a sphere of radius 0.5 m kept at 10 % of its faces (2,048): chord sag ~ 0.5 (1 - cos a),
    # with a the angle of a face, ~4 degrees: a few millimetres
    assert np.median(dz) < 0.005 and dz.max() < 0.05
    near = fe.instance == fe.instance[fe.instance > 0].min()  # the nearest sphere: not simplified
    assert fl.depth[near].tobytes() == fe.depth[near].tobytes()


def test_lod_settings_are_checked():
    with pytest.raises(ConfigError, match="keep"):
        LevelOfDetail(keep=1.5)
    with pytest.raises(ConfigError, match="below_px"):
        LevelOfDetail(below_px=0)
    with pytest.raises(ConfigError, match="lod"):
        Renderer(gg.Scene(), lod=0.5)


def test_lod_is_an_accuracy_setting_that_capture_follows():
    from genie_gl.capture import capture
    from genie_gl.sensors.accuracy import AccuracySettings, from_dict

    scene, pose = balls()
    sensor = gg.Sensor.pinhole(320, 240, 260.0)
    (exact,) = capture(scene, sensor, [pose], seed=0, depth_only=True, raster="gl")
    (lod,) = capture(
        scene,
        sensor,
        [pose],
        seed=0,
        depth_only=True,
        accuracy=AccuracySettings(lod_px=60.0),
        raster="gl",
    )
    with Renderer(scene, lod=LevelOfDetail(below_px=60.0)) as r:
        direct = r.render(sensor, pose, depth_only=True)
    assert (
        lod.depth.tobytes() == direct.depth.tobytes()
        and lod.depth.tobytes() != exact.depth.tobytes()
    )
    with pytest.raises(ConfigError, match="lod_px"):
        from_dict({"lod_px": -3}, "profile.yaml")
