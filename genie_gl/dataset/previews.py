"""Preview pictures of a dataset scene, readable on their own: each has a title, a legend of
the classes shown, axes in metres (top view) or a depth colour bar in metres (cameras)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .. import labels
from ..capture import render
from ..cloud import to_cloud
from ..layout.picture import layout_image
from ..sensors.pose import look_at
from ..sensors.camera import Sensor


def _legend(ax, ids) -> None:
    from matplotlib.patches import Patch

    handles = [
        Patch(
            facecolor=np.array(labels.color(k)) / 255,
            edgecolor="0.35",
            linewidth=0.6,
            label=f"{k} {labels.name(k)}",
        )
        for k in sorted(ids)
    ]
    if handles:
        ax.legend(
            handles=handles,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            fontsize=7,
            frameon=False,
            title="class",
            title_fontsize=8,
        )


def _save(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    tmp = path.with_name(
        f".{path.stem}.{os.getpid()}.tmp.png"
    )  # the temporary name every writer of ours uses
    fig.savefig(tmp, dpi=100, metadata={"Software": None})
    plt.close(fig)
    tmp.replace(path)


def camera_picture(frame, title: str, path: Path) -> None:
    """Depth (with a colour bar in metres), labels (with a legend), colour when there is one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = frame.depth
    valid = d > 0
    panels = 3 if frame.rgb is not None else 2
    fig, axes = plt.subplots(1, panels, figsize=(4.2 * panels + 1.6, 3.6))
    v = d[valid]
    lo, hi = (float(np.percentile(v, 1)), float(np.percentile(v, 99))) if v.size else (0.0, 1.0)
    im = axes[0].imshow(
        np.where(valid, d, np.nan), cmap="viridis", vmin=lo, vmax=max(hi, lo + 1e-3)
    )
    fig.colorbar(im, ax=axes[0], fraction=0.046, pad=0.02, label="depth (m); blank: no return")
    axes[0].set_title("depth")
    pal = labels.palette()
    axes[1].imshow(np.where(valid[..., None], pal[frame.semantic], 0).astype(np.uint8))
    axes[1].set_title("semantic labels")
    _legend(axes[-1], np.unique(frame.semantic[valid]))
    if frame.rgb is not None:
        axes[2].imshow(frame.rgb)
        axes[2].set_title("colour")
    for ax in axes:
        ax.set_xlabel("u (px)")
        ax.set_ylabel("v (px)")
    fig.suptitle(title)
    fig.tight_layout()
    _save(fig, path)


def cloud_top_picture(cloud, bounds, title: str, path: Path) -> None:
    """The merged cloud from above, coloured by class (highest point wins), axes in metres."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x0, y0, w, h = bounds
    s = 900 / max(w, h)
    W, H = int(w * s) + 1, int(h * s) + 1
    img = np.full((H, W, 3), 255, np.uint8)
    xyz = cloud.world_xyz
    order = np.argsort(xyz[:, 2], kind="stable")
    c = np.clip(((xyz[order, 0] - x0) * s).astype(int), 0, W - 1)
    r = np.clip(((y0 + h - xyz[order, 1]) * s).astype(int), 0, H - 1)
    img[r, c] = labels.palette()[cloud.semantic[order]]
    fig, ax = plt.subplots(figsize=(9, 9 * h / w * 0.9 + 1.2) if w >= h else (7, 7 * h / w))
    ax.imshow(img, extent=(x0, x0 + w, y0, y0 + h))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    _legend(ax, np.unique(cloud.semantic))
    fig.tight_layout()
    _save(fig, path)


def layout_picture(layout, title: str, path: Path, *, path_xy: np.ndarray | None = None) -> None:
    """The layout's leaves coloured by region type, with a legend of the types and axes in
    metres; ``path_xy`` (n, 2): a trajectory drawn over it (its start marked)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    x0, y0, w, h = layout.bounds
    s = max(4.0, min(20.0, 900.0 / max(w, h)))
    img = np.asarray(layout_image(layout, px_per_m=s, legend=False))
    fig, ax = plt.subplots(figsize=(9, 9 * h / w * 0.9 + 1.2) if w >= h else (7, 7 * h / w))
    ax.imshow(img, extent=(x0, x0 + img.shape[1] / s, y0 + h - img.shape[0] / s, y0 + h))
    if path_xy is not None:
        ax.plot(path_xy[:, 0], path_xy[:, 1], color="black", lw=1.4, label="trajectory")
        ax.plot(path_xy[:1, 0], path_xy[:1, 1], "o", color="black", ms=6)
        ax.set_xlim(x0, x0 + w)
        ax.set_ylim(y0, y0 + h)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    used = sorted({r.type for r in layout.leaves()})
    # swatches outlined: a near-white region type (empty floor) stays visible on the white legend
    ax.legend(
        handles=[
            Patch(
                facecolor=np.array(layout.region_types[t].color) / 255,
                edgecolor="0.35",
                linewidth=0.6,
                label=t,
            )
            for t in used
        ],
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=7,
        frameon=False,
        title="region type",
        title_fontsize=8,
    )
    fig.tight_layout()
    _save(fig, path)


