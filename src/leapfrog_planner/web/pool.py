"""Bounded concurrent solves: worker processes, a short queue, and a time limit per solve.

The planner is compiled code: a solve cannot be interrupted from another thread. Each solve
therefore runs in a worker process (:mod:`.worker`), which is killed when it runs past the time
limit and replaced by a fresh one (warmed up in the background). At most ``workers + queue``
requests are admitted at once; one more is refused at once (:class:`PoolFull`, HTTP 503)
instead of piling up. A request still waiting when a newer one of the same session arrives is
dropped (:class:`Superseded`): the page only wants the answer to its latest edit.

:meth:`SolvePool.start` returns at once: the processes warm up in the background (on a fresh
machine the first compiles the kernels, about 20 s a model), each saying which model it is
at (``preparing`` in :meth:`SolvePool.stats`); while none is ready, a request is refused at once
with that progress (:class:`Preparing`, HTTP 503). :meth:`SolvePool.run` blocks; the web
application calls it from a thread.
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

log = logging.getLogger(__name__)

#: How long a worker may take to start (a fresh machine compiles the kernels: about 20 s a model).
START_TIMEOUT_S = 900.0

#: The module a solver process runs (``python -m WORKER THREADS MODEL...``).
WORKER = "leapfrog_planner.web.worker"


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


def preparing_text(progress: dict) -> str:
    """What ``progress`` (see :meth:`_Worker.progress`) says, in words."""
    done, total, model = progress["models_done"], progress["models"], progress["model"]
    where = f"the {model} kernels, model {done + 1} of {total}, " if model else ""
    return (
        f"the solver is being prepared ({where}{progress['seconds']:.0f} s so far; the first"
        " start on a machine compiles the kernels, about 20 s a model)"
    )


class _Worker:
    """One solver process (``python -m leapfrog_planner.web.worker``), and the two ends of the
    pipes the server talks to it through. A process of its own rather than a multiprocessing
    child: nothing of the server's main module is imported again in it."""

    def __init__(self, models, threads: int):
        argv = [sys.executable, "-m", WORKER, str(threads), *models]
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        self.send = Connection(os.dup(self.proc.stdin.fileno()), readable=False)
        self.recv = Connection(os.dup(self.proc.stdout.fileno()), writable=False)
        self.proc.stdin.close()
        self.proc.stdout.close()
        self.models = tuple(models)
        self.started = time.monotonic()
        self.warming: tuple[int, float] | None = (0, self.started)  # model index, since when
        self.ready = False

    def wait_ready(self, timeout: float) -> None:
        """Wait for ``("ready", pid)``, noting the ``("warming", index)`` messages before it."""
        end = self.started + timeout
        while True:
            if not self.recv.poll(max(0.0, end - time.monotonic())):
                raise WorkerLost(f"a solver process did not start within {timeout:g} s")
            try:
                kind, value = self.recv.recv()
            except EOFError:
                raise WorkerLost(
                    f"a solver process ended as it started (exit code {self.proc.wait()})"
                ) from None
            if kind == "warming":
                self.warming = (int(value), time.monotonic())
            elif kind == "ready":
                return
            else:
                raise WorkerLost(str(value))

    def progress(self) -> dict:
        """Where its warm-up is: the model, how many are done, the seconds so far."""
        index, since = self.warming or (len(self.models), self.started)
        now = time.monotonic()
        return {
            "model": self.models[index] if index < len(self.models) else None,
            "models_done": index,
            "models": len(self.models),
            "model_seconds": round(now - since, 1),
            "seconds": round(now - self.started, 1),
        }

    def call(self, job, limit: float):
        self.send.send(job)
        if not self.recv.poll(limit):
            raise TimeLimit(f"time limit: the solve ran past {limit:g} s and was stopped")
        return self.recv.recv()

    def kill(self) -> None:
        with contextlib.suppress(OSError):
            self.proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(5)
        for conn in (self.send, self.recv):
            with contextlib.suppress(OSError):
                conn.close()


