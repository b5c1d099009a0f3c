"""What genie-gl asks of a way to get a headless OpenGL context (pyrender's ``platforms`` are
the model): start one and hand it to moderngl, look up GL entry points, make it current
around a call, release it. One module per platform; :mod:`genie_gl.render.gl.context` chooses
among them in one place."""

from __future__ import annotations

from abc import ABC, abstractmethod
from contextlib import AbstractContextManager, nullcontext
from typing import ClassVar

import moderngl


class Platform(ABC):
    """One headless OpenGL (>= 3.3 core) platform, for one context.

    Subclasses set ``name`` and implement :meth:`start` and :meth:`proc_address`; the others
    have defaults that suit a platform whose context stays current in its thread.
    """

    name: ClassVar[str]

    def unusable(self) -> str | None:
        """Why this platform cannot start in this process (one sentence), or None."""
        return None

    @abstractmethod
    def start(self, device_index: int) -> moderngl.Context:
        """Create the context (on GPU ``device_index`` where the platform chooses one), make
        it current and return moderngl's handle of it. Raises what the driver raises."""

    @abstractmethod
    def proc_address(self, name: bytes) -> int:
        """The address of the GL entry point ``name`` (0 when the driver has none)."""

    def current(self, ctx: moderngl.Context) -> AbstractContextManager:
        """A context manager making ``ctx`` current around a call (nothing by default)."""
        return nullcontext()

    def release(self) -> None:
        """Free what the platform holds beside moderngl's context (after ``ctx.release()``)."""
