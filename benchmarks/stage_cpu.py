"""CPU seconds per stage of the steady scenes of ``genie dataset assembly_line --cameras 40
--sensor ideal_pinhole`` (the setup of ``genie bench pipeline``), made in this process as a
dataset worker makes them: scene 0 (with the warm-up) is left out, the median of the others
is printed per stage, with the whole scene's CPU time (all threads: llvmpipe's and numba's).
CPU time, not wall time, so that a loaded machine blurs it less; the load is printed first.

    python docs/stage_cpu.py [steady scenes]        # default 6
"""
import os
import statistics
import sys
import tempfile
import time

from genie_gl.dataset.config import DatasetConfig
from genie_gl.dataset.executors import make_scene
from genie_gl.dataset.run import prepare
from genie_gl.render.threads import limit_threads

n = int(sys.argv[1]) if len(sys.argv) > 1 else 6
limit_threads(os.cpu_count() or 1)   # one worker: every core, as genie dataset --workers 1 gives it
with tempfile.TemporaryDirectory(prefix="genie-stage-cpu-") as out:
    cfg = DatasetConfig(strategy="assembly_line", out=out, scenes=n + 1, cameras=40, previews=0,
                        sensor="ideal_pinhole")
    inputs, _ = prepare(cfg)
    rows = []
    for i in range(n + 1):
        marks: list[tuple[str, float]] = []
        r = make_scene(cfg, inputs, i, stage=lambda name: marks.append((name, time.process_time())))
        end = time.process_time()
        cpu = {a[0]: (b[1] if b else end) - a[1] for a, b in zip(marks, marks[1:] + [None]) if a[0] != "warm-up"}
        if i:
            rows.append(cpu | {"total": r["cpu_s"]})
print(f"load average (1 min) {os.getloadavg()[0]:.1f}; median CPU s per steady scene ({n} scenes): "
      + ", ".join(f"{k} {statistics.median(r[k] for r in rows):.3f}" for k in rows[0]))