def overview_pose(bounds):
    """A camera above one corner of the hall looking at its centre (world_from_camera)."""
    x0, y0, w, h = bounds
    return look_at([x0 - 0.15 * w, y0 - 0.35 * h, 0.45 * max(w, h)], [x0 + w / 2, y0 + h / 2, 0.0])


def overview_picture(scene, layout, title: str, path: Path, raster: str | None = None) -> None:
    """The scene rendered from above one corner of the hall (by ``raster``: the dataset's), with a
    title."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    frame = render(
        scene,
        Sensor.pinhole(1024, 640, 620.0, far_m=1e3),
        overview_pose(layout.bounds),
        raster=raster,
    )
    fig, ax = plt.subplots(figsize=(10.24, 6.9))
    ax.imshow(frame.rgb)
    ax.set_axis_off()
    ax.set_title(title)
    fig.tight_layout()
    _save(fig, path)


def write_previews(
    folder: Path, index: int, layout, frames, scene=None, raster: str | None = None
) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    layout_picture(
        layout,
        f"scene {index}: layout ({len(layout.leaves())} regions)",
        folder / f"scene_{index:04d}_layout.png",
    )
    for c, f in enumerate(frames[:2]):
        camera_picture(
            f, f"scene {index}, camera {c}", folder / f"scene_{index:04d}_cam{c:02d}.png"
        )
    if scene is not None:
        overview_picture(
            scene,
            layout,
            f"scene {index}: {len(scene.instances)} objects, rendered from above a corner",
            folder / f"scene_{index:04d}_overview.png",
            raster,
        )
    cloud = to_cloud(frames)
    cloud_top_picture(
        cloud,
        layout.bounds,
        f"scene {index}: merged cloud from above ({len(cloud):,} points)",
        folder / f"scene_{index:04d}_cloud_top.png",
    )


def write_recording_previews(
    folder: Path,
    index: int,
    layout,
    frames,
    trajectory,
    map_cloud=None,
    scene=None,
    raster: str | None = None,
) -> None:
    """The pictures of a scene captured along a trajectory: the path on the layout, a frame or
    two, the scene from above, and the fused map from above (a mobile-scan map) or the frames'
    points (a recording)."""
    folder.mkdir(parents=True, exist_ok=True)
    layout_picture(
        layout,
        f"scene {index}: trajectory, {trajectory.length_m:.0f} m in {trajectory.duration_s:.0f} s",
        folder / f"scene_{index:04d}_path.png",
        path_xy=trajectory.positions[:, :2],
    )
    for c, f in enumerate(frames[:2]):
        camera_picture(
            f,
            f"scene {index}, frame {c} ({(f.meta or {}).get('rig_sensor', '')})",
            folder / f"scene_{index:04d}_cam{c:02d}.png",
        )
    if scene is not None:
        overview_picture(
            scene,
            layout,
            f"scene {index}: {len(scene.instances)} objects, rendered from above a corner",
            folder / f"scene_{index:04d}_overview.png",
            raster,
        )
    if map_cloud is not None:
        cloud_top_picture(
            map_cloud,
            layout.bounds,
            f"scene {index}: fused mobile-scan map from above ({len(map_cloud):,} points)",
            folder / f"scene_{index:04d}_map_top.png",
        )
    elif frames:
        cloud = to_cloud(frames)
        cloud_top_picture(
            cloud,
            layout.bounds,
            f"scene {index}: {len(frames)} frames' points from above",
            folder / f"scene_{index:04d}_cloud_top.png",
        )
