"""The noise kernels that draw from the Generator inside their loop give what the reference
computation gives: numpy's ``rng.standard_normal(n)`` over the valid pixels, then the model
in numpy (value for value, and the same generator state afterwards)."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.effects import kernels
from genie_gl.effects.registry import DepthNoise


def depth_with_holes(seed=0, h=40, w=50):
    g = np.random.default_rng(seed)
    d = g.uniform(0.3, 6.0, (h, w)).astype(np.float32)
    d[g.random((h, w)) < 0.3] = 0.0
    return d


@pytest.mark.parametrize("step", [1 / 32, 0.1, 0.0])  # a power of two (multiplied), others divided
def test_stereo_noise_rng_equals_numpy_draws_and_model(step):
    d = depth_with_holes()
    fb, sigma_d = 426.2 * 0.05, 0.08
    out, lost, changed = kernels.stereo_noise_rng(d, np.random.default_rng(7), fb, sigma_d, step)
    ref_rng = np.random.default_rng(7)
    valid = d > 0
    z = d.astype(np.float64)[valid]
    noisy = z + ref_rng.standard_normal(z.size) * (z * z * sigma_d / fb)  # the model, in numpy
    if step:
        disp = np.round(fb / np.maximum(noisy, 1e-6) / step) * step
        noisy = np.where(disp > 0, fb / np.maximum(disp, 1e-12), 0.0)
    ref = np.zeros_like(d)
    ref[valid] = noisy.astype(np.float32)
    assert lost == 0 and out.tobytes() == ref.tobytes()
    assert changed == int((out != d).sum()) > 0.9 * valid.sum()  # the pixels it changed, counted
    old, old_lost = kernels.stereo_noise(
        d, np.random.default_rng(7).standard_normal(z.size), fb, sigma_d, step
    )
    assert old_lost == lost and old.tobytes() == out.tobytes()


def test_linear_noise_rng_equals_numpy_draws_and_counts_lost():
    d = depth_with_holes(1)
    a, b, z0 = 1.0, 0.0, 0.5  # σ 1 m: about a fifth of the returns pushed to <= 0
    g = np.random.default_rng(3)
    out, lost, changed = kernels.linear_noise_rng(d, g, a, b, z0)
    ref_rng = np.random.default_rng(3)
    valid = d > 0
    z = d.astype(np.float64)[valid]
    noisy = (z + ref_rng.standard_normal(z.size) * (a + b * np.maximum(z - z0, 0.0))).astype(
        np.float32
    )
    ref = np.zeros_like(d)
    ref[valid] = np.where(noisy > 0, noisy, 0)
    assert lost == int((noisy <= 0).sum()) > 0
    assert out.tobytes() == ref.tobytes()
    assert changed == int((out != d).sum()) and changed >= lost
    assert g.standard_normal() == ref_rng.standard_normal()  # the same state afterwards


@pytest.mark.parametrize("model", ["stereo", "tof_linear"])
def test_depth_noise_apply_leaves_the_generator_where_numpy_draws_would(model):
    d = depth_with_holes(2)
    s = gg.Sensor.pinhole(d.shape[1], d.shape[0], 400.0)
    inst = (d > 0).astype(np.uint32)
    f = gg.Frame(d, inst, inst.astype(np.uint16), None, s, np.eye(4), None)
    g = np.random.default_rng(11)
    DepthNoise(model=model, baseline_m=0.05, subpixel=0.08).apply(f, rng=g)
    ref = np.random.default_rng(11)
    ref.standard_normal(int((d > 0).sum()))
    assert g.standard_normal(4).tolist() == ref.standard_normal(4).tolist()


@pytest.mark.parametrize("model", ["stereo", "tof_linear"])
def test_compiled_depth_noise_records_the_pixels_it_changed(model):
    """The compiled models hand simulate their own count of changed pixels (meta["depth_noise"]),
    so that it need not compare frames; the count is the frames' difference."""
    d = depth_with_holes(4)
    s = gg.Sensor.pinhole(d.shape[1], d.shape[0], 400.0)
    inst = (d > 0).astype(np.uint32)
    f = gg.Frame(d, inst, inst.astype(np.uint16), None, s, np.eye(4), None)
    out = DepthNoise(model=model, baseline_m=0.05, subpixel=0.08).apply(
        f, rng=np.random.default_rng(5)
    )
    changed = int((out.depth != d).sum())
    assert out.meta["depth_noise"] == {"changed": changed} and changed > 0.9 * (d > 0).sum()


