"""A reference renderer on pyrender, behind the same interface as :class:`Renderer`.

Used by the tests to cross-check ours and by ``genie bench render`` as a peer. It renders
pyrender's SEG mode (no multisampling, depth and segmentation together; its DEPTH_ONLY mode
multisamples and returns one sample's depth, millimetres off), with the conversions pyrender
needs: the OpenGL camera frame (y up, z backward) and pixel centres at +0.5 (pass cx + 0.5,
cy + 0.5 to its IntrinsicsCamera).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import trimesh

from ..errors import ConfigError
from ..frame import Frame
from ..scene.model import Scene
from ..sensors.camera import Sensor

GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])


def _id_color(i: int) -> tuple[int, int, int]:
    return (i & 0xFF, (i >> 8) & 0xFF, (i >> 16) & 0xFF)


class ReferenceRenderer:
    """pyrender-backed renderer of ideal pinhole depth, instance and semantic buffers.

    Instance ids must fit in 24 bits (they are encoded in pyrender's segmentation colours).
    """

    def __init__(self, scene: Scene, *, platform: str = "egl") -> None:
        # pyrender chooses its platform from this variable at import: the only way to ask.
        os.environ.setdefault("PYOPENGL_PLATFORM", platform)
        import pyrender  # noqa: PLC0415

        self._pyrender = pyrender
        self.scene = pyrender.Scene(bg_color=[0, 0, 0, 0], ambient_light=[1.0, 1.0, 1.0])
        self.seg_map: dict[Any, tuple[int, int, int]] = {}
        self.semantic_of: dict[int, int] = {0: 0}
        cache: dict[str, Any] = {}
        for inst in scene.instances:
            if inst.instance >= 1 << 24:
                raise ValueError(
                    f"reference renderer: instance id {inst.instance} needs more than 24 bits"
                )
            mesh = cache.get(inst.mesh)
            if mesh is None:
                m = scene.meshes[inst.mesh]
                tm = trimesh.Trimesh(m.vertices, m.faces, process=False)
                mesh = cache[inst.mesh] = pyrender.Mesh.from_trimesh(tm, smooth=False)
            node = self.scene.add(mesh, pose=inst.world_from_model)
            self.seg_map[node] = _id_color(inst.instance)
            self.semantic_of[inst.instance] = inst.semantic
        self._renderer = None
        self._size: tuple[int, int] | None = None
        self._cam_node = None

    def render(self, sensor: Sensor, pose: np.ndarray, **_: Any) -> Frame:
        """Depth (pyrender's linearised depth buffer), instance and semantic; no colour. A
        pinhole camera only: a sensor with a lens is refused (``gg.render`` renders it)."""
        if not sensor.is_pinhole:
            raise ConfigError(
                f"reference renderer: sensor {getattr(sensor, 'name', '')!r} has lens distortion "
                f"({sensor.model} model); "
                "it renders ideal pinhole cameras only (gg.render / Renderer.render render the "
                "lens)"
            )
        pr = self._pyrender
        if self._size != (sensor.width, sensor.height):
            self.release()
            self._renderer = pr.OffscreenRenderer(sensor.width, sensor.height)
            self._size = (sensor.width, sensor.height)
        cam = pr.IntrinsicsCamera(
            sensor.fx,
            sensor.fy,
            sensor.cx + 0.5,
            sensor.cy + 0.5,
            znear=sensor.near_m,
            zfar=sensor.far_m,
        )
        if self._cam_node is not None:
            self.scene.remove_node(self._cam_node)
        self._cam_node = self.scene.add(cam, pose=np.asarray(pose, float) @ GL_FROM_CV)
        color, depth = self._renderer.render(
            self.scene, flags=pr.RenderFlags.SEG, seg_node_map=self.seg_map
        )
        c = color.astype(np.uint32)
        instance = c[..., 0] | (c[..., 1] << 8) | (c[..., 2] << 16)
        lut_keys = np.array(sorted(self.semantic_of), dtype=np.uint32)
        lut_vals = np.array([self.semantic_of[k] for k in lut_keys], dtype=np.uint16)
        semantic = lut_vals[np.searchsorted(lut_keys, instance).clip(0, len(lut_keys) - 1)]
        semantic[instance == 0] = 0
        return Frame(
            np.ascontiguousarray(depth, dtype=np.float32),
            instance.astype(np.uint32),
            semantic.astype(np.uint16),
            None,
            sensor,
            np.asarray(pose, float),
        )

    def release(self) -> None:
        """Free pyrender's GL objects and its context, but not the EGL display.

        pyrender's own ``OffscreenRenderer.delete`` ends with ``eglTerminate`` on the default
        display, which every other EGL context of the process shares (ours included): after
        it, our contexts fail. So the context is destroyed here and the display left alone.
        """
        r, self._renderer, self._size = self._renderer, None, None
        if r is None:
            return
        platform = r._platform
        platform.make_current()
        r._renderer.delete()
        display, context = (
            getattr(platform, "_egl_display", None),
            getattr(platform, "_egl_context", None),
        )
        if display is None:  # another platform (OSMesa): nothing shared to protect
            platform.delete_context()
        else:
            from OpenGL import EGL  # noqa: PLC0415

            EGL.eglMakeCurrent(display, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE, EGL.EGL_NO_CONTEXT)
            if context is not None:
                EGL.eglDestroyContext(display, context)
        # what pyrender's delete leaves behind, so that its __del__ finds nothing to delete
        # (it would otherwise terminate the display after all)
        r._renderer = r._platform = None

    def __enter__(self) -> "ReferenceRenderer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.release()
