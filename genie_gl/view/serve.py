"""Rerun's own web viewer, hosted locally for a recording: the ``rerun`` command-line viewer
that ships in the ``rerun-sdk`` wheel, run with ``--web-viewer`` (an HTTP server for the
viewer's page and a gRPC server that streams the recording to it).

It listens on the loopback address unless told otherwise, so on a headless box the user
opens the printed URL in a browser on the same machine or through an SSH tunnel
(``ssh -L PORT:127.0.0.1:PORT host``).
"""

from __future__ import annotations

import ipaddress
import os
import socket
import subprocess
import time
import urllib.parse
import urllib.request
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError

LOOPBACK = "127.0.0.1"
WEB_PORT = 9090


def rerun_executable() -> Path:
    """The ``rerun`` viewer binary of the installed ``rerun-sdk`` wheel."""
    try:
        import rerun_cli
    except ImportError as exc:
        raise ConfigError(
            f"genie view --serve needs the rerun-sdk package: pip install 'genie-gl[view]' ({exc})"
        ) from None
    exe = Path(rerun_cli.__file__).parent / "rerun"
    if not exe.is_file():
        raise ConfigError(f"{exe}: the rerun-sdk wheel's viewer is missing; reinstall rerun-sdk")
    return exe


def free_port(host: str) -> int:
    """A TCP port free on ``host`` now (the system's choice)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def check_bind(bind: str) -> str:
    """``bind`` as an IP address the servers can listen on; one clear error otherwise."""
    try:
        return str(ipaddress.ip_address(bind))
    except ValueError:
        raise ConfigError(
            f"--bind {bind!r}: expected an IP address such as 127.0.0.1 (this machine only) or "
            "0.0.0.0 (every interface)"
        ) from None


@dataclass
class Served:
    """A running web viewer: its process, the page's URL and the recording's gRPC URL."""

    process: subprocess.Popen
    url: str
    grpc_url: str
    bind: str = LOOPBACK
    port: int = WEB_PORT

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


def serve(
    rrd: str | os.PathLike,
    *,
    bind: str = LOOPBACK,
    port: int = WEB_PORT,
    grpc_port: int | None = None,
    timeout_s: float = 60.0,
    log_path: str | os.PathLike | None = None,
) -> Served:
    """Host Rerun's web viewer on ``bind:port`` showing recording ``rrd``; returns once the
    page answers (a :class:`ConfigError` with the viewer's output if it does not)."""
    rrd = Path(rrd)
    if not rrd.is_file():
        raise ConfigError(f"{rrd}: no such recording")
    bind = check_bind(bind)
    if not 0 <= port <= 65535:
        raise ConfigError(f"--port {port}: expected 0..65535")
    host = f"[{bind}]" if ":" in bind else bind
    reach = {"0.0.0.0": LOOPBACK, "::": "::1"}.get(bind, bind)
    reach_host = f"[{reach}]" if ":" in reach else reach
    port = port or free_port(bind)
    grpc_port = grpc_port or free_port(bind)
    cmd = [
        str(rerun_executable()),
        "--web-viewer",
        "--bind",
        bind,
        "--web-viewer-port",
        str(port),
        "--port",
        str(grpc_port),
        "--hide-welcome-screen",
        str(rrd),
    ]
    log = open(log_path, "wb") if log_path else subprocess.DEVNULL
    try:
        process = subprocess.Popen(
            cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL
        )
    finally:
        if log_path:
            log.close()
    grpc_url = f"rerun+http://{reach_host}:{grpc_port}/proxy"
    url = f"http://{reach_host}:{port}/?url={urllib.parse.quote(grpc_url, safe='')}"
    served = Served(process, url, grpc_url, bind, port)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise ConfigError(
                f"the rerun web viewer stopped at once (exit {process.returncode}); is port {port} "
                "or "
                f"{grpc_port} on {bind} in use? ({' '.join(cmd)})"
            )
        try:
            with urllib.request.urlopen(f"http://{reach_host}:{port}/", timeout=2) as r:
                if r.status == 200:
                    return served
        except OSError:
            time.sleep(0.2)
    served.stop()
    raise ConfigError(
        f"the rerun web viewer did not answer on {host}:{port} within {timeout_s:g} s"
    )
