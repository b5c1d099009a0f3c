"""The built-in asset library: procedural, parametric industrial assets in metres.

Every asset function takes its parameters and returns a ``trimesh.Trimesh`` standing on
z = 0, centred on x = y = 0, its front facing +y. ``VARIANTS`` lists named variants per
class; :func:`make` builds (and caches) one.

Curved parts (wheels, rollers, the tiller, the car body's cross-sections) are polygons. The
assets that have some (``CURVED``) take a keyword ``segments``: None keeps each part's own
count, ``n`` gives every full circle ``n`` segments (the tessellation accuracy knob).
"""

from __future__ import annotations

from functools import lru_cache, partial
from typing import Any

import numpy as np
import trimesh

from ...errors import ConfigError
from .parts import assemble, box, box_min, cylinder, loft

# -- pallets ------------------------------------------------------------------------------


def pallet(length: float = 1.2, width: float = 0.8, height: float = 0.144) -> trimesh.Trimesh:
    """A block pallet: bottom boards, 9 blocks, stringer boards and top deck boards.

    EUR pallet: 1.2 x 0.8 x 0.144 m (deck 22 mm, blocks 78 mm, bottom boards 22 mm). The
    length runs along x.
    """
    board, block_h = 0.022, height - 2 * 0.022
    parts = []
    ys = [-width / 2 + 0.05, 0.0, width / 2 - 0.05]
    xs = [-length / 2 + 0.0725, 0.0, length / 2 - 0.0725]
    for y in ys:  # bottom boards along x
        parts.append(box([length, 0.1, board], [0, y, board / 2]))
    for x in xs:
        for y in ys:
            parts.append(
                box(
                    [0.145, 0.1, block_h - 2 * board],
                    [x, y, board + (block_h - 2 * board) / 2 + 1e-4],
                )
            )
    for x in xs:  # stringer boards across
        parts.append(box([0.145, width, board], [x, 0, block_h - board / 2]))
    n_top = 5
    for i in range(n_top):  # top deck boards along x, gaps between them
        y = -width / 2 + 0.05 + i * (width - 0.1) / (n_top - 1)
        parts.append(box([length, 0.1, board], [0, y, height - board / 2]))
    return assemble(parts)


def half_pallet() -> trimesh.Trimesh:
    """The 0.8 x 0.6 x 0.144 m half pallet."""
    return pallet(0.8, 0.6, 0.144)


# -- racks --------------------------------------------------------------------------------


def rack(
    bays: int = 1,
    levels: int = 3,
    bay_width: float = 2.7,
    depth: float = 1.1,
    level_height: float = 1.0,
) -> trimesh.Trimesh:
    """A pallet rack: uprights, pairs of beams per level and a deck on each level."""
    W, post = bays * bay_width, 0.08
    H = levels * level_height + 0.2
    parts = []
    for i in range(bays + 1):
        x = -W / 2 + i * bay_width
        x = min(max(x, -W / 2 + post / 2), W / 2 - post / 2)
        for y in (-depth / 2 + post / 2, depth / 2 - post / 2):
            parts.append(box([post, post, H], [x, y, H / 2]))
    for lv in range(levels):
        z = 0.15 + lv * level_height
        for y in (-depth / 2 + post / 2, depth / 2 - post / 2):
            parts.append(box([W - 2 * post - 0.002, post * 0.8, 0.1], [0, y, z + 0.05]))
        parts.append(box([W - 2 * post - 0.002, depth - 2 * post - 0.002, 0.02], [0, 0, z + 0.11]))
    return assemble(parts)


# -- car body ------------------------------------------------------------------------------