class SolvePool:
    """``workers`` solver processes, at most ``queue`` requests waiting for one, ``time_limit``
    seconds per solve. ``models`` are warmed up in each process before it takes a job."""

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
        self.models, self.threads = tuple(models), threads
        self._idle: queues.Queue[_Worker] = queues.Queue()
        self._all: set[_Worker] = set()
        self._lock = threading.Lock()
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
        alone (on a fresh machine it compiles the kernels into the disk cache), then the others
        together (they load them from there). :meth:`wait_ready` waits for the first."""
        if self._started:
            return
        self._started = True
        first = self._spawn()
        threading.Thread(target=self._start_rest, args=(first,), daemon=True).start()

    def _start_rest(self, first: _Worker) -> None:
        self._ready(first)
        for _ in range(self.workers - 1):
            if self._closed:
                return
            try:
                w = self._spawn()
            except (OSError, RuntimeError) as e:  # RuntimeError: the pool closed meanwhile
                log.error("could not start a solver process: %s", e)
                return
            threading.Thread(target=self._ready, args=(w,), daemon=True).start()

    def wait_ready(self, timeout: float = START_TIMEOUT_S) -> bool:
        """Wait until a process is ready (true), none is left starting, or ``timeout`` s."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self._lock:
                if any(w.ready for w in self._all):
                    return True
                if not self._all or self._closed:
                    return False
            time.sleep(0.05)
        return False

    def _spawn(self) -> _Worker:
        w = self._spawner.submit(_Worker, self.models, self.threads).result()
        with self._lock:
            self._all.add(w)
        return w

    def _ready(self, w: _Worker) -> None:
        try:
            w.wait_ready(START_TIMEOUT_S)
        except (PoolError, EOFError, OSError) as e:
            if not self._closed:  # not a server stopped while its solver was being prepared
                log.error("solver process failed to start: %s", e)
            self._drop(w)
            return
        with self._lock:
            w.warming, w.ready = None, not self._closed
        if self._closed:
            self._drop(w)
        else:
            self._idle.put(w)

    def _drop(self, w: _Worker) -> None:
        w.kill()
        with self._lock:
            self._all.discard(w)

    def _replace(self, w: _Worker) -> None:
        """Kill ``w`` and start another in its place (warmed up in the background)."""
        self._drop(w)
        if not self._closed:
            fresh = self._spawn()
            threading.Thread(target=self._ready, args=(fresh,), daemon=True).start()

    def close(self) -> None:
        self._closed = True
        self._spawner.shutdown(wait=False)
        with self._lock:
            workers = list(self._all)
            self._all.clear()
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

    def run(self, job, stale: Callable[[], bool] | None = None):
        """The worker's answer to ``job`` (call it inside :meth:`admitted`, from a thread).
        ``stale`` is asked once a worker is free: true drops the job (:class:`Superseded`).
        While no process is ready yet and one is warming up, :class:`Preparing` at once."""
        self._check_prepared()
        w = self._next_idle()
        if stale is not None and stale():
            self._idle.put(w)
            with self._lock:
                self.counts["superseded"] += 1
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
        self._idle.put(w)
        self._count("solved")
        return out

    def _next_idle(self) -> _Worker:
        while True:
            try:
                return self._idle.get(timeout=0.5)
            except queues.Empty:
                with self._lock:
                    alive = bool(self._all)
            if not alive or self._closed:
                raise WorkerLost("no solver process is running (see the server's log)")

    def _check_prepared(self) -> None:
        with self._lock:
            if any(w.ready for w in self._all):
                return
            progress = self._preparing()
        if progress is None:
            return  # nothing starting: _next_idle says no process is running
        self._count("not_ready")
        raise Preparing(f"{preparing_text(progress)}; try again when /api/health says ready")

    def _preparing(self) -> dict | None:
        """The progress of the warm-up furthest along (call it holding the lock)."""
        warming = [w for w in self._all if w.warming is not None]
        if not warming:
            return None
        return max((w.progress() for w in warming), key=lambda p: p["models_done"])

    def _count(self, key: str) -> None:
        with self._lock:
            self.counts[key] += 1

    def stats(self) -> dict:
        with self._lock:
            return {
                "workers": self.workers,
                "ready": sum(w.ready for w in self._all),
                "preparing": self._preparing(),
                "busy": self._busy,
                "admitted": self._admitted,
                "capacity": self.capacity,
                "time_limit_s": self.time_limit,
                "pids": sorted(w.proc.pid for w in self._all if w.proc.pid),
                **self.counts,
            }
