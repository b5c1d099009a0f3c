"""The report card: each sensor profile against the field's depth-quality metrics and the
published measurements of the real device.

* :mod:`.metrics` — the metrics (Intel's depth quality tool, Azure Kinect's error
  definitions, edge and banding metrics), pure numpy;
* :mod:`.scenes` — the standard test scenes (walls, a step, thin bars, material panels);
* :mod:`.references` — ``sensors/<name>.reference.yml``: published figures with sources;
* :mod:`.measurements` — the scenes rendered through a profile and measured;
* :mod:`.report` — :func:`report_card` (``gg.report_card``): the measurements judged against the
published figures;
* :mod:`.captures` — a user's own depth captures of a wall, measured the same way;
* :mod:`.pages` — the Markdown pages and PNG curves under ``docs/sensors/``.

The package imports none of them, so the pure metrics load without GL.
"""
