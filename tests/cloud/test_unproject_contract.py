"""The contract of genie_gl.cloud.unproject around the kernel: the ray layouts its docstrings
promise, colour read from views of every layout (in place only inside memory the view's owner
holds), the float32 pose, and the room checks of ``unproject_into`` (nothing written on
failure)."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.camera import Camera
from genie_gl.cloud import kernels
from genie_gl.cloud.unproject import _colour_source, ray_table, rays, unproject, unproject_into

H, W = 6, 70


def frame(rng, *, rgb=None, pose=None, sensor=None):
    d = rng.uniform(0.5, 30.0, (H, W)).astype(np.float32)
    d[rng.random(d.shape) < 0.25] = 0
    ids = rng.integers(1, 2**16, d.shape)
    return gg.Frame(
        d,
        ids.astype(np.uint32),
        ids.astype(np.uint16),
        rgb,
        sensor or gg.Sensor.pinhole(W, H, 80.0),
        np.eye(4) if pose is None else pose,
    )


def skew_free_camera(**kw):
    return Camera(W, H, np.array([[61.0, 0.0, 33.5], [0.0, 57.0, 2.25], [0.0, 0.0, 1.0]]), **kw)


def test_rays_are_separable_for_a_skew_free_pinhole_and_tables_otherwise():
    """rays(): (1, W) by column and (H, 1) by row for a pinhole without skew (x = (u - cx)/fx,
    y = (v - cy)/fy), (H, W) tables for a skewed or distorted camera; the same rays either way."""
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    cam = skew_free_camera()
    tx, ty = rays(cam)
    assert tx.shape == (1, W) and ty.shape == (H, 1) and tx.dtype == ty.dtype == np.float32
    np.testing.assert_allclose(tx[0], (u[0] - 33.5) / 61.0, rtol=1e-7)
    np.testing.assert_allclose(ty[:, 0], (v[:, 0] - 2.25) / 57.0, rtol=1e-7)
    table = ray_table(cam).reshape(2, H, W)
    np.testing.assert_allclose(np.broadcast_to(tx, (H, W)), table[0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(np.broadcast_to(ty, (H, W)), table[1], rtol=0, atol=1e-7)

    K = cam.K.copy()
    K[0, 1] = 4.0  # skew: u = fx x + s y + cx
    tx, ty = rays(Camera(W, H, K))
    assert tx.shape == ty.shape == (H, W)
    y = (v - 2.25) / 57.0
    np.testing.assert_allclose(ty, y, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(tx, (u - 33.5 - 4.0 * y) / 61.0, rtol=1e-6, atol=1e-7)

    tx, ty = rays(skew_free_camera(dist=np.array([-0.05, 0.01, 0.0, 0.0])))
    assert tx.shape == ty.shape == (H, W)


def test_unproject_writes_the_float32_expression_of_the_float32_pose():
    """Points are d · (m0 x + (m1 y + m2)) + m3 evaluated in float32 with the pose rows rounded
    to float32 (the translation taken relative to the origin in float64): bit for bit, so
    every path that unprojects a frame writes the same points; and within float32 rounding of
    the float64 truth."""
    rng = np.random.default_rng(11)
    a, b = 0.7, -0.4
    Rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = Rz @ Rx, [1234.56, -987.6, 12.3]
    origin = np.array([1200.0, -1000.0, 0.0])
    f = frame(rng, pose=pose, sensor=skew_free_camera())
    c = unproject(f, origin=origin)
    M = np.concatenate([pose[:3, :3], (pose[:3, 3] - origin)[:, None]], 1).astype(np.float32)
    tx, ty = (np.broadcast_to(t, (H, W)) for t in rays(f.sensor))
    m = f.depth > 0
    d, x, y = f.depth[m], tx[m], ty[m]
    ref = np.stack([d * (M[r, 0] * x + (M[r, 1] * y + M[r, 2])) + M[r, 3] for r in range(3)], 1)
    assert ref.dtype == np.float32
    np.testing.assert_array_equal(c.xyz, ref)
    truth = (
        (np.stack([x, y, np.ones_like(x)], 1).astype(np.float64) * d[:, None].astype(np.float64))
        @ pose[:3, :3].T
        + pose[:3, 3]
        - origin
    )
    np.testing.assert_allclose(c.xyz, truth, rtol=0, atol=1e-4)
    np.testing.assert_array_equal(c.origin, origin)


def byte_range(a):
    lo, hi = np.lib.array_utils.byte_bounds(a)
    return lo, hi


@pytest.mark.parametrize("layout", ["argb_view", "owner_one_byte_short"])
def test_colour_view_is_never_widened_past_its_owners_memory(layout):
    """A (H, W, 3) view with the RGBA strides whose fourth byte of the last pixel is no part
    of its owner (the [..., 1:] view of an ARGB block; a buffer of 4 H W - 1 bytes) is copied,
    never widened into an (H, W, 4) array reaching past the owner's end; its colours are kept."""
    rng = np.random.default_rng(5)
    if layout == "argb_view":
        owner = rng.integers(0, 256, (H, W, 4)).astype(np.uint8)
        view = owner[..., 1:]
    else:
        owner = rng.integers(0, 256, 4 * H * W - 1).astype(np.uint8)
        view = np.ndarray((H, W, 3), np.uint8, buffer=owner, strides=(4 * W, 4, 1))
    assert view.strides == (4 * W, 4, 1) and not view.flags.c_contiguous
    out = _colour_source(view)
    olo, ohi = byte_range(owner)
    lo, hi = byte_range(out)
    assert not np.shares_memory(out, owner) or (olo <= lo and hi <= ohi)
    np.testing.assert_array_equal(out[..., :3], view)
    f = frame(rng, rgb=view)
    np.testing.assert_array_equal(unproject(f).rgb, view[f.depth > 0])


