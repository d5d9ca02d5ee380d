"""A sweep's processes die with it, whatever kills it (SIGKILL included).

Workers are forked from multiprocessing's forkserver, whose parent is the sweep. On Linux each of
them asks the kernel to kill it when its parent dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``): the
forkserver through its preload (:mod:`._forkserver_preload`), a worker in its initializer. Then
the resource tracker, which waits for every holder of its pipe to go, ends too. Measured before:
after ``kill -9`` of a sweep the forkserver, the tracker and both workers (400 MB) stayed alive
and kept the caller's pipes open. Elsewhere this is a no-op.
"""

from __future__ import annotations

import ctypes
import signal
import sys

PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """Have the kernel kill this process when its parent dies (Linux only)."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
    except (OSError, AttributeError):  # pragma: no cover - an unusual libc
        pass
