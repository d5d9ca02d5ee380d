"""Compiling a model's Newton loops in a process of their own while plans go on without them.

On a fresh machine a model's first plan compiles its kernels. The integrator, which every plan
needs, compiles in about 10 s; the compiled Newton loops (``shoot_newton`` and ``sweep_warm``,
which take the integrator into simple and multiple shooting and Leapfrog's sweep) take about
35 s more. They are the faster twin of the Python loop, with the same iterates bit for bit
(tested), so no plan needs to wait for them: until they are in the disk cache, plans run the
Python loop, and one process of their own (``leapfrog warmup MODEL``) compiles them there, for
the next plan to find.

``LEAPFROG_COMPILE_IN_BACKGROUND=0``, or a block under :func:`here`, compiles them in the
planning process instead, when first needed (as the background process itself does, and what
times the loops: the benchmarks).
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType

log = logging.getLogger(__name__)

ENV = "LEAPFROG_COMPILE_IN_BACKGROUND"

#: A lock older than this belongs to a compile that died without removing it.
STALE_S = 15 * 60


_HERE = contextvars.ContextVar("compile_loops_here", default=False)


def in_background() -> bool:
    """Whether missing Newton loops are compiled in a process of their own (the default)."""
    return not _HERE.get() and os.environ.get(ENV, "1").strip() != "0"


@contextlib.contextmanager
def here():
    """Within this block, missing Newton loops are compiled in this process, when first run."""
    token = _HERE.set(True)
    try:
        yield
    finally:
        _HERE.reset(token)


def lock_path(kernels: ModuleType) -> Path:
    """The file beside the generated module ``kernels`` whose presence says that its loops are
    being compiled in the background (it holds that process's id)."""
    return Path(kernels.__file__).with_suffix(".compiling")


def running(kernels: ModuleType) -> bool:
    """Whether a background compile of the loops of the module ``kernels`` is under way."""
    lock = lock_path(kernels)
    try:
        age = time.time() - lock.stat().st_mtime
    except OSError:
        return False
    if age >= STALE_S:
        return False
    try:
        pid = int(lock.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return age < 10.0  # just created: its process id is being written
    return _alive(pid)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process: alive
        return True
    return True


def start(model: str, kernels: ModuleType) -> bool:
    """Start compiling the loops of the built-in ``model`` (whose generated module is
    ``kernels``) in a process of its own, unless one is under way. Returns whether one is under
    way now."""
    if running(kernels):
        return True
    lock = lock_path(kernels)
    with contextlib.suppress(OSError):
        lock.unlink()  # stale
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except FileExistsError:  # another process started one just now
        return True
    except OSError as exc:
        log.info("could not start compiling the %s loops in the background: %s", model, exc)
        return False
    with os.fdopen(fd, "w") as f:
        try:
            proc = subprocess.Popen(
                [sys.executable, "-m", "leapfrog_planner.cli", "warmup", model],
                env={**os.environ, ENV: "0"},
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,  # Ctrl-C of the planning process leaves it be
            )
        except OSError as exc:
            f.close()
            lock.unlink(missing_ok=True)
            log.info("could not start compiling the %s loops in the background: %s", model, exc)
            return False
        f.write(f"{proc.pid}\n")
    log.info("compiling the %s Newton loops in the background (process %d)", model, proc.pid)
    return True


def finished(kernels: ModuleType) -> None:
    """The loops of the module ``kernels`` are compiled: remove its lock (whoever compiled
    them)."""
    with contextlib.suppress(OSError):
        lock_path(kernels).unlink()
