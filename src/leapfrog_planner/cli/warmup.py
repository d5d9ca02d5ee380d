"""``leapfrog warmup``, and the compile notice every planning command shows on its first run."""

from __future__ import annotations

import contextlib
import signal
import threading
import time

import click

from .common import EXIT_OK, console, err

#: Loading cached kernels takes about 0.3 s; a warm-up still running after this is compiling.
COMPILING_AFTER_S = 1.5


@contextlib.contextmanager
def held_interrupts():
    """Hold Ctrl-C while numba loads or compiles kernels (interrupted there, the process died
    of a segmentation fault, measured), and raise it once the block ends, or earlier where the
    block calls the function it is given (a safe point between steps)."""
    caught = []

    def pending():
        if caught:
            raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = signal.signal(signal.SIGINT, lambda *_: caught.append(True))
    try:
        yield pending
    finally:
        signal.signal(signal.SIGINT, previous)
    pending()


def ensure_compiled(models, show: bool = True) -> None:
    """Warm the kernels of ``models`` up before any timed work. When that takes long (a fresh
    cache: numba compiles), say so on a terminal: what is compiling, that it happens once per
    machine, and how long it took."""
    from ..planning.warmup import warm_up

    show = show and err.is_terminal
    for model in dict.fromkeys(models):
        note = f"compiling the {model} kernels, once per machine (about 40 s)"
        if not show:
            with held_interrupts():
                warm_up(model)
            continue
        with err.status(f"loading the {model} kernels") as status:
            timer = threading.Timer(COMPILING_AFTER_S, lambda s=status, n=note: s.update(n))
            timer.start()
            try:
                with held_interrupts():
                    seconds = warm_up(model)
            finally:
                timer.cancel()
        if seconds > COMPILING_AFTER_S:
            err.print(f"compiled the {model} kernels in {seconds:.0f} s", highlight=False)


@click.command()
@click.argument("models", nargs=-1)
def warmup(models):
    """Compile the kernels of MODELS (default: every built-in model) ahead of time.

    The first plan of a model on a machine compiles its kernels (about 40 s); they are cached on
    disk, and later runs load them in well under a second."""
    from ..model import MODELS

    unknown = [m for m in models if m not in MODELS]
    if unknown:
        raise click.UsageError(f"unknown model {unknown[0]!r} (known: {', '.join(MODELS)})")
    from ..planning.warmup import warm_up

    for model in models or MODELS:
        t0 = time.perf_counter()
        with err.status(f"compiling the {model} kernels (about 40 s unless cached)"):
            with held_interrupts():
                warm_up(model)
        console.print(f"{model}: ready in {time.perf_counter() - t0:.1f} s", highlight=False)
    return EXIT_OK