def car(
    length: float = 4.6,
    width: float = 1.8,
    height: float = 1.45,
    wheel_r: float = 0.32,
    *,
    segments: int | None = None,
) -> trimesh.Trimesh:
    """A car body lofted through sections (bonnet, cabin, boot) with four wheels.

    The car's length runs along y (its front towards +y).
    """
    xs = np.linspace(-length / 2, length / 2, 13)
    u = (xs + length / 2) / length
    half = width / 2 * (0.86 + 0.14 * np.sin(np.pi * np.clip(u * 1.1 - 0.05, 0, 1)) ** 0.5)
    z0 = np.full_like(xs, 0.18)
    roof = (
        np.interp(u, [0, 0.12, 0.3, 0.42, 0.75, 0.88, 1], [0.55, 0.75, 0.85, 1.0, 1.0, 0.8, 0.6])
        * height
    )
    body = loft(xs, half, z0, roof, ring=segments or 20)
    wheels = []
    for x in (-length / 2 + 0.8, length / 2 - 0.8):
        for y in (-width / 2 + 0.2, width / 2 - 0.2):
            wheels.append(
                cylinder(wheel_r, 0.2, [x, y, wheel_r], axis="y", sections=segments or 18)
            )
    m = assemble([body] + wheels)
    m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1]))
    m.apply_translation([0, 0, -m.bounds[0][2]])  # polygonal wheels: stand on z = 0
    return m


# -- handling equipment ---------------------------------------------------------------------


def pallet_jack(
    fork_length: float = 1.15, width: float = 0.54, *, segments: int | None = None
) -> trimesh.Trimesh:
    """Hand pallet truck: two forks, a pump body, a tiller handle and wheels (forks along -y)."""
    parts = [
        box([0.16, fork_length, 0.08], [x, -fork_length / 2, 0.045])
        for x in (-width / 2 + 0.08, width / 2 - 0.08)
    ]
    parts.append(box([width, 0.25, 0.3], [0, 0.12, 0.2]))
    parts.append(cylinder(0.025, 1.1, [0, 0.3, 0.85], axis="z", sections=segments or 10))
    parts.append(box([0.3, 0.05, 0.05], [0, 0.3, 1.42]))
    parts.append(cylinder(0.09, 0.06, [0, 0.12, 0.09], axis="x", sections=segments or 14))
    return assemble(parts)


def forklift(
    length: float = 2.3, width: float = 1.1, *, segments: int | None = None
) -> trimesh.Trimesh:
    """Counterbalance forklift: chassis, counterweight, mast, forks, overhead guard, wheels.

    Forks point to +y.
    """
    parts = [box([width, length * 0.7, 0.7], [0, -0.1, 0.55])]  # chassis
    parts.append(box([width, 0.35, 0.6], [0, -length * 0.45 + 0.05, 0.75]))  # counterweight
    for x in (-0.35, 0.35):  # mast uprights
        parts.append(box([0.1, 0.12, 2.2], [x, length * 0.32, 1.2]))
    parts.append(box([0.8, 0.1, 0.5], [0, length * 0.37, 0.5]))  # carriage
    for x in (-0.25, 0.25):  # forks
        parts.append(box([0.12, 1.1, 0.05], [x, length * 0.37 + 0.6, 0.08]))
    for x in (-width / 2 + 0.05, width / 2 - 0.05):  # guard posts
        for y in (-0.55, 0.35):
            parts.append(box([0.06, 0.06, 1.15], [x, y, 1.475]))
    parts.append(box([width, 1.0, 0.05], [0, -0.1, 2.075]))  # guard roof
    for y in (-0.65, 0.55):
        for x in (-width / 2 + 0.05, width / 2 - 0.05):
            parts.append(
                cylinder(
                    0.25, 0.18, [x + np.sign(x) * 0.04, y, 0.25], axis="x", sections=segments or 18
                )
            )
    return assemble(parts)


def dolly(
    length: float = 1.2, width: float = 0.8, *, segments: int | None = None
) -> trimesh.Trimesh:
    """Transport dolly: a platform on four casters (carried by the STRs)."""
    parts = [box([length, width, 0.05], [0, 0, 0.2])]
    for x in (-length / 2 + 0.1, length / 2 - 0.1):
        for y in (-width / 2 + 0.1, width / 2 - 0.1):
            parts.append(box([0.05, 0.05, 0.07], [x, y, 0.14]))
            parts.append(cylinder(0.05, 0.04, [x, y, 0.05], axis="x", sections=segments or 12))
    return assemble(parts)


