"""Tessellation of the built-in curved assets: ``build_scene(..., segments=n)``."""

import numpy as np
import pytest

import genie_gl as gg
from genie_gl.errors import ConfigError
from genie_gl.scene import Catalogue
from genie_gl.scene.assets import library as lib


def cylinder_vertices(n):
    return 2 * n + 2  # two rings and two cap centres


def car_vertices(ring, wheel):
    return 13 * ring + 2 + 4 * cylinder_vertices(wheel)  # the body's 13 sections and 4 wheels


@pytest.mark.parametrize("segments,ring,wheel", [(None, 20, 18), (7, 7, 7), (48, 48, 48)])
def test_segments_gives_every_circle_of_a_car_n_segments_and_none_keeps_the_parts_own(
    segments, ring, wheel
):
    m = lib.make("car", "sedan", segments)
    assert len(m.vertices) == car_vertices(ring, wheel)
    assert m.is_watertight and m.bounds[0][2] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("cls", sorted(lib.CURVED))
def test_curved_classes_follow_segments_and_the_rest_share_one_cached_mesh(cls):
    for v in lib.VARIANTS[cls]:
        coarse, fine = lib.make(cls, v, 6), lib.make(cls, v, 40)
        assert (
            len(fine.vertices) > len(coarse.vertices)
            and coarse.is_watertight
            and fine.is_watertight
        )
        assert lib.make(cls, v, 40) is fine  # cached per (variant, segments)
        np.testing.assert_allclose(fine.extents[:2], lib.make(cls, v).extents[:2], atol=2e-3)
    for other in sorted(set(lib.VARIANTS) - lib.CURVED):
        v = next(iter(lib.VARIANTS[other]))
        assert lib.make(other, v, 6) is lib.make(other, v)  # no curved part: one mesh


def test_segments_none_builds_the_default_scene_byte_for_byte(tmp_path):
    layout = gg.generate_layout("assembly_line", seed=4)
    a, b = gg.build_scene(layout, seed=1), gg.build_scene(layout, seed=1, segments=None)
    assert list(a.meshes) == list(b.meshes)
    for k in a.meshes:
        np.testing.assert_array_equal(a.meshes[k].vertices, b.meshes[k].vertices)
        np.testing.assert_array_equal(a.meshes[k].faces, b.meshes[k].faces)
    gg.write_usd(a, tmp_path / "a.usda")
    gg.write_usd(b, tmp_path / "b.usda")
    assert (tmp_path / "a.usda").read_bytes() == (tmp_path / "b.usda").read_bytes()
    # the default is each part's own count: the scene's sedan is the 20-ring, 18-wheel one
    assert len(a.meshes["car_sedan"].vertices) == car_vertices(20, 18)


def test_a_tessellated_scene_keeps_names_ids_and_draws_and_is_deterministic(tmp_path):
    layout = gg.generate_layout("assembly_line", seed=4)
    base = gg.build_scene(layout, seed=1)
    a, b = (
        gg.build_scene(layout, seed=1, segments=12),
        gg.build_scene(layout, seed=1, segments=np.int64(12)),
    )
    gg.write_usd(a, tmp_path / "a.usda")
    gg.write_usd(b, tmp_path / "b.usda")
    assert (tmp_path / "a.usda").read_bytes() == (tmp_path / "b.usda").read_bytes()
    assert list(a.meshes) == list(base.meshes)
    assert [(i.name, i.mesh, i.semantic) for i in a.instances] == [
        (i.name, i.mesh, i.semantic) for i in base.instances
    ]
    assert len(a.meshes["car_sedan"].vertices) == car_vertices(12, 12)
    assert len(a.meshes["pallet_eur"].vertices) == len(base.meshes["pallet_eur"].vertices)
    # a catalogue keeps its tessellation through copies
    assert Catalogue(segments=12).copy().mesh("car", "sedan") is lib.make("car", "sedan", 12)


@pytest.mark.parametrize("bad", [2, 0, -8, 2.5, 16.0, True, "16"])
def test_segments_must_be_an_integer_of_at_least_three(bad):
    layout = gg.generate_layout("assembly_line", seed=4)
    with pytest.raises(ConfigError, match="build_scene: segments must be an integer >= 3") as e:
        gg.build_scene(layout, seed=1, segments=bad)
    assert "\n" not in str(e.value)


@pytest.mark.gl
def test_the_rendered_depth_of_a_forklifts_wheels_approaches_the_fine_tessellation():
    """Seen obliquely, the wheels' silhouettes and treads: the depth and ids at 8, 16, 32 and
    64 segments per circle come ever closer to those at 256."""
    from genie_gl.render import Renderer, create_context
    from genie_gl.sensors.pose import look_at

    sensor = gg.Sensor.pinhole(160, 120, 200.0, near_m=0.1, far_m=20.0)
    pose = look_at([2.2, -1.4, 0.5], [0.6, -0.65, 0.25])  # the rear right wheel, 1.7 m away
    gl = create_context("egl")
    try:

        def render(n):
            scene = gg.Scene()
            scene.add(
                scene.add_mesh(Catalogue(segments=n).mesh("forklift", "standard"), "forklift"),
                np.eye(4),
                instance=1,
            )
            with Renderer(scene, context=gl) as r:
                return r.render(sensor, pose)

        ref = render(256)
        p99, ids = [], []
        for n in (8, 16, 32, 64):
            f = render(n)
            both = (f.depth > 0) & (ref.depth > 0)
            p99.append(np.percentile(np.abs(f.depth - ref.depth)[both], 99))
            ids.append(int((f.instance != ref.instance).sum()))
    finally:
        gl.release()
    assert all(a > b for a, b in zip(p99, p99[1:])), p99
    assert all(a > b for a, b in zip(ids, ids[1:])), ids
    # a facet's sag falls as 1/n^2: from 8 to 64 segments the p99 error falls far more than 8x
    assert p99[0] > 20 * p99[-1] and ids[0] > 20 * max(ids[-1], 1)
