"""Look at what genie-gl made: exported files as a Rerun recording (``.rrd``), and Rerun's
web viewer hosted locally for it.

::

    import genie_gl as gg
    rrd = gg.view("out/demo")                      # out/demo/view.rrd
    served = gg.view("out/demo", serve=True)       # the same, and the web viewer on 127.0.0.1

Reads only exported files (:mod:`.folders`); imports nothing above ``export``.
"""

from __future__ import annotations

import os
from pathlib import Path

from .folders import SceneView, Shot, read_views
from .recording import MAX_POINTS, write_rrd
from .serve import LOOPBACK, WEB_PORT, Served, serve

__all__ = ["view", "read_views", "write_rrd", "serve", "SceneView", "Shot", "Served"]


def default_rrd(path: str | os.PathLike) -> Path:
    """Where a recording of ``path`` goes by default: ``view.rrd`` inside a folder, ``NAME.rrd``
    beside a file."""
    p = Path(path)
    return p / "view.rrd" if p.is_dir() else p.with_suffix(".rrd")


def view(
    path: str | os.PathLike,
    out: str | os.PathLike | None = None,
    *,
    serve_web: bool = False,
    bind: str = LOOPBACK,
    port: int = WEB_PORT,
    max_points: int = MAX_POINTS,
) -> Path | Served:
    """Write the Rerun recording of ``path`` (a dataset, scene, recording or capture folder,
    or a USD scene) to ``out`` (default :func:`default_rrd`); with ``serve_web``, host the
    web viewer for it on ``bind:port`` and return the running :class:`Served` (call its
    ``stop()``), else return the recording's path."""
    rrd = write_rrd(read_views(path), out or default_rrd(path), max_points=max_points)
    return serve(rrd, bind=bind, port=port) if serve_web else rrd
