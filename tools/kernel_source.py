"""The CPU raster's kernel modules joined into one source, for the tools that patch or compare
it (``raster_ab.py``, ``raster_profile.py``, ``raster_threads.py``): the modules of
``genie_gl/render/cpu/`` the frame kernel is made of, in import order, with their imports of
each other dropped and their relative imports of the package made absolute; loaded as a
module of its own from a temporary folder.
"""

import importlib.util
import re
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MODULES = ("bins.py", "bounds.py", "coverage.py", "raster.py")  # each after what it imports
_OWN = r"(?:bins|bounds|coverage)"


def joined(read: Callable[[str], str | None] | None = None) -> str:
    """The kernel modules' sources as one module; ``read(name)`` gives a module's source (None:
    the version has no such module); by default the work tree's."""
    if read is None:
        read = lambda name: (ROOT / "genie_gl/render/cpu" / name).read_text()  # noqa: E731
    parts = []
    for name in MODULES:
        source = read(name)
        if source is None:
            continue
        if parts:
            source = source.replace("from __future__ import annotations\n", "")
        parts.append(source)
    source = "\n".join(parts)
    source = re.sub(rf"^from \.{_OWN} import \((?:.|\n)*?\)\n", "", source, flags=re.M)
    source = re.sub(rf"^from \.{_OWN} import .*\n", "", source, flags=re.M)
    source = source.replace("from ...", "from genie_gl.").replace(
        "from ..", "from genie_gl.render."
    )
    return source


def load(source: str, where: Path, name: str):
    """``source`` written to ``where / name.py`` and loaded as module ``name``."""
    path = where / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
