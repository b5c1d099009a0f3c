"""The CPU raster's renderer: a frame's instances drawn by the exact CPU raster, no GL.

:class:`CPURenderer` is what ``Renderer(scene, raster="cpu")`` makes. Per frame: the
instances in view (:mod:`genie_gl.render.visibility`), drawn by
:meth:`~genie_gl.render.cpu.raster.Rasteriser.draw` into the frame's
:class:`~genie_gl.render.fragments.Fragments` (the winner of each pixel is decided in
:func:`genie_gl.render.cpu.coverage._wins`: the nearest float64 depth, ties to the lower
(instance slot, face)), shaded by :func:`genie_gl.render.shading.shade`.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Collection, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from itertools import chain, islice

import numba
import numpy as np

from ...frame import Frame
from ...limits import BYTES_PER_PIXEL, MAX_SIDE, check_frame_side, check_memory, memory_limit_bytes
from ...sensors.camera import Sensor
from ...validation.arguments import check_pose
from ..fragments import Fragments, no_triangles
from ..memory import frame_buffers
from ..renderer import Renderer
from ..shading import FrameArrays, MeshArrays, SlotShading, shade, shade_rays, to_frame
from ...lens.distortion import lens_views
from .bins import lens_samples, unserved
from .raster import Rasteriser

# the CPU raster's 1 / z (float64) and slot << 32 | face (int64) per pixel
CPU_RASTER_BYTES_PER_PIXEL = 16
# at most this many bytes of raster buffers for frames drawn side by side (one set a frame)
SIDE_BY_SIDE_BYTES = 256 << 20
# frames handed out at once per thread when frames are drawn side by side: two, so that a
# thread never waits for another's heavier frame before it starts one
AHEAD = 2


class CPURenderer(Renderer, raster="cpu"):
    """The exact CPU raster's :class:`~genie_gl.render.renderer.Renderer` (see there;
    ``depth_precision``, ``targets`` and ``readback`` do not apply; ``cull=False`` tests
    every triangle at every pixel centre of its box: the reference the culled frame equals
    byte for byte, slow). No GL context: usable from any thread.

    It also draws a distorted sensor's frame directly (:attr:`draws_lenses`): each pixel's
    own ray, binned on the pinhole views that hold the lens's rays
    (:func:`genie_gl.lens.distortion.lens_views`), is intersected by the same kernel and the
    same winner rule as a pixel centre (:meth:`_lens_frame`); no view is rendered and
    resampled."""

    draws_lenses = True

    def _uploaded(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._rasteriser = Rasteriser(self._culler)
        self._side: list[Rasteriser] = []  # free twins, for frames drawn side by side
        self._sizes_checked: set[tuple[int, int]] = set()  # sizes found room for

    def _frame(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        triangles: bool,
    ) -> Frame:
        """A frame drawn by the CPU raster (:meth:`_draw`, on every thread numba has)."""
        frame, self.stats = self._draw(
            sensor, pose, color, normals, only, triangles, self._rasteriser, False
        )
        return frame

    def _draw(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        triangles: bool,
        rasteriser: Rasteriser,
        serial: bool,
    ) -> tuple[Frame, dict]:
        """A frame drawn by the CPU raster, and its stats: the instances in view
        (:meth:`_visible`), their clusters drawn into the frame's winners by ``rasteriser``
        (:meth:`Rasteriser.draw`; ``serial``: on this thread alone), the winners shaded
        (:func:`~genie_gl.render.shading.shade`; a frame of depth and ids alone is shaded
        strip by strip as it is drawn). A distorted sensor: :meth:`_lens_frame`."""
        t0 = time.perf_counter()
        W, H, K = sensor.width, sensor.height, sensor.K
        pose = check_pose(pose, "render pose")
        self._check_size(W, H)
        if not sensor.is_pinhole:
            return self._lens_frame(sensor, pose, color, normals, only, t0, rasteriser, serial)
        near = float(sensor.clip_near_m)
        out = frame_buffers(H, W, color, normals, triangles)
        seen = self._visible(pose, K, W, H, near, only)
        drawn_triangles = no_triangles(self._ids, self._semantic) if triangles else None
        fragments = Fragments(H, W, None, None, out)
        drawn = faces = simplified = 0
        face0 = np.zeros(len(self._mesh), np.int64)
        cfm = np.zeros((max(1, len(self._mesh)), 3, 4))
        if seen is not None:
            cfm, slots, m = seen.camera_from_model, seen.slots, seen.mesh
            r = rasteriser
            ids_only = not (color or normals or triangles) and H * W > 1
            inverse_z, winner = r.draw(
                slots,
                m,
                seen.backcull,
                cfm,
                seen.eye,
                self._det[slots],
                K,
                W,
                H,
                near,
                seen.planes,
                self.cull,
                (self._ids, self._semantic, sensor.near_m, sensor.far_m, out) if ids_only else None,
                serial=serial,
            )
            fragments = Fragments(H, W, inverse_z, winner, out, shaded=ids_only)
            face0[slots] = self._fbase[m]
            drawn, faces, simplified = len(slots), int(self._nfaces[m].sum()), seen.simplified
            if triangles:
                d = drawn_triangles
                d.first[slots], d.count[slots], d.base_vertex[slots], d.backcull[slots] = (
                    self._fbase[m],
                    self._nfaces[m],
                    self._vbase[m],
                    seen.backcull,
                )
                d.mesh_first[slots], d.mesh_count[slots] = self._fbase[m], self._nfaces[m]
                drawn_triangles = d._replace(
                    camera_from_model=cfm, indices=self._culler.faces.reshape(-1)
                )
        t1 = time.perf_counter()
        rgb = self._colour if len(self._mesh) else np.zeros((1, 3), np.uint8)
        if not fragments.shaded:  # (a frame of depth and ids alone was filled as it was drawn)
            shade(
                fragments,
                self._culler.vertices,
                self._culler.faces,
                rasteriser.face_vbase(self._vbase, self._fbase, self._nfaces),
                cfm,
                self._ids,
                self._semantic,
                rgb,
                face0,
                K,
                sensor.near_m,
                sensor.far_m,
            )
        t2 = time.perf_counter()
        stats = {
            "cull_s": 0.0,
            "draw_s": t1 - t0,
            "readback_s": t2 - t1,
            "instances_drawn": drawn,
            "triangles_drawn": faces,
            "instances_simplified": simplified,
            "occlusion_culled": False,
        }
        return to_frame(
            out,
            sensor,
            pose,
            color,
            normals,
            drawn_triangles,
            self._triangle_scene() if triangles else None,
            near,
            1e3 * (t2 - t0),
        ), stats

    def _check_size(self, W: int, H: int) -> None:
        """Refuse a frame larger than genie-gl draws or than memory holds (once per size)."""
        if (W, H) in self._sizes_checked:
            return
        check_frame_side(W, H, "Renderer", MAX_SIDE, "the largest frame genie-gl draws")
        # the raster's buffers (1 / z float64, slot and face int64) and the frame's arrays
        check_memory(
            W * H * (CPU_RASTER_BYTES_PER_PIXEL + BYTES_PER_PIXEL),
            memory_limit_bytes(),
            f"a {W}x{H} px frame x {CPU_RASTER_BYTES_PER_PIXEL + BYTES_PER_PIXEL} B",
            "Renderer: use a smaller sensor",
            option=None,
        )
        self._sizes_checked.add((W, H))

    def _lens_frame(
        self,
        sensor: Sensor,
        pose: np.ndarray,
        color: bool,
        normals: bool,
        only: Collection[int] | None,
        t0: float,
        rasteriser: Rasteriser,
        serial: bool,
    ) -> tuple[Frame, dict]:
        """A distorted sensor's frame, each pixel's own ray drawn exactly: per pinhole view
        that holds some of the lens's rays (one for a lens one view can hold, cube faces for a
        fisheye), the instances that view sees, drawn by :meth:`Rasteriser.draw` against the
        rays binned on a grid of its frame (:func:`~genie_gl.render.cpu.bins.lens_samples`),
        then shaded along the same rays (:func:`~genie_gl.render.shading.shade_rays`). Depth
        is the camera's z; surfaces nearer than ``near_m`` or farther than ``far_m`` give no
        return; normals in the camera frame.
        Returns the frame and its stats, drawn by ``rasteriser`` on every thread numba has
        or, with ``serial``, on this thread alone.
        """
        W, H = sensor.width, sensor.height
        out = frame_buffers(H, W, color, normals)
        views = lens_views(sensor, oversample=1.0)
        for a in out.values():  # the pixels without a ray (past a fisheye's fold) hold nothing
            a.reshape(H * W, -1)[unserved(views)] = 0
        arrays = FrameArrays(
            out["depth"].reshape(-1),
            out["instance"].reshape(-1),
            out["semantic"].reshape(-1),
            out["rgba"].reshape(-1, 4) if color else np.zeros((1, 4), np.uint8),
            out["normal"].reshape(-1, 3) if normals else np.zeros((1, 3), np.float32),
            np.zeros((1, 2), np.uint32),
        )
        drawn = faces = simplified = 0
        r = rasteriser
        colours = self._colour if len(self._mesh) else np.zeros((1, 3), np.uint8)
        face_vbase = r.face_vbase(self._vbase, self._fbase, self._nfaces)
        near = float(sensor.clip_near_m)
        for m in views:
            ls = lens_samples(m)
            Kg, Wg, Hg = ls.grid
            view_pose = pose.copy()
            view_pose[:3, :3] = pose[:3, :3] @ m.rotation
            seen = self._visible(view_pose, Kg, Wg, Hg, near, only)
            if seen is None:
                inverse_z = np.zeros(len(ls.pixel))
                winner = np.zeros(len(ls.pixel), np.int64)
                cfm, face0 = np.zeros((max(1, len(self._mesh)), 3, 4)), np.zeros(1, np.int64)
            else:
                inverse_z, winner = r.draw(
                    seen.slots,
                    seen.mesh,
                    seen.backcull,
                    seen.camera_from_model,
                    seen.eye,
                    self._det[seen.slots],
                    Kg,
                    Wg,
                    Hg,
                    near,
                    seen.planes,
                    self.cull,
                    samples=ls.samples,
                    serial=serial,
                )
                cfm = seen.camera_from_model
                face0 = np.zeros(len(self._mesh), np.int64)
                face0[seen.slots] = self._fbase[seen.mesh]
                drawn += len(seen.slots)
                faces += int(self._nfaces[seen.mesh].sum())
                simplified += seen.simplified
            if ls.z_scale is not None:  # a cube face's z is not the camera's
                inverse_z = inverse_z / ls.z_scale
            shade_rays(
                inverse_z,
                winner,
                MeshArrays(self._culler.vertices, self._culler.faces, face_vbase),
                SlotShading(cfm, self._ids, self._semantic, colours, face0),
                (m.ray_x.reshape(-1), m.ray_y.reshape(-1)),
                ls.ray_of,
                ls.pixel,
                W,
                sensor.near_m,
                sensor.far_m,
                arrays,
                color,
                normals,
                serial,
            )
            if normals and ls.z_scale is not None:  # the view's frame to the camera's
                nv = arrays.normal[ls.pixel]
                arrays.normal[ls.pixel] = (nv @ m.rotation.T).astype(np.float32)
        t2 = time.perf_counter()
        stats = {
            "cull_s": 0.0,
            "draw_s": t2 - t0,
            "readback_s": 0.0,
            "instances_drawn": drawn,
            "triangles_drawn": faces,
            "instances_simplified": simplified,
            "occlusion_culled": False,
        }
        frame = to_frame(out, sensor, pose, color, normals, None, None, near, 1e3 * (t2 - t0))
        meta = {**frame.meta, "lens_views": len(views), "resample": "exact"}
        return frame.replace(meta=meta), stats

    def _frames(
        self,
        sensor: Sensor,
        poses: Iterable[np.ndarray],
        color: bool,
        normals: bool,
        only: Sequence[Collection[int] | None] | None,
        triangles: bool,
    ) -> Iterator[Frame]:
        """The frames in order. Frames of depth and ids alone, two or more, with two or more
        threads for numba (:func:`numba.get_num_threads`), a pinhole's or a lens's (its
        rays drawn by :meth:`_lens_frame`): drawn side by side, one frame per
        thread, each on its thread alone with a rasteriser of its own, while the caller takes
        the frames before them: a light frame leaves most of its strips' threads idle, and
        each frame is the same whichever thread draws it (:mod:`.raster`). Up to
        :data:`AHEAD` frames a thread are handed out at once (frame k by rasteriser k mod
        their number), so a thread that ends a light frame starts the next while another
        draws a heavy one; no more than :data:`SIDE_BY_SIDE_BYTES` of raster buffers. Otherwise each
        frame is drawn, on every thread, when it is asked for. ``self.stats``: the last
        frame handed over's."""
        room = SIDE_BY_SIDE_BYTES // (sensor.width * sensor.height * CPU_RASTER_BYTES_PER_PIXEL)
        threads = min(numba.get_num_threads(), room)
        ahead = min(AHEAD * threads, room)  # frames handed out at once
        poses = iter(poses)
        head = list(islice(poses, 2))
        if (
            color
            or normals
            or triangles
            or threads < 2
            or len(head) < 2
            or sensor.width * sensor.height < 2  # (shaded after drawing, on every thread)
        ):
            for k, pose in enumerate(chain(head, poses)):
                yield self._frame(
                    sensor, pose, color, normals, None if only is None else only[k], triangles
                )
            return
        # (taken while in use: frames of another generator of this renderer draw with others)
        side = [self._side.pop() if self._side else self._rasteriser.twin() for _ in range(ahead)]
        drawing: deque[Future] = deque()
        pool = ThreadPoolExecutor(threads, thread_name_prefix="genie-raster")
        try:
            for k, pose in enumerate(chain(head, poses)):
                done = None
                if len(drawing) == ahead:  # frame k - ahead, whose rasteriser k takes
                    done = drawing.popleft().result()
                drawing.append(
                    pool.submit(
                        self._draw,
                        sensor,
                        pose,
                        False,
                        False,
                        None if only is None else only[k],
                        False,
                        side[k % ahead],
                        True,
                    )
                )
                if done is not None:
                    frame, self.stats = done
                    yield frame
            while drawing:
                frame, self.stats = drawing.popleft().result()
                yield frame
        finally:  # (also for a caller that stops early: nothing more starts, what runs ends)
            for f in drawing:
                f.cancel()
            pool.shutdown(wait=True)
            self._side.extend(side)
