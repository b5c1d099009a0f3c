"""Sensors: camera model, calibration I/O, profiles, effects and placement (paper §3.4.1)."""
from .calibration import Calibration, read_calibration, write_calibration
from .camera import Sensor
from .effects import EFFECTS, build_effects
from .placement import place_sensors
from .profile import load_sensor
from .simulate import simulate

__all__ = ["EFFECTS", "Calibration", "Sensor", "build_effects", "load_sensor", "place_sensors",
           "read_calibration", "simulate", "write_calibration"]