def test_nguyen_noise_is_z_plus_sigma_times_the_generators_normals():
    """The numpy path (kinect_nguyen2012 with its incidence term): each return is
    z + σ_z(z, θ)·N, N the generator's standard normals in pixel order, σ_z from Nguyen et al.
    written out here, θ from the normals and each pixel's ray; rounded once to float32."""
    h, w, fpx = 30, 40, 60.0
    rng = np.random.default_rng(8)
    d = rng.uniform(0.6, 3.0, (h, w)).astype(np.float32)
    d[rng.random((h, w)) < 0.2] = 0.0
    s = gg.Sensor.pinhole(w, h, fpx)
    tilt = np.radians(rng.uniform(0, 84, (h, w)))  # incidence angles from 0° to 84°
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    ray = np.stack([(u - s.cx) / fpx, (v - s.cy) / fpx, np.ones_like(u)], -1)
    ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
    side = np.cross(ray, [0.0, 1.0, 0.0])
    side /= np.linalg.norm(side, axis=-1, keepdims=True)
    normal = -ray * np.cos(tilt)[..., None] + side * np.sin(tilt)[..., None]  # θ from the ray
    inst = (d > 0).astype(np.uint32)
    f = gg.Frame(
        d, inst, inst.astype(np.uint16), None, s, np.eye(4), normal=normal.astype(np.float32)
    )
    out = DepthNoise(model="kinect_nguyen2012").apply(f, rng=np.random.default_rng(21))
    valid = d > 0
    z = d.astype(np.float64)[valid]
    n = normal.astype(np.float32).astype(np.float64)[valid]
    t = np.arccos(np.clip(-(n * ray[valid]).sum(-1), 0.0, 1.0))
    t = np.minimum(t, np.radians(85.0))
    sigma = (
        0.0012
        + 0.0019 * (z - 0.4) ** 2
        + np.where(t > np.pi / 3, 0.0001 / np.sqrt(z) * t**2 / (np.pi / 2 - t) ** 2, 0)
    )
    ref = z + np.random.default_rng(21).standard_normal(z.size) * sigma
    assert (t > np.pi / 3).sum() > 100
    np.testing.assert_array_equal(
        out.depth[valid], ref.astype(np.float32)
    )  # in float64, rounded once
    assert np.abs(out.depth[valid] - d[valid]).max() > 0.01  # noise, not the frame


def test_the_effects_reference_computations_give_the_fused_bytes_and_record():
    """``fused=False`` (what ``genie bench planning`` times beside the fused path) runs the
    reference computation of the effect's own code: the same frame, byte for byte."""
    from genie_gl.sensors.camera import Stereo
    from genie_gl.effects.shadow import StereoShadow

    d = depth_with_holes(2, 48, 64)
    d[10:30, 20:30] = 0.9  # a near block: edges that cast a stereo shadow
    sensor = gg.Sensor.pinhole(64, 48, 60.0, stereo=Stereo(0.05))
    inst = (d > 0).astype(np.uint32)
    frame = gg.Frame(d, inst, inst.astype(np.uint16), None, sensor, np.eye(4))
    for fused in (
        DepthNoise(model="stereo", subpixel_step=1 / 32),
        DepthNoise(model="tof_linear"),
        StereoShadow(method="scanline"),
    ):
        reference = fused.__class__(**{**vars(fused), "fused": False})
        a, b = (
            fused.apply(frame, rng=np.random.default_rng(5)),
            reference.apply(frame, rng=np.random.default_rng(5)),
        )
        for name in ("depth", "instance", "semantic"):
            assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), (fused.name, name)
        assert a.meta[fused.name] == b.meta[fused.name]
        assert (a.depth != d).any()  # the effect did change the frame


def test_every_effect_on_every_frame_gives_the_frame_the_checks_give():
    """``simulate(decide=False)`` (the pipeline before the planner) runs every effect the
    checks would skip, and gives the same frame: a skip never changes the output."""
    from genie_gl.effects.simulate import simulate
    from genie_gl.sensors.camera import Stereo
    from genie_gl.effects.registry import build_effects

    effects = build_effects(
        [
            {"type": "range", "min_m": 0.3, "max_m": 5.0},
            {"type": "stereo_shadow"},
            {"type": "depth_noise", "model": "stereo"},
            {"type": "edge_dropout"},
        ],
        "test",
    )
    sensor = gg.Sensor.pinhole(64, 48, 60.0, effects=effects, stereo=Stereo(0.05))
    for d in (
        depth_with_holes(3, 48, 64),
        np.zeros((48, 64), np.float32),
    ):  # the second: nothing to do
        inst = (d > 0).astype(np.uint32)

        def render(s, pose, **kw):
            return gg.Frame(d, inst, inst.astype(np.uint16), None, s, pose)

        a = simulate(sensor, np.eye(4), render=render, rng=np.random.default_rng(1))
        b = simulate(sensor, np.eye(4), render=render, rng=np.random.default_rng(1), decide=False)
        assert (
            a.depth.tobytes() == b.depth.tobytes() and a.instance.tobytes() == b.instance.tobytes()
        )
        assert all(e["run"] for e in b.meta["effects"])
    assert not all(e["run"] for e in a.meta["effects"])  # on the empty frame the checks skip
