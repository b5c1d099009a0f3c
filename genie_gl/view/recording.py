"""Scenes as a Rerun recording (``.rrd``), written with ``rerun-sdk``.

Entities, per scene ``S`` (``scene_0000``, or the folder's name):

- ``S/world``: the world frame (Z up); ``S/world/cloud/class``: the world cloud, ``class_ids``
  the semantic id, coloured and named by the one annotation context (the paper's ten classes
  in the previews' colours, :mod:`genie_gl.labels`) logged at the root; ``S/world/cloud/instance``:
  the same points coloured per instance (:func:`instance_colors`), ids in ``instance_id``;
- ``S/world/trajectory``: the body's path as a line; ``S/world/body``: the body (rig or
  scanner) pose on the ``time`` timeline;
- ``S/world/cameras/NAME``: each camera's pose (on ``time`` for a recording, static for a
  standing camera); ``.../image``: its pinhole (K, size, OpenCV axes) with ``depth``
  (metres), ``semantic`` (class ids, the same annotation context) and ``instance`` images;
- ``S/world/meshes/N``: a USD scene's meshes, ``class_ids`` per vertex;
- ``S/layout``: the layout picture, as the previews draw it.

Points beyond ``max_points`` per scene are thinned with a fixed stride (every k-th point, k
the smallest that fits), so the same files give the same recording.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path

import numpy as np

from .. import labels
from ..errors import ConfigError
from ..layout.picture import layout_image
from .folders import SceneView

TIMELINE = "time"
APPLICATION = "genie-gl"
MAX_POINTS = 2_000_000
POINT_RADIUS = (
    -2.0
)  # negative: in screen points (Rerun's convention), so sparse clouds stay visible


def _rerun():
    try:
        import rerun as rr
    except ImportError as exc:
        raise ConfigError(
            f"genie view needs the rerun-sdk package: pip install 'genie-gl[view]' ({exc})"
        ) from None
    return rr


def annotation_context(rr):
    """The paper's classes (:mod:`genie_gl.labels`): id, name and the previews' colour."""
    return rr.AnnotationContext(
        [
            rr.AnnotationInfo(id=k, label=labels.name(k), color=labels.color(k))
            for k in sorted(labels.CLASSES)
        ]
    )


def instance_colors(instance: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colours of instance ids: a fixed hash per id (0, none: grey)."""
    ids = np.asarray(instance, np.uint64)
    h = (ids * np.uint64(2654435761)) & np.uint64(0xFFFFFF)
    rgb = np.stack(
        [
            (h >> np.uint64(16)) & np.uint64(255),
            (h >> np.uint64(8)) & np.uint64(255),
            h & np.uint64(255),
        ],
        -1,
    ).astype(np.uint8)
    rgb = (rgb // 2 + 96).astype(np.uint8)  # neither black nor white
    rgb[ids == 0] = (128, 128, 128)
    return rgb


def ring_colors(ring: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colours of scanner channels: a hue wheel over the channels, lowest blue."""
    r = np.asarray(ring, np.float64)
    t = (r - r.min()) / max(float(r.max() - r.min()), 1.0) if len(r) else r
    hue = 0.66 * (1.0 - t)  # 0.66 (blue) for the lowest channel, 0 (red) for the highest
    k = (np.stack([hue + 1 / 3, hue, hue - 1 / 3], 1) * 6.0) % 6.0
    rgb = np.clip(np.minimum(k, 4.0 - k), 0.0, 1.0)
    return (255 * rgb).astype(np.uint8)


def stride(n: int, max_points: int) -> int:
    """The smallest k for which every k-th of ``n`` points is at most ``max_points``."""
    return max(1, -(-n // max(1, max_points)))


def write_rrd(
    views: list[SceneView], path: str | os.PathLike, *, max_points: int = MAX_POINTS
) -> Path:
    """Write ``views`` as a Rerun recording at ``path`` (a temporary file, renamed when whole);
    returns the path."""
    rr = _rerun()
    path = Path(path)
    if not views:
        raise ConfigError(f"{path}: nothing to record (no scene)")
    if path.suffix != ".rrd":
        raise ConfigError(f"{path}: a Rerun recording is named *.rrd")
    if path.exists() and not rrd_is_ours(path):
        raise ConfigError(
            f"{path}: already exists and was not written by genie-gl; it is left as it is (remove "
            "or "
            "rename it, or give --out another path)"
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    rec_id = uuid.uuid5(uuid.NAMESPACE_URL, "genie-gl:" + ",".join(v.name for v in views))
    rec = rr.RecordingStream(APPLICATION, recording_id=rec_id, send_properties=False)
    rec.set_log_time_enabled(False)  # the data's own clock only ("time"), not the writer's
    rec.set_log_tick_enabled(False)
    try:
        rec.save(tmp)
        rec.log("/", annotation_context(rr), static=True)
        for v in views:
            _log_scene(rr, rec, v, max_points)
        rec.send_blueprint(blueprint(views))
        rec.flush()
        rec.disconnect()
        tmp.replace(path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _eye(v: SceneView):
    """An eye above one corner of the scene looking at its middle (z up), as the previews'
    overview; None for a scene without points or meshes."""
    import rerun.blueprint as rrb

    pts = v.xyz if len(v.xyz) else (np.concatenate([m[0] for m in v.meshes]) if v.meshes else None)
    if pts is None:
        return None
    lo, hi = np.percentile(pts, 1, axis=0), np.percentile(pts, 99, axis=0)
    w, h = max(hi[0] - lo[0], 1.0), max(hi[1] - lo[1], 1.0)
    mid = (lo + hi) / 2
    eye = [lo[0] - 0.15 * w, lo[1] - 0.35 * h, hi[2] + 0.45 * max(w, h)]
    return rrb.archetypes.EyeControls3D(
        position=eye, look_target=[mid[0], mid[1], lo[2]], eye_up=[0, 0, 1]
    )


def blueprint(views: list[SceneView]):
    """The viewer's layout: per scene a tab with the 3-D view (classes; a second tab with the
    instance layer), the layout picture and the first camera's images beside it."""
    import rerun.blueprint as rrb

    tabs = []
    for v in views:
        root = f"{v.name}/world"
        eye = _eye(v)
        views3d = rrb.Tabs(
            rrb.Spatial3DView(
                origin=root,
                contents=["$origin/**", "-$origin/cloud/instance", "-$origin/cloud/ring"],
                name="classes",
                eye_controls=eye,
            ),
            rrb.Spatial3DView(
                origin=root,
                contents=["$origin/**", "-$origin/cloud/class", "-$origin/cloud/ring"],
                name="instances",
                eye_controls=eye,
            ),
            *(
                [
                    rrb.Spatial3DView(
                        origin=root,
                        contents=["$origin/**", "-$origin/cloud/class", "-$origin/cloud/instance"],
                        name="rings",
                        eye_controls=eye,
                    )
                ]
                if v.ring is not None
                else []
            ),
        )
        side = []
        if v.layout is not None:
            side.append(rrb.Spatial2DView(origin=f"{v.name}/layout", name="layout"))
        cams = sorted({s.camera for s in v.shots if s.K is not None})
        if cams:
            side.append(rrb.Spatial2DView(origin=f"{root}/cameras/{cams[0]}/image", name=cams[0]))
        part = (
            rrb.Horizontal(views3d, rrb.Vertical(*side), column_shares=[3, 1]) if side else views3d
        )
        tabs.append(rrb.Horizontal(part, name=v.name) if side else part)
    return rrb.Blueprint(rrb.Tabs(*tabs) if len(tabs) > 1 else tabs[0], collapse_panels=False)


def rrd_is_ours(path: Path) -> bool:
    """True when ``path`` is a Rerun recording genie-gl wrote (its application id)."""
    from rerun.chunk import RrdReader

    try:
        return any(r.application_id == APPLICATION for r in RrdReader(path).recordings())
    except (OSError, ValueError, RuntimeError):
        return False


def _transform(rr, T: np.ndarray):
    return rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3])


