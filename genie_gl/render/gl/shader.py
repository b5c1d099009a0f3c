"""Shader programs from ``shaders/<name>.vert|.frag``, with defines injected after ``#version``.

Driver errors keep pointing at the right line: a ``#line`` directive follows the injected
defines. A failed build raises :class:`~genie_gl.errors.ShaderError` naming the file.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import moderngl

from ...errors import ShaderError
from ...resources import data_dir


def _with_defines(source: str, defines: Iterable[str]) -> str:
    lines = source.splitlines()
    if not lines or not lines[0].startswith("#version"):
        return source
    inject = [f"#define {d}" for d in defines]
    return "\n".join([lines[0], *inject, "#line 2", *lines[1:]]) + "\n"


def load_program(
    ctx: moderngl.Context, name: str, defines: Iterable[str] = (), cache: dict | None = None
) -> moderngl.Program:
    """Build ``shaders/<name>.vert`` + ``shaders/<name>.frag`` with ``defines``.

    ``cache`` (a dict owned by the caller, one per context) keeps one program per (name,
    defines).
    """
    key = (name, tuple(sorted(defines)))
    if cache is not None and key in cache:
        return cache[key]
    folder = data_dir("shaders")
    sources = {}
    for stage in ("vert", "frag"):
        path = Path(folder) / f"{name}.{stage}"
        if not path.is_file():
            raise ShaderError(str(path), "file not found")
        sources[stage] = _with_defines(path.read_text(), key[1])
    try:
        program = ctx.program(vertex_shader=sources["vert"], fragment_shader=sources["frag"])
    except moderngl.Error as exc:
        raise ShaderError(str(Path(folder) / f"{name}.{{vert,frag}}"), str(exc)) from exc
    if cache is not None:
        cache[key] = program
    return program
