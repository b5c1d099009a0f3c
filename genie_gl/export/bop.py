"""BOP-style RGB-D frames for image models (bop_toolkit's "BOP-scenewise" layout, FORMATS.md §4)::

    DIR/camera.json                                  the camera of the dataset
    DIR/models/obj_{obj_id:06d}.ply, models_info.json   object models in mm, centred on their box
    DIR/{split}/{scene_id:06d}/scene_camera.json     cam_K, depth_scale, cam_R_w2c, cam_t_w2c (mm)
                               scene_gt.json         per image: obj_id, cam_R_m2c, cam_t_m2c (mm)
                               scene_gt_info.json    bbox_obj, bbox_visib, px_count_*, visib_fract
                               rgb/{im_id:06d}.png   depth/{im_id:06d}.png (uint16, mm /
                               depth_scale)
                               mask/{im_id:06d}_{gt_id:06d}.png   mask_visib/... (0 or 255)

Ground-truth objects are the instances of non-background classes (semantic id != 0) seen in
an image. ``obj_id`` is stable across scenes and runs: the built-in asset variants are numbered
in catalogue order (1, 2, …); any other mesh gets 1000 + a hash of its name. Full silhouettes
(``mask``, ``px_count_all``, ``bbox_obj``) come from renders of each object alone
(:func:`genie_gl.capture.silhouettes`, rendered by the capture); without them only the visible parts
are written.
The scene folder is written under a temporary name and renamed when complete.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import shutil
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np
import trimesh
from scipy.spatial import cKDTree

from ..errors import ConfigError, ExportError
from ..frame import Frame
from ..outputs import atomic_write_bytes, atomic_write_text, claim_folder, publish_folder
from ..scene.assets.library import SEMANTIC, VARIANTS
from ..scene.model import Scene
from .registry import DatasetFormat, register_format

MAX_U16 = 65535


def object_ids() -> dict[str, int]:
    """obj_id of every built-in foreground asset variant (mesh name ``class_variant``)."""
    names = [f"{c}_{v}" for c in VARIANTS for v in VARIANTS[c] if SEMANTIC.get(c, 0) != 0]
    return {n: i + 1 for i, n in enumerate(names)}


def object_id(mesh_name: str, ids: Mapping[str, int] | None = None) -> int:
    ids = object_ids() if ids is None else ids
    return ids.get(mesh_name, 1000 + zlib.crc32(mesh_name.encode()) % 1_000_000)


def bop_json(content: dict) -> str:
    """bop_toolkit's ``save_json`` layout: one sorted top-level key per line."""
    items = sorted(content.items(), key=lambda kv: kv[0])
    body = ",\n".join(f'  "{k}": {json.dumps(v, sort_keys=True)}' for k, v in items)
    return "{\n" + body + "\n}" if items else "{}"


def bbox(mask: np.ndarray) -> list[int]:
    """[x, y, w, h] of a mask, top-left origin; [-1, -1, -1, -1] when empty."""
    rows, cols = np.flatnonzero(mask.any(1)), np.flatnonzero(mask.any(0))
    if len(rows) == 0:
        return [-1, -1, -1, -1]
    return [int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1)]


def depth_png(depth_m: np.ndarray, depth_scale: float) -> np.ndarray:
    """uint16 image of depth in units of ``depth_scale`` mm; beyond the range and no return: 0."""
    v = np.round(depth_m.astype(np.float64) * 1000.0 / depth_scale)
    return np.where((v > 0) & (v <= MAX_U16), v, 0).astype(np.uint16)


def _png(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise ConfigError("BOP export: PNG encoding failed")
    return buf.tobytes()


def _camera(frame: Frame, depth_scale: float) -> dict:
    s = frame.sensor
    return {
        "cx": float(s.K[0, 2]),
        "cy": float(s.K[1, 2]),
        "depth_scale": depth_scale,
        "fx": float(s.K[0, 0]),
        "fy": float(s.K[1, 1]),
        "height": s.height,
        "width": s.width,
    }


DEPTH_SCALES = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0)