def _log_scene(rr, rec, v: SceneView, max_points: int) -> None:
    root = v.name
    rec.log(f"{root}/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    if len(v.xyz):
        k = stride(len(v.xyz), max_points)
        xyz = v.xyz[::k].astype(np.float32)
        rec.log(
            f"{root}/world/cloud/class",
            rr.Points3D(xyz, class_ids=v.semantic[::k], radii=POINT_RADIUS),
            static=True,
        )
        inst = v.instance[::k]
        rec.log(
            f"{root}/world/cloud/instance",
            rr.Points3D(xyz, colors=instance_colors(inst), radii=POINT_RADIUS),
            rr.AnyValues(instance_id=inst.astype(np.uint32)),
            static=True,
        )
        if v.ring is not None:  # a scanner's points by channel
            ring = v.ring[::k]
            rec.log(
                f"{root}/world/cloud/ring",
                rr.Points3D(xyz, colors=ring_colors(ring), radii=POINT_RADIUS),
                rr.AnyValues(ring=ring.astype(np.uint16)),
                static=True,
            )
    for n, (verts, faces, sem, inst) in enumerate(v.meshes):
        rec.log(
            f"{root}/world/meshes/{n:05d}",
            rr.Mesh3D(
                vertex_positions=verts,
                triangle_indices=faces,
                class_ids=np.full(len(verts), sem, np.uint16),
            ),
            rr.AnyValues(instance_id=[inst]),
            static=True,
        )
    if v.world_from_body is not None:
        rec.log(
            f"{root}/world/trajectory",
            rr.LineStrips3D([v.world_from_body[:, :3, 3]], colors=[(20, 20, 20)]),
            static=True,
        )
        for t, T in zip(v.times_s, v.world_from_body):
            rec.set_time(TIMELINE, duration=float(t))
            rec.log(f"{root}/world/body", _transform(rr, T), rr.TransformAxes3D(0.5))
    for s in v.shots:
        cam = f"{root}/world/cameras/{s.camera}"
        static = s.time_s is None
        if not static:
            rec.set_time(TIMELINE, duration=float(s.time_s))
        rec.log(cam, _transform(rr, s.world_from_camera), static=static)
        if s.K is not None:
            rec.log(
                f"{cam}/image",
                rr.Pinhole(
                    image_from_camera=s.K,
                    resolution=list(s.size),
                    camera_xyz=rr.ViewCoordinates.RDF,
                    image_plane_distance=0.3,
                ),
                static=static,
            )
        if s.depth is not None:
            rec.log(f"{cam}/image/depth", rr.DepthImage(s.depth, meter=1.0), static=static)
        if s.semantic is not None:
            rec.log(f"{cam}/image/semantic", rr.SegmentationImage(s.semantic), static=static)
        if s.instance is not None:
            rec.log(f"{cam}/image/instance", rr.Image(instance_colors(s.instance)), static=static)
    if v.layout is not None:
        rec.log(f"{root}/layout", rr.Image(np.asarray(layout_image(v.layout))), static=True)
