"""What a solver process of ``leapfrog serve`` runs: it warms its first model up (loads its
compiled kernels, or on a fresh machine compiles them, about 20 s a model), then answers jobs
from its pipe, one at a time, until the pipe closes, and loads the other models meanwhile, one
after the other: those already in the disk cache when no job waits, the others as a process of
its own (:func:`warm_apart`) has compiled them into the disk cache. The server sends a job
only for a model already warm: a plan of the first model is answered while the others are
still compiling. (The compiling is a process apart, not a thread: numba compiling
Python-heavy in a thread kept a plan's many short calls of compiled kernels waiting for the
interpreter lock, measured 10 s and more for a plan of a few milliseconds.)

A job is ``(kind, scenario, options, image, seconds)``: what to send back, ``"view"`` (what
the page draws, as JSON), ``"json"`` (the result file ``leapfrog solve --json`` writes) or
``"csv"`` (``leapfrog export --csv`` with its default step); the scenario in the layout of a
scenario file; the planner's options; the image of a map opened on the page (``None`` without
one: its YAML file may name the image where it lay on the user's machine); and the plan's time
limit (``None``: the scenario's own, if any; else the lesser). The answer is ``("ok",
bytes)``, ``("bad", message)`` for input the planner refused, or ``("error", message)``.

Between the answers, in the order things happen, the warm-up says where it is: ``("warming",
model)`` as it starts a model, then ``("warm", model)`` once this process has it loaded, or
``("warm-failed", model, message)``.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
from collections import OrderedDict
from pathlib import Path

log = logging.getLogger(__name__)

#: The time step of the CSV download (the default of ``leapfrog export --dt``).
CSV_DT = 0.01


#: Maps kept with their field, by files, options and robot radius (the last few a page used).
MAX_MAPS = 4
_maps: OrderedDict[tuple, object] = OrderedDict()


def _map(table: dict, image: str, radius: float):
    """The scenario's map, read from its YAML file and ``image`` once and kept (with its
    field: a map of 2000 x 2000 cells takes half a second to build it)."""
    from ..planning.scenario_map import ScenarioMap
    from ..world import load_ros_map

    key = (table["file"], image, table.get("unknown", "occupied"), table.get("length"), radius)
    if key in _maps:
        _maps.move_to_end(key)
        return _maps[key]
    occupancy = next((m.occupancy for k, m in _maps.items() if k[:2] == key[:2]), None)
    if occupancy is None:
        occupancy = load_ros_map(table["file"], image=image)
    _maps[key] = ScenarioMap(key[0], key[2], key[3], occupancy=occupancy)
    while len(_maps) > MAX_MAPS:
        _maps.popitem(last=False)
    return _maps[key]


def _plan(scenario: dict, options: dict, threads: int, image: str | None, seconds: float | None):
    from dataclasses import replace

    from ..planning.planner import Planner, PlannerSettings
    from ..planning.scenario import scenario_from_dict

    if image is None or "map" not in scenario:
        sc = scenario_from_dict(scenario, "scenario")
    else:
        rest = {k: v for k, v in scenario.items() if k != "map"}
        sc = scenario_from_dict(rest, "scenario")
        sc = replace(sc, map=_map(scenario["map"], image, sc.robot_radius))
    settings = PlannerSettings.of_scenario(sc, None, **{"threads": threads, **options})
    if seconds is not None:  # the scenario's own limit, when it is the lesser
        own = settings.time_limit
        settings = replace(settings, time_limit=seconds if own is None else min(own, seconds))
    return Planner(sc, settings).plan()


def _csv(result) -> bytes:
    from ..planning.export import write_csv

    with tempfile.TemporaryDirectory(prefix="leapfrog-serve-") as folder:
        path = Path(folder) / "result.csv"
        write_csv(result, path, CSV_DT)
        return path.read_bytes()


def answer(job, threads: int = 0) -> tuple[str, object]:
    """The answer to one job (see the module's documentation)."""
    from .._atomic import json_text
    from ..errors import LeapfrogError
    from .view import result_view

    kind, scenario, options, image, seconds = job
    try:
        result = _plan(scenario, options, threads, image, seconds)
        if kind == "view":
            body = json.dumps(result_view(result), allow_nan=False, separators=(",", ":"))
            return "ok", body.encode()
        if kind == "json":
            return "ok", json_text(result.to_dict()).encode()
        if kind == "csv":
            return "ok", _csv(result)
        return "error", f"unknown job {kind!r}"
    except LeapfrogError as e:
        return "bad", " ".join(str(e).splitlines())
    except Exception as e:  # reported as one line; the server stays up
        log.exception("job failed")
        return "error", f"{type(e).__name__}: {' '.join(str(e).splitlines())}"


#: The kinds of the warm-up's messages (every other message answers a job).
WARMING, WARM, WARM_FAILED = "warming", "warm", "warm-failed"


def warm(models, send) -> None:
    """Warm the kernels of ``models`` up here, one after the other, saying where it is through
    ``send`` (see the module's documentation). A model that fails is said and left: the
    others are still warmed up."""
    for model in models:
        send((WARMING, model))
        warm_here(model, send)


def warm_here(model: str, send) -> None:
    """Warm ``model`` up in this process and say ``("warm", model)``, or why it failed."""
    from ..planning.warmup import warm_up

    try:
        warm_up(model)
    except Exception as e:  # said to the server, which refuses plans of that model
        log.exception("warm-up of %s failed", model)
        send((WARM_FAILED, model, f"{type(e).__name__}: {' '.join(str(e).splitlines())}"))
    else:
        send((WARM, model))


def warm_apart(models):
    """A process of its own that warms ``models`` up (it compiles their kernels into the disk
    cache, on a fresh machine), saying where it is, as this one would, on its standard output:
    the process, and the end of the pipe it says it through. It is this module run with
    ``--warm-up`` (the module ``-m`` ran: a test's stand-in runs its own)."""
    from multiprocessing.connection import Connection

    spec = getattr(sys.modules["__main__"], "__spec__", None)
    module = spec.name if spec is not None else __name__
    argv = [sys.executable, "-m", module, "--warm-up", *models]
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE)
    said = Connection(os.dup(proc.stdout.fileno()), writable=False)
    proc.stdout.close()
    return proc, said


