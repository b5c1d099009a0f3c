"""The frame-to-points kernel against a plain numpy evaluation of the same float32 expression:
the run-by-run (vectorised) and the pixel-by-pixel paths must write the same bits, whatever
the pattern of valid pixels."""

import numpy as np
import pytest

from genie_gl.cloud import kernels


def reference(depth, tx, ty, M, sem, inst, rgb):
    """The kernel's expression, d * (m0 x + (m1 y + m2)) + m3 in float32, for depth > 0."""
    H, W = depth.shape
    x, y = np.broadcast_to(tx, (H, W)), np.broadcast_to(ty, (H, W))
    m = depth > 0
    d, x, y = depth[m], x[m], y[m]
    xyz = np.stack([d * (M[r, 0] * x + (M[r, 1] * y + M[r, 2])) + M[r, 3] for r in range(3)], 1)
    return xyz, sem[m], inst[m], None if rgb is None else rgb[m][:, :3]


def first_principles(depth, tx, ty, M):
    """Independent truth in float64: a pixel is a return only if its depth is a finite
    positive number; its point is the pose applied to depth · (x, y, 1)."""
    H, W = depth.shape
    d = depth.astype(np.float64)
    ok = np.isfinite(d) & (np.nan_to_num(d, nan=-1.0) > 0)
    rays = np.stack(
        [np.broadcast_to(tx, (H, W)), np.broadcast_to(ty, (H, W)), np.ones((H, W))], -1
    )[ok]
    Md = M.astype(np.float64)
    return (rays.astype(np.float64) * d[ok][:, None]) @ Md[:, :3].T + Md[:, 3]


