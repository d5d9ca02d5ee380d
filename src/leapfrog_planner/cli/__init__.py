"""The ``leapfrog`` command: :mod:`.main` (the group, ``solve``, ``shoot``, ``derive``,
``scenarios`` and the error handling), :mod:`.experiments` (``paper``, ``bench``) and
:mod:`.batch` (``generate``, ``sweep``, ``report``).

This module stays light: :func:`run` imports the command (numba, SciPy, click: most of a
second) inside its own handler, so that a Ctrl-C during the start ends with one line too.
"""

import os
import sys

__all__ = ["run"]  # the command itself: :func:`.main.main`


def run() -> None:
    """Console entry point: the command, started under a Ctrl-C handler."""
    try:
        from .main import run as run_command
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr, flush=True)
        os._exit(130)
    run_command()
