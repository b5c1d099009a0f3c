"""The lens maps of genie_gl/camera.py at their hard edges: inputs that divide by zero, overflow
or have no answer (points on the image plane z = 0, the camera centre, pixels past a lens's
fold, pixels whose ray would leave the unit sphere, NaN and infinite pixels) must give NaN
quietly, never a flood of numpy RuntimeWarnings to the user; and the pinhole inverse must
recover, to 1e-9, every point of strong random lenses up to just inside their fold (the forward
map distort_normalized is the truth), with NaN past the fold. Small and fast (well under a
second): the "lens" mutation group runs this file against each mutant."""
import warnings

import numpy as np

from genie_gl.camera import MAX_OFF_AXIS, Camera, _fold, distort_normalized

K = np.array([[120.0, 0.0, 64.2], [0.0, 110.0, 47.7], [0.0, 0.0, 1.0]])
EDGE_POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.3, 0.2, 1.0],
                        [0.0, 0.0, 1.0], [1e3, -1e3, 1e-3], [0.0, 0.0, -1.0], [np.nan, 0.0, 1.0]])


def edge_pixels(cam: Camera) -> np.ndarray:
    """The principal point, pixels far past any fold and a NaN pixel."""
    return np.array([[cam.cx, cam.cy], [cam.cx + 1e4, cam.cy], [cam.cx, cam.cy - 1e3],
                     [cam.cx + 1e8, cam.cy + 1e8], [0.0, 0.0], [np.nan, 3.0]])


def exercise(cam: Camera) -> None:
    """Every lens map of ``cam`` on its edge inputs, with every warning an error."""
    cam.max_off_axis
    cam.project(EDGE_POINTS)
    cam.unproject(edge_pixels(cam))
    cam.directions()
    cam.rays()


def quiet(cam_factory) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exercise(cam_factory())


def test_pinhole_lens_maps_raise_no_warnings_at_the_edges():
    """Ideal, barrel (folds), pincushion and rational pinhole lenses: z = 0 points, the camera
    centre and far/NaN pixels give NaN or a value, never a RuntimeWarning."""
    for dist in ([], [-0.45, 0.05, 0.001, -0.002], [0.2, 0.1, 0.0, 0.0], [-0.3, 0.08, 0.001, 0.002, 0.0, 0.1, 0.02, 0.01],
                 [-0.31, 0.02, 0.001, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01, -0.01, 0.02, 0.003]):
        quiet(lambda: Camera(128, 96, K, np.array(dist, float)))


def test_fisheye_lens_maps_raise_no_warnings_at_the_edges():
    for dist in ([], [0.05, -0.02, 0.003, -0.001], [-0.3, 0.01, 0.0, 0.0]):
        quiet(lambda: Camera(128, 96, K, np.array(dist, float), model="fisheye"))


def test_omni_lens_maps_raise_no_warnings_at_the_edges():
    """ξ > 1 (pixels whose ray leaves the sphere: the root of a negative), ξ = -1 (the
    projection centre on the sphere: 0/0 on the axis), ξ = -cos(89.9°) (a division by zero at
    the rim) and a radial-tangential part that folds."""
    for dist in ([1.7], [-1.0], [-np.cos(MAX_OFF_AXIS)], [0.8, -0.5, 0.1, 0.001, 0.002], [1.3, 0.1, 0.0, 0.0, 0.0]):
        quiet(lambda: Camera(128, 96, K, np.array(dist, float), model="omni"))
