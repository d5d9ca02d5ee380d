"""Bounded concurrent solves: worker processes, a short queue, and a time limit per solve.

The planner is compiled code: a solve cannot be interrupted from another thread. Each solve
therefore runs in a worker process (:mod:`.worker`), which is killed when it runs past the time
limit and replaced by a fresh one (warmed up in the background). At most ``workers + queue``
requests are admitted at once; one more is refused at once (:class:`PoolFull`, HTTP 503)
instead of piling up. A request still waiting when a newer one of the same session arrives is
dropped (:class:`Superseded`): the page only wants the answer to its latest edit.

:meth:`SolvePool.start` returns at once. Each process warms its models up one after the
other, in their order (on a fresh machine the first process compiles the kernels, about 20 s a
model; the others start once it is done and load them from the disk cache), and takes jobs as
soon as its first model is warm (see :mod:`.worker`): a plan is sent only to a process that has
warmed that plan's model up. While none has, the plan is refused at once with the warm-up's
progress (:class:`Preparing`, HTTP 503).
:meth:`SolvePool.stats` says each model's state (:data:`WAITING`, :data:`COMPILING`,
:data:`READY`, :data:`FAILED`) and where the warm-up is (``preparing``). :meth:`SolvePool.run`
blocks; the web application calls it from a thread.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue as queues
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.connection import Connection

from .worker import WARM, WARM_FAILED, WARMING

log = logging.getLogger(__name__)

#: How long a worker may take to warm up (a fresh machine compiles the kernels: 20 s a model).
START_TIMEOUT_S = 900.0

#: The module a solver process runs (``python -m WORKER THREADS MODEL...``).
WORKER = "leapfrog_planner.web.worker"

#: A model's state in a solver process, and in :meth:`SolvePool.stats` (the best among the
#: processes; :data:`STOPPED` when none is running).
WAITING, COMPILING, READY, FAILED, STOPPED = "waiting", "compiling", "ready", "failed", "stopped"


class PoolError(Exception):
    """A solve that was not done; ``status`` is the HTTP status to answer with."""

    status = 500


class PoolFull(PoolError):
    status = 503


class TimeLimit(PoolError):
    status = 504


class Superseded(PoolError):
    status = 409


class WorkerLost(PoolError):
    status = 500


class Preparing(PoolError):
    """No solver process is ready yet: they are loading (or compiling) the kernels."""

    status = 503
    headers = {"Retry-After": "2"}


def preparing_text(progress: dict, model: str | None = None) -> str:
    """What ``progress`` (see :meth:`_Worker.progress`) says, in words, for a plan of ``model``
    (by default the one being warmed up)."""
    done, total, at = progress["models_done"], progress["models"], progress["model"]
    seconds = f"{progress['seconds']:.0f} s so far"
    if at:  # the seconds on that model, and in all
        seconds = f"{progress['model_seconds']:.0f} s on them, {progress['seconds']:.0f} s in all"
    where = f"the {at} kernels, model {done + 1} of {total}, " if at else ""
    if model is not None and at is not None and model != at:
        where = f"the {model} kernels after the {at} kernels, model {done + 1} of {total}, "
    return (
        f"the solver is being prepared ({where}{seconds}; the first start on a machine"
        " compiles the kernels, about 20 s a model)"
    )


class _Worker:
    """One solver process (``python -m leapfrog_planner.web.worker``), the two ends of the
    pipes the server talks to it through, and where its warm-up is. A process of its own rather
    than a multiprocessing child: nothing of the server's main module is imported again in it.

    A thread reads everything the process says: the warm-up's messages update :attr:`state`
    (under the pool's ``lock``, which it notifies), the answers wait in :attr:`answers` for
    :meth:`call`."""

    def __init__(self, models, threads: int, lock: threading.Condition):
        argv = [sys.executable, "-m", WORKER, str(threads), *models]
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self.send = Connection(os.dup(self.proc.stdin.fileno()), readable=False)
        self.recv = Connection(os.dup(self.proc.stdout.fileno()), writable=False)
        self.proc.stdin.close()
        self.proc.stdout.close()
        self.models = tuple(models)
        self.started = time.monotonic()
        self.state = dict.fromkeys(self.models, WAITING)  # model -> WAITING, COMPILING, ...
        self.since = self.started  # when the model being warmed up began
        self.failures: dict[str, str] = {}  # model -> why its warm-up failed
        self.ended = False  # the process ended (or its pipe broke)
        self.warmed = threading.Event()  # every model warm (or failed), or the process ended
        self.answers: queues.Queue = queues.Queue()  # the answers; None once the process ended
        self._lock = lock
        self.reader = threading.Thread(target=self._listen, name="leapfrog-serve-read")
        self.reader.daemon = True
        self.reader.start()

    def _listen(self) -> None:
        while True:
            try:
                message = self.recv.recv()
            except (EOFError, OSError):
                break
            if message[0] in (WARMING, WARM, WARM_FAILED):
                self._note(*message)
            else:
                self.answers.put(message)
        self.answers.put(None)
        with self._lock:
            self.ended = True
            self.warmed.set()
            self._lock.notify_all()

    def _note(self, kind: str, model: str, why: str = "") -> None:
        """A message of the warm-up: ``model`` is being warmed up, warm, or failed (``why``)."""
        with self._lock:
            if kind == WARMING:
                self.state[model], self.since = COMPILING, time.monotonic()
            elif kind == WARM:
                self.state[model] = READY
            else:
                self.state[model], self.failures[model] = FAILED, why
                log.error("a solver process could not prepare the %s kernels: %s", model, why)
            if all(s in (READY, FAILED) for s in self.state.values()):
                self.warmed.set()
            self._lock.notify_all()

    def serves(self, model: str | None) -> bool:
        """Whether a plan of ``model`` can be sent to it: warm (a model it does not warm up,
        compiled by the plan itself, always can). A process that ended since is found out by
        the job sent (and replaced)."""
        return self.state.get(model, READY) == READY

    @property
    def ready(self) -> bool:
        """Every model warm."""
        return all(s == READY for s in self.state.values())

    @property
    def warming(self) -> bool:
        return not self.warmed.is_set()

    def progress(self) -> dict:
        """Where its warm-up is: the model (the one being warmed up, else the next), how many
        are done, the seconds so far."""
        now = time.monotonic()
        compiling = next((m for m, s in self.state.items() if s == COMPILING), None)
        at = compiling or next((m for m, s in self.state.items() if s == WAITING), None)
        return {
            "model": at,
            "models_done": sum(s in (READY, FAILED) for s in self.state.values()),
            "models": len(self.models),
            "model_seconds": round(now - self.since, 1) if compiling else 0.0,
            "seconds": round(now - self.started, 1),
        }

    def call(self, job, limit: float):
        self.send.send(job)
        try:
            out = self.answers.get(timeout=limit)
        except queues.Empty:
            raise TimeLimit(f"time limit: the solve ran past {limit:g} s and was stopped") from None
        if out is None:
            raise EOFError("the solver process ended")
        return out

    def kill(self) -> None:
        with contextlib.suppress(OSError):
            self.proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(5)
        if self.reader is not threading.current_thread():
            self.reader.join(1.0)  # it reads the end of the pipe: closed after that
        for conn in (self.send, self.recv):
            with contextlib.suppress(OSError):
                conn.close()


#: The share of the server's time limit that a plan is given as its own ``time_limit``: it then
#: ends with the best answer found so far, said in its message, and the page draws it; a solve
#: still running at the server's limit (one step that cannot stop) is stopped (504).
PLAN_SHARE = 0.8


class SolvePool:
    """``workers`` solver processes, at most ``queue`` requests waiting for one, ``time_limit``
    seconds per solve. Each process warms ``models`` up, in that order, while it takes jobs."""

    def __init__(
        self,
        workers: int = 2,
        queue: int = 32,
        time_limit: float = 20.0,
        models=("unicycle", "diff-drive", "car"),
        threads: int = 0,
    ):
        if workers < 1 or queue < 0 or not time_limit > 0:
            raise ValueError("workers >= 1, queue >= 0 and time_limit > 0 are required")
        self.workers, self.queue, self.time_limit = workers, queue, float(time_limit)
        self.plan_limit = PLAN_SHARE * self.time_limit  # a plan's own time limit (seconds)
        self.models, self.threads = tuple(models), threads
        # One lock over the pool and its processes' warm-up states; notified on every change
        # (a process idle again, a model warm, a process gone), which a waiting request checks.
        self._lock = threading.Condition()
        self._idle: list[_Worker] = []
        self._all: set[_Worker] = set()
        self._admitted = 0
        self._busy = 0
        self._closed = False
        self._started = False
        # Every process is started from this one thread, which lives as long as the pool: a
        # worker asks the kernel to kill it when the thread that started it ends (measured:
        # started from a short-lived thread, workers were killed under load, exit -9).
        self._spawner = ThreadPoolExecutor(1, thread_name_prefix="leapfrog-serve-spawn")
        self.counts = {
            "solved": 0,
            "time_limit": 0,
            "full": 0,
            "superseded": 0,
            "lost": 0,
            "not_ready": 0,
        }

    # ------------------------------------------------------------------ life cycle

    def start(self) -> None:
        """Start the processes and return at once; they warm up in the background: the first
        alone (on a fresh machine it compiles the kernels into the disk cache), then, once it
        has warmed every model up, the others together (they load them from there). Each takes
        jobs of the models it has warmed up meanwhile. :meth:`wait_ready` waits for the first
        to warm every model up."""
        if self._started:
            return
        self._started = True
        first = self._spawn()
        threading.Thread(target=self._start_rest, args=(first,), daemon=True).start()

    def _start_rest(self, first: _Worker) -> None:
        self._watch(first)
        for _ in range(self.workers - 1):
            if self._closed:
                return
            try:
                w = self._spawn()
            except (OSError, RuntimeError) as e:  # RuntimeError: the pool closed meanwhile
                log.error("could not start a solver process: %s", e)
                return
            threading.Thread(target=self._watch, args=(w,), daemon=True).start()

    def wait_ready(self, timeout: float = START_TIMEOUT_S) -> bool:
        """Wait until a process has warmed every model up (true), none is left warming up (a
        model's warm-up failed, or no process is running), or ``timeout`` s."""
        end = time.monotonic() + timeout
        with self._lock:
            while True:
                if any(w.ready for w in self._all):
                    return True
                left = end - time.monotonic()
                if not any(w.warming for w in self._all) or self._closed or left <= 0:
                    return False
                self._lock.wait(min(left, 0.5))

    def _spawn(self) -> _Worker:
        """A new process, idle at once: it takes jobs of the models it has warmed up."""
        w = self._spawner.submit(_Worker, self.models, self.threads, self._lock).result()
        with self._lock:
            self._all.add(w)
            self._idle.append(w)
            self._lock.notify_all()
        return w

    def _watch(self, w: _Worker) -> None:
        """Wait for ``w``'s warm-up to end; a process that ended meanwhile, or took longer than
        :data:`START_TIMEOUT_S`, is said and dropped."""
        if not w.warmed.wait(START_TIMEOUT_S):
            why = f"it did not warm up within {START_TIMEOUT_S:g} s"
        elif w.ended:
            why = f"it ended as it started (exit code {w.proc.wait()})"
        else:
            return
        if not self._closed:  # not a server stopped while its solver was being prepared
            log.error("solver process failed to start: %s", why)
        self._drop(w)

    def _drop(self, w: _Worker) -> None:
        w.kill()
        with self._lock:
            self._all.discard(w)
            if w in self._idle:
                self._idle.remove(w)
            self._lock.notify_all()

    def _replace(self, w: _Worker) -> None:
        """Kill ``w`` and start another in its place (warmed up in the background)."""
        self._drop(w)
        if not self._closed:
            fresh = self._spawn()
            threading.Thread(target=self._watch, args=(fresh,), daemon=True).start()

    def close(self) -> None:
        self._closed = True
        self._spawner.shutdown(wait=False)
        with self._lock:
            workers = list(self._all)
            self._all.clear()
            self._idle.clear()
            self._lock.notify_all()
        for w in workers:
            w.kill()

    # ------------------------------------------------------------------ solving

    @property
    def capacity(self) -> int:
        return self.workers + self.queue

    @contextlib.contextmanager
    def admitted(self):
        """A place among the ``workers + queue`` requests in the pool, or :class:`PoolFull`."""
        with self._lock:
            if self._closed or self._admitted >= self.capacity:
                self.counts["full"] += 1
                raise PoolFull(
                    f"busy: {self._admitted} requests are being solved or waiting (at most"
                    f" {self.capacity}); try again shortly"
                )
            self._admitted += 1
        try:
            yield
        finally:
            with self._lock:
                self._admitted -= 1

    def run(self, job, stale: Callable[[], bool] | None = None, model: str | None = None):
        """The worker's answer to ``job``, a plan of ``model`` (by default the first of the
        pool's models); call it inside :meth:`admitted`, from a thread. ``stale`` is asked once
        a worker is free: true drops the job (:class:`Superseded`). While no process has warmed
        ``model`` up and one is warming it up, :class:`Preparing` at once."""
        if model is None and self.models:
            model = self.models[0]
        self._check_prepared(model)
        w = self._next_idle(model)
        if stale is not None and stale():
            self._put_back(w)
            self._count("superseded")
            raise Superseded("superseded by a newer request")
        with self._lock:
            self._busy += 1
        t0 = time.perf_counter()
        try:
            out = w.call(job, self.time_limit)
        except TimeLimit:
            log.warning("solve stopped at the time limit (%.3g s)", time.perf_counter() - t0)
            self._count("time_limit")
            self._replace(w)
            raise
        except (EOFError, OSError) as e:
            self._count("lost")
            code = w.proc.poll()
            self._replace(w)
            raise WorkerLost(f"the solver process ended unexpectedly (exit code {code})") from e
        finally:
            with self._lock:
                self._busy -= 1
        self._put_back(w)
        self._count("solved")
        return out

    def _put_back(self, w: _Worker) -> None:
        with self._lock:
            if w in self._all:
                self._idle.append(w)
            self._lock.notify_all()

    def _next_idle(self, model: str | None) -> _Worker:
        """An idle process that has warmed ``model`` up (the first to be), taken."""
        with self._lock:
            while True:
                w = next((w for w in self._idle if w.serves(model)), None)
                if w is not None:
                    self._idle.remove(w)
                    return w
                if self._model_state(model) == FAILED:
                    raise PoolError(self._failure(model))
                if not self._all or self._closed:
                    raise WorkerLost("no solver process is running (see the server's log)")
                self._lock.wait(0.5)

    def _check_prepared(self, model: str | None) -> None:
        with self._lock:
            if any(w.serves(model) for w in self._all):
                return
            failed = self._model_state(model) == FAILED
            why = self._failure(model) if failed else ""
            progress = self._preparing()
        if failed:
            raise PoolError(why)
        if progress is None:
            return  # nothing starting: _next_idle says no process is running
        self._count("not_ready")
        then = f"try again when /api/health says the {model} is ready"
        raise Preparing(f"{preparing_text(progress, model)}; {then}")

    def _failure(self, model: str | None) -> str:
        """Why no process could warm ``model`` up (call it holding the lock)."""
        why = next((w.failures[model] for w in self._all if model in w.failures), "")
        return f"the solver could not prepare the {model} kernels: {why}"

    def _model_state(self, model: str | None) -> str:
        """The best state of ``model`` among the processes (call it holding the lock)."""
        states = {w.state.get(model, READY) for w in self._all}
        return next((s for s in (READY, COMPILING, WAITING, FAILED) if s in states), STOPPED)

    def _preparing(self) -> dict | None:
        """The progress of the warm-up furthest along (call it holding the lock)."""
        warming = [w for w in self._all if w.warming]
        if not warming:
            return None
        return max((w.progress() for w in warming), key=lambda p: p["models_done"])

    def _count(self, key: str) -> None:
        with self._lock:
            self.counts[key] += 1

    def stats(self) -> dict:
        """The pool's state: ``ready``, the processes that have warmed every model up;
        ``models``, each model's state (:data:`READY` when a process can plan it now);
        ``preparing``, where the warm-up furthest along is (``None`` when none is under way);
        and the counts."""
        with self._lock:
            return {
                "workers": self.workers,
                "ready": sum(w.ready for w in self._all),
                "models": {m: self._model_state(m) for m in self.models},
                "preparing": self._preparing(),
                "busy": self._busy,
                "admitted": self._admitted,
                "capacity": self.capacity,
                "time_limit_s": self.time_limit,
                # live processes only: one that ended may wait a moment for its watcher
                "pids": sorted(w.proc.pid for w in self._all if w.proc.pid and not w.ended),
                **self.counts,
            }