def test_colour_of_an_rgba_read_back_is_a_read_only_view_of_the_block():
    rng = np.random.default_rng(6)
    rgba = rng.integers(0, 256, (H, W, 4)).astype(np.uint8)
    out = _colour_source(rgba[..., :3])
    # named first: a failure message must not print an array that points at foreign memory
    dtype, shape, shared, writeable = (
        out.dtype,
        out.shape,
        np.shares_memory(out, rgba),
        out.flags.writeable,
    )
    assert dtype == np.uint8 and shape == (H, W, 4) and shared and not writeable
    np.testing.assert_array_equal(out, rgba)


@pytest.mark.parametrize(
    "layout", ["columns_reversed", "slice_of_a_wider_rgb", "slice_of_a_wider_rgba"]
)
def test_colour_from_views_of_any_layout(layout):
    """Colour views the kernel cannot read in place (negative strides, a window of a wider
    image) are copied: the points carry the colours of their pixels."""
    rng = np.random.default_rng(7)
    if layout == "columns_reversed":
        rgb = rng.integers(0, 256, (H, W, 3)).astype(np.uint8)[:, ::-1]
    elif layout == "slice_of_a_wider_rgb":
        rgb = rng.integers(0, 256, (H, W + 9, 3)).astype(np.uint8)[:, 4 : 4 + W]
    else:
        rgb = rng.integers(0, 256, (H, W + 9, 4)).astype(np.uint8)[:, 4 : 4 + W, :3]
    assert not rgb.flags.c_contiguous
    f = frame(rng, rgb=rgb)
    c = unproject(f)
    np.testing.assert_array_equal(c.rgb, np.array(rgb)[f.depth > 0])
    np.testing.assert_array_equal(c.semantic, f.semantic[f.depth > 0])


def buffers(n, *, short=None, colour=True):
    xyz = np.full(
        (n + 2, 4) if short == "xyz_width" else (n + 1 if short == "xyz" else n + 2, 3),
        7.0,
        np.float32,
    )
    sem = np.full(n if short == "semantic" else n + 1, 7, np.uint16)
    inst = np.full(n if short == "instance" else n + 1, 7, np.uint32)
    rgb = np.full((n if short == "rgb" else n + 1, 3), 7, np.uint8) if colour else None
    return xyz, sem, inst, rgb


@pytest.mark.parametrize("known", [True, False])
@pytest.mark.parametrize("short", ["xyz", "xyz_width", "semantic", "instance", "rgb"])
def test_unproject_into_refuses_any_output_without_room_and_writes_nothing(short, known):
    """Every output needs room for n + 1 points (xyz: n + 2 rows of 3); one row short of any of
    them (or xyz four wide) is a ValueError before anything is written."""
    rng = np.random.default_rng(8)
    f = frame(rng, rgb=rng.integers(0, 256, (H, W, 3)).astype(np.uint8))
    n = kernels.count_valid(f.depth)
    outs = buffers(n, short=short)
    with pytest.raises(ValueError, match=f"{n} points need xyz"):
        unproject_into(f, np.zeros(3), *outs, n=n if known else None)
    for a in outs:
        assert (a == 7).all()  # nothing written
    ok = buffers(n)
    assert unproject_into(f, np.zeros(3), *ok, n=n if known else None) == n
    np.testing.assert_array_equal(ok[1][:n], f.semantic[f.depth > 0])
    np.testing.assert_array_equal(ok[3][:n], f.rgb[f.depth > 0])


def test_unproject_into_writes_colour_only_when_both_sides_have_it():
    """rgb=None on a coloured frame: points and labels, no colour; an rgb buffer for a frame
    without colour: left as it was."""
    rng = np.random.default_rng(9)
    f = frame(rng, rgb=rng.integers(0, 256, (H, W, 3)).astype(np.uint8))
    n = kernels.count_valid(f.depth)
    xyz, sem, inst, _ = buffers(n, colour=False)
    assert unproject_into(f, np.zeros(3), xyz, sem, inst, None) == n
    np.testing.assert_array_equal(xyz[:n], unproject(f).xyz)
    np.testing.assert_array_equal(inst[:n], f.instance[f.depth > 0])
    plain = f.replace(rgb=None)
    xyz, sem, inst, rgb = buffers(n)
    assert unproject_into(plain, np.zeros(3), xyz, sem, inst, rgb) == n
    assert (rgb == 7).all()
    np.testing.assert_array_equal(sem[:n], f.semantic[f.depth > 0])
