"""The package's kernel cache: fresh only while a kernel's module and every module of the
package it imports are unchanged (a kernel compiles in the kernels it calls from other
modules; numba's own stamp hashes only the file that defines it)."""

import numba

from genie_gl import jit
from genie_gl.render.cpu import raster


def test_the_package_kernels_are_cached_under_their_modules_stamp():
    assert jit.installed()
    locator = raster._raster._cache._impl.locator
    assert isinstance(locator, jit._ImportStamped)
    assert locator.get_source_stamp() == jit.source_stamp(raster.__file__)


def test_the_stamp_follows_the_imported_modules_only(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.py").write_text("from .sub.b import f\nfrom . import c\n")
    (tmp_path / "sub" / "b.py").write_text("from ..d import g\n")
    (tmp_path / "c.py").write_text("x = 1\n")
    (tmp_path / "d.py").write_text("def g():\n    return 1\n")
    (tmp_path / "e.py").write_text("y = 2\n")
    monkeypatch.setattr(jit, "PACKAGE", tmp_path)

    def stamp():
        monkeypatch.setattr(jit, "_stamps", {})
        return jit.source_stamp(tmp_path / "a.py")

    first = stamp()
    assert jit.source_stamp(tmp_path / "a.py") == first  # once per module and process
    (tmp_path / "e.py").write_text("y = 3\n")  # not imported: the kernel stays
    assert stamp() == first
    for changed in ("d.py", "c.py", "sub/b.py"):  # imported, directly or not: compiled afresh
        (tmp_path / changed).write_text((tmp_path / changed).read_text() + "# changed\n")
        assert stamp() != first
        first = stamp()
    outside = tmp_path.parent / "elsewhere.py"
    outside.write_text("def f():\n    return 1\n")
    cls = next(
        c
        for c in numba.core.caching.CacheImpl._locator_classes
        if issubclass(c, jit._ImportStamped)
    )
    assert cls.from_function(lambda: 1, str(outside)) is None


def test_a_numba_without_the_names_warns_and_keeps_its_own_cache(monkeypatch):
    import pytest

    monkeypatch.delattr(numba.core.caching, "CacheImpl")
    with pytest.warns(RuntimeWarning, match="stamped by their own file only"):
        jit._install()
