"""Errors of a frame against its reference, in the units a user thinks in.

The reference is a dict of (H, W) arrays on the reference camera's pixel grid: ``depth``
(0: none), ``instance``, ``semantic`` and ``normal`` (unit, camera frame) — analytic truth or
a frame rendered at the most exact setting. A frame at another resolution is compared
through its points: each is projected into the reference camera (same pose, same lens), and
the reference's 1/z is interpolated bilinearly there when the four neighbours are one
surface (one instance, depths within 1 % of each other; 1/z is affine in the pixel position on
a plane, so a plane's depth is recovered exactly), else taken at the nearest pixel.

* ``depth_median_mm``, ``depth_p99_mm``: |Δz| over points whose instance agrees with the
  reference's (mixed ids are counted by the id errors, not here).
* ``p2s_mean_mm``, ``p2s_p99_mm``: distance of every point of the cloud to the reference
  surface's tangent plane on its ray, ``|Δz · (d · n)|`` (flying pixels count here).
* ``id_pct``, ``semantic_pct``: % of pixels valid in either whose instance (semantic) id differs
  from the reference's; ``silhouette_pct`` the same on the reference's silhouettes (pixels
  with another instance in their 3 x 3 neighbourhood); ``edge_px``: the area between the two
  labellings over the reference's contour length, the mean silhouette displacement in pixels.
* ``sampling_mm``: the median distance from a point of the reference surface
  (``SAMPLING_PROBES`` of them, at random places inside its pixels: on no pixel grid) to the
  nearest point of the cloud: how finely the cloud samples the
  surfaces, the pay-off of resolution (ids and depth of a frame at another resolution are
  compared at its nearest pixel to each reference pixel centre, which costs it a fraction of
  a pixel at silhouettes whether it is finer or coarser).
* ``valid_ratio``: valid pixels over the reference's.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..capture.supersample import STEP
from ..frame import Frame
from ..sensors.camera import Sensor
from ..lens.distortion import project as lens_project
from ..effects.geometry import incidence_angle, pixel_rays

SAMPLING_PROBES = 20000


def project(sensor: Sensor, xy: np.ndarray) -> np.ndarray:
    """(N, 2) pixel coordinates of normalised rays ``xy`` (N, 2) through ``sensor``'s lens
    (the camera model's own forward map where it has one: every lens model)."""
    if callable(getattr(sensor, "project", None)):
        return np.asarray(
            sensor.project(np.concatenate([xy, np.ones((len(xy), 1))], 1)), np.float64
        )[:, :2]
    if sensor.is_pinhole:
        K = sensor.K
        return np.stack(
            [K[0, 0] * xy[:, 0] + K[0, 1] * xy[:, 1] + K[0, 2], K[1, 1] * xy[:, 1] + K[1, 2]], 1
        )
    return lens_project(xy, sensor.K, sensor.dist)


def same_grid(a: Sensor, b: Sensor) -> bool:
    return a.size == b.size and np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)


