"""The report card's standard test scenes, each with its closed-form truth.

Every scene is seen from the identity pose (camera frame = world frame: x right, y down,
z forward, metres), so each surface's depth along any pixel's ray has a closed form
(:class:`~genie_gl.card.metrics.Plane.depth_along`):

* ``wall`` — a flat matte wall (albedo 0.8, UsdPreviewSurface roughness 1) at ``distance_m``
  on the optical axis, turned by ``angle_deg`` about the camera's vertical axis (incidence
  angle on the axis), as the methodology's flat target;
* ``step`` — the same wall ``STEP_M`` farther back, with a matte panel at ``distance_m``
  covering the left half of the view: a vertical depth step on the optical axis (flying pixels,
  lateral noise, the edge's fill);
* ``bars`` — vertical bars of widths ``BAR_WIDTHS_MM`` at ``distance_m`` in front of the wall
  ``BAR_GAP_M`` behind them: what thin structures return;
* ``panels`` — square panels of the materials of ``PANEL_MATERIALS`` side by side on a wall
  at ``distance_m`` (dark and shiny surfaces through the sensor's material effects).

The wall, step and panels are large quads (no back-face culling: they are open meshes); the
bars are boxes. Instance ids: the wall 1, the step's panel 2, bars and panels 10 + k.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene.model import Material, Mesh, Scene
from .metrics import Plane

MATTE = Material(diffuse_color=(0.8, 0.8, 0.8), metallic=0.0, roughness=1.0)
STEP_M = 0.5  # the step's depth jump, m
BAR_WIDTHS_MM = (2.0, 5.0, 10.0, 20.0, 40.0)
BAR_GAP_M = 0.5  # bars stand this far in front of the wall
BAR_SPAN = 0.6  # bars spread over this fraction of the view's width
PANEL_SPAN = 0.7  # panels cover this fraction of the view's width
PANEL_MATERIALS: dict[str, Material] = {
    "white": MATTE,
    "dark_15": Material(diffuse_color=(0.15, 0.15, 0.15), metallic=0.0, roughness=1.0),
    "dark_05": Material(diffuse_color=(0.05, 0.05, 0.05), metallic=0.0, roughness=1.0),
    "glossy": Material(diffuse_color=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.05),
    "metal": Material(diffuse_color=(0.9, 0.9, 0.9), metallic=1.0, roughness=0.1),
}
WALL_ID, PANEL_ID, FIRST_PART_ID = 1, 2, 10
KINDS = ("wall", "step", "bars", "panels")
_QUAD = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)


@dataclass(frozen=True)
class TestScene:
    """A test scene and its truth.

    Attributes
    ----------
    kind : one of :data:`KINDS`.
    distance_m : depth of the target (the wall, the step's panel, the bars, the panels) on
        the optical axis, m.
    angle_deg : the wall's turn about the camera's vertical axis (``wall`` only; else 0).
    scene : the :class:`~genie_gl.Scene` to render from the identity pose.
    planes : instance id -> the plane of that instance's front surface (camera frame).
    parts : instance id -> name of each bar (``"bar_<width>mm"``) or panel (material name).
    """

    kind: str
    distance_m: float
    angle_deg: float
    scene: Scene
    planes: dict[int, Plane]
    parts: dict[int, str] = field(default_factory=dict)

    @property
    def pose(self) -> np.ndarray:
        """(4, 4) float64 world_from_camera: the identity."""
        return np.eye(4)


def _quad(corners: np.ndarray) -> Mesh:
    return Mesh(np.asarray(corners, np.float64), _QUAD)


def _wall_plane(distance_m: float, angle_deg: float) -> tuple[Plane, np.ndarray, np.ndarray]:
    """The wall's plane (normal away from the camera) and two unit axes spanning it."""
    a = np.radians(angle_deg)
    n = np.array([np.sin(a), 0.0, np.cos(a)])
    return (
        Plane(n, float(-distance_m * np.cos(a))),
        np.array([np.cos(a), 0.0, -np.sin(a)]),
        np.array([0.0, 1.0, 0.0]),
    )


def _wall_mesh(distance_m: float, angle_deg: float, half: float) -> Mesh:
    _, ax, ay = _wall_plane(distance_m, angle_deg)
    c = np.array([0.0, 0.0, distance_m])
    return _quad(
        [c + half * (sx * ax + sy * ay) for sx, sy in [(-1, -1), (1, -1), (1, 1), (-1, 1)]]
    )


def _half_extent(distance_m: float, angle_deg: float) -> float:
    # wide enough to fill a 130° view; a turned wall runs off towards infinity on one side
    return float(max(4.0, 3.0 * distance_m / max(np.cos(np.radians(angle_deg)), 0.2)))


def wall(distance_m: float, angle_deg: float = 0.0) -> TestScene:
    """A matte wall whose plane crosses the optical axis at ``distance_m``, turned by
    ``angle_deg`` (0-80) about the vertical axis."""
    _check(distance_m, angle_deg)
    s = Scene()
    s.add(
        _wall_mesh(distance_m, angle_deg, _half_extent(distance_m, angle_deg)),
        instance=WALL_ID,
        material=MATTE,
        name="wall",
    )
    return TestScene(
        "wall",
        float(distance_m),
        float(angle_deg),
        s,
        {WALL_ID: _wall_plane(distance_m, angle_deg)[0]},
    )


def step(distance_m: float) -> TestScene:
    """A panel at ``distance_m`` covering x < 0 in front of a wall ``STEP_M`` behind it."""
    _check(distance_m, 0.0)
    back = distance_m + STEP_M
    half = _half_extent(back, 0.0)
    s = Scene()
    s.add(_wall_mesh(back, 0.0, half), instance=WALL_ID, material=MATTE, name="wall")
    z = distance_m
    s.add(
        _quad([[-half, -half, z], [0.0, -half, z], [0.0, half, z], [-half, half, z]]),
        instance=PANEL_ID,
        material=MATTE,
        name="step",
    )
    planes = {WALL_ID: _wall_plane(back, 0.0)[0], PANEL_ID: _wall_plane(distance_m, 0.0)[0]}
    return TestScene("step", float(distance_m), 0.0, s, planes)


def bars(
    distance_m: float, x_half_tan: float, widths_mm: tuple[float, ...] = BAR_WIDTHS_MM
) -> TestScene:
    """Vertical bars (square section of their width) whose front faces stand at
    ``distance_m``, spread over ``BAR_SPAN`` of a view whose half-width subtends
    ``x_half_tan`` (tan of half the horizontal field), ``BAR_GAP_M`` in front of a wall."""
    _check(distance_m, 0.0)
    back = distance_m + BAR_GAP_M
    half = _half_extent(back, 0.0)
    s = Scene()
    s.add(_wall_mesh(back, 0.0, half), instance=WALL_ID, material=MATTE, name="wall")
    planes = {WALL_ID: _wall_plane(back, 0.0)[0]}
    parts = {}
    xs = np.linspace(-BAR_SPAN, BAR_SPAN, len(widths_mm)) * x_half_tan * distance_m
    for k, (x, w_mm) in enumerate(zip(xs, widths_mm)):
        w = w_mm / 1000.0
        lo = np.array([x - w / 2, -half, distance_m])
        hi = np.array([x + w / 2, half, distance_m + w])
        v = np.array(
            [
                [lo[0], lo[1], lo[2]],
                [hi[0], lo[1], lo[2]],
                [hi[0], hi[1], lo[2]],
                [lo[0], hi[1], lo[2]],
                [lo[0], lo[1], hi[2]],
                [hi[0], lo[1], hi[2]],
                [hi[0], hi[1], hi[2]],
                [lo[0], hi[1], hi[2]],
            ]
        )
        f = np.array(
            [
                [0, 2, 1],
                [0, 3, 2],
                [4, 5, 6],
                [4, 6, 7],
                [0, 1, 5],
                [0, 5, 4],
                [3, 7, 6],
                [3, 6, 2],
                [0, 4, 7],
                [0, 7, 3],
                [1, 2, 6],
                [1, 6, 5],
            ],
            dtype=np.uint32,
        )
        iid = FIRST_PART_ID + k
        s.add(Mesh(v, f, closed=True), instance=iid, material=MATTE, name=f"bar_{w_mm:g}mm")
        planes[iid] = _wall_plane(distance_m, 0.0)[0]
        parts[iid] = f"bar_{w_mm:g}mm"
    return TestScene("bars", float(distance_m), 0.0, s, planes, parts)


def panels(
    distance_m: float, x_half_tan: float, materials: dict[str, Material] | None = None
) -> TestScene:
    """Square panels of ``materials`` (default :data:`PANEL_MATERIALS`) side by side, 1 mm in
    front of a matte wall at ``distance_m + 0.001``, over ``PANEL_SPAN`` of the view's width."""
    _check(distance_m, 0.0)
    mats = PANEL_MATERIALS if materials is None else materials
    back = distance_m + 0.001
    half = _half_extent(back, 0.0)
    s = Scene()
    s.add(_wall_mesh(back, 0.0, half), instance=WALL_ID, material=MATTE, name="wall")
    planes = {WALL_ID: _wall_plane(back, 0.0)[0]}
    parts = {}
    width = 2 * PANEL_SPAN * x_half_tan * distance_m / len(mats)
    for k, (name, mat) in enumerate(mats.items()):
        x0 = -PANEL_SPAN * x_half_tan * distance_m + k * width
        x1, h = x0 + width * 0.9, width * 0.45
        iid = FIRST_PART_ID + k
        z = distance_m
        s.add(
            _quad([[x0, -h, z], [x1, -h, z], [x1, h, z], [x0, h, z]]),
            instance=iid,
            material=mat,
            name=name,
        )
        planes[iid] = _wall_plane(distance_m, 0.0)[0]
        parts[iid] = name
    return TestScene("panels", float(distance_m), 0.0, s, planes, parts)


def _check(distance_m: float, angle_deg: float) -> None:
    if not (np.isfinite(distance_m) and 0.05 <= distance_m <= 100.0):
        raise ValueError(f"test scene: distance_m must be in [0.05, 100] m, got {distance_m}")
    if not (np.isfinite(angle_deg) and 0.0 <= angle_deg <= 80.0):
        raise ValueError(f"test scene: angle_deg must be in [0, 80], got {angle_deg}")
