"""The capture mode of a dataset (``genie dataset --capture NAME``): its base class and registry.

A :class:`CaptureMode` is one way of capturing a dataset scene: standing cameras placed for
coverage, a rig's recording along a trajectory, a mobile-scan map fused from it, and whatever
a new rig (a spinning scanner, a panorama head) needs. Each mode is one module that registers
one object here, as formats register in :mod:`genie_gl.export.registry`; the run, the
configuration, the limits and the manifest ask the object and never compare its name:

- :attr:`~CaptureMode.options`: the configuration fields it uses of those only some modes
  use (given to a mode that does not use it: refused); :meth:`~CaptureMode.check`, what they
  must satisfy; :meth:`~CaptureMode.prepare`, what must work before any scene starts;
- :meth:`~CaptureMode.input_files`: the files beyond the strategy and sensor whose content
  decides the bytes (the fingerprint);
- :meth:`~CaptureMode.estimate`: its memory and disk, checked against the limits by
  :meth:`~CaptureMode.check_limits`;
- :meth:`~CaptureMode.takes`: which formats can write what it hands over;
:meth:`~CaptureMode.capture`,
  a scene's frames (a :class:`Captured`), and :meth:`~CaptureMode.write`, how they go to the
  format (the files it adds beside the format's own: :attr:`~CaptureMode.files`).

The orchestration (:mod:`genie_gl.dataset.scene`: curation, export, previews, publishing)
is one tail for every mode. The plugins register when :mod:`genie_gl.dataset` is imported.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ...errors import ConfigError, did_you_mean
from ...limits import (
    MAX_SIDE,
    check_disk,
    check_frame_side,
    check_memory,
    check_regions,
    memory_limit_bytes,
)


@dataclass(frozen=True)
class Estimate:
    """A run's estimate from above, and the words of the limit messages.

    nodes : regions a scene's layout can make; layout_work : its regions or overlap tests / 10;
    pixels : pixels of the largest frame; memory_bytes : of all workers together; disk_bytes :
    what the run writes; memory_what, memory_fix : how the memory was counted and what lowers
    it; disk_fix : what lowers the disk.
    """

    nodes: int
    layout_work: int
    pixels: int
    memory_bytes: int
    disk_bytes: int
    memory_what: str = ""
    memory_fix: str = ""
    disk_fix: str = "make fewer --scenes"


@dataclass(eq=False)
class Captured:
    """What a mode hands the tail for one scene.

    Attributes
    ----------
    layout, scene : the scene's layout and scene.
    clock : ``perf_counter`` at the end of each stage so far (``"start"`` first).
    frames : standing cameras' frames (empty for a recording).
    kept : [(tile key, PointCloud)] chunks the cleaning rules kept.
    counts : (65536,) int64 points per class id.
    points : points of every frame (a map: of the map).
    shots : frames taken.
    info : entries of the scene's record before ``cameras`` (``instances``, a trajectory's summary).
    rig, trajectory, recording, extra : what a moving capture hands a format
    (:class:`~genie_gl.export.SceneData`).
    tally : a moving capture's :class:`~.moving.Tally` of the frames that streamed past.
    costs : () -> (frame cost ms by part, effect totals), asked once the frames were consumed.
    previews : (folder, index) -> None, the scene's pictures.
    ahead_s, ahead_cpu_s : a helper process's seconds per stage and CPU seconds (:mod:`..ahead`).
    """

    layout: Any
    scene: Any
    clock: dict[str, float]
    frames: list = field(default_factory=list)
    kept: list = field(default_factory=list)
    counts: np.ndarray = field(default_factory=lambda: np.zeros(65536, np.int64))
    points: int = 0
    shots: int = 0
    info: dict[str, Any] = field(default_factory=dict)
    rig: Any = None
    trajectory: Any = None
    recording: Any = None
    extra: dict[str, Any] = field(default_factory=dict)
    tally: Any = None
    costs: Callable[[], tuple[dict, dict]] = lambda: ({}, {})
    previews: Callable[[Path, int], None] = lambda folder, index: None
    ahead_s: dict[str, float] | None = None
    ahead_cpu_s: float = 0.0


class CaptureMode:
    """One way of capturing a dataset scene; subclasses register one instance each
    (:func:`register_mode`). ``cfg`` below is the run's :class:`~genie_gl.dataset.DatasetConfig`."""

    name: ClassVar[str] = ""
    description: ClassVar[str] = ""
    #: its place in lists and messages (``--help``, "expected one of ...")
    rank: ClassVar[int] = 100
    #: configuration fields it uses of those only some modes use (in the order messages name them)
    options: ClassVar[tuple[str, ...]] = ()
    #: whether its name and options enter the fingerprint (standing cameras' never did)
    fingerprints_mode: ClassVar[bool] = True
    #: whether a helper process may make its scenes' layout, scene and placement ahead
    made_ahead: ClassVar[bool] = False
    #: what it writes into a scene folder beside the format's files
    files: ClassVar[tuple[str, ...]] = ()

    def check(self, cfg) -> None:
        """Refuse (:class:`ConfigError`) option values it cannot use; nothing by default."""

    def prepare(self, cfg, inputs) -> None:
        """Check, before any work, what its scenes need (placement, a waypoints file)."""

    def input_files(self, cfg) -> dict[str, str]:
        """Role -> path of the files it reads whose content decides the bytes written."""
        return {}

    def takes(self, fmt) -> bool:
        """Whether format ``fmt`` (a :class:`~genie_gl.export.registry.DatasetFormat`) writes what
        it captures."""
        raise NotImplementedError

    def curates(self, fmt) -> bool:
        """Whether its scenes in ``fmt`` are point-cloud chunks that ``--class-balance`` and
        ``--points-budget`` may sub-sample."""
        return bool(fmt.chunks)

    def estimate(self, cfg, strategy, sensor) -> Estimate:
        raise NotImplementedError

    def check_limits(self, cfg, strategy, sensor, out: Path) -> Estimate:
        """Refuse ``cfg`` with a :class:`~genie_gl.errors.LimitError` when its estimate
        exceeds a limit (:mod:`genie_gl.limits`); the estimate otherwise."""
        e = self.estimate(cfg, strategy, sensor)
        check_regions(e.layout_work, cfg.max_nodes, str(getattr(strategy, "source", "strategy")))
        check_frame_side(sensor.width, sensor.height, f"--sensor {cfg.sensor}", MAX_SIDE)
        check_memory(
            e.memory_bytes, memory_limit_bytes(cfg.max_memory_gb), e.memory_what, e.memory_fix
        )
        check_disk(e.disk_bytes, out, f"--out {out}", max_disk_gb=cfg.max_disk_gb, fix=e.disk_fix)
        return e

    def capture(
        self, cfg, inputs, streams, fmt, *, stage: Callable[[str], None], ahead=None
    ) -> Captured:
        """Scene ``streams.index`` made and captured: layout, scene, placement, frames, chunks."""
        raise NotImplementedError

    def write(self, fmt, data, folder: Path, got: Captured) -> None:
        """Hand the scene to the format: its files into ``folder`` (``data``: the
        :class:`~genie_gl.export.SceneData`); the clock's ``export`` stage."""
        fmt.write_scene(data, folder)

    def finish(self, fmt) -> Callable | None:
        """What the format writes once every scene is there ((out, config, stats)), if anything."""
        return fmt.finish

    def reference(self) -> dict[int, float] | None:
        """The class shares the histogram shows beside the dataset's (None: none)."""
        return None


