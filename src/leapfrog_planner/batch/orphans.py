"""A sweep's processes die with it, whatever kills it (SIGKILL included).

Workers are forked from multiprocessing's forkserver, whose parent is the sweep. On Linux each of
them asks the kernel to kill it when its parent dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``): the
forkserver through its preload (:mod:`._forkserver_preload`), a worker in its initializer. Then
the resource tracker, which waits for every holder of its pipe to go, ends too. Measured before:
after ``kill -9`` of a sweep the forkserver, the tracker and both workers (400 MB) stayed alive
and kept the caller's pipes open. The request does not look back: a parent that died while the
process was still starting (a sweep killed 1.5 to 2.5 s after it began, measured) is caught by
comparing the parent with the one expected, and the process exits. Elsewhere this is a no-op.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1

#: The sweep's process id, in the environment its pool's processes inherit.
PARENT = "LEAPFROG_SWEEP_PID"


def mark_parent() -> None:
    """In the sweep, before its pool starts: the parent its forkserver (or spawned workers)
    must find."""
    os.environ[PARENT] = str(os.getpid())


def expected_parent() -> int | None:
    return int(os.environ.get(PARENT) or 0) or None


def die_with_parent(expected: int | None = None) -> None:
    """Have the kernel kill this process when its parent dies (Linux only); exit at once when
    the parent is no longer ``expected`` (it died before the request)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
    except (OSError, AttributeError):  # pragma: no cover - an unusual libc
        return
    if expected is not None and os.getppid() != expected:
        os._exit(1)
