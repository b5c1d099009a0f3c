"""A worker's warm-up builds every built-in asset variant once (``Catalogue.build_builtins``):
the scenes after it find each in the per-process caches and build none."""

from genie_gl.scene.assets import library as lib
from genie_gl.scene.assets.catalogue import ASSETS, _builtin_scene_mesh


def test_building_the_builtins_leaves_nothing_for_a_scene_to_build():
    cat = ASSETS.copy(segments=97)  # a tessellation no other test uses: the caches start without it
    before = lib._make.cache_info().misses
    assert cat.build_builtins() == sum(len(v) for v in lib.VARIANTS.values())
    built = lib._make.cache_info().misses - before
    assert built >= len(lib.CURVED & set(lib.VARIANTS))  # the curved classes, new at 97 segments
    misses = lib._make.cache_info().misses, _builtin_scene_mesh.cache_info().misses
    for cls, variants in lib.VARIANTS.items():
        for v in variants:
            assert cat.scene_mesh(cls, v) is cat.scene_mesh(cls, v)
            cat.mesh(cls, v)
    assert (lib._make.cache_info().misses, _builtin_scene_mesh.cache_info().misses) == misses
