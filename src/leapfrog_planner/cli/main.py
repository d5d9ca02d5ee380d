"""The ``leapfrog`` command group and its entry point: bad input gives one line on stderr and
exit 2, a solver failure exit 1."""

from __future__ import annotations

import logging
import os
import sys

import click

from ..errors import LeapfrogError
from .batch import generate, report, sweep
from .common import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, err
from .ctrl_c import interrupted
from .experiments import bench, paper
from .results import export, plot, schema
from .serve import serve
from .solve import derive, scenarios, shoot, solve
from .warmup import warmup


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="leapfrog-planner")
def cli():
    """Optimal trajectories for mobile robots: Pontryagin's principle, shooting, Leapfrog."""


for command in (
    solve,
    shoot,
    derive,
    scenarios,
    plot,
    export,
    schema,
    warmup,
    paper,
    bench,
    generate,
    sweep,
    report,
    serve,
):
    cli.add_command(command)


EXIT_INTERRUPTED = 130


def _interrupted(e: BaseException) -> bool:
    """Ctrl-C, also as numba reports it from inside a compiled call (a SystemError whose
    context is the KeyboardInterrupt) and as click reports it (Abort from the interrupt)."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def main(argv=None) -> None:
    """Entry point: maps errors to one line and an exit code instead of a traceback."""
    try:
        code = cli.main(args=argv, prog_name="leapfrog", standalone_mode=False)
    except (KeyboardInterrupt, click.exceptions.Abort) as e:
        if not _interrupted(e):
            if not isinstance(e, click.exceptions.Abort):
                raise
            # click turns an EOFError into Abort: a file ended early (a damaged cache entry)
            err.print(f"error: a file ended early ({e.__context__!r})", markup=False)
            sys.exit(EXIT_FAILED)
        err.print("interrupted", markup=False, highlight=False)
        sys.exit(EXIT_INTERRUPTED)
    except OSError as e:  # a file that vanished or a full disk while writing
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        err.print(f"error: {where}{e.strerror or e}", highlight=False, soft_wrap=True, markup=False)
        sys.exit(EXIT_FAILED)
    except click.UsageError as e:
        err.print(f"error: {e.format_message()}", highlight=False, soft_wrap=True, markup=False)
        sys.exit(EXIT_BAD_INPUT)
    except click.ClickException as e:
        err.print(f"error: {e.format_message()}", highlight=False, soft_wrap=True, markup=False)
        sys.exit(EXIT_BAD_INPUT)
    except LeapfrogError as e:
        err.print(f"error: {e}", highlight=False, soft_wrap=True, markup=False)
        sys.exit(EXIT_BAD_INPUT)
    except Exception as e:
        # Any other error after a Ctrl-C is the Ctrl-C: Python and numba may wrap its
        # KeyboardInterrupt (a SystemError from a compiled call; a class created while it is
        # raised fails with RuntimeError "Error calling __set_name__", seen during an import
        # 0.35 s into `leapfrog solve`).
        if not (_interrupted(e) or interrupted()):
            raise
        err.print("interrupted", markup=False, highlight=False)
        sys.exit(EXIT_INTERRUPTED)
    sys.exit(code if isinstance(code, int) else EXIT_OK)


def run() -> None:
    """Console entry point: :func:`main`, then exit without the interpreter's teardown.

    Tearing down numba and LLVM takes about half a second after the work is done (measured:
    ``leapfrog solve paper-case-4`` 2.8 s -> 2.0 s). By then every output file is written and
    closed (atomically), so only the standard streams and logging need flushing.
    """
    try:
        main()
        code = EXIT_OK
    except SystemExit as e:
        if e.code is None or isinstance(e.code, int):
            code = e.code or EXIT_OK
        else:
            print(e.code, file=sys.stderr)
            code = 1
    except KeyboardInterrupt:  # Ctrl-C between main's handlers and here
        code = EXIT_INTERRUPTED
    if code == EXIT_OK and interrupted():  # a Ctrl-C whose KeyboardInterrupt was swallowed
        err.print("interrupted", markup=False, highlight=False)
        code = EXIT_INTERRUPTED
    mp_util = sys.modules.get("multiprocessing.util")
    if mp_util is not None:  # os._exit skips them: they remove multiprocessing's pymp-* folder
        mp_util._run_finalizers()
    logging.shutdown()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