# -- containers -----------------------------------------------------------------------------


def klt(
    length: float = 0.6, width: float = 0.4, height: float = 0.28, wall: float = 0.008
) -> trimesh.Trimesh:
    """Small load carrier (KLT), open top: a floor and four walls."""
    parts = [box([length, width, wall], [0, 0, wall / 2])]
    h = height - wall
    parts.append(box([length, wall, h], [0, -width / 2 + wall / 2, wall + h / 2 + 1e-4]))
    parts.append(box([length, wall, h], [0, width / 2 - wall / 2, wall + h / 2 + 1e-4]))
    parts.append(
        box([wall, width - 2 * wall - 1e-3, h], [-length / 2 + wall / 2, 0, wall + h / 2 + 1e-4])
    )
    parts.append(
        box([wall, width - 2 * wall - 1e-3, h], [length / 2 - wall / 2, 0, wall + h / 2 + 1e-4])
    )
    return assemble(parts)


def stillage(
    length: float = 1.24, width: float = 0.835, height: float = 0.97, mesh_pitch: float = 0.1
) -> trimesh.Trimesh:
    """Mesh stillage: steel base frame, corner posts and wire-mesh sides (bars)."""
    post, bar = 0.04, 0.006
    parts = [box([length, width, 0.05], [0, 0, 0.025 + 0.1])]
    for x in (-length / 2 + post / 2, length / 2 - post / 2):
        for y in (-width / 2 + post / 2, width / 2 - post / 2):
            parts.append(box([post, post, height], [x, y, height / 2]))
    z_lo, z_hi = 0.18, height - 0.02
    for y in (-width / 2 + post / 2, width / 2 - post / 2):  # long sides: vertical bars
        for x in np.arange(-length / 2 + post + mesh_pitch / 2, length / 2 - post, mesh_pitch):
            parts.append(box([bar, bar, z_hi - z_lo], [x, y, (z_lo + z_hi) / 2]))
        for z in np.arange(z_lo, z_hi, 2 * mesh_pitch):
            parts.append(
                box([length - 2 * post - 0.002, bar, bar], [0, y + (bar if y < 0 else -bar), z])
            )
    for x in (-length / 2 + post / 2, length / 2 - post / 2):  # short sides
        for y in np.arange(-width / 2 + post + mesh_pitch / 2, width / 2 - post, mesh_pitch):
            parts.append(box([bar, bar, z_hi - z_lo], [x, y, (z_lo + z_hi) / 2]))
    return assemble(parts)


def cabinet(
    width: float = 1.0, depth: float = 0.5, height: float = 1.95, doors: int = 2
) -> trimesh.Trimesh:
    """Storage cabinet: body, doors (with a gap between them) and handles on the front (+y)."""
    parts = [box([width, depth - 0.02, height], [0, -0.01, height / 2])]
    dw = width / doors
    for i in range(doors):
        x = -width / 2 + dw * (i + 0.5)
        parts.append(box([dw - 0.006, 0.018, height - 0.02], [x, depth / 2 - 0.011, height / 2]))
        hx = x + (dw / 2 - 0.06) * (1 if i % 2 == 0 else -1)
        parts.append(box([0.02, 0.03, 0.15], [hx, depth / 2 + 0.013, height * 0.52]))
    return assemble(parts)


# -- background -----------------------------------------------------------------------------


def conveyor(length: float = 5.6, width: float = 1.2) -> trimesh.Trimesh:
    """An assembly-line skid conveyor segment: two rails on legs and a skid frame (along y)."""
    parts = []
    for x in (-width / 2 + 0.05, width / 2 - 0.05):
        parts.append(box([0.1, length, 0.12], [x, 0, 0.5]))
        for y in np.linspace(-length / 2 + 0.1, length / 2 - 0.1, 4):
            parts.append(box([0.08, 0.08, 0.44], [x, y, 0.22]))
    for y in (-length / 2 + 0.6, length / 2 - 0.6):
        parts.append(box([width + 0.2, 0.12, 0.08], [0, y, 0.6]))
    return assemble(parts)


