"""Time-of-flight physics: multipath from one indirect bounce, mixed pixels, phase
wrapping and low-albedo range loss.

An AMCW ToF camera (Kinect v2, Azure Kinect) measures the phase of its modulated light; a
pixel that receives light over several paths measures the phase of the *sum* of their
phasors. Everything here mixes in that phase domain, at the profile's modulation frequency
``frequency_mhz`` (a round trip of length L has phase 2π·f·L/c; the range is half the path).

* ``tof_multipath`` — one indirect bounce, computed from a reflective shadow map (Dachsbacher
  & Stamminger, "Reflective Shadow Maps", I3D 2005; as OpenGL ToF simulators do, e.g.
  Keller & Kolb, "Real-time simulation of time-of-flight sensors", SIMPAT 2009, and
  Meister et al., "Simulation of Time-of-Flight Sensors using Global Illumination", VMV
  2013): the illuminator sits beside the lens, so the scene seen from it is the camera's own
  render. ``samples`` pixels of it (a stratified grid, no random draw) become virtual point
  lights with the flux their pixel footprint receives, reflected by the surface's material
  (Lambertian albedo·(1 − metallic) plus a Phong lobe around the mirror direction, exponent
  2/roughness⁴ − 2, weighted by F0 = lerp(0.04, albedo, metallic)). Each pixel adds every
  light that faces it (both cosines > 0; occlusion between the two is ignored, as in RSMs)
  as a phasor of relative amplitude (indirect irradiance / direct irradiance) and extra path
  ΔL = r_Q + |Q − P| − r_P ≥ 0. While ΔL stays under half the modulation wavelength every
  phasor lies in the upper half plane, so the measured range only grows: multipath pushes
  depth away from the sensor, never closer. Two surfaces that do not face each other (one
  convex object) give exactly nothing.
* ``mixed_pixels`` — a pixel on a depth edge sees a share α ~ U(0, 1) of the near surface and
  1 − α of the far one; it reports the range of α·A_n·e^{iφ_n} + (1 − α)·A_f·e^{iφ_f}, with
  A = albedo / r² (the flying pixels of ToF cameras, which can land outside the gap once the
  path difference nears half a wavelength).
* ``ambiguity`` — a phase is known modulo 2π: a return beyond the ambiguity range c/(2f) of
  the (unwrapped) modulation is reported at r mod ambiguity_m when the device wraps, or
  dropped when its depth engine filters them.
* ``low_albedo`` — the return's signal falls as albedo/r²: a pixel returns only while
  albedo/r² ≥ ref_albedo/ref_range_m², the device's stated operating point (Azure Kinect: 15 %
  reflectivity at the NFOV range limit).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import ConfigError
from ..frame import Frame
from ..jit import njit
from . import kernels
from .base import Decision, Effect, View, drop, record
from .geometry import pixel_rays, surface_normals

C_M_PER_S = 299_792_458.0


def _ranges(frame: Frame) -> np.ndarray:
    """(H, W) float64 range (distance along the ray) of every pixel; 0 where no return."""
    xy = pixel_rays(frame.sensor)
    z = frame.depth.astype(np.float64)
    return z * np.sqrt(1.0 + xy[..., 0] ** 2 + xy[..., 1] ** 2)


def _with_range(frame: Frame, r_new: np.ndarray, r_old: np.ndarray, where: np.ndarray) -> Frame:
    z = frame.depth.astype(np.float64)
    out = z.copy()
    out[where] = z[where] * (r_new[where] / r_old[where])
    return frame.replace(depth=out.astype(np.float32))


@njit(cache=True, nogil=True)
def _phasor(
    px, py, pz, nx, ny, nz, rp, Q, NQ, rq, flux, rho, kd, ks, shine, cut, refl, k, min_d
):  # pragma: no cover - compiled
    """Indirect phasor (re, im) of the surface point P (normal n, range rp) relative to its
    direct return, summed over the lights Q (normals NQ, ranges rq; see the module docstring)."""
    cos_in = -(px * nx + py * ny + pz * nz) / rp
    scale = rp * rp / max(cos_in, 0.05)
    sr, si = 0.0, 0.0
    for j in range(Q.shape[0]):
        dx, dy, dz = Q[j, 0] - px, Q[j, 1] - py, Q[j, 2] - pz
        cos_p = nx * dx + ny * dy + nz * dz
        if cos_p <= 0.0:
            continue
        cos_q = -(NQ[j, 0] * dx + NQ[j, 1] * dy + NQ[j, 2] * dz)
        if cos_q <= 0.0:
            continue
        d2 = dx * dx + dy * dy + dz * dz
        if d2 < min_d * min_d:
            continue
        d = np.sqrt(d2)
        f = kd[j] * rho[j] * (1.0 / np.pi)
        c = -(refl[j, 0] * dx + refl[j, 1] * dy + refl[j, 2] * dz) / d
        if c > cut[j]:
            f += ks[j] * (shine[j] + 2.0) * (0.5 / np.pi) * np.exp(shine[j] * np.log(c))
        a = f * flux[j] * cos_q * cos_p / (d2 * d2) * scale
        dl = rq[j] + d - rp
        if dl < 0.0:
            dl = 0.0
        sr += a * np.cos(k * dl)
        si += a * np.sin(k * dl)
    return sr, si


@njit(cache=True, nogil=True)
def _multipath(
    depth, xy, normal, ids, stride, Q, NQ, rq, flux, rho, kd, ks, shine, cut, refl, k, min_d
):  # pragma: no cover - compiled
    """New depth (H, W) float32 with every pixel's range grown by its indirect light, and the
    number of pixels moved. One receiver per ``stride`` block (its centre) is shared by the
    block's pixels on its surface (same id, depth within 2 %, normals within ~18°); the others
    get their own."""
    H, W = depth.shape
    out = depth.copy()
    gh, gw = (H + stride - 1) // stride, (W + stride - 1) // stride
    centre = np.full((gh, gw), np.nan)
    half = stride // 2
    inv2k = 1.0 / (2.0 * k)
    moved = 0
    for v in range(H):
        for u in range(W):
            z = np.float64(depth[v, u])
            if z <= 0:
                continue
            x, y = xy[v, u, 0], xy[v, u, 1]
            ray = np.sqrt(1.0 + x * x + y * y)
            rp = z * ray
            nx, ny, nz = (
                np.float64(normal[v, u, 0]),
                np.float64(normal[v, u, 1]),
                np.float64(normal[v, u, 2]),
            )
            gv, gu = v // stride, u // stride
            cv, cu = min(gv * stride + half, H - 1), min(gu * stride + half, W - 1)
            zc = np.float64(depth[cv, cu])
            same = (
                zc > 0
                and ids[cv, cu] == ids[v, u]
                and abs(z - zc) <= 0.02 * zc
                and nx * normal[cv, cu, 0] + ny * normal[cv, cu, 1] + nz * normal[cv, cu, 2] >= 0.95
            )
            if same:
                dr = centre[gv, gu]
                if np.isnan(dr):
                    xc, yc = xy[cv, cu, 0], xy[cv, cu, 1]
                    sr, si = _phasor(
                        xc * zc,
                        yc * zc,
                        zc,
                        np.float64(normal[cv, cu, 0]),
                        np.float64(normal[cv, cu, 1]),
                        np.float64(normal[cv, cu, 2]),
                        zc * np.sqrt(1.0 + xc * xc + yc * yc),
                        Q,
                        NQ,
                        rq,
                        flux,
                        rho,
                        kd,
                        ks,
                        shine,
                        cut,
                        refl,
                        k,
                        min_d,
                    )
                    dr = np.arctan2(si, 1.0 + sr) * inv2k
                    centre[gv, gu] = dr
            else:
                sr, si = _phasor(
                    x * z,
                    y * z,
                    z,
                    nx,
                    ny,
                    nz,
                    rp,
                    Q,
                    NQ,
                    rq,
                    flux,
                    rho,
                    kd,
                    ks,
                    shine,
                    cut,
                    refl,
                    k,
                    min_d,
                )
                dr = np.arctan2(si, 1.0 + sr) * inv2k
            if dr != 0.0:
                new = np.float32(z * ((rp + dr) / rp))
                if new != depth[v, u]:
                    out[v, u] = new
                    moved += 1
    return out, moved


@dataclass
class TofMultipath(Effect):
    """One indirect bounce mixed in the phase domain (see the module docstring).

    Parameters
    ----------
    frequency_mhz : modulation frequency whose phase is mixed (the lowest of a multi-frequency
        device: the one its unwrapped range comes from).
    samples : virtual point lights taken from the reflective shadow map (accuracy knob).
    stride : the indirect light is computed at one pixel per ``stride`` x ``stride`` block
        and shared by the block's pixels that lie on the same surface (same instance, depth
        within 2 %, normals within 18°); every other pixel (edges, creases) gets its own.
        1: every pixel its own (accuracy knob).
    min_distance_m : lights nearer a pixel than this are left out (the integrand's
        singularity; the pixel's own surface).
    """

    name: ClassVar[str] = "tof_multipath"
    systematic_error: ClassVar[bool] = (
        True  # indirect light lengthens the range of a wall near a floor
    )
    needs_normals: ClassVar[bool] = True
    needs_materials: ClassVar[bool] = True
    needs_convexity: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 400.0
    accuracy_knobs: ClassVar[Mapping[str, str]] = {"multipath_samples": "samples"}
    frequency_mhz: float = 16.0
    samples: int = 32
    stride: int = 8
    min_distance_m: float = 0.02

    def __post_init__(self) -> None:
        if not self.frequency_mhz > 0:
            raise ConfigError(
                f"tof_multipath.frequency_mhz: expected > 0, got {self.frequency_mhz}"
            )
        if int(self.samples) < 1:
            raise ConfigError(f"tof_multipath.samples: expected >= 1, got {self.samples}")
        if int(self.stride) < 1:
            raise ConfigError(f"tof_multipath.stride: expected >= 1, got {self.stride}")

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if len(view.ids) == 1 and bool(view.convex[0]):
            return Decision(
                False, "one convex object in view: no surface faces another, no second bounce"
            )
        what = (
            "reflective material" if view.reflective.any() else "surfaces that may face each other"
        )
        return Decision(
            True, f"{what} in range ({len(view.ids)} objects): a second bounce can reach the sensor"
        )

    def lights(self, valid: np.ndarray) -> tuple[np.ndarray, float]:
        """Flat pixel indices of the virtual point lights (centres of a stratified grid, valid
        pixels only) and the pixels each stands for."""
        H, W = valid.shape
        cell = max(1, int(np.ceil(np.sqrt(H * W / int(self.samples)))))
        v, u = np.meshgrid(
            np.arange(cell // 2, H, cell), np.arange(cell // 2, W, cell), indexing="ij"
        )
        idx = (v * W + u).ravel()
        return idx[valid.ravel()[idx]], float(cell * cell)

    def multipath_depth(self, frame: Frame, materials: Any) -> tuple[np.ndarray, int]:
        """(H, W) float32 depth with the indirect bounce mixed in, and the pixels it moved."""
        valid = frame.depth > 0
        vpl, cell = self.lights(valid)
        if len(vpl) == 0:
            return frame.depth, 0
        xy = pixel_rays(frame.sensor)
        z = frame.depth.ravel()[vpl].astype(np.float64)
        x, y = xy.reshape(-1, 2)[vpl].T
        Q = np.stack([x * z, y * z, z], 1)
        rq = np.linalg.norm(Q, axis=1)
        nq = (
            frame.normal.reshape(-1, 3)[vpl].astype(np.float64)
            if frame.normal is not None
            else surface_normals(frame).reshape(-1, 3)[vpl]
        )
        rows = materials.rows(frame.instance.ravel()[vpl])
        rho = materials.albedo[rows]
        metal = materials.metallic[rows]
        rough = np.maximum(materials.roughness[rows], 0.05)
        kd = 1.0 - metal
        ks = 0.04 + (rho - 0.04) * metal
        shine = 2.0 / rough**4 - 2.0
        cut = np.exp(np.log(1e-4) / np.maximum(shine, 1e-6))
        incoming = Q / rq[:, None]
        refl = incoming - 2.0 * (incoming * nq).sum(1)[:, None] * nq
        f = frame.sensor.fx
        flux = (z / rq) ** 2 * cell / (f * f)
        k = 2 * np.pi * self.frequency_mhz * 1e6 / C_M_PER_S
        normal = (
            frame.normal if frame.normal is not None else surface_normals(frame).astype(np.float32)
        )
        return _multipath(
            frame.depth,
            xy,
            normal,
            frame.instance,
            int(self.stride),
            np.ascontiguousarray(Q),
            np.ascontiguousarray(nq),
            rq,
            flux,
            rho,
            kd,
            ks,
            shine,
            cut,
            np.ascontiguousarray(refl),
            k,
            float(self.min_distance_m),
        )

    def apply(self, frame: Frame, *, rng: np.random.Generator, materials: Any = None) -> Frame:
        if materials is None:
            raise ConfigError(
                "tof_multipath needs the scene's materials: run it through simulate()/capture()"
            )
        depth, moved = self.multipath_depth(frame, materials)
        if moved == 0:
            return record(frame, self.name, moved=0)
        return record(frame.replace(depth=depth), self.name, moved=int(moved))


@dataclass
class MixedPixels(Effect):
    """ToF flying pixels: edge pixels report the mixed phase of their two surfaces."""

    name: ClassVar[str] = "mixed_pixels"
    draws: ClassVar[bool] = True
    needs_materials: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 60.0
    frequency_mhz: float = 16.0
    jump_m: float = 0.05

    def __post_init__(self) -> None:
        if not self.jump_m > 0 or not self.frequency_mhz > 0:
            raise ConfigError(
                f"mixed_pixels: jump_m and frequency_mhz must be > 0 "
                f"(got {self.jump_m}, {self.frequency_mhz})"
            )

    def check(self, frame: Frame, **needs: Any) -> str | None:
        if kernels.has_step(frame.depth, float(self.jump_m)):
            return None
        return f"no depth step over {self.jump_m} m between neighbours"

    def apply(self, frame: Frame, *, rng: np.random.Generator, materials: Any = None) -> Frame:
        edge, nb = kernels.edge_pixels(frame.depth, float(self.jump_m))
        alpha = rng.random(edge.size)
        if edge.size == 0:
            return record(frame, self.name, mixed=0)
        r = _ranges(frame).ravel()
        rho = (
            np.full(r.shape, 0.5)
            if materials is None
            else materials.albedo[materials.rows(frame.instance.ravel())]
        )
        k = 2 * np.pi * self.frequency_mhz * 1e6 / C_M_PER_S
        a_self = alpha * rho[edge] / r[edge] ** 2
        a_nb = (1 - alpha) * rho[nb] / r[nb] ** 2
        dphi = 2 * k * (r[nb] - r[edge])
        shift = np.arctan2(a_nb * np.sin(dphi), a_self + a_nb * np.cos(dphi)) / (2 * k)
        z = frame.depth.astype(np.float64).ravel()
        z[edge] *= (r[edge] + shift) / r[edge]
        out = frame.replace(depth=np.maximum(z, 0).reshape(frame.depth.shape).astype(np.float32))
        return record(out, self.name, mixed=int(edge.size))


@dataclass
class Ambiguity(Effect):
    """Returns beyond the ambiguity range: reported at r mod ``ambiguity_m`` (``wrap``, up to
    ``max_wraps`` wraps; farther ones dropped) or dropped."""

    name: ClassVar[str] = "ambiguity"
    cost_ms_per_mpx: ClassVar[float] = 15.0
    ambiguity_m: float = 18.75
    wrap: bool = True
    max_wraps: int = 1

    def __post_init__(self) -> None:
        if not self.ambiguity_m > 0:
            raise ConfigError(f"ambiguity.ambiguity_m: expected > 0, got {self.ambiguity_m}")

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        if view.r_max <= self.ambiguity_m:
            return Decision(
                False, f"everything in view lies within the {self.ambiguity_m} m ambiguity range"
            )
        return None

    def check(self, frame: Frame, **needs: Any) -> str | None:
        if not (_ranges(frame) > self.ambiguity_m).any():
            return f"no return beyond the {self.ambiguity_m} m ambiguity range"
        return None

    def reach_m(self, sensor: Any) -> float | None:
        return self.ambiguity_m * (self.max_wraps + 1) if self.wrap else None

    def apply(self, frame: Frame, *, rng: np.random.Generator) -> Frame:
        r = _ranges(frame)
        beyond = r > self.ambiguity_m
        if not beyond.any():
            return frame
        if not self.wrap:
            return drop(frame, beyond)
        out = _with_range(frame, np.mod(r, self.ambiguity_m), r, beyond)
        # past max_wraps wraps the return is too weak to count (and the far plane is its reach)
        gone = beyond & (~(out.depth > 0) | (r > self.reach_m(frame.sensor)))
        return drop(out, gone) if gone.any() else out


@dataclass
class LowAlbedo(Effect):
    """No return where albedo / r² < ref_albedo / ref_range_m² (too little light comes back)."""

    name: ClassVar[str] = "low_albedo"
    needs_materials: ClassVar[bool] = True
    cost_ms_per_mpx: ClassVar[float] = 20.0
    ref_albedo: float = 0.15
    ref_range_m: float = 3.86

    def __post_init__(self) -> None:
        if not (0 < self.ref_albedo <= 1 and self.ref_range_m > 0):
            raise ConfigError(
                f"low_albedo: need 0 < ref_albedo <= 1 and ref_range_m > 0 "
                f"(got {self.ref_albedo}, {self.ref_range_m})"
            )

    @property
    def threshold(self) -> float:
        return self.ref_albedo / self.ref_range_m**2

    def plan(self, view: View) -> Decision | None:
        if view.empty:
            return Decision(False, "nothing in range or view")
        worst = float(view.albedo.min()) / max(view.r_max, 1e-9) ** 2
        if worst >= self.threshold:
            return Decision(
                False,
                f"darkest surface in view (albedo {view.albedo.min():.2f}) still returns "
                f"at {view.r_max:.2f} m",
            )
        return None

    def apply(self, frame: Frame, *, rng: np.random.Generator, materials: Any = None) -> Frame:
        if materials is None:
            raise ConfigError(
                "low_albedo needs the scene's materials: run it through simulate()/capture()"
            )
        albedo = materials.per_pixel(materials.albedo, frame.instance)
        lost, n = kernels.dim_returns(
            frame.depth, pixel_rays(frame.sensor), albedo, float(self.threshold)
        )
        out = drop(frame, lost) if n else frame
        return record(out, self.name, dropped=int(n))
