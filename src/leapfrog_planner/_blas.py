"""Single-threaded BLAS around the solvers.

The library only multiplies and factors tiny matrices (3x3 to about 40x40). For those, OpenBLAS's
worker threads only add latency, badly so when the other cores are busy: a 7x7 matrix exponential
was measured at 12 ms with threads against 0.1 ms without. Limiting costs a fraction of a
millisecond, so it is done once per top-level call (re-entrant), not per small operation,
with one controller for the process (building it is the slow part).
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from functools import wraps

from threadpoolctl import ThreadpoolController

_state = threading.local()
_controller: ThreadpoolController | None = None


def _limit():
    # Inspecting the loaded libraries costs about 1 ms; do it once, then limiting costs ~20 us.
    global _controller
    if _controller is None:
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")


@contextmanager
def single_threaded_blas():
    if getattr(_state, "active", False):
        yield
        return
    _state.active = True
    try:
        with _limit():
            yield
    finally:
        _state.active = False


@contextmanager
def held_by_parent():
    """In a worker thread of a caller inside :func:`single_threaded_blas`: the limit is process
    wide and already held, so nested calls must not set and restore it again (a restore from one
    thread would lift the limit under another)."""
    previous = getattr(_state, "active", False)
    _state.active = True
    try:
        yield
    finally:
        _state.active = previous


def blas_single_threaded(fn):
    """Decorator form of :func:`single_threaded_blas`."""

    @wraps(fn)
    def wrapper(*args, **kwargs):
        with single_threaded_blas():
            return fn(*args, **kwargs)

    return wrapper
