"""The capture stage: rigs along trajectories (:mod:`.trajectory`) and the frames of a
mobile-scan map with its registration error (:mod:`.mobile_map`), composed around
``gg.capture`` (renderer, lens, plan, accuracy settings, effects).

``genie_gl.capture`` is both this package and the public function ``gg.capture(scene, sensor,
poses, seed=...)`` (DESIGN.md): importing a submodule binds the package as an attribute of
``genie_gl``, so the package forwards calls to the function, as ``genie_gl.render`` does.
"""
import sys as _sys
import types as _types


def capture(*args, **kwargs):
    """``gg.capture``: see :func:`genie_gl.render.batch.capture`."""
    from ..render.batch import capture as _capture

    return _capture(*args, **kwargs)


class _CallableModule(_types.ModuleType):
    def __call__(self, *args, **kwargs):
        return capture(*args, **kwargs)


_sys.modules[__name__].__class__ = _CallableModule
