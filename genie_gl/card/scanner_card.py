"""A spinning scanner's report card: its simulated point rate, range noise, returns and field
of view, measured on test scenes, beside the profile's datasheet figures and their sources.

Two scenes, both standing still at the scanner's origin:

- a closed room (``ROOM_M`` square, ``ROOM_HEIGHT_M`` high, the head at mid height) that every
  beam hits: the beams fired in one second (the point rate), the returns per beam, the
  elevation span of the points and the share of azimuth it covers;
- a flat wall ``WALL_M`` ahead, the profile's effects on: each point's range minus the wall's
  exact range along its beam, whose standard deviation is the range noise.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import trimesh

from ..capture.scanning import scan
from ..errors import ConfigError
from ..resources import resolve
from ..scene.model import Material, Scene
from ..effects.lidar import RangeNoise
from ..sensors.scanner import Scanner
from ..effects.scanner_profile import SUFFIX

ROOM_M = 30.0
ROOM_HEIGHT_M = 30.0
WALL_M = 10.0
AZIMUTH_BIN_DEG = 1.0


def _slab(scene: Scene, size, centre, semantic: int = 1) -> None:
    T = np.eye(4)
    T[:3, 3] = centre
    scene.add(trimesh.creation.box(size), T, semantic=semantic, material=Material((0.5, 0.5, 0.5)))


def room_scene(
    side_m: float = ROOM_M, height_m: float = ROOM_HEIGHT_M, *, post: bool = False
) -> Scene:
    """A closed box room, centred on the origin: floor, ceiling and four walls 0.2 m thick;
    ``post``: with a 5 cm post 5 m ahead, whose edges split a beam's footprint (two echoes)."""
    s, h, t = side_m, height_m, 0.2
    scene = Scene()
    for z in (-h / 2, h / 2):
        _slab(scene, (s + 2 * t, s + 2 * t, t), (0, 0, z + np.sign(z) * t / 2))
    for x in (-s / 2, s / 2):
        _slab(scene, (t, s + 2 * t, h), (x + np.sign(x) * t / 2, 0, 0))
    for y in (-s / 2, s / 2):
        _slab(scene, (s, t, h), (0, y + np.sign(y) * t / 2, 0))
    if post:
        _slab(scene, (0.05, 0.05, h), (5.0, 0, 0), semantic=2)
    return scene


def wall_scene(distance_m: float = WALL_M) -> Scene:
    """A flat wall facing the origin, its face the plane x = ``distance_m``, 200 m wide."""
    scene = Scene()
    _slab(scene, (1.0, 200.0, 200.0), (distance_m + 0.5, 0, 0))
    return scene


def noise_sigma(scanner: Scanner) -> float | None:
    """The profile's range-noise sigma (m), or None when it has no range noise."""
    for e in scanner.effects:
        if isinstance(e, RangeNoise):
            return float(e.sigma_m)
    return None


def published_point_rate(scanner: Scanner) -> int:
    """Points per second the datasheet gives for single return: every channel of each whole
    firing in one second over the field of view."""
    firings = np.floor(1.0 / scanner.firing_period_s * scanner.fov_deg / 360.0 + 1e-9)
    return int(scanner.channels * firings)


