"""The package's kernel cache: fresh only while every module of the package is unchanged (a
kernel compiles in the kernels it calls from other modules; numba's own stamp hashes only
the file that defines it)."""
import numba

from genie_gl import jit
from genie_gl.render import raster


def test_the_package_kernels_are_cached_under_the_whole_package_stamp():
    assert jit.installed()
    locator = raster._raster._cache._impl.locator
    assert isinstance(locator, jit._WholePackage)
    assert locator.get_source_stamp() == jit.package_stamp()


def test_the_stamp_changes_with_any_module_and_functions_outside_keep_numba_s_own(tmp_path, monkeypatch):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.py").write_text("y = 2\n")
    monkeypatch.setattr(jit, "PACKAGE", tmp_path)
    monkeypatch.setattr(jit, "_stamp", [])
    first = jit.package_stamp()
    assert jit.package_stamp() == first            # computed once per process
    (tmp_path / "sub" / "b.py").write_text("y = 3\n")
    monkeypatch.setattr(jit, "_stamp", [])
    assert jit.package_stamp() != first            # a called module changed: every kernel recompiles
    outside = tmp_path.parent / "elsewhere.py"
    outside.write_text("def f():\n    return 1\n")
    cls = next(c for c in numba.core.caching.CacheImpl._locator_classes if issubclass(c, jit._WholePackage))
    assert cls.from_function(lambda: 1, str(outside)) is None
