"""The ``leapfrog`` command: :mod:`.main` (the group, ``solve``, ``shoot``, ``derive``,
``scenarios`` and the error handling), :mod:`.experiments` (``paper``, ``bench``) and
:mod:`.batch` (``generate``, ``sweep``, ``report``).

This module stays light: :func:`run` imports the command (numba, SciPy, click: most of a
second) inside its own handler, so that a Ctrl-C during the start ends with one line too.
"""

import os
import signal
import sys

__all__ = ["run"]  # the command itself: :func:`.main.main`

_interrupted = False


def remember_ctrl_c(signum, frame):
    """Ctrl-C, remembered only: raised later, where :func:`interrupted` is checked (a safe point
    between steps)."""
    global _interrupted
    _interrupted = True


def _on_ctrl_c(signum, frame):
    """Ctrl-C: remembered, then raised as usual. CPython can swallow the KeyboardInterrupt: it
    is raised wherever Python code runs next, and C code that calls a ``__hash__`` or a property
    may discard the error (measured: Ctrl-C 0.15 s into ``leapfrog solve``, during numba's
    import, was lost in about 1 run of 10, and the command ended with exit 0)."""
    remember_ctrl_c(signum, frame)
    raise KeyboardInterrupt


def interrupted() -> bool:
    """Whether Ctrl-C was pressed, even where its KeyboardInterrupt was swallowed."""
    return _interrupted


def exit_interrupted() -> None:
    print("interrupted", file=sys.stderr, flush=True)
    os._exit(130)


def run() -> None:
    """Console entry point: the command, started under a Ctrl-C handler."""
    signal.signal(signal.SIGINT, _on_ctrl_c)
    try:
        from .main import run as run_command
    except KeyboardInterrupt:
        exit_interrupted()
    except Exception:  # a Ctrl-C wrapped in another error (see main.main)
        if interrupted():
            exit_interrupted()
        raise
    if interrupted():  # during the imports, and swallowed there
        exit_interrupted()
    run_command()
