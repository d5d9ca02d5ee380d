"""Starting ``leapfrog serve`` in tests: a free local port, and the wait until its solver
processes are ready (shared by the browser tests and the README's command)."""

from __future__ import annotations

import json
import socket
import subprocess
import time
import urllib.request


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_ready(proc: subprocess.Popen, url: str, timeout: float) -> str | None:
    """Poll ``url``'s health until a solver process is ready: ``None`` then, else why not (the
    server ended, or the time ran out)."""
    end = time.monotonic() + timeout
    while True:
        try:
            with urllib.request.urlopen(url + "/api/health", timeout=2) as r:
                if json.load(r)["ready"] >= 1:
                    return None
        except OSError:
            pass
        if proc.poll() is not None:
            return f"leapfrog serve ended with exit code {proc.returncode}"
        if time.monotonic() > end:
            return f"leapfrog serve was not ready within {timeout:g} s"
        time.sleep(0.1)
