"""What a solver process of ``leapfrog serve`` runs: it loads the compiled kernels once, then
answers jobs from its pipe, one at a time, until the pipe closes.

A job is ``(kind, scenario, options)``: the scenario in the layout of a scenario file, the
planner's options, and what to send back: ``"view"`` (what the page draws, as JSON), ``"json"``
(the result file ``leapfrog solve --json`` writes) or ``"csv"`` (``leapfrog export --csv`` with
its default step). The answer is ``("ok", bytes)``, ``("bad", message)`` for input the planner
refused, or ``("error", message)``.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import sys
import tempfile
from pathlib import Path

log = logging.getLogger(__name__)

#: The time step of the CSV download (the default of ``leapfrog export --dt``).
CSV_DT = 0.01


def _plan(scenario: dict, options: dict, threads: int):
    from ..planning.planner import Planner
    from ..planning.scenario import scenario_from_dict

    sc = scenario_from_dict(scenario, "scenario")
    return Planner(sc, threads=threads, **options).plan()


def _csv(result) -> bytes:
    from ..planning.export import write_csv

    with tempfile.TemporaryDirectory(prefix="leapfrog-serve-") as folder:
        path = Path(folder) / "result.csv"
        write_csv(result, path, CSV_DT)
        return path.read_bytes()


def answer(job, threads: int = 0) -> tuple[str, object]:
    """The answer to one job (see the module's documentation)."""
    from ..errors import LeapfrogError
    from .view import result_view

    kind, scenario, options = job
    try:
        result = _plan(scenario, options, threads)
        if kind == "view":
            body = json.dumps(result_view(result), allow_nan=False, separators=(",", ":"))
            return "ok", body.encode()
        if kind == "json":
            return "ok", json.dumps(result.to_dict(), indent=1, allow_nan=False).encode()
        if kind == "csv":
            return "ok", _csv(result)
        return "error", f"unknown job {kind!r}"
    except LeapfrogError as e:
        return "bad", " ".join(str(e).splitlines())
    except Exception as e:  # reported as one line; the server stays up
        log.exception("job failed")
        return "error", f"{type(e).__name__}: {' '.join(str(e).splitlines())}"


def warm(models) -> None:
    from ..planning.warmup import warm_up

    for model in models:
        warm_up(model)


def serve(receive, send, models, threads: int) -> None:
    """The process's loop: warm up, say ``("ready", pid)``, then answer jobs."""
    from ..batch.orphans import die_with_parent

    die_with_parent()
    # Ctrl-C at the server reaches its whole process group: the server ends its workers itself
    # (interrupted inside numba, a process can die of a segmentation fault).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        warm(models)
    except Exception as e:
        send.send(("error", f"warm-up failed: {type(e).__name__}: {e}"))
        return
    send.send(("ready", os.getpid()))
    while True:
        try:
            job = receive.recv()
        except (EOFError, OSError):  # the server closed the pipe: done
            return
        send.send(answer(job, threads))


def main(argv: list[str]) -> None:
    """``python -m leapfrog_planner.web.worker THREADS MODEL...``: jobs arrive on standard
    input and answers leave on the original standard output; the process's own output goes to
    standard error, so that nothing else writes into the pipe."""
    from multiprocessing.connection import Connection

    out = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.__stdout__ = os.fdopen(1, "w", closefd=False)
    serve(Connection(0, writable=False), Connection(out, readable=False), argv[1:], int(argv[0]))


if __name__ == "__main__":
    main(sys.argv[1:])