def choose_depth_scale(max_depth_m: float) -> float:
    """The finest of the usual steps (0.1, 0.2, 0.5, 1, 2, 5 ... mm per unit) at which
    ``max_depth_m`` still fits a 16-bit PNG (BOP writes it per image in scene_camera.json)."""
    need = float(max_depth_m) * 1000.0 / MAX_U16
    for s in DEPTH_SCALES:
        if need <= s:
            return s
    raise ExportError(
        f"BOP depth: {max_depth_m:.6g} m is beyond the 16-bit PNG range at "
        f"{DEPTH_SCALES[-1]:g} mm per unit ({MAX_U16 * DEPTH_SCALES[-1] / 1000:g} m)"
    )


def model_ply(vertices_mm: np.ndarray, faces: np.ndarray, normals: np.ndarray) -> bytes:
    """Binary PLY of a model as bop_toolkit's ``load_ply`` reads it (only float, double, int and
    uchar; triangles as ``list uchar int vertex_indices``), with vertex normals."""
    v = np.empty(
        len(vertices_mm),
        [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")],
    )
    v["x"], v["y"], v["z"] = np.asarray(vertices_mm, np.float64).T
    v["nx"], v["ny"], v["nz"] = np.asarray(normals, np.float64).T
    f = np.empty(len(faces), [("n", "u1"), ("i", "<i4", (3,))])
    f["n"], f["i"] = 3, faces
    header = (
        [
            "ply",
            "format binary_little_endian 1.0",
            "comment genie-gl object model, mm",
            f"element vertex {len(v)}",
        ]
        + [f"property float {k}" for k in ("x", "y", "z", "nx", "ny", "nz")]
        + [f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    )
    return ("\n".join(header) + "\n").encode() + v.tobytes() + f.tobytes()


def _rot(axis: int, degrees: int) -> np.ndarray:
    a = np.deg2rad(degrees)
    c, s = round(np.cos(a)), round(np.sin(a))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(4)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def discrete_symmetries(vertices_mm: np.ndarray, tol_mm: float = 1.0) -> list[list[float]]:
    """Turns about the model's axes (90/180/270 degrees about z, 180 about x and y) that map its
    vertex set onto itself within ``tol_mm``: BOP's ``symmetries_discrete`` (4x4 row-major, mm)."""
    v = np.asarray(vertices_mm, np.float64)
    if len(v) < 2:
        return []
    tree = cKDTree(v)
    found = []
    for axis, deg in ((2, 90), (2, 180), (2, 270), (0, 180), (1, 180)):
        R = _rot(axis, deg)
        d, _ = tree.query(v @ R[:3, :3].T)
        if d.max() <= tol_mm:
            found.append(R.ravel().tolist())
    return found


def write_models(scene: Scene, out_dir: str | os.PathLike, names: Sequence[str]) -> dict[int, dict]:
    """Write ``models/obj_XXXXXX.ply`` (mm, centred on the bounding box, with vertex normals) for
    the named meshes and merge their entries into ``models_info.json`` (diameter, box,
    ``symmetries_discrete`` where the model has them) and ``models/names.json``; returns the
    entries written."""
    out = Path(out_dir) / "models"
    info: dict[int, dict] = {}
    names_of: dict[int, str] = {}
    for name in sorted(set(names)):
        m = scene.meshes[name]
        v = m.vertices.astype(np.float64)
        lo, hi = v.min(0), v.max(0)
        v_mm = (v - (lo + hi) / 2) * 1000.0
        tm = trimesh.Trimesh(v_mm, m.faces, process=False)
        hull = tm.convex_hull.vertices if len(v_mm) > 3 else v_mm
        diameter = (
            float(np.sqrt(((hull[:, None] - hull[None]) ** 2).sum(-1)).max())
            if len(hull) > 1
            else 0.0
        )
        oid = object_id(name)
        atomic_write_bytes(out / f"obj_{oid:06d}.ply", model_ply(v_mm, m.faces, tm.vertex_normals))
        size = (hi - lo) * 1000.0
        info[oid] = {
            "diameter": diameter,
            "min_x": float(-size[0] / 2),
            "min_y": float(-size[1] / 2),
            "min_z": float(-size[2] / 2),
            "size_x": float(size[0]),
            "size_y": float(size[1]),
            "size_z": float(size[2]),
        }
        sym = discrete_symmetries(v_mm)
        if sym:
            info[oid]["symmetries_discrete"] = sym
        names_of[oid] = name
    out.mkdir(parents=True, exist_ok=True)
    with open(out / ".lock", "w") as lock:  # dataset workers add their scenes' models concurrently
        fcntl.flock(lock, fcntl.LOCK_EX)
        for file, new in (("models_info.json", info), ("names.json", names_of)):
            path = out / file
            known = (
                {int(k): v for k, v in json.loads(path.read_text()).items()}
                if path.exists()
                else {}
            )
            atomic_write_text(path, bop_json({**known, **new}))
    return info


#: the files BOP's writer puts in a scene folder (relative paths): a user's own files there stay
SCENE_FILE = re.compile(
    r"(rgb|depth)/\d{6}\.png|mask(_visib)?/\d{6}_\d{6}\.png|scene_(camera|gt|gt_info)\.json"
)


def scene_files(folder: Path) -> list[str]:
    """The files of BOP scene ``folder`` that genie-gl wrote (:data:`SCENE_FILE`)."""
    if not folder.is_dir() or folder.is_symlink():
        return []
    return [
        rel
        for rel in (p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
        if SCENE_FILE.fullmatch(rel)
    ]


def write_scene(
    scene: Scene,
    frames: Sequence[Frame],
    out_dir: str | os.PathLike,
    *,
    scene_id: int = 0,
    split: str = "train_pbr",
    depth_scale: float | None = None,
    full_masks: Sequence[Mapping[int, np.ndarray]] | None = None,
) -> Path:
    """Write ``frames`` of ``scene`` as BOP scene ``scene_id`` under ``out_dir`` with
    ``camera.json`` and the models it uses; returns the scene folder. The models and the camera
    are written first and the scene folder is renamed into place last, so a run killed at any
    moment leaves a dataset whose every scene loads.

    depth_scale : mm per depth-PNG unit; None (default): chosen for this scene, the finest step
        at which its farthest depth fits 16 bits (:func:`choose_depth_scale`).
    full_masks : per frame, {instance id: (H, W) bool full silhouette}.
    """
    folder = claim_folder(
        out_dir, "bop", (split, "camera.json", "models"), option="out_dir", reserve=True
    )
    out = folder.path
    final = out / split / f"{scene_id:06d}"
    for stale in final.parent.glob(f".tmp-{final.name}-*"):  # what a killed run left
        shutil.rmtree(stale, ignore_errors=True)
    tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
    used = write_scene_files(scene, frames, tmp, depth_scale=depth_scale, full_masks=full_masks)
    write_dataset_files(scene, frames[0], out, used, 1.0 if depth_scale is None else depth_scale)
    publish_folder(
        tmp, final, previous=scene_files(final)
    )  # a user's files in an earlier scene folder stay
    folder.finish(
        {"scenes": sorted(int(p.name) for p in (out / split).iterdir() if p.name.isdigit())}
    )
    return final


def write_dataset_files(
    scene: Scene,
    frame: Frame,
    out_dir: str | os.PathLike,
    meshes: Sequence[str],
    depth_scale: float = 1.0,
) -> None:
    """``camera.json`` and the models of ``meshes`` at the dataset root."""
    atomic_write_text(
        Path(out_dir) / "camera.json",
        json.dumps(_camera(frame, depth_scale), indent=2, sort_keys=True),
    )
    write_models(scene, out_dir, meshes)


def write_scene_files(
    scene: Scene,
    frames: Sequence[Frame],
    folder: str | os.PathLike,
    *,
    depth_scale: float | None = None,
    full_masks: Sequence[Mapping[int, np.ndarray]] | None = None,
) -> list[str]:
    """The files of one BOP scene folder (images, masks, the three JSON files) written into
    ``folder``; returns the names of the meshes its ground truth refers to."""
    if not frames:
        raise ConfigError("BOP export: no frames")
    if full_masks is not None and len(full_masks) != len(frames):
        raise ConfigError(
            f"BOP export: full_masks has {len(full_masks)} entries for {len(frames)} frames"
        )
    if depth_scale is None:
        depth_scale = choose_depth_scale(
            max(float(f.depth.max()) if f.depth.size else 0.0 for f in frames)
        )
    tmp = Path(folder)
    for sub in (
        ("depth", "mask_visib")
        + (("rgb",) if frames[0].rgb is not None else ())
        + (("mask",) if full_masks is not None else ())
    ):
        (tmp / sub).mkdir(parents=True, exist_ok=True)
    by_id = {inst.instance: inst for inst in scene.instances}
    ids = object_ids()
    cams, gts, infos, used = {}, {}, {}, set()
    for im, f in enumerate(frames):
        c_w = np.linalg.inv(f.world_from_camera)
        cams[im] = {
            "cam_K": f.sensor.K.ravel().tolist(),
            "depth_scale": depth_scale,
            "cam_R_w2c": c_w[:3, :3].ravel().tolist(),
            "cam_t_w2c": (1000.0 * c_w[:3, 3]).tolist(),
        }
        (tmp / "depth" / f"{im:06d}.png").write_bytes(_png(depth_png(f.depth, depth_scale)))
        if f.rgb is not None:
            (tmp / "rgb" / f"{im:06d}.png").write_bytes(
                _png(np.ascontiguousarray(f.rgb[..., ::-1]))
            )
        seen = np.unique(f.instance[(f.semantic != 0) & (f.depth > 0)])
        gts[im], infos[im] = [], []
        for gt_id, iid in enumerate(int(i) for i in seen if int(i) in by_id):
            inst = by_id[iid]
            v = scene.meshes[inst.mesh].vertices
            centre = np.eye(4)
            centre[:3, 3] = (v.min(0).astype(np.float64) + v.max(0)) / 2
            m2c = c_w @ inst.world_from_model @ centre
            gts[im].append(
                {
                    "obj_id": object_id(inst.mesh, ids),
                    "cam_R_m2c": m2c[:3, :3].ravel().tolist(),
                    "cam_t_m2c": (1000.0 * m2c[:3, 3]).tolist(),
                }
            )
            used.add(inst.mesh)
            visib = f.instance == iid
            (tmp / "mask_visib" / f"{im:06d}_{gt_id:06d}.png").write_bytes(
                _png(255 * visib.astype(np.uint8))
            )
            n_vis = int(visib.sum())
            entry = {"bbox_visib": bbox(visib), "px_count_visib": n_vis}
            if full_masks is not None:
                full = np.asarray(full_masks[im].get(iid, visib)) | visib
                (tmp / "mask" / f"{im:06d}_{gt_id:06d}.png").write_bytes(
                    _png(255 * full.astype(np.uint8))
                )
                n_all = int(full.sum())
                entry |= {
                    "bbox_obj": bbox(full),
                    "px_count_all": n_all,
                    "px_count_valid": int((full & (f.depth > 0)).sum()),
                    "visib_fract": n_vis / max(n_all, 1),
                }
            infos[im].append(entry)
    (tmp / "scene_camera.json").write_text(bop_json(cams))
    (tmp / "scene_gt.json").write_text(bop_json(gts))
    (tmp / "scene_gt_info.json").write_text(bop_json(infos))
    return sorted(used)


# --- the dataset format: DIR/train_pbr/NNNNNN per scene, models and camera at the root


def _write_dataset_scene(data, folder: Path) -> None:
    # the full silhouettes were rendered by the capture (DatasetFormat.full_masks): export renders
    # nothing
    data.extra["bop_meshes"] = write_scene_files(
        data.scene, data.frames, folder, full_masks=data.extra["full_masks"]
    )


def _before_rename(data, out: Path) -> None:
    write_dataset_files(data.scene, data.frames[0], out, data.extra.get("bop_meshes", []))


DATASET = register_format(
    DatasetFormat(
        "bop",
        "train_pbr",
        digits=6,
        chunks=False,
        full_masks=True,
        dataset_outputs=("camera.json", "models"),
        write_scene=_write_dataset_scene,
        before_rename=_before_rename,
        bytes_per_point=0.0,
        bytes_per_pixel=4.0,  # 16-bit depth + RGB + masks, PNG-compressed
        description="BOP scene-wise RGB-D frames, masks, poses and object models",
    )
)
