"""numba's ``njit`` for the package's kernels, with a cache that is fresh only while a
kernel's module and the package modules it imports are unchanged.

numba keeps a compiled kernel (``cache=True``) until the file that defines it changes: its
stamp hashes that one file. A kernel compiles in the kernels it calls from other modules
(the exact raster's frame kernel in :mod:`genie_gl.render.cpu.raster` draws with
:mod:`genie_gl.render.cpu.coverage`'s), so a change to a called module alone would leave the old
code running, with no error, until the calling file changed too. Every kernel module takes
``njit`` from here; importing this module first gives numba cache locators whose stamp
hashes the kernel's module and every module of the package it imports, directly or not (once
per module and process), so a change to any of them compiles the kernel afresh. Functions
outside the package keep numba's own locators.
"""

from __future__ import annotations

import hashlib
import re
import types
import warnings
from pathlib import Path

import numba
from numba import njit, prange  # noqa: F401  (re-exported: ``from genie_gl.jit import njit``)
from numba.core import caching

PACKAGE = Path(__file__).resolve().parent
_RELATIVE = re.compile(r"^\s*from\s+(\.+)([\w.]*)\s+import\s+(.+?)\s*$", re.M)
_stamps: dict[Path, str] = {}


def _imported(path: Path) -> list[Path]:
    """The package's files that module ``path`` imports with relative imports (the modules
    named, and for ``from . import x`` the submodules x)."""
    out = []
    for dots, name, names in _RELATIVE.findall(path.read_text(encoding="utf-8")):
        base = path.parent
        for _ in range(len(dots) - 1):
            base = base.parent
        target = base.joinpath(*name.split(".")) if name else base
        heads = (
            [target]
            if name
            else [target / n.strip().split(" ")[0] for n in names.strip("()").split(",")]
        )
        for head in heads:
            for candidate in (head.with_suffix(".py"), head / "__init__.py"):
                if candidate.is_file():
                    out.append(candidate.resolve())
                    break
    return out


def source_stamp(path: str | Path) -> str:
    """The sha256 of module ``path`` and of every module of the package it imports, directly
    or not (paths and contents), computed once per module and process."""
    path = Path(path).resolve()
    if path not in _stamps:
        seen, todo = set(), [path]
        while todo:
            f = todo.pop()
            if f not in seen and f.is_relative_to(PACKAGE):
                seen.add(f)
                todo.extend(_imported(f))
        h = hashlib.sha256()
        for f in sorted(seen):
            h.update(str(f.relative_to(PACKAGE)).encode())
            h.update(f.read_bytes())
        _stamps[path] = h.hexdigest()
    return _stamps[path]


class _ImportStamped:
    """A numba cache locator for functions defined in the package, stamped by their module and
    every module of the package it imports."""

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            inside = Path(py_file).resolve().is_relative_to(PACKAGE)
        except (OSError, ValueError):
            inside = False
        return super().from_function(py_func, py_file) if inside else None

    def get_source_stamp(self):
        return source_stamp(self._py_file)


def serial_copy(kernel, name: str):
    """``kernel`` (an ``njit(parallel=True)`` dispatcher of the package) compiled once more
    without parallel loops (its ``prange`` runs as ``range``, on the calling thread) with
    the same options, cached under ``name`` (a cache entry of its own: numba names a
    kernel's cache files by its function's name, and a parallel and a serial compilation of
    one function would otherwise overwrite each other). For frames drawn side by side, one
    per thread: numba's default threading layer (workqueue) aborts when two threads launch
    parallel kernels at once; serial kernels launch nothing."""
    f = kernel.py_func
    code = f.__code__.replace(co_name=name)
    copy = types.FunctionType(code, f.__globals__, name, f.__defaults__, f.__closure__)
    copy.__qualname__, copy.__module__, copy.__doc__ = name, f.__module__, f.__doc__
    options = {k: v for k, v in kernel.targetoptions.items() if k not in ("parallel", "nopython")}
    return njit(cache=True, **options)(copy)


def _numba(name: str):
    """A class of numba's caching module by its name (public in recent numba, "_" before)."""
    return getattr(caching, name, None) or getattr(caching, "_" + name)


def installed() -> bool:
    """Whether numba picks this module's locators for the package's kernels."""
    return any(issubclass(c, _ImportStamped) for c in _numba("CacheImpl")._locator_classes)


def _install() -> None:
    """Put this module's locators first. Where numba's caching module lacks the names used
    here (a numba newer than this was written for), warn once and keep numba's own locators:
    kernels still compile and cache, stamped by their own file only (``tests/test_jit.py``
    fails there, so the change is seen)."""
    try:
        classes = _numba("CacheImpl")._locator_classes
        bases = [
            _numba(n)
            for n in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")
        ]
    except AttributeError as exc:
        warnings.warn(
            f"genie_gl.jit: numba {numba.__version__}'s cache has no {exc.name!r}; compiled "
            "kernels "
            "are stamped by their own file only (clear __pycache__/*.nbi after changing a module a "
            "kernel imports)",
            RuntimeWarning,
            stacklevel=2,
        )
        return
    if not installed():
        classes[:0] = [
            type(f"Package{base.__name__.lstrip('_')}", (_ImportStamped, base), {})
            for base in bases
        ]


_install()
