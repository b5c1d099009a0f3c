"""LiDAR effects on echoes with known answers: noise of the stated sigma, the blind zone, the
dropouts' thresholds, and the footprint's echoes per return mode."""

from dataclasses import replace

import numpy as np
import pytest

from genie_gl.effects.lidar_base import Echoes, SceneMaterials
from genie_gl.effects.lidar import (
    BeamDivergence,
    BlindZone,
    Dropout,
    RangeNoise,
    build_lidar_effects,
)
from genie_gl.effects.scanner_profile import load_scanner

SCENE = SceneMaterials(instances=3, shiny_metal=1, min_albedo=0.1, max_albedo=0.8)


def echoes(r, *, refl=0.5, cos=1.0, metallic=0.0, roughness=0.6, beam=None):
    r = np.asarray(r, np.float64)
    n = len(r)
    f = lambda v: np.broadcast_to(np.asarray(v, np.float64), (n,)).copy()  # noqa: E731
    return Echoes(
        np.arange(n) if beam is None else np.asarray(beam, np.int64),
        r,
        np.arange(1, n + 1, dtype=np.uint32),
        np.ones(n, np.uint16),
        np.tile([0.0, 0.0, 1.0], (n, 1)),
        f(cos),
        f(refl),
        f(metallic),
        f(roughness),
        f(refl) * f(cos),
        np.ones(n, np.uint8),
        np.ones(n, np.uint8),
    )


@pytest.fixture(scope="module")
def vlp16():
    return load_scanner("velodyne_vlp16")


def test_range_noise_has_its_sigma_and_step_and_is_the_seeds(vlp16):
    e = echoes(np.full(40000, 10.0))
    fx = RangeNoise(sigma_m=0.015, resolution_m=0.002)
    a = fx.apply(e, vlp16, rng=np.random.default_rng(1))
    b = fx.apply(e, vlp16, rng=np.random.default_rng(1))
    assert np.array_equal(a.range_m, b.range_m)
    assert np.std(a.range_m - 10.0) == pytest.approx(np.hypot(0.015, 0.002 / np.sqrt(12)), rel=0.03)
    np.testing.assert_allclose(a.range_m / 0.002, np.round(a.range_m / 0.002), atol=1e-6)
    assert not RangeNoise().plan(SCENE, vlp16).run  # nothing to do: skipped


