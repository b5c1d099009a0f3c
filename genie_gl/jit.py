"""numba's ``njit`` for the package's kernels, with a cache that is fresh only while the whole
package is unchanged.

numba keeps a compiled kernel (``cache=True``) until the file that defines it changes: its
stamp hashes that one file. A kernel compiles in the kernels it calls from other modules
(the exact raster's frame kernel in :mod:`genie_gl.render.raster` draws with
:mod:`genie_gl.render.coverage`'s), so a change to a called module alone would leave the old
code running, with no error, until the calling file changed too. Every kernel module takes
``njit`` from here; importing this module first gives numba cache locators whose stamp
hashes every ``.py`` file of the package (once per process), so any change to the package
compiles its kernels afresh. Functions outside the package keep numba's own locators.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

from numba import njit, prange  # noqa: F401  (re-exported: ``from genie_gl.jit import njit``)
from numba.core import caching

PACKAGE = Path(__file__).resolve().parent
_stamp: list[str] = []


def package_stamp() -> str:
    """The sha256 of every ``.py`` file of the package (paths and contents), computed once."""
    if not _stamp:
        h = hashlib.sha256()
        for path in sorted(PACKAGE.rglob("*.py")):
            h.update(str(path.relative_to(PACKAGE)).encode())
            h.update(path.read_bytes())
        _stamp.append(h.hexdigest())
    return _stamp[0]


class _WholePackage:
    """A numba cache locator for functions defined in the package, stamped by the whole package."""

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            inside = Path(py_file).resolve().is_relative_to(PACKAGE)
        except (OSError, ValueError):
            inside = False
        return super().from_function(py_func, py_file) if inside else None

    def get_source_stamp(self):
        return package_stamp()


def _numba(name: str):
    """A class of numba's caching module by its name (public since numba 0.61, "_" before)."""
    return getattr(caching, name, None) or getattr(caching, "_" + name)


def installed() -> bool:
    """Whether numba picks this module's locators for the package's kernels."""
    return any(issubclass(c, _WholePackage) for c in _numba("CacheImpl")._locator_classes)


def _install() -> None:
    classes = _numba("CacheImpl")._locator_classes
    if not installed():
        classes[:0] = [type(f"Package{base.__name__.lstrip('_')}", (_WholePackage, base), {})
                       for base in map(_numba, ("UserProvidedCacheLocator", "InTreeCacheLocator",
                                                "UserWideCacheLocator"))]


_install()
