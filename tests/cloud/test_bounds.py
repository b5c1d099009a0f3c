"""The compiled cloud kernels run with bounds checks switched off; here their tests run again
with numba's bounds checking forced on (its own cache, so nothing is shared with the fast
builds): an index past an array's end raises instead of corrupting memory unseen."""

import os
import subprocess
import sys
from pathlib import Path

import pytest


@pytest.mark.slow
def test_cloud_kernels_stay_inside_their_arrays(tmp_path):
    here = Path(__file__).parent
    env = dict(os.environ, NUMBA_BOUNDSCHECK="1", NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    files = [str(here / "test_unproject_kernel.py"), str(here / "test_frame_chunks.py")]
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *files],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
