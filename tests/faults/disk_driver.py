"""Run one genie command (or API call) on a file system of its own, inside a user and mount
namespace (``unshare -rm python disk_driver.py SPEC``), and report what it left there.

SPEC (JSON): ``mounts`` {folder: tmpfs options ("size=64k", "ro")}, ``plant`` {path: text}
written before the tmpfs is made read-only (``ro`` mounts are remounted after planting),
``argv`` (a genie command) or ``python`` (code run with ``python -c``), ``timeout``, and
``inspect`` (a folder). Prints one JSON line: rc, stderr, seconds, and every file under
``inspect`` with its SHA-256."""

import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path


def main() -> None:
    spec = json.loads(Path(sys.argv[1]).read_text())
    for folder, opts in spec["mounts"].items():
        os.makedirs(folder, exist_ok=True)
        rw = ",".join(o for o in opts.split(",") if o != "ro") or "size=1m"
        subprocess.run(["mount", "-t", "tmpfs", "-o", rw, "tmpfs", folder], check=True)
    for path, text in spec.get("plant", {}).items():
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(text)
    for folder, opts in spec["mounts"].items():
        if "ro" in opts.split(","):
            subprocess.run(["mount", "-o", "remount,ro", folder], check=True)
    cmd = (
        [sys.executable, "-m", "genie_gl.cli", *spec["argv"]]
        if "argv" in spec
        else [sys.executable, "-c", spec["python"]]
    )
    t = time.perf_counter()
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=spec.get("timeout", 300))
        rc, err = r.returncode, r.stderr
    except subprocess.TimeoutExpired:
        rc, err = None, "timeout"
    seconds = time.perf_counter() - t
    files = {}
    root = Path(spec["inspect"])
    for p in sorted(root.rglob("*")) if root.exists() else []:
        if p.is_file():
            files[str(p.relative_to(root))] = hashlib.sha256(p.read_bytes()).hexdigest()
    print(json.dumps({"rc": rc, "stderr": err, "seconds": seconds, "files": files}))


if __name__ == "__main__":
    main()