def patterned_depth(rng, H, W, pattern):
    d = rng.uniform(0.3, 40.0, (H, W)).astype(np.float32)
    if pattern == "scattered":  # random dropout: pixel-by-pixel path
        d[rng.random((H, W)) < 0.3] = 0
    elif pattern == "runs":  # long holes, runs across 64-pixel word boundaries
        for v in range(H):
            for _ in range(rng.integers(0, 6)):
                a = rng.integers(0, W)
                d[v, a : a + rng.integers(1, 150)] = 0
    elif pattern == "nan_scattered":  # NaN, negative and zero holes in words of many runs
        r = rng.random((H, W))
        d[r < 0.2] = np.nan
        d[(r >= 0.2) & (r < 0.3)] = -rng.uniform(0.1, 5.0, int(((r >= 0.2) & (r < 0.3)).sum()))
        d[(r >= 0.3) & (r < 0.35)] = 0
    elif pattern == "empty":
        d[:] = 0
    elif pattern == "mixed":  # words of every kind in one frame, NaN and negative depths invalid
        d[::2, rng.integers(0, W, H // 2 + 1)[0]] = 0
        d[1::3][rng.random(d[1::3].shape) < 0.5] = 0
        d[0, 60:68] = np.nan
        d[-1, :5] = -1.0
        d[2, 64:128] = 0
    return d


@pytest.mark.parametrize("W", [5, 64, 200, 640, 848])
@pytest.mark.parametrize(
    "pattern", ["full", "scattered", "runs", "empty", "mixed", "nan_scattered"]
)
@pytest.mark.parametrize("separable", [True, False])
def test_kernel_writes_exactly_the_reference_points(W, pattern, separable):
    rng = np.random.default_rng(W * 7 + len(pattern))
    H = 9
    depth = patterned_depth(rng, H, W, pattern)
    tx = rng.normal(size=(1 if separable else H, W)).astype(np.float32)
    ty = rng.normal(size=(H, 1 if separable else W)).astype(np.float32)
    M = rng.normal(size=(3, 4)).astype(np.float32)
    sem = rng.integers(0, 2**16, (H, W)).astype(np.uint16)
    inst = rng.integers(0, 2**32, (H, W), dtype=np.uint64).astype(np.uint32)
    rgba = rng.integers(0, 256, (H, W, 4)).astype(np.uint8)
    for rgb in (None, np.ascontiguousarray(rgba[..., :3]), rgba):
        n_ref = int(np.count_nonzero(depth > 0))
        xyz = np.full((n_ref + 2, 3), np.nan, np.float32)
        so, io = np.zeros(n_ref + 1, np.uint16), np.zeros(n_ref + 1, np.uint32)
        co = np.zeros((n_ref + 1 if rgb is not None else 0, 3), np.uint8)
        src = np.zeros((0, 0, 3), np.uint8) if rgb is None else rgb
        n = kernels.unproject(depth, tx, ty, M, sem, inst, src, xyz, so, io, co)
        assert n == n_ref
        if rgb is None:  # the count and the points against first principles (NaN is no return)
            truth = first_principles(depth, tx, ty, M)
            assert n == len(truth)
            scale = np.abs(truth).max() if len(truth) else 1.0
            np.testing.assert_allclose(xyz[:n], truth, rtol=0, atol=1e-5 * scale)
        rx, rs, ri, rc = reference(depth, tx, ty, M, sem, inst, rgb)
        np.testing.assert_array_equal(xyz[:n], rx)  # bit for bit: both paths, same expression
        np.testing.assert_array_equal(so[:n], rs)
        np.testing.assert_array_equal(io[:n], ri)
        if rgb is not None:
            np.testing.assert_array_equal(co[:n], rc)


@pytest.mark.parametrize("separable", [True, False])
def test_unprojection_drops_nan_depth_in_every_path(separable):
    """NaN (and negative) depth is no return in each of the kernel's paths: in words written
    pixel by pixel (more than MAX_RUNS runs), in dense runs, and in the row's tail past its
    last whole 64-pixel word. The kernel gets room for every pixel, so a NaN counted as a
    return shows as a wrong count, not as a write past the buffer; the truth is pixel by pixel
    in float64: the finite positive depths, each scaled along its ray (x, y, 1)."""
    H, W = 4, 200  # 3 whole words and a tail of 8 per row
    rng = np.random.default_rng(11)
    d = rng.uniform(0.5, 9.0, (H, W)).astype(np.float32)
    d[0, 1::2] = np.nan  # every other pixel: words of 32 runs
    d[1, 64:128] = np.nan  # a whole word of NaN between dense runs
    d[1, 3:60:7] = np.nan  # and scattered ones before it
    d[2, 192::2] = np.nan  # the tail, pixel by pixel
    d[3, ::3] = np.nan
    d[3, 1::9] = -1.5
    d[3, 2::11] = 0.0
    ok = np.isfinite(d) & (np.nan_to_num(d, nan=-1.0) > 0)
    # the holes planted above, counted by hand: row 3 has 67 NaN, 23 negatives (none on a
    # NaN) and 10 zeros (18 minus 6 on a NaN and 2 on a negative)
    assert ok.sum() == W * H - (100 + 64 + 9 + 4 + 67 + 23 + 10)
    tx = (np.arange(W, dtype=np.float32) - 99.5) / 150.0
    ty = (np.arange(H, dtype=np.float32) - 1.5) / 150.0
    if separable:
        tx, ty = tx[None, :], ty[:, None]
    else:
        tx, ty = np.broadcast_to(tx, (H, W)).copy(), np.broadcast_to(ty[:, None], (H, W)).copy()
    M = np.array([[0, 0, 1, 2.0], [-1, 0, 0, -3.0], [0, -1, 0, 1.5]], np.float32)
    xyz = np.full((H * W + 2, 3), np.nan, np.float32)
    so, io = np.zeros(H * W + 1, np.uint16), np.zeros(H * W + 1, np.uint32)
    ids = np.arange(H * W, dtype=np.uint32).reshape(H, W)
    n = kernels.unproject(
        d,
        tx,
        ty,
        M,
        ids.astype(np.uint16),
        ids,
        np.zeros((0, 0, 3), np.uint8),
        xyz,
        so,
        io,
        np.zeros((0, 3), np.uint8),
    )
    assert n == int(ok.sum())
    assert kernels.count_valid(d) == int(ok.sum())
    np.testing.assert_array_equal(io[:n], ids[ok])  # exactly the finite positive pixels, in order
    v, u = np.nonzero(ok)
    x = (u - 99.5) / 150.0
    y = (v - 1.5) / 150.0
    cam = np.stack([x, y, np.ones_like(x)], 1) * d[ok].astype(np.float64)[:, None]
    truth = cam @ M[:, :3].astype(np.float64).T + M[:, 3]
    np.testing.assert_allclose(xyz[:n], truth, rtol=0, atol=1e-5)


def test_colour_read_from_an_rgba_view_without_copy():
    """Frames carry colour as an [..., :3] view of the RGBA read-back; the kernel reads it in
    place and gives the same colours as a contiguous copy."""
    import genie_gl as gg
    from genie_gl.cloud import unproject
    from genie_gl.cloud.unproject import _colour_source

    rng = np.random.default_rng(3)
    s = gg.Sensor.pinhole(130, 70, 90.0)
    d = rng.uniform(1, 5, (70, 130)).astype(np.float32)
    d[rng.random(d.shape) < 0.2] = 0
    rgba = rng.integers(0, 256, (70, 130, 4)).astype(np.uint8)
    ids = rng.integers(0, 9, d.shape)
    view = gg.Frame(d, ids.astype(np.uint32), ids.astype(np.uint16), rgba[..., :3], s, np.eye(4))
    copy = view.replace(rgb=np.ascontiguousarray(rgba[..., :3]))
    assert _colour_source(view.rgb).shape == (70, 130, 4)  # the RGBA block itself
    np.testing.assert_array_equal(unproject(view).rgb, unproject(copy).rgb)
    np.testing.assert_array_equal(unproject(view).rgb, rgba[d > 0][:, :3])


def test_merge_counts_and_normals_agree_with_the_kernel_on_invalid_depths():
    """NaN and negative depths are no return, for the point count (which sizes the merged
    arrays), the points and the normals alike."""
    import genie_gl as gg
    from genie_gl.cloud import to_cloud
    from genie_gl.sensors.pose import look_at

    rng = np.random.default_rng(4)
    s = gg.Sensor.pinhole(150, 40, 100.0)
    frames = []
    for k, eye in enumerate(([3.0, 0.0, 1.0], [0.0, 4.0, 2.0])):
        d = rng.uniform(1, 5, (40, 150)).astype(np.float32)
        d[rng.random(d.shape) < 0.1] = 0
        d[3, 10:90] = np.nan
        d[7, :20] = -2.0
        normal = np.zeros((40, 150, 3), np.float32)
        normal[..., 2] = -1.0  # facing the camera
        ids = np.full(d.shape, k + 1)
        frames.append(
            gg.Frame(
                d,
                ids.astype(np.uint32),
                ids.astype(np.uint16),
                None,
                s,
                look_at(eye, [0.0, 0.0, 0.0]),
                normal,
            )
        )
    assert kernels.count_valid(frames[0].depth) == int((frames[0].depth > 0).sum())
    c = to_cloud(frames)
    valid = [f.depth > 0 for f in frames]
    assert len(c) == sum(int(v.sum()) for v in valid)
    for k, f in enumerate(frames):
        m = c.camera == k
        assert (c.instance[m] == k + 1).all() and np.isfinite(c.xyz[m]).all()
        toward = f.world_from_camera[:3, :3] @ [0.0, 0.0, -1.0]
        np.testing.assert_allclose(
            c.normal[m], np.broadcast_to(toward, (int(m.sum()), 3)), atol=1e-6
        )


def test_unproject_into_checks_the_room_before_writing():
    import genie_gl as gg
    from genie_gl.cloud.unproject import unproject_into

    s = gg.Sensor.pinhole(70, 8, 50.0)
    d = np.ones((8, 70), np.float32)
    f = gg.Frame(d, np.ones(d.shape, np.uint32), np.ones(d.shape, np.uint16), None, s, np.eye(4))
    n = d.size
    ok = (
        np.full((n + 2, 3), 7.0, np.float32),
        np.zeros(n + 1, np.uint16),
        np.zeros(n + 1, np.uint32),
    )
    assert unproject_into(f, np.zeros(3), *ok) == n
    short = (
        np.full((n + 1, 3), 7.0, np.float32),
        np.zeros(n + 1, np.uint16),
        np.zeros(n + 1, np.uint32),
    )
    with pytest.raises(ValueError, match=f"{n} points need xyz"):
        unproject_into(f, np.zeros(3), *short)
    assert (short[0] == 7.0).all()  # nothing written
