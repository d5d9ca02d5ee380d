"""The ``leapfrog`` command: :mod:`.main` (the group and the error handling), :mod:`.solve`
(``solve``, ``shoot``, ``derive``, ``scenarios``), :mod:`.results` (``plot``, ``export``),
:mod:`.experiments` (``paper``, ``bench``), :mod:`.batch` (``generate``, ``sweep``, ``report``),
:mod:`.serve` and :mod:`.warmup`.

This module stays light: :func:`run` imports the command (numba, SciPy, click: most of a
second) inside its own handler, so that a Ctrl-C during the start ends with one line too. The
Ctrl-C state lives in :mod:`.ctrl_c`, which the commands read: they never import this module.
"""

import signal
import sys

from .ctrl_c import exit_interrupted, interrupted, on_ctrl_c, quiet_swallowed_ctrl_c

__all__ = ["run"]  # the command itself: :func:`.main.main`


def run() -> None:
    """Console entry point: the command, started under a Ctrl-C handler."""
    signal.signal(signal.SIGINT, on_ctrl_c)
    sys.unraisablehook = quiet_swallowed_ctrl_c
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