def silhouettes(instance: np.ndarray) -> tuple[np.ndarray, int]:
    """(H, W) bool: pixels with another instance among their 8 neighbours; and the contour
    length in pixels (4-neighbour pairs whose instances differ)."""
    p = np.pad(instance, 1, mode="edge")
    H, W = instance.shape
    band = np.zeros((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            band |= p[1 + dy : 1 + dy + H, 1 + dx : 1 + dx + W] != instance
    length = int(
        (instance[:, 1:] != instance[:, :-1]).sum() + (instance[1:] != instance[:-1]).sum()
    )
    return band, length


def _interp_depth(
    ref: dict, u: np.ndarray, v: np.ndarray, iu: np.ndarray, iv: np.ndarray, with_mask: bool = False
):
    """Reference depth at (u, v): bilinear in 1/z over one surface, else the nearest pixel's
    (and, ``with_mask``, where it was one surface)."""
    D, I = ref["depth"], ref["instance"]
    H, W = D.shape
    u0 = np.clip(np.floor(u).astype(np.intp), 0, W - 2)
    v0 = np.clip(np.floor(v).astype(np.intp), 0, H - 2)
    fu, fv = np.clip(u - u0, 0, 1), np.clip(v - v0, 0, 1)
    quad = [(v0, u0), (v0, u0 + 1), (v0 + 1, u0), (v0 + 1, u0 + 1)]
    ids = [I[q] for q in quad]
    zs = [D[q].astype(np.float64) for q in quad]
    one = np.ones_like(fu, bool)
    z_lo, z_hi = np.minimum.reduce(zs), np.maximum.reduce(zs)
    one &= z_hi <= z_lo * (1 + STEP)  # one surface: no depth step between the four
    for i, z in zip(ids, zs):
        one &= (i == I[iv, iu]) & (z > 0)
    w = [(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv]
    inv = sum(wk / np.where(z > 0, z, 1.0) for wk, z in zip(w, zs))
    out = np.where(one, 1.0 / np.maximum(inv, 1e-12), D[iv, iu])
    return (out, one) if with_mask else out


def surface_probes(ref: dict, ref_sensor: Sensor, n: int = 0) -> np.ndarray:
    """(M, 3) camera-frame points of the reference surface at ``n`` (default
    ``SAMPLING_PROBES``) places drawn uniformly inside its valid pixels, with a generator of
    fixed seed (the same probes for every row); places whose four neighbouring pixels are not
    one surface are left out."""
    n = n or SAMPLING_PROBES
    D = ref["depth"]
    H, W = D.shape
    rng = np.random.default_rng(0)
    u = rng.uniform(0, W - 1, n)
    v = rng.uniform(0, H - 1, n)
    iu, iv = np.rint(u).astype(np.intp), np.rint(v).astype(np.intp)
    zi, ok = _interp_depth(ref, u, v, iu, iv, with_mask=True)
    u0 = np.minimum(np.floor(u).astype(np.intp), W - 2)
    v0 = np.minimum(np.floor(v).astype(np.intp), H - 2)
    R = pixel_rays(ref_sensor)
    fu, fv = (u - u0)[:, None], (v - v0)[:, None]
    xy = (
        (1 - fu) * (1 - fv) * R[v0, u0]
        + fu * (1 - fv) * R[v0, u0 + 1]
        + (1 - fu) * fv * R[v0 + 1, u0]
        + fu * fv * R[v0 + 1, u0 + 1]
    )
    pts = np.concatenate([xy, np.ones((n, 1))], 1) * zi[:, None]
    return pts[ok & np.isfinite(pts).all(1)]


def compare(frame: Frame, ref: dict, ref_sensor: Sensor) -> dict:
    """The errors of ``frame`` against ``ref`` (see the module docstring)."""
    grid = same_grid(frame.sensor, ref_sensor)
    H, W = ref_sensor.height, ref_sensor.width
    valid = frame.depth > 0
    z = frame.depth[valid].astype(np.float64)
    rays = pixel_rays(frame.sensor)[valid]
    if grid:
        iv, iu = np.nonzero(valid)
        inside = np.ones(len(z), bool)
        u, v = iu.astype(np.float64), iv.astype(np.float64)
    else:
        uv = project(ref_sensor, rays)
        u, v = uv[:, 0], uv[:, 1]
        iu, iv = np.rint(u), np.rint(v)
        inside = np.isfinite(u) & np.isfinite(v) & (iu >= 0) & (iu < W) & (iv >= 0) & (iv < H)
        iu = np.where(inside, iu, 0).astype(np.intp)
        iv = np.where(inside, iv, 0).astype(np.intp)
    zr_near = ref["depth"][iv, iu]
    ok = inside & (zr_near > 0)
    zr = zr_near.astype(np.float64) if grid else _interp_depth(ref, u, v, iu, iv)
    dz = z - zr
    agree = ok & (ref["instance"][iv, iu] == frame.instance[valid])
    adz = np.abs(dz[agree]) * 1e3
    d = np.concatenate([rays, np.ones((len(rays), 1))], 1)
    p2s = np.abs(dz * (d * ref["normal"][iv, iu]).sum(1))[ok] * 1e3

    # ids on the reference grid
    if grid:
        fi, fs, fv = frame.instance, frame.semantic, valid
    else:
        rr = pixel_rays(ref_sensor).reshape(-1, 2)
        uv = project(frame.sensor, rr)
        fu, fvv = np.rint(uv[:, 0]), np.rint(uv[:, 1])
        ins = (
            np.isfinite(fu)
            & np.isfinite(fvv)
            & (fu >= 0)
            & (fu < frame.sensor.width)
            & (fvv >= 0)
            & (fvv < frame.sensor.height)
        )
        fu = np.where(ins, fu, 0).astype(np.intp)
        fvv = np.where(ins, fvv, 0).astype(np.intp)
        fi = np.where(ins, frame.instance[fvv, fu], 0).reshape(H, W)
        fs = np.where(ins, frame.semantic[fvv, fu], 0).reshape(H, W)
        fv = np.where(ins, valid[fvv, fu], False).reshape(H, W)
    rvalid = ref["depth"] > 0
    union = rvalid | fv
    ri = np.where(rvalid, ref["instance"], 0)
    rs = np.where(rvalid, ref["semantic"], 0)
    fi = np.where(fv, fi, 0)
    fs = np.where(fv, fs, 0)
    miss_i = (ri != fi) & union
    miss_s = ((rs != fs) | (rvalid != fv)) & union
    band, length = silhouettes(ri)
    n_union = max(int(union.sum()), 1)
    n_band = max(int((band & union).sum()), 1)

    # how finely the cloud samples the surfaces: from points of the reference surface at
    # random places inside its pixels (never on any one pixel grid) to the nearest point
    gap = np.zeros(0)
    if len(z):
        probe = surface_probes(ref, ref_sensor)
        if len(probe):
            pts = np.concatenate([rays, np.ones((len(rays), 1))], 1) * z[:, None]
            gap = cKDTree(pts).query(probe)[0] * 1e3

    def pct(a: np.ndarray, q: float) -> float:
        return float(np.percentile(a, q)) if a.size else 0.0

    return {
        "depth_median_mm": pct(adz, 50),
        "depth_p99_mm": pct(adz, 99),
        "p2s_mean_mm": float(p2s.mean()) if p2s.size else 0.0,
        "p2s_p99_mm": pct(p2s, 99),
        "id_pct": 100.0 * miss_i.sum() / n_union,
        "semantic_pct": 100.0 * miss_s.sum() / n_union,
        "silhouette_pct": 100.0 * (miss_i & band).sum() / n_band,
        "edge_px": float(miss_i.sum() / max(length, 1)),
        "sampling_mm": pct(gap, 50),
        "valid_ratio": float(
            valid.sum()
            / max(int(rvalid.sum()), 1)
            * (ref_sensor.width * ref_sensor.height)
            / (frame.sensor.width * frame.sensor.height)
        ),
        "points": int(valid.sum()),
    }


def pool(parts: list[dict]) -> dict:
    """Errors over several cameras: the mean of each figure (points summed)."""
    out = {k: float(np.mean([p[k] for p in parts])) for k in parts[0] if k != "points"}
    out["points"] = int(sum(p["points"] for p in parts))
    return out


def noise_check(
    effect, frames: list[Frame], *, rng: np.random.Generator, bins: int = 4
) -> list[dict]:
    """The measured σ of ``effect`` (a depth-noise model with ``sigma``) against the model's, in
    ``bins`` depth bins of equal pixel count over ``frames`` (ideal frames with normals).

    Returns per bin: ``z_m`` (median depth), ``measured_mm`` (std of the residual),
    ``model_mm`` (RMS of the model's σ over the bin's pixels), ``pixels``. A distribution
    check, never a per-pixel one."""
    res, zs, model = [], [], []
    for f in frames:
        noisy = effect.apply(f, rng=rng)
        both = (f.depth > 0) & (noisy.depth > 0)
        z = f.depth[both].astype(np.float64)
        theta = incidence_angle(f)[both] if getattr(effect, "needs_normals", False) else None
        res.append(noisy.depth[both].astype(np.float64) - z)
        zs.append(z)
        model.append(effect.sigma(z, f.sensor.fx, theta, f.sensor))
    r, z, m = np.concatenate(res), np.concatenate(zs), np.concatenate(model)
    if not z.size:
        return []
    edges = np.quantile(z, np.linspace(0, 1, bins + 1))
    out = []
    for k in range(bins):
        sel = (z >= edges[k]) & ((z < edges[k + 1]) if k < bins - 1 else (z <= edges[k + 1]))
        if sel.sum() < 50:
            continue
        out.append(
            {
                "z_m": float(np.median(z[sel])),
                "measured_mm": 1e3 * float(np.std(r[sel])),
                "model_mm": 1e3 * float(np.sqrt(np.mean(m[sel] ** 2))),
                "pixels": int(sel.sum()),
            }
        )
    return out
