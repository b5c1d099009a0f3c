"""The GL raster's read-back: a drawn frame's targets into the frame's arrays.

:class:`FrameJob` is one frame on its way through the GL raster: planned (culled, its draws
written), issued, fetched, finished (:class:`~genie_gl.render.gl.renderer.GLRenderer`).
:class:`Readout` is the half of :class:`~genie_gl.render.gl.renderer.GLRenderer` that reads
a frame back once it is drawn: which targets a frame reads (the packed depth and ids, or three
targets; colour, normals, the pixel's triangle), read at once or through pixel buffer objects
(``readback="pbo"``), unpacked by :func:`~genie_gl.render.gl.readback.unpack` with the sensor's
range applied, window depth turned into metres for the GL depth modes, and the
:class:`~genie_gl.frame.Frame` made (:func:`~genie_gl.render.shading.to_frame`). The GL
raster's fragments are its targets as its shader wrote them (depth and instance id packed,
colour, normals, the triangle target): decoding them here, with the sensor's range rule of
:mod:`genie_gl.render.shading`, keeps the GL raster's bytes. It works on the renderer's state
(its context, targets, semantic table and options) and on the job it is handed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import RenderError
from ...frame import Frame
from ...sensors.camera import Sensor
from ..fragments import DrawnTriangles
from ..memory import frame_buffers
from ..shading import to_frame
from .readback import unpack

_BYTES = {"f1": 1, "u2": 2, "u4": 4, "f4": 4}


@dataclass(eq=False)
class FrameJob:
    """One frame of the GL raster, from its plan to its Frame.

    Attributes
    ----------
    sensor, pose : what it draws (pose: (4, 4) float64 world_from_camera).
    color, normals : whether its colour and normal targets are drawn.
    slot : its set of targets (0: :meth:`render`; 1, 2: alternate frames of :meth:`frames`).
    fbo, extra : its framebuffer, and the 24-bit depth pass's (framebuffer, texture) or [].
    program : the geometry program it draws with (until issued).
    proj : (proj_x, proj_y), its clip coefficients
        (:func:`~genie_gl.render.projection.clip_coefficients`).
    lists : [(draw commands, back-face culling)] (until issued).
    culled : whether it draws from the culled index buffer.
    drawn_triangles : what turns its triangle target into vertices, or None (not asked for).
    triangles, simplified, occluded : triangles drawn, instances drawn simplified, whether it
        was occlusion-culled (its stats).
    t0, t1 : when planning began and ended (perf_counter s).
    fbo24 : the 24-bit depth pass's framebuffer once issued with that precision, else None.
    drawn : instances drawn (once issued).
    t_issue : when it was issued.
    pbo : readback="pbo": its pixel buffer objects, read into at issue.
    out : the frame's arrays once fetched (until finished).
    t2, fetch_s : when the fetch began, and how long it took.
    """

    sensor: Sensor
    pose: np.ndarray
    color: bool
    normals: bool
    slot: int
    fbo: Any
    extra: list
    program: Any
    proj: tuple[np.ndarray, np.ndarray]
    lists: list | None
    culled: bool
    drawn_triangles: DrawnTriangles | None
    triangles: int
    simplified: int
    occluded: bool
    t0: float
    t1: float
    fbo24: Any = None
    drawn: int = 0
    t_issue: float = 0.0
    pbo: list | None = None
    out: dict | None = None
    t2: float = 0.0
    fetch_s: float = 0.0

    def take_out(self) -> dict:
        """The fetched arrays, handed over once (the job keeps no reference)."""
        out, self.out = self.out, None
        return out


class Readout:
    """The renderer's read-back methods (a mix-in of
    :class:`~genie_gl.render.renderer.Renderer`)."""

    def _reads(self, job: FrameJob) -> list[tuple[int, int, str, str]]:
        """(attachment, components, dtype, name) of every read of a frame; attachment -1 is
        the depth buffer (of the 24-bit pass when there is one)."""
        color, normals = job.color, job.normals
        linear = self.depth_precision == "float32"
        reads = [] if linear else [(-1, 1, "f4", "depth")]
        if self._packed:
            reads.append((0, 2, "u4", "packed"))
            at = 1
        else:
            reads += ([(0, 1, "f4", "depth")] if linear else []) + [
                (1, 1, "u4", "instance"),
                (2, 1, "u2", "semantic"),
            ]
            at = 3
        if color:  # RGBA is read as stored (a 3-component read converts: 7x slower)
            reads.append((at, 4, "f1", "rgba"))
        if normals:
            reads.append((at + 1, 3, "f4", "normal"))  # the colour target is there, used or not
        if job.drawn_triangles is not None:
            reads.append((at + (2 if normals else 1 if color else 0), 2, "u4", "primitive"))
        return reads

    def _start_read(self, job: FrameJob) -> None:
        """readback="pbo": copy the frame's targets into its pixel buffer objects now."""
        W, H = job.sensor.width, job.sensor.height
        job.pbo = []
        for k, (att, comps, dtype, _) in enumerate(self._reads(job)):
            source = job.fbo24 if att < 0 and job.fbo24 is not None else job.fbo
            key = (id(job.fbo), k, comps, dtype)
            if key not in self._pbos:
                self._pbos[key] = self.ctx.buffer(reserve=W * H * comps * _BYTES[dtype])
            source.read_into(self._pbos[key], components=comps, attachment=att, dtype=dtype)
            job.pbo.append(self._pbos[key])

    def _scratch(self, H: int, W: int, slot: int = 0) -> np.ndarray:
        """The packed target's read-back buffer of target set ``slot`` (a frame's is unpacked
        before its slot draws again, so one per slot and size)."""
        bufs = self.__dict__.setdefault("_packed_bufs", {})
        buf = bufs.get(slot)
        if buf is None or buf.shape[:2] != (H, W):
            buf = bufs[slot] = np.empty((H, W, 2), np.uint32)
        return buf

    def _read(self, job: FrameJob, finish: bool = False) -> Frame:
        """Read a drawn frame back (waits for its rasterisation) and make the Frame."""
        self._fetch(job, finish)
        return self._finish(job)

    def _fetch(self, job: FrameJob, finish: bool = False) -> None:
        """The GL half of a read-back: wait for the frame's rasterisation and copy its targets
        into the frame's arrays (``job.out``). :meth:`_finish` makes the Frame from them,
        with no GL call: :meth:`Renderer.frames` runs it while the next frame rasterises."""
        ctx, sensor, color, normals = self.ctx, job.sensor, job.color, job.normals
        W, H = sensor.width, sensor.height
        if finish:
            ctx.finish()  # so that the read-back time below is the copy alone
        t2 = time.perf_counter()
        want_triangles = job.drawn_triangles is not None
        out = frame_buffers(H, W, color, normals, want_triangles)
        if self._packed:
            out["packed"] = self._scratch(H, W, job.slot)
        pbos = job.pbo
        for k, (att, comps, dtype, name) in enumerate(self._reads(job)):
            if pbos is not None:
                pbos[k].read_into(out[name])
            else:
                source = job.fbo24 if att < 0 and job.fbo24 is not None else job.fbo
                source.read_into(out[name], components=comps, attachment=att, dtype=dtype)
        err = ctx.error
        if err != "GL_NO_ERROR":
            raise RenderError(f"OpenGL error after rendering: {err}")
        job.out, job.t2, job.fetch_s = out, t2, time.perf_counter() - t2

    def _finish(self, job: FrameJob) -> Frame:
        """The CPU half of a read-back (after :meth:`_fetch`): the packed pixels unpacked, the
        sensor's range applied, depth in metres; the Frame."""
        t_unpack = time.perf_counter()
        sensor, color, normals, out, t2 = (
            job.sensor,
            job.color,
            job.normals,
            job.take_out(),
            job.t2,
        )
        linear = self.depth_precision == "float32"
        want_triangles = job.drawn_triangles is not None
        depth, instance, semantic = out["depth"], out["instance"], out["semantic"]
        rgb = out["rgba"][..., :3] if color else None
        normal = out["normal"] if normals else None
        emptied = 0
        if self._packed:  # ids, semantic ids and (linear) depth with the range applied, in one pass
            emptied = unpack(
                out["packed"],
                self._semantics,
                depth if linear else None,
                instance,
                semantic,
                sensor.near_m,
                sensor.far_m,
            )
        if not linear:
            self._linearise(depth, instance, sensor)
        t3 = time.perf_counter()
        if self._packed and linear:
            if emptied and (rgb is not None or normal is not None):
                beyond = instance == 0
                beyond &= out["packed"][..., 1] != 0
                if rgb is not None:
                    rgb[beyond] = 0
                if normal is not None:
                    normal[beyond] = 0
        else:
            half = np.float32(0.5 * sensor.near_m)
            too_near = np.abs(depth - half) < half if job.drawn else None  # 0 < depth < near_m
            if job.drawn and (float(depth.max()) > sensor.far_m or too_near.any()):
                # infinite-far projection, near plane below the range: the range is applied here
                beyond = (depth > sensor.far_m) | too_near
                depth[beyond] = 0
                instance[beyond] = 0
                semantic[beyond] = 0
                if rgb is not None:
                    rgb[beyond] = 0
                if normal is not None:
                    normal[beyond] = 0
        t0, t1 = job.t0, job.t1
        self.stats = {
            "cull_s": t1 - t0,
            "draw_s": t2 - job.t_issue,
            "readback_s": job.fetch_s + (t3 - t_unpack),
            "instances_drawn": job.drawn,
            "triangles_drawn": job.triangles,
            "instances_simplified": job.simplified,
            "occlusion_culled": job.occluded,
        }
        return to_frame(
            out,
            sensor,
            job.pose,
            color,
            normals,
            job.drawn_triangles,
            self._triangle_scene() if want_triangles else None,
            self._clip_near(sensor),
            1e3 * (time.perf_counter() - t0),
        )

    def _linearise(self, depth: np.ndarray, instance: np.ndarray, sensor: Sensor) -> None:
        """Window depth read back into ``depth`` -> z in metres (0 where no instance)."""
        n = np.float64(self._clip_near(sensor))
        d = depth.astype(np.float64)
        hit = instance != 0
        if self.depth_precision == "reversed_z":  # d = near / z
            z = np.divide(n, d, out=np.zeros_like(d), where=hit & (d > 0))
        else:  # d = A + B / z with A = f / (f - n), B = -f n / (f - n)
            f = np.float64(sensor.far_m)
            z = np.divide(f * n, f - d * (f - n), out=np.zeros_like(d), where=hit & (d < 1))
        depth[...] = z
