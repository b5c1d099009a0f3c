"""CPU seconds per stage of the steady scenes of ``genie dataset assembly_line --cameras 40
--sensor ideal_pinhole`` (the setup of ``genie bench pipeline``), made in this process as a
dataset worker makes them.

Scene 0 (with the warm-up) is left out, the median of the others is printed per stage, with
the whole scene's CPU time (all threads: llvmpipe's and numba's). CPU time, not wall time, so
that a loaded machine blurs it less::

    python -m benchmarks stage_cpu 6
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time

from genie_gl.dataset.config import DatasetConfig
from genie_gl.dataset.executors import make_scene
from genie_gl.dataset.run import prepare
from genie_gl.render.threads import limit_threads

from .common import header, parser


def run(steady: int = 6, cameras: int = 40, strategy: str = "assembly_line") -> dict[str, float]:
    """Median CPU seconds per steady scene of each stage, and ``total`` (the scene's CPU)."""
    limit_threads(
        os.cpu_count() or 1
    )  # one worker: every core, as genie dataset --workers 1 gives it
    with tempfile.TemporaryDirectory(prefix="genie-stage-cpu-") as out:
        cfg = DatasetConfig(
            strategy=strategy,
            out=out,
            scenes=steady + 1,
            cameras=cameras,
            previews=0,
            sensor="ideal_pinhole",
        )
        inputs, _ = prepare(cfg)
        rows = []
        for i in range(steady + 1):
            marks: list[tuple[str, float]] = []
            r = make_scene(
                cfg, inputs, i, stage=lambda name: marks.append((name, time.process_time()))
            )
            end = time.process_time()
            cpu = {
                a[0]: (b[1] if b else end) - a[1]
                for a, b in zip(marks, marks[1:] + [None])
                if a[0] != "warm-up"
            }
            if i:
                rows.append(cpu | {"total": r["cpu_s"]})
    return {k: statistics.median(r[k] for r in rows) for k in rows[0]}


def main(argv: list[str]) -> None:
    p = parser("stage_cpu", __doc__)
    p.add_argument("steady", nargs="?", type=int, default=6, help="steady scenes (default 6)")
    p.add_argument("--cameras", type=int, default=40)
    a = p.parse_args(argv)
    print(header())
    r = run(a.steady, a.cameras)
    print(
        f"median CPU s per steady scene ({a.steady} scenes): "
        + ", ".join(f"{k} {v:.3f}" for k, v in r.items())
    )
