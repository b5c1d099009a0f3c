"""The scratch copies of the checkout that `make mutants` and `make planted-bugs` work in
(build/mutants/<group>, build/planted/<bug>): the package, its tests and the data they read,
never the working tree itself."""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COPY = ["genie_gl", "tests", "layouts", "sensors", "shaders", "pyproject.toml", "README.md"]


def copy_checkout(
    dst: Path, src: Path = ROOT, *, caches: bool = False, extra: tuple[str, ...] = ()
) -> None:
    """``dst`` emptied and filled with ``src``'s COPY entries (and ``extra``); ``caches`` keeps
    the __pycache__ folders (numba's compiled kernels among them), which a copy of a fresh
    checkout leaves out."""
    shutil.rmtree(dst, ignore_errors=True)
    dst.mkdir(parents=True)
    ignore = (
        shutil.ignore_patterns("*.pyc")
        if caches
        else shutil.ignore_patterns("__pycache__", "*.pyc")
    )
    for name in (*COPY, *extra):
        s = src / name
        if s.is_dir():
            shutil.copytree(s, dst / name, ignore=ignore)
        elif s.exists():
            shutil.copy2(s, dst / name)