def test_blind_zone_drops_the_near_echoes(vlp16):
    e = echoes([0.3, 0.89, 0.9, 5.0])
    out = BlindZone().apply(e, vlp16, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(out.range_m, [0.9, 5.0])  # the profile's 0.9 m
    assert BlindZone(min_m=0.0).plan(SCENE, vlp16).run is False


def test_dropouts_follow_received_power_metal_lobe_and_grazing(vlp16):
    fx = Dropout(reference_reflectance=0.8, reference_range_m=120.0)
    # 10 % at normal incidence reaches sqrt(10/80) x 120 = 42.4 m (Ouster's 40 m at 10 %)
    out = fx.apply(echoes([40.0, 42.0, 43.0, 60.0], refl=0.1), vlp16, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(out.range_m, [40.0, 42.0])
    # a mirror-smooth metal returns only within 15 deg of its normal
    cos = np.cos(np.radians([5.0, 14.0, 16.0, 40.0]))
    out = fx.apply(
        echoes([5.0] * 4, cos=cos, metallic=1.0, roughness=0.1), vlp16, rng=np.random.default_rng(0)
    )
    assert len(out) == 2
    # grazing beyond 85 deg gives nothing, whatever the surface
    cos = np.cos(np.radians([80.0, 86.0]))
    out = fx.apply(echoes([2.0, 2.0], cos=cos, refl=0.9), vlp16, rng=np.random.default_rng(0))
    assert len(out) == 1


def _footprint(vlp16, mode, ranges):
    s = replace(vlp16, returns=mode)
    fx = BeamDivergence(separation_m=1.0)
    _, w = fx.pattern(s)
    sub = echoes(ranges, beam=np.zeros(len(ranges), np.int64))
    return fx.combine(sub, w[: len(ranges)], s), w


@pytest.mark.parametrize(
    "mode, expect", [("strongest", [5.0]), ("last", [8.0]), ("dual", [5.0, 8.0])]
)
def test_a_footprint_across_an_edge_gives_the_modes_echoes(vlp16, mode, expect):
    # the centre and 3 of the 6 outer sub-rays on a near face at 5 m, the other 3 on a wall at 8 m
    out, w = _footprint(vlp16, mode, [5.0, 5.0, 5.0, 5.0, 8.0, 8.0, 8.0])
    np.testing.assert_allclose(out.range_m, expect)
    assert list(out.return_number) == list(range(1, len(expect) + 1)) and set(out.returns) == {
        len(expect)
    }
    # intensity: the share of the beam's energy on that surface times its reflectivity
    near = w[:4].sum() / w.sum() * 0.5
    assert out.intensity[0] == pytest.approx(
        near if expect[0] == 5.0 else w[4:].sum() / w.sum() * 0.5
    )


def test_surfaces_nearer_than_the_separation_blend_into_a_mixed_pixel(vlp16):
    out, w = _footprint(vlp16, "dual", [5.0, 5.0, 5.0, 5.0, 5.6, 5.6, 5.6])
    assert len(out) == 1 and 5.0 < out.range_m[0] < 5.6
    assert out.range_m[0] == pytest.approx((w[:4].sum() * 5.0 + w[4:].sum() * 5.6) / w.sum())


def test_subrays_span_the_cone_and_keep_the_beam(vlp16):
    fx = BeamDivergence()
    d = np.array([[1.0, 0.0, 0.0], [0.0, 0.6, -0.8]])
    sub = fx.subrays(d, vlp16).reshape(2, 7, 3)
    np.testing.assert_array_equal(sub[:, 0], d)
    ang = np.arccos(np.clip(np.einsum("bkj,bj->bk", sub[:, 1:], d), -1, 1))
    np.testing.assert_allclose(ang, 1.5e-3, rtol=1e-6)  # half of the 3.0 mrad cone


def _combined_by_beam(sub, weight, s, fx):
    """The footprint's echoes beam by beam, written out plainly: each beam's rows by range,
    grouped while within the separation, each group at its weighted range."""
    w_sum = fx.pattern(s)[1].sum()
    out = []
    for b in np.unique(sub.beam):
        rows = np.flatnonzero(sub.beam == b)
        rows = rows[np.argsort(sub.range_m[rows], kind="stable")]
        groups = [[rows[0]]]
        for a, c in zip(rows[:-1], rows[1:]):
            if sub.range_m[c] - sub.range_m[a] >= fx.separation_m:
                groups.append([])
            groups[-1].append(c)
        st = [weight[g] * (sub.intensity[g] + 1e-9) for g in groups]
        total = [x.sum() for x in st]
        strongest = int(np.argmax(total))
        keep = {"strongest": [strongest], "last": [len(groups) - 1]}.get(
            s.returns,
            sorted(
                {len(groups) - 1} | ({int(np.argmax(total[:-1]))} if len(groups) > 1 else set())
            ),
        )
        for g in keep:
            rep = groups[g][int(np.argmax(st[g]))]
            r = (st[g] * sub.range_m[groups[g]]).sum() / total[g]
            out.append((b, r, total[g] / w_sum, sub.instance[rep]))
    return out


@pytest.mark.parametrize("mode", ["strongest", "last", "dual"])
def test_footprints_of_many_beams_combine_as_written_out(vlp16, mode):
    # 400 beams of 0-7 sub-ray echoes over 1-3 surfaces (ties in range too)
    rng = np.random.default_rng(5)
    s, fx = replace(vlp16, returns=mode), BeamDivergence(separation_m=1.0)
    w_all = fx.pattern(s)[1]
    beam, ranges, weight = [], [], []
    for b in range(400):
        k = int(rng.integers(0, 8))
        walls = rng.choice([3.0, 3.4, 6.0, 9.5], size=3)
        beam += [b] * k
        ranges += list(walls[rng.integers(0, 3, k)] + rng.choice([0.0, 0.01], k))
        weight += list(w_all[np.sort(rng.choice(7, k, replace=False))])
    sub = replace(echoes(ranges, beam=beam), intensity=rng.uniform(0.1, 0.9, len(beam)))
    sub = replace(sub, instance=np.arange(1, len(beam) + 1, dtype=np.uint32))
    weight = np.asarray(weight)
    out = fx.combine(sub, weight, s)
    want = _combined_by_beam(sub, weight, s, fx)
    shuffled = np.random.default_rng(6).permutation(len(beam))  # rows in any order: the same
    again = fx.combine(sub.taken(shuffled), weight[shuffled], s)
    np.testing.assert_array_equal(again.beam, out.beam)
    np.testing.assert_allclose(again.range_m, out.range_m, rtol=1e-12)  # sums in another order
    assert len(out) == len(want) > 400 * 0.8
    np.testing.assert_array_equal(out.beam, [b for b, *_ in want])
    np.testing.assert_allclose(out.range_m, [r for _, r, *_ in want], rtol=1e-12)
    np.testing.assert_allclose(out.intensity, [i for *_, i, _ in want], rtol=1e-12)
    np.testing.assert_array_equal(out.instance, [x for *_, x in want])


def test_effect_lists_are_strict():
    with pytest.raises(Exception, match=r"effects\[0\].sigma_m: expected a number >= 0"):
        build_lidar_effects([{"type": "range_noise", "sigma_m": -1}], "x.lidar.yml")
    with pytest.raises(Exception, match=r"listed twice"):
        build_lidar_effects([{"type": "dropout"}, {"type": "dropout"}], "x.lidar.yml")
    with pytest.raises(Exception, match=r"rings: expected a whole number"):
        build_lidar_effects([{"type": "beam_divergence", "rings": 1.5}], "x.lidar.yml")