def measure(scanner: Scanner, *, seed: int = 0) -> dict[str, Any]:
    """The card's measurements of ``scanner`` (its figures, in SI units)."""
    ideal = replace(scanner, effects=(), returns="strongest")
    revs = int(round(scanner.rate_hz))  # one second of scans
    room = scan(room_scene(), ideal, scans=revs, seed=seed)
    # each firing's start: a point's time less its channel's delay within the firing
    starts = np.concatenate([s.start_s + s.time_s - ideal.channel_time_s[s.channel] for s in room])
    fired = np.unique(np.round(starts / 1e-7).astype(np.int64))
    channels_per_s = (
        scanner.channels
    )  # each firing fires every channel; points come in whole firings
    firing_rate = (fired.size - 1) / ((fired[-1] - fired[0]) * 1e-7)
    pts = np.concatenate([s.sensor_xyz for s in room])
    elev = np.degrees(np.arctan2(pts[:, 2], np.hypot(pts[:, 0], pts[:, 1])))
    az = np.degrees(np.arctan2(pts[:, 1], pts[:, 0])) % 360.0
    bins = np.unique(np.floor(az / AZIMUTH_BIN_DEG)).size
    dual = (
        scan(room_scene(post=True), replace(scanner, returns="dual"), scans=1, seed=seed)[0]
        if "dual" in (scanner.sources.get("return_modes", "") + scanner.returns)
        else None
    )
    wall = scan(wall_scene(), scanner, scans=1, seed=seed)[0]
    d = wall.sensor_xyz / np.linalg.norm(wall.sensor_xyz, axis=1, keepdims=True)
    face = d[:, 0] > 0.5  # beams within 60 degrees of the wall's normal
    # the along-beam error: the point's distance off the wall's plane over the beam's cosine
    residual = (wall.sensor_xyz[face, 0] - WALL_M) / d[face, 0]
    return {
        "point_rate_per_s": channels_per_s
        * int(np.floor(firing_rate + 1e-9)),  # whole firings per second
        "mean_point_rate_per_s": channels_per_s * firing_rate,
        "points_returned_per_s": sum(len(s) for s in room) / (revs / scanner.rate_hz),
        "elevation_span_deg": [float(elev.min()), float(elev.max())],
        "azimuth_covered_deg": bins * AZIMUTH_BIN_DEG,
        "range_noise_sigma_m": float(np.std(residual)),
        "wall_points": int(face.sum()),
        "max_returns_per_beam": None if dual is None else int(dual.returns.max()),
    }


def scanner_card(scanner: Scanner, *, seed: int = 0) -> dict[str, Any]:
    """Rows (figure, datasheet, source, simulated) and the raw measurements of ``scanner``."""
    m = measure(scanner, seed=seed)
    src = scanner.sources
    el = np.degrees(scanner.elevation_rad)
    sigma = noise_sigma(scanner)
    rows = [
        (
            "point rate, single return (pts/s)",
            published_point_rate(scanner),
            src.get("firing_period_us", "derived: channels x whole firings per second"),
            round(m["point_rate_per_s"]),
        ),
        (
            "range noise sigma (m)",
            sigma,
            src.get("range_accuracy_m", ""),
            round(m["range_noise_sigma_m"], 5),
        ),
        (
            "vertical field of view (deg)",
            [round(float(el.min()), 3), round(float(el.max()), 3)],
            src.get("elevation_deg", ""),
            [round(v, 2) for v in m["elevation_span_deg"]],
        ),
        (
            "horizontal field of view (deg)",
            scanner.fov_deg,
            src.get("fov_deg", ""),
            m["azimuth_covered_deg"],
        ),
        (
            "returns per beam, dual mode",
            2 if m["max_returns_per_beam"] else 1,
            src.get("return_modes", ""),
            m["max_returns_per_beam"] or 1,
        ),
        ("range (m)", [scanner.min_range_m, scanner.max_range_m], src.get("range_m", ""), None),
    ]
    return {"sensor": scanner.name, "rows": rows, "measured": m, "seed": seed}


def scanner_card_markdown(card: dict[str, Any]) -> str:
    """The card as a Markdown table."""
    lines = [
        f"# {card['sensor']}",
        "",
        "Simulated by `genie report-card --sensor " + card["sensor"] + "` (seed "
        f"{card['seed']}): a closed {ROOM_M:g} m room for the rate, returns and field of view; a "
        "flat wall "
        f"{WALL_M:g} m ahead for the range noise.",
        "",
        "| figure | datasheet | simulated | source |",
        "|---|---|---|---|",
    ]
    for name, ref, source, ours in card["rows"]:
        lines.append(f"| {name} | {ref} | {'-' if ours is None else ours} | {source or '-'} |")
    return "\n".join(lines) + "\n"


def scanner_profile_file(name: str):
    """The scanner profile ``name`` names (``sensors/<name>.lidar.yml`` or a ``*.lidar.yml``
    path), or None when it names a camera profile."""

    if str(name).endswith(SUFFIX):  # a scanner profile's file: a mistake in its name is said
        return resolve(name, "sensors", (SUFFIX,))
    try:
        return resolve(name, "sensors", (SUFFIX,))
    except ConfigError:
        return None
