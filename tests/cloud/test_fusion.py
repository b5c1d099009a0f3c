"""The mobile-scan map's voxel pass: the first point of each voxel, in order, across frames,
against a plain Python dictionary of voxels; points outside the grid counted, not kept."""

import numpy as np

from genie_gl.cloud.fusion import _first_in_voxel


def reference(frames, shift, voxel, dims):
    seen, kept, outside = set(), [], []
    for xyz in frames:
        take, out = [], 0
        for p, x in enumerate(xyz.astype(np.float64)):
            ijk = tuple(int(np.floor((x[d] + shift[d]) / voxel)) for d in range(3))
            if any(v < 0 or v >= n for v, n in zip(ijk, dims)):
                out += 1
            elif ijk not in seen:
                seen.add(ijk)
                take.append(p)
        kept.append(take)
        outside.append(out)
    return kept, outside


def test_each_voxel_keeps_its_first_point_across_frames_and_outside_points_are_counted():
    rng = np.random.default_rng(0)
    dims = np.array([7, 5, 3], np.int64)
    voxel = 0.25
    shift = np.array([0.1, -0.2, 0.05])
    frames = [rng.uniform(-0.6, 2.1, (400, 3)).astype(np.float32) for _ in range(4)]
    bits = np.zeros((int(dims.prod()) + 7) // 8, np.uint8)
    got = [_first_in_voxel(f, shift, voxel, dims, bits) for f in frames]
    kept, outside = reference(frames, shift, voxel, dims)
    assert [g[0].tolist() for g in got] == kept
    assert [int(g[1]) for g in got] == outside and sum(outside) > 0
    # every voxel some point reached is marked, and no other
    assert (
        int(np.unpackbits(bits, bitorder="little").sum())
        == sum(len(k) for k in kept)
        < int(dims.prod()) + 1
    )
    assert len(got[-1][0]) < len(got[0][0])  # later frames find most voxels taken
