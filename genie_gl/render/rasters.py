"""Which rasteriser draws a frame: the exact CPU engine or OpenGL, by name.

Two rasterisers fill the same frames: ``"cpu"`` (:mod:`genie_gl.render.cpu.raster`: per pixel
centre the nearest triangle along its ray, float64, no GL) and ``"gl"`` (moderngl on the
machine's OpenGL driver). Without a hardware GPU the OpenGL driver is Mesa's llvmpipe, a
software rasteriser slower than the CPU engine from a hundred thousand triangles up, and
less exact: there the CPU engine is the default of :func:`genie_gl.render`,
:func:`genie_gl.capture`, ``genie capture``, ``genie dataset`` and the benchmarks. GL stays
one setting away (``raster: gl`` in an accuracy block, ``--raster gl``).

A hardware GPU is recognised without starting GL, from the devices its kernel driver makes:
an NVIDIA device node (``/dev/nvidia0``), or a DRM render node whose driver is not a
virtual one (``vgem``, ``vkms``: no rasteriser behind them). A machine without these draws
with llvmpipe whatever the OpenGL library says.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

from ..errors import ConfigError, did_you_mean
from ..sensors.accuracy import RASTER as RASTERS

VIRTUAL_DRIVERS = ("vgem", "vkms")  # DRM drivers with no rasteriser behind them


@functools.lru_cache(maxsize=1)
def hardware_gpu() -> bool:
    """Whether this machine has a GPU its OpenGL driver can draw on (see the module's
    docstring); decided once per process."""
    if Path("/dev/nvidia0").exists():
        return True
    drm = Path("/sys/class/drm")
    if not drm.is_dir():
        return False
    for node in drm.glob("renderD*"):
        driver = node / "device" / "driver"
        try:
            name = os.path.basename(os.readlink(driver))
        except OSError:
            continue
        if name not in VIRTUAL_DRIVERS:
            return True
    return False


def default_raster() -> str:
    """``"gl"`` on a machine with a hardware GPU, else ``"cpu"``."""
    return "gl" if hardware_gpu() else "cpu"


def check_raster(value: str | None, where: str) -> str | None:
    """``value`` when it is a raster's name or None (the machine's default, decided later);
    else one ConfigError naming ``where``."""
    if value is None or value in RASTERS:
        return value
    raise ConfigError(
        f"{where}: raster {value!r} is unknown; expected {' or '.join(RASTERS)}"
        f"{did_you_mean(str(value), RASTERS)}"
    )


def resolve_raster(value: str | None, where: str = "raster") -> str:
    """The raster that draws: ``value``, or the machine's default when it is None."""
    return check_raster(value, where) or default_raster()