def floor(width: float, height: float, thickness: float = 0.05) -> trimesh.Trimesh:
    return box_min([width, height, thickness], [0, 0, -thickness])


def column(size: float = 0.4, height: float = 6.0) -> trimesh.Trimesh:
    return box([size, size, height], [0, 0, height / 2])


VARIANTS = {
    "pallet": {"eur": pallet, "half": half_pallet},
    "rack": {
        "1bay_3lv": lambda: rack(1, 3),
        "1bay_2lv": lambda: rack(1, 2, level_height=1.3),
        "narrow_3lv": lambda: rack(1, 3, bay_width=1.9, depth=0.9),
    },
    "car": {
        "sedan": car,
        "hatchback": partial(car, 4.1, 1.75, 1.5),
        "estate": partial(car, 4.8, 1.85, 1.5),
    },
    "jack": {"standard": pallet_jack, "short": partial(pallet_jack, 0.9, 0.52)},
    "forklift": {"standard": forklift, "compact": partial(forklift, 2.0, 1.0)},
    "dolly": {"standard": dolly, "small": partial(dolly, 0.8, 0.6)},
    "klt": {"6428": klt, "4314": lambda: klt(0.4, 0.3, 0.147), "6422": lambda: klt(0.6, 0.4, 0.22)},
    "stillage": {"standard": stillage, "low": lambda: stillage(1.24, 0.835, 0.6)},
    "cabinet": {"two_door": cabinet, "one_door": lambda: cabinet(0.6, 0.5, 1.8, doors=1)},
    "conveyor": {"skid": conveyor, "short_skid": lambda: conveyor(4.0, 1.2)},
}


def rack_shelves(
    levels: int = 3,
    bay_width: float = 2.7,
    depth: float = 1.1,
    level_height: float = 1.0,
    post: float = 0.08,
) -> list[tuple[float, float, float, float]]:
    """The shelves of a one-bay :func:`rack`, bottom up: (deck top z, clear height under the
    next beams, inner width between the uprights, depth) in metres, in the rack's frame."""
    return [
        (0.15 + lv * level_height + 0.12, level_height - 0.12, bay_width - 2 * post, depth)
        for lv in range(levels)
    ]


# what the built-in racks can carry (scene building loads them)
SHELVES = {
    "rack": {
        "1bay_3lv": rack_shelves(3),
        "1bay_2lv": rack_shelves(2, level_height=1.3),
        "narrow_3lv": rack_shelves(3, bay_width=1.9, depth=0.9),
    }
}

# semantic ids of DESIGN.md's label map
SEMANTIC = {
    "pallet": 1,
    "rack": 2,
    "car": 3,
    "jack": 4,
    "stillage": 5,
    "cabinet": 6,
    "dolly": 7,
    "forklift": 8,
    "klt": 9,
    "conveyor": 0,
    "floor": 0,
    "wall": 0,
    "column": 0,
}
STACKABLE = {"pallet", "klt", "stillage"}
# classes with curved parts: their variants take ``segments=``
CURVED = {"car", "jack", "forklift", "dolly"}


def check_segments(segments: Any, where: str) -> int | None:
    """``segments`` as an int (None stays None); ConfigError unless an integer >= 3."""
    if segments is None:
        return None
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or segments < 3:
        raise ConfigError(
            f"{where}: segments must be an integer >= 3 (segments per circle) or None, "
            f"got {segments!r}"
        )
    return int(segments)


def make(cls: str, variant: str, segments: int | None = None) -> trimesh.Trimesh:
    """Build (once per process and tessellation) variant ``variant`` of asset class ``cls``.

    ``segments`` (None or an integer >= 3): segments per circle of its curved parts; a class
    without any (not in ``CURVED``) ignores it and shares one mesh for every value.
    """
    segments = check_segments(segments, f"asset {cls}/{variant}")
    return _make(cls, variant, segments if cls in CURVED else None)


@lru_cache(maxsize=None)
def _make(cls: str, variant: str, segments: int | None) -> trimesh.Trimesh:
    build = VARIANTS[cls][variant]
    return build() if segments is None else build(segments=segments)
