"""Sensor effects: each maps an ideal Frame to a realistic one (the base class, one registry,
the effects and their kernels), ``simulate`` that applies them, and sensor profiles
(a calibration plus its effect list)."""
