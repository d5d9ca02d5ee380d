"""``leapfrog warmup``, and the compile notice every planning command shows on its first run."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from functools import partial
from pathlib import Path

import click

from .common import EXIT_OK, console, err
from .ctrl_c import interrupted, remember_ctrl_c


@contextlib.contextmanager
def held_interrupts():
    """Hold Ctrl-C while numba loads or compiles kernels (interrupted there, the process died
    of a segmentation fault, measured), and raise it once the block ends, or earlier where the
    block calls the function it is given (a safe point between steps)."""

    def pending():
        if interrupted():  # here, or earlier where its KeyboardInterrupt was swallowed
            raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = signal.signal(signal.SIGINT, remember_ctrl_c)
    try:
        yield pending
    finally:
        signal.signal(signal.SIGINT, previous)
    pending()


#: Set in the environment when a damaged cache was cleared and the command started again.
REBUILT = "LEAPFROG_CACHE_REBUILT"


def _heal(exc: Exception) -> None:
    """Warming up a fixed, valid plan failed: the compiled cache is damaged (numba's index or
    data files, measured: random or flipped bytes, empty or truncated files). Clear it and run
    the command again in a fresh process: first the models' cache, then, if that was not it,
    numba's cache of the package itself; a third failure is not the cache's."""
    stage = int(os.environ.get(REBUILT, "0") or 0)
    if stage >= 2:
        raise exc
    from .._cache import cache_dir

    err.print(
        f"warning: the compiled kernel cache was damaged ({type(exc).__name__}); rebuilding it",
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
    import numba  # a read-only installation keeps numba's cache of the package elsewhere

    package = numba.config.CACHE_DIR or Path(__file__).resolve().parent.parent
    folder = cache_dir() if stage == 0 else Path(package)
    for pattern in ("**/*.nbi", "**/*.nbc", "models/*.py", "tableaux-*.npz"):
        for p in folder.glob(pattern):
            with contextlib.suppress(OSError):
                p.unlink()
    os.environ[REBUILT] = str(stage + 1)
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, "-m", "leapfrog_planner.cli", *sys.argv[1:]])


def ensure_compiled(models, show: bool = True, methods=None, timed: bool = False) -> None:
    """Warm the kernels of ``models`` up before any timed work (one kernel set per model serves
    every scenario of it, bounded controls included). When that takes long (a fresh
    cache: numba compiles), say so, on a terminal and off it (a script, a notebook, CI): what is
    compiling, that it happens once per machine, and how long it took. A damaged cache is
    cleared and the command run again. Given ``methods``, only the kernels of those local
    methods (a plan with one method loads 0.08 s less). A ``timed`` command (a benchmark)
    compiles the Newton loops here, not in the background, so that it times them."""
    try:
        for model in dict.fromkeys(models):
            _ensure_compiled(model, show, methods, timed)
    except Exception as exc:
        _heal(exc)


def _ensure_compiled(model: str, show: bool, methods, here: bool = False) -> None:
    from ..compiled import background
    from ..planning.warmup import said_when_compiling, warm_up

    what = f"{model} kernels"
    expected = 15 if background.in_background() and not here else 60  # measured: 15 s, 61 s
    note = f"compiling the {what}, once per machine (about {expected} s)"
    if not show:
        with held_interrupts():
            warm_up(model, methods, here)
        return
    with contextlib.ExitStack() as stack:
        if err.is_terminal:
            status = stack.enter_context(err.status(f"loading the {what}"))
            say = partial(status.update, note)
        else:  # a plain line
            say = partial(_line, f"{note} ...")
        first = stack.enter_context(said_when_compiling(say))
        stack.enter_context(held_interrupts())
        seconds = warm_up(model, methods, here)
    if first.started:
        _line(f"compiled the {what} in {seconds:.0f} s")
    if _loops_compiling(model):
        _line(
            f"compiling the {model} model's Newton loop in the background (half a minute); until it"
            " is ready, plans run the Python loop: the same answers, bit for bit, slower"
        )


def _loops_compiling(model: str) -> bool:
    from ..compiled import background
    from ..compiled.kernels import load_kernels

    return background.in_background() and background.running(load_kernels(model))


def _line(text: str) -> None:
    err.print(text, highlight=False, markup=False, soft_wrap=True)


@click.command()
@click.argument("models", nargs=-1)
def warmup(models):
    """Compile the kernels of MODELS (default: every built-in model) ahead of time.

    The first plan of a model on a machine compiles its kernels (about 20 s, and its compiled
    Newton loops half a minute more in the background); `warmup` compiles all of them here
    (about a minute a model). They are cached on disk, and later runs load them in well under a
    second. One kernel set per model serves every scenario: obstacles, maps, bounds on the
    controls and the robot's size are data."""
    from ..model import MODELS

    unknown = [m for m in models if m not in MODELS]
    if unknown:
        raise click.UsageError(f"unknown model {unknown[0]!r} (known: {', '.join(MODELS)})")
    for model in models or MODELS:
        t0 = time.perf_counter()
        _ensure_compiled(model, True, None, here=True)
        console.print(f"{model}: ready in {time.perf_counter() - t0:.1f} s", highlight=False)
    return EXIT_OK
