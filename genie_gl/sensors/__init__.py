"""The sensor model: a camera with its lens coefficients, range, accuracy settings and
effect list (:class:`Sensor`), OpenCV/ROS/Kalibr calibration I/O, and camera poses. Effects,
lens, motion and placement are packages of their own (``genie_gl.effects``, ``.lens``,
``.motion``, ``.placement``)."""

from .calibration import Calibration, read_calibration, write_calibration
from .camera import Sensor

__all__ = ["Calibration", "Sensor", "read_calibration", "write_calibration"]
