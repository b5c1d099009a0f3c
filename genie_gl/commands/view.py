"""``genie view PATH [--out FILE.rrd] [--serve [--bind ADDR] [--port P]]``.

Writes a Rerun recording (``.rrd``) of what genie-gl exported at PATH: a dataset folder, one
scene or recording folder of it, a ``genie capture`` folder or a USD scene. Open it with
``rerun FILE.rrd``, or with ``--serve`` host Rerun's web viewer here (on 127.0.0.1 unless
``--bind`` says otherwise) and open the printed URL in a browser.
"""

from __future__ import annotations

import argparse
import time

from . import count


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", help="dataset folder, scene/recording/capture folder, or USD scene")
    p.add_argument(
        "--out",
        default=None,
        metavar="FILE.rrd",
        help="the recording (default: PATH/view.rrd for a folder, PATH.rrd beside a file)",
    )
    p.add_argument(
        "--max-points",
        type=count(1, 10**9),
        default=2_000_000,
        help="points per scene at most (every k-th point beyond it)",
    )
    p.add_argument(
        "--serve", action="store_true", help="host Rerun's web viewer for it and print its URL"
    )
    p.add_argument(
        "--bind",
        default="127.0.0.1",
        help="address the web viewer listens on (default 127.0.0.1: this machine only)",
    )
    p.add_argument(
        "--port",
        type=count(0, 65535),
        default=9090,
        help="the web viewer's HTTP port (0: any free)",
    )


def run(args: argparse.Namespace) -> int:
    from ..view import default_rrd, read_views, serve, write_rrd
    from ..view.serve import check_bind

    if args.serve:
        check_bind(args.bind)  # before any work
    views = read_views(args.path)
    rrd = write_rrd(views, args.out or default_rrd(args.path), max_points=args.max_points)
    points = sum(len(v.xyz) for v in views)
    cams = sum(len(v.shots) for v in views)
    print(
        f"view: {len(views)} scene(s), {points:,} points, {cams} camera shots -> {rrd} (open with: "
        f"rerun {rrd})"
    )
    if not args.serve:
        return 0
    served = serve(rrd, bind=args.bind, port=args.port)
    print(
        f"view: Rerun web viewer listening on {served.bind} port {served.port}; "
        f"open {served.url} (Ctrl-C stops it)",
        flush=True,
    )
    try:
        while served.process.poll() is None:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        served.stop()
    return 0
