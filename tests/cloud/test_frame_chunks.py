"""frame_chunks: the dataset's chunks straight from the frames, equal to chunking the merged
cloud."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.cloud import choose_origin, chunks, frame_chunks, to_cloud
from genie_gl.sensors.pose import look_at


def ground_frames(shift=(0.0, 0.0, 0.0), n=5, colour=True, normals=True, lens="pinhole"):
    """Cameras looking down at a ground plane from 3 m, spread over a few 4 m tiles; holes of
    every kind (rows out of range, scattered dropout)."""
    rng = np.random.default_rng(11)
    s = gg.Sensor.pinhole(96, 64, 60.0)
    if lens == "distorted":
        s = gg.Sensor(96, 64, s.K, dist=np.array([-0.2, 0.05, 0.001, -0.002, 0.0]))
    frames = []
    for k in range(n):
        eye = np.array([2.5 * k - 4.0, 1.5 * (k % 3) - 2.0, 3.0]) + shift
        pose = look_at(eye, eye + [0.3, 0.2, -3.0])
        d = rng.uniform(2.8, 3.6, (64, 96)).astype(np.float32)
        d[rng.random(d.shape) < 0.15] = 0
        d[: 4 * k] = 0
        ids = rng.integers(0, 5, d.shape)
        rgb = rng.integers(0, 256, (64, 96, 3)).astype(np.uint8) if colour else None
        normal = rng.normal(size=(64, 96, 3)).astype(np.float32) if normals else None
        frames.append(
            gg.Frame(d, ids.astype(np.uint32) + 100, ids.astype(np.uint16), rgb, s, pose, normal)
        )
    return frames


def assert_same_tiles(a, b):
    assert [k for k, _ in a] == [k for k, _ in b]
    for (_, ta), (_, tb) in zip(a, b):
        np.testing.assert_array_equal(ta.origin, tb.origin)
        for name in ("xyz", "semantic", "instance", "rgb", "normal", "camera"):
            va, vb = getattr(ta, name), getattr(tb, name)
            assert (va is None) == (vb is None), name
            if va is not None:
                np.testing.assert_array_equal(va, vb, err_msg=name)


@pytest.mark.parametrize("max_points", [None, 300, 2000])
@pytest.mark.parametrize("min_points", [1, 1500])
def test_frame_chunks_equal_chunks_of_the_merged_cloud(max_points, min_points):
    frames = ground_frames()
    merged = to_cloud(frames)
    kw = dict(min_points=min_points, max_points=max_points)
    a = chunks(merged, 4.0, rng=np.random.default_rng(3), **kw)
    b, total = frame_chunks(frames, 4.0, rng=np.random.default_rng(3), **kw)
    assert total == len(merged)
    assert len(a) >= 2  # several tiles, some down-sampled and some dropped, depending on the case
    assert_same_tiles(a, b)


@pytest.mark.parametrize("size", [4.0, 0.02])
def test_frame_chunks_through_a_distorted_lens_and_tiny_tiles(size):
    """The ray-table path, and tiles so small that a camera's points reach beyond the first
    window of tiles counted around it."""
    frames = ground_frames(lens="distorted")
    a = chunks(to_cloud(frames), size, min_points=3, max_points=40, rng=np.random.default_rng(2))
    b, _ = frame_chunks(frames, size, min_points=3, max_points=40, rng=np.random.default_rng(2))
    assert len(a) > 10
    assert_same_tiles(a, b)


def test_frame_chunks_far_from_the_origin_and_without_optional_fields():
    frames = ground_frames(shift=(4.0e5, -3.0e5, 0.0), colour=False, normals=False)
    a = chunks(to_cloud(frames), 4.0, min_points=10, max_points=500, rng=np.random.default_rng(8))
    b, _ = frame_chunks(frames, 4.0, min_points=10, max_points=500, rng=np.random.default_rng(8))
    assert np.abs(b[0][1].origin).max() > 1e5
    assert_same_tiles(a, b)


def test_frame_chunks_of_frames_that_see_nothing():
    frames = [f.replace(depth=np.zeros_like(f.depth)) for f in ground_frames(n=2)]
    assert frame_chunks(frames, 4.0, max_points=10, rng=np.random.default_rng(0)) == ([], 0)
    with pytest.raises(ValueError, match="rng"):
        frame_chunks(ground_frames(n=1), 4.0, max_points=10)


def test_frame_chunks_refuse_a_tile_grid_beyond_reason():
    with pytest.raises(ValueError, match="too small for the frames' extent"):
        frame_chunks(ground_frames(n=2), 1e-4, max_points=10, rng=np.random.default_rng(0))


@pytest.mark.parametrize("window, room", [(7, 4), (129, 8)])
def test_frame_chunks_with_frames_from_runs_and_frames_recomputed(monkeypatch, window, room):
    """Pass 2 walks pass 1's runs of pixels per tile for frames whose points stay in the
    window of tiles counted around their camera and whose runs fit the room given, and
    computes every pixel's tile again for the others. A small window (3 of the 6 frames
    reach beyond it) or little room for runs (4 of the 6 frames have too many) mixes both in
    one call; the tiles are still those of the merged cloud."""
    import genie_gl.cloud.process as process
    import genie_gl.cloud.tally as tally

    frames = ground_frames(n=6)
    monkeypatch.setattr(process, "WINDOW", window)
    monkeypatch.setattr(tally, "WINDOW", window)
    monkeypatch.setattr(tally, "RUN_ROOM", room)
    from_runs = []
    real = process._window_tiles
    monkeypatch.setattr(process, "_window_tiles", lambda *a: from_runs.append(a) or real(*a))
    a = chunks(to_cloud(frames), 1.0, min_points=5, max_points=60, rng=np.random.default_rng(4))
    b, _ = frame_chunks(frames, 1.0, min_points=5, max_points=60, rng=np.random.default_rng(4))
    assert 0 < len(from_runs) < len(frames)
    assert_same_tiles(a, b)


@pytest.mark.parametrize("inline", [False, True], ids=["thread", "inline"])
@pytest.mark.parametrize("window", [7, 129])
def test_frames_counted_as_they_come_give_the_tiles_of_frames_counted_at_once(
    monkeypatch, window, inline
):
    """A FrameTally counts each frame on its own thread (or, inline, on the caller's) as it
    is handed over (as the capture makes them); frame_chunks takes those counts and cuts the
    same tiles as when it counts the frames itself, on one thread or two. With a small
    window some frames reach beyond it (counted over their exact extent)."""
    import numba

    import genie_gl.cloud.process as process
    import genie_gl.cloud.tally as tally_module
    from genie_gl.cloud import FrameTally, origin_of

    monkeypatch.setattr(process, "WINDOW", window)
    monkeypatch.setattr(tally_module, "WINDOW", window)
    frames = ground_frames(n=6)
    kw = dict(min_points=5, max_points=60)
    origin = origin_of([f.world_from_camera for f in frames])
    np.testing.assert_array_equal(origin, choose_origin(frames))
    import threading

    tally = FrameTally(1.0, origin, inline=inline)
    for f in frames:
        tally.add(f)
        if inline:  # counted by add itself, on this thread: no thread of its own
            assert all(fut.done() for fut in tally._futures)
            assert not any(t.name.startswith("frame-tally") for t in threading.enumerate())
    assert tally.matches(frames, origin, 1.0)
    counted = []
    real = tally.results
    monkeypatch.setattr(tally, "results", lambda: counted.append(1) or real())
    a, total_a = frame_chunks(frames, 1.0, rng=np.random.default_rng(4), tally=tally, **kw)
    assert counted == [1]  # its counts were taken
    with pytest.raises(RuntimeError, match="closed"):
        tally.add(frames[0])
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        b, total_b = frame_chunks(frames, 1.0, rng=np.random.default_rng(4), **kw)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        c, total_c = frame_chunks(frames, 1.0, rng=np.random.default_rng(4), **kw)
    finally:
        numba.set_num_threads(threads)
    assert total_a == total_b == total_c > 0 and len(a) > 3
    assert_same_tiles(a, b)
    assert_same_tiles(a, c)
    assert_same_tiles(chunks(to_cloud(frames), 1.0, rng=np.random.default_rng(4), **kw), a)


def test_a_tally_of_other_frames_origin_or_tiles_is_not_taken():
    """Counts of other frames (a frame left out, or another object), another origin or
    another tile size are not used: frame_chunks counts again, and the tiles stay right."""
    from genie_gl.cloud import FrameTally, origin_of

    frames = ground_frames(n=4)
    origin = origin_of([f.world_from_camera for f in frames])
    want, _ = frame_chunks(frames, 4.0, max_points=50, rng=np.random.default_rng(1))
    cases = [
        (frames[:3], origin, 4.0),
        ([f.replace(depth=f.depth.copy()) for f in frames], origin, 4.0),
        (frames, origin + [100.0, 0, 0], 4.0),
        (frames, origin, 2.0),
    ]
    for handed, o, size in cases:
        tally = FrameTally(size, o)
        for f in handed:
            tally.add(f)
        assert not tally.matches(frames, origin, 4.0)
        got, _ = frame_chunks(frames, 4.0, max_points=50, rng=np.random.default_rng(1), tally=tally)
        assert_same_tiles(want, got)
        with pytest.raises(RuntimeError, match="closed"):  # closed by frame_chunks all the same
            tally.add(frames[0])


@pytest.mark.parametrize("inline", [False, True], ids=["thread", "inline"])
def test_a_tally_hands_on_the_error_of_a_frame_it_could_not_count(inline):
    from genie_gl.cloud import FrameTally, origin_of

    frames = ground_frames(n=2)
    tally = FrameTally(1e-4, origin_of([f.world_from_camera for f in frames]), inline=inline)
    for f in frames:
        tally.add(f)
    with pytest.raises(ValueError, match="too small for the frames' extent"):
        frame_chunks(frames, 1e-4, max_points=10, rng=np.random.default_rng(0), tally=tally)


def test_a_tally_shortens_the_switch_interval_only_while_it_counts():
    import sys

    from genie_gl.cloud import FrameTally
    from genie_gl.cloud.tally import SWITCH_INTERVAL_S

    before = sys.getswitchinterval()
    assert before > SWITCH_INTERVAL_S
    a, b = FrameTally(4.0, np.zeros(3)), FrameTally(4.0, np.zeros(3))
    assert sys.getswitchinterval() == SWITCH_INTERVAL_S
    a.close()
    a.close()  # closing twice counts once
    assert sys.getswitchinterval() == SWITCH_INTERVAL_S  # b still counts
    b.close()
    assert sys.getswitchinterval() == before
    c = FrameTally(4.0, np.zeros(3), inline=True)  # counting on the caller's thread: left alone
    assert sys.getswitchinterval() == before
    c.close()
    c.close()
    assert sys.getswitchinterval() == before


def test_a_tally_that_is_not_one_is_a_clear_error():
    with pytest.raises(
        gg.ConfigError, match="frame_chunks: tally: expected a FrameTally, got a list of 0"
    ):
        frame_chunks(ground_frames(n=1), 4.0, max_points=10, rng=np.random.default_rng(0), tally=[])