def serve(receive, send, models, threads: int) -> None:
    """The process's loop: warm the first of ``models`` up, then answer jobs (the server sends
    only jobs of models already warm) and, between them, load the other models: those in the
    disk cache when nothing is asked, the rest once the process compiling them apart
    (:func:`warm_apart`) says they are there."""
    from multiprocessing.connection import wait

    _as_a_child()
    if models:  # nothing to answer before the first
        send.send((WARMING, models[0]))
        warm_here(models[0], send.send)
    cached = [m for m in models[1:] if _in_disk_cache(m)]  # loaded here: under a second each
    rest = [m for m in models[1:] if m not in cached]
    helper, said = warm_apart(rest) if rest else (None, None)
    while True:
        ready = wait([receive] + ([said] if said else []), timeout=0 if cached else None)
        if receive in ready:
            try:
                job = receive.recv()
            except (EOFError, OSError):  # the server closed the pipe: done
                return
            send.send(answer(job, threads))
        elif said in ready:
            helper, said = _heard(helper, said, rest, send)
        elif cached:  # nothing asked: load the next model in the disk cache
            send.send((WARMING, cached[0]))
            warm_here(cached.pop(0), send.send)


def _in_disk_cache(model: str) -> bool:
    """Whether ``model``'s kernels are in the disk cache; where the look fails (a damaged
    cache), not: the process apart warms it up, and says why if that fails too."""
    from ..planning.warmup import in_disk_cache

    try:
        return in_disk_cache(model)
    except Exception:
        log.warning("could not look the %s kernels up in the disk cache", model, exc_info=True)
        return False


def _heard(helper, said, rest: list[str], send):
    """Pass on what the process compiling ``rest`` apart said (a model it compiled is loaded
    here); returns that process and its pipe, or ``(None, None)`` once it ended."""
    try:
        message = said.recv()
    except (EOFError, OSError):  # the helper ended: what it did not warm up failed
        code = helper.wait()
        for model in rest:
            send.send((WARM_FAILED, model, f"the process compiling it ended (exit {code})"))
        said.close()
        return None, None
    if message[0] == WARM:  # in the disk cache: loaded here, under a second
        warm_here(message[1], send.send)
    else:
        send.send(message)
    if message[0] != WARMING:
        rest.remove(message[1])
    return helper, said


def _as_a_child() -> None:
    """The process dies with its parent; Ctrl-C at the server reaches its whole process group:
    the server ends its workers itself (interrupted inside numba, a process can die of a
    segmentation fault)."""
    from ..batch.orphans import die_with_parent

    die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def main(argv: list[str]) -> None:
    """``python -m leapfrog_planner.web.worker THREADS MODEL...``: jobs arrive on standard
    input and answers leave on the original standard output; the process's own output goes to
    standard error, so that nothing else writes into the pipe. ``... --warm-up MODEL...``: warm
    the models up, saying so there, and end (:func:`warm_apart`)."""
    from multiprocessing.connection import Connection

    out = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.__stdout__ = os.fdopen(1, "w", closefd=False)
    send = Connection(out, readable=False)
    if argv[0] == "--warm-up":
        _as_a_child()
        warm(argv[1:], send.send)
        return
    serve(Connection(0, writable=False), send, argv[1:], int(argv[0]))


if __name__ == "__main__":
    main(sys.argv[1:])
