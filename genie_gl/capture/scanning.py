"""``gg.scan``: a scanner or a scanner rig along a trajectory (or standing still), scan by scan.

Each head scans whole revolutions from its ``offset_s`` after the trajectory's start until
the trajectory ends; each firing of each scan fires from the head's pose at the firing's
time, ``world_from_body(t) @ body_from_scanner`` (the trajectory interpolated: positions
linearly, rotations by slerp), so the scans carry the motion skew of a spinning head.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ..errors import ConfigError
from ..scene.materials import MaterialTable
from ..scene.model import Scene
from ..sensors.beams import scan_beams, scan_starts
from ..sensors.scanner import Scanner
from ..motion.scanner_rig import ScannerRig
from ..motion.trajectory import Trajectory
from .scan import plan_scan, take_scan
from .scan_record import Scan


def scan_rng(seed: int, head_index: int, scan_index: int) -> np.random.Generator:
    """The generator of one scan: from (seed, head, scan), independent of the others."""
    return np.random.default_rng(
        np.random.SeedSequence([int(seed), int(head_index), int(scan_index)])
    )


def iter_scans(
    scene: Scene,
    rig: ScannerRig,
    trajectory: Trajectory | np.ndarray,
    *,
    seed: int,
    duration_s: float | None = None,
    scans: int | None = None,
) -> Iterator[Scan]:
    """Scans of every head of ``rig``, head by head, in time order.

    ``trajectory``: a :class:`Trajectory`, or a fixed (4, 4) world_from_body (then ``scans``
    revolutions per head, default 1). ``duration_s`` crops a trajectory."""
    table = MaterialTable.from_scene(scene)
    fixed = not isinstance(trajectory, Trajectory)
    if fixed:
        body = np.asarray(trajectory, np.float64)
        if body.shape != (4, 4) or not np.all(np.isfinite(body)):
            raise ConfigError(
                f"scan: expected a Trajectory or a (4, 4) world_from_body, got shape {body.shape}"
            )
        t0 = 0.0
    else:
        t0 = trajectory.start_s
        end = (
            trajectory.end_s
            if duration_s is None
            else min(trajectory.end_s, t0 + float(duration_s))
        )
    for k, head in enumerate(rig.heads):
        scanner = head.scanner
        plan = plan_scan(scene, scanner, table)
        if fixed:
            starts = (
                t0
                + head.offset_s
                + np.arange(1 if scans is None else int(scans)) * scanner.scan_period_s
            )
            pose_at = body @ head.body_from_scanner
        else:
            starts = scan_starts(scanner, t0, end, head.offset_s)
            if scans is not None:
                starts = starts[: int(scans)]
            pose_at = _pose_at(trajectory, head.body_from_scanner)
        for i, start in enumerate(starts):
            beams = scan_beams(
                scanner, pose_at, float(start), index=i, clock_start_s=t0 + head.offset_s
            )
            yield take_scan(
                scene,
                scanner,
                beams,
                rng=scan_rng(seed, k, i),
                table=table,
                plan=plan,
                head=head.name,
                head_index=k,
            )


def _pose_at(trajectory: Trajectory, body_from_scanner: np.ndarray):
    def pose_at(times: np.ndarray) -> np.ndarray:
        t = np.clip(times, trajectory.start_s, trajectory.end_s)
        return trajectory.at(t, then=body_from_scanner)

    return pose_at


def scan(
    scene: Scene,
    scanner_or_rig: Scanner | ScannerRig,
    trajectory: Trajectory | np.ndarray | None = None,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    scans: int | None = None,
) -> list[Scan]:
    """Scans of a scanner (or every head of a rig) in ``scene``.

    Parameters
    ----------
    scene : the scene.
    scanner_or_rig : a :class:`Scanner` (one head at the body's origin) or a :class:`ScannerRig`.
    trajectory : a :class:`Trajectory` (scans until it ends, or ``duration_s``), a fixed (4, 4)
        world_from_body (``scans`` revolutions, default 1), or None (the identity pose).
    seed : int, the seed of every random draw (each scan its own stream).

    Returns
    -------
    list[Scan], head by head, each head's scans in time order; an empty result is an error.
    """
    rig = (
        scanner_or_rig
        if isinstance(scanner_or_rig, ScannerRig)
        else ScannerRig.single(scanner_or_rig)
    )
    if not isinstance(rig, ScannerRig):
        raise ConfigError(
            f"scan: expected a Scanner or a ScannerRig, got {type(scanner_or_rig).__name__}"
        )
    out = list(
        iter_scans(
            scene,
            rig,
            np.eye(4) if trajectory is None else trajectory,
            seed=seed,
            duration_s=duration_s,
            scans=scans,
        )
    )
    if not out:
        raise ConfigError(
            "scan: the trajectory is shorter than one revolution of every head; no scan was made"
        )
    return out