CAPTURE_MODES: dict[str, CaptureMode] = {}
#: the mode of a run that names none: standing cameras (:mod:`.standing`)
DEFAULT_MODE = "static"


def register_mode(mode: CaptureMode) -> CaptureMode:
    CAPTURE_MODES[mode.name] = mode
    ranked = sorted(CAPTURE_MODES.values(), key=lambda m: m.rank)
    CAPTURE_MODES.clear()
    CAPTURE_MODES.update((m.name, m) for m in ranked)
    return mode


def get_mode(name: str, where: str = "--capture") -> CaptureMode:
    try:
        return CAPTURE_MODES[name]
    except (KeyError, TypeError):
        raise ConfigError(
            f"{where} {name!r:.40}: unknown{did_you_mean(str(name), CAPTURE_MODES)}; expected one "
            "of "
            f"{', '.join(CAPTURE_MODES)}"
        ) from None


def mode_options() -> tuple[str, ...]:
    """Every field some mode uses and another does not, in the order the messages name them."""
    seen: dict[str, None] = {}
    for mode in CAPTURE_MODES.values():
        seen.update(dict.fromkeys(mode.options))
    return tuple(seen)


def users_of(option: str) -> tuple[str, ...]:
    """The names of the modes that use ``option``."""
    return tuple(n for n, m in CAPTURE_MODES.items() if option in m.options)


def stamp(clock: dict[str, float], *stages: str) -> None:
    """The stages ``stages`` end now."""
    now = time.perf_counter()
    for s in stages:
        clock[s] = now
