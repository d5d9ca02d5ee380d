"""What the command remembers of a Ctrl-C, and how it ends then. Light (no import beyond the
standard library): :func:`.run` installs the handler before the command's imports."""

import os
import signal
import sys

_pressed = False


def remember_ctrl_c(signum=signal.SIGINT, frame=None):
    """Ctrl-C, remembered only: raised later, where :func:`interrupted` is checked (a safe point
    between steps)."""
    global _pressed
    _pressed = True


def on_ctrl_c(signum, frame):
    """Ctrl-C: remembered, then raised as usual. CPython can swallow the KeyboardInterrupt: it
    is raised wherever Python code runs next, and C code that calls a ``__hash__`` or a property
    may discard the error (measured: Ctrl-C 0.15 s into ``leapfrog solve``, during numba's
    import, was lost in about 1 run of 10, and the command ended with exit 0)."""
    remember_ctrl_c(signum, frame)
    raise KeyboardInterrupt


def quiet_swallowed_ctrl_c(unraisable) -> None:
    """``sys.unraisablehook``: a KeyboardInterrupt that CPython could not raise (it arrived in
    a callback, such as the import system's module-lock cleanup) is remembered already
    (:func:`on_ctrl_c`) and ends the command at the next safe point with one line; CPython's
    own hook would print "Exception ignored in ..." and a traceback first (seen once in CI: a
    Ctrl-C 0.15 s into ``leapfrog solve``). Anything else goes to that hook as before."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        return
    sys.__unraisablehook__(unraisable)


def interrupted() -> bool:
    """Whether Ctrl-C was pressed, even where its KeyboardInterrupt was swallowed."""
    return _pressed


def exit_interrupted() -> None:
    print("interrupted", file=sys.stderr, flush=True)
    os._exit(130)
