"""Where a sweep's pairs run: local worker processes, or an existing Dask distributed cluster.

Both engines call ``on_record(record)`` in the sweep's process, once per pair, as pairs finish.

Local (:class:`LocalEngine`): a ``concurrent.futures.ProcessPoolExecutor`` with at most one pair
in flight per worker, so the sweep knows when each pair started. A pair over its time limit is
stopped inside the worker (SIGALRM); one that ignores it (stuck in compiled code) is killed with
its worker after ``kill_grace`` more seconds and recorded as a timeout. A worker that dies takes
the pairs in flight with it: those are re-run one at a time, and the one that kills its worker
again is recorded as a crash; the others complete normally.

Dask (:class:`DaskEngine`): pairs go in chunks (one Dask task runs several pairs) so that the
scheduler's per-task cost is small against the planning time. Dask itself re-runs the tasks of a
worker that died; a chunk that keeps killing workers ends in ``KilledWorker`` and is split into
single pairs, and a single pair that kills workers is recorded as a crash. Time limits are
checked inside the worker at each Leapfrog progress event (Dask runs tasks in threads, where no
alarm signal can interrupt them). A chunk still processing after twice its pairs' time limits
plus ``kill_grace`` has its worker restarted (through the worker's nanny) and is split into
single pairs; a single pair that hangs so is recorded as a timeout.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import os
import tempfile
import threading
import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from .orphans import mark_parent
from .tasks import (
    PairTask,
    SweepError,
    SweepSettings,
    failure_record,
    init_local_worker,
    run_chunk,
    run_task,
)

#: The longest path of a Unix socket (``sun_path`` less its final NUL on Linux).
UNIX_SOCKET_PATH = 107
#: What multiprocessing adds to the temporary directory for the forkserver's socket:
#: ``/pymp-XXXXXXXX/listener-XXXXXXXX``.
_FORKSERVER_SOCKET = len("/pymp-xxxxxxxx/listener-xxxxxxxx")


def forkserver_fits(tempdir: str) -> bool:
    """Whether the forkserver's socket can be made in ``tempdir``: under a long ``TMPDIR``
    starting it fails with "AF_UNIX path too long"."""
    return len(os.fsencode(tempdir)) + _FORKSERVER_SOCKET <= UNIX_SOCKET_PATH


def _context():
    # forkserver: workers are forked from a clean, thread-free server (the sweep's own process
    # runs the progress display's thread; forking it would be unsafe). Spawned workers where
    # there is no forkserver, or no room for its socket's path.
    mark_parent()  # the pool's processes check that they start while the sweep lives
    methods = mp.get_all_start_methods()
    if "forkserver" not in methods or not forkserver_fits(tempfile.gettempdir()):
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["leapfrog_planner.batch._forkserver_preload"])  # see .orphans
    return ctx


class LocalEngine:
    name = "local"

    def __init__(self, settings: SweepSettings):
        self.workers = int(settings.workers)
        self.limit = float(settings.time_limit)
        self.grace = float(settings.kill_grace)

    def close(self) -> None:
        pass

    def _pool(self, started) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=_context(),
            initializer=init_local_worker,
            initargs=(started,),
        )

    def run(self, tasks: list[PairTask], on_record) -> None:
        # started[i]: when pair i began in its worker (0: not yet); see sweep.init_local_worker
        started = _context().RawArray("d", max(t.index for t in tasks) + 1)
        pending = deque(tasks)
        suspects: deque[PairTask] = deque()  # in flight when a worker died: re-run alone
        inflight: dict = {}  # future -> (task, start time, ran alone)
        pool = self._pool(started)

        def submit(t: PairTask, alone: bool) -> bool:
            """False when the pool is already broken (a worker died since the last check)."""
            started[t.index] = 0.0
            try:
                inflight[pool.submit(run_task, t)] = (t, time.monotonic(), alone)
            except BrokenProcessPool:
                return False
            return True

        try:
            while pending or suspects or inflight:
                pool_broke = False
                if suspects:
                    if not inflight:
                        if submit(suspects[0], True):
                            suspects.popleft()
                        else:
                            pool_broke = True
                else:
                    while pending and len(inflight) < self.workers:
                        if not submit(pending[0], False):
                            pool_broke = True
                            break
                        pending.popleft()
                done, _ = wait(list(inflight), timeout=0.25, return_when=FIRST_COMPLETED)
                broken = []
                for f in done:
                    t, start, alone = inflight.pop(f)
                    try:
                        on_record(f.result())
                    except BrokenProcessPool:
                        broken.append((t, start, alone))
                    except Exception as exc:  # e.g. a result that cannot be unpickled
                        on_record(failure_record(t, "error", f"{type(exc).__name__}: {exc}"))
                now = time.monotonic()
                overdue = {
                    t.index
                    for t, _, _ in inflight.values()
                    if started[t.index] > 0 and now - started[t.index] > self.limit + self.grace
                }
                if overdue:
                    _kill_workers(pool)
                if broken or overdue or pool_broke:
                    # Every pair still in flight fails with the pool; collect them all. (A pool
                    # can also be found broken by submit, before any future reports it.)
                    rest, _ = wait(list(inflight), timeout=30)
                    for f in rest:
                        t, start, alone = inflight.pop(f)
                        try:
                            on_record(f.result())
                        except Exception:
                            broken.append((t, start, alone))
                    for f, (t, start, alone) in list(inflight.items()):  # never returned
                        broken.append((t, start, alone))
                        del inflight[f]
                    for t, start, alone in sorted(broken, key=lambda b: b[0].index):
                        began = started[t.index] or start
                        elapsed = now - began
                        if t.index in overdue:
                            on_record(
                                failure_record(
                                    t,
                                    "timeout",
                                    f"still running after {elapsed:.1f} s, past the"
                                    f" time limit {self.limit:g} s: worker killed",
                                    elapsed,
                                )
                            )
                        elif alone:
                            on_record(
                                failure_record(t, "crash", "the worker process died", elapsed)
                            )
                        elif overdue:
                            pending.appendleft(t)  # killed because of another pair: innocent
                        else:
                            suspects.append(t)
                    pool.shutdown(wait=False, cancel_futures=True)
                    pool = self._pool(started)
        finally:
            if inflight:  # interrupted: do not wait for pairs whose results nobody records
                _kill_workers(pool)
            pool.shutdown(wait=True, cancel_futures=True)


def _kill_workers(pool: ProcessPoolExecutor) -> None:
    # concurrent.futures has no public way to stop a running call; its worker processes are
    # in the (long-stable) private mapping _processes.
    for p in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            p.kill()
        except (OSError, ValueError):
            pass


class DaskEngine:
    name = "dask"

    def __init__(self, address: str, settings: SweepSettings):
        try:
            from distributed import Client
        except ImportError:
            raise SweepError(
                "--scheduler needs Dask: pip install 'leapfrog-planner[cluster]'"
            ) from None
        self.settings = settings
        try:
            self.client = Client(address, timeout="5s", set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise SweepError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from None

    def chunk_size(self, n: int) -> int:
        """About 8 chunks per worker thread: the workers that finish first idle for about half
        a chunk at the end (measured with 4 per thread on 200 pairs and 2 workers: 12% of the
        compute time; with 8: 5%, with 16: 5%, each chunk costing a scheduler round trip)."""
        if self.settings.chunk_size:
            return int(self.settings.chunk_size)
        threads = max(1, sum(self.client.nthreads().values()))
        return max(1, min(64, math.ceil(n / (8 * threads))))

    def run(self, tasks: list[PairTask], on_record) -> None:
        from distributed import as_completed

        live: dict = {}  # key -> (future, chunk)
        seen: dict = {}  # key -> when the scheduler was first seen to have it processing
        self._innocent: set = set()  # keys on a worker restarted because of another chunk
        k = self.chunk_size(len(tasks))
        waiting = deque(tasks[i : i + k] for i in range(0, len(tasks), k))
        ac = as_completed([], loop=self.client.loop, with_results=False)  # our own client

        def submit(chunk):
            f = self.client.submit(run_chunk, chunk, pure=False)
            live[f.key] = (f, chunk)
            ac.add(f)

        try:
            # No more chunks in flight than worker threads: a chunk is then running, not queued,
            # from its submission, which the hang watchdog needs. Dask still places the tasks,
            # moves the data and replaces dead workers.
            slots = self._threads()
            checked = time.monotonic()
            while live or waiting:
                while waiting and len(live) < slots:
                    submit(waiting.popleft())
                batch = ac.next_batch(block=False) if ac.has_ready() else []
                for f in batch:
                    if f.key in live:  # not one the watchdog gave up on
                        _, chunk = live.pop(f.key)
                        self._collect(f, chunk, on_record, waiting)
                if not batch:
                    time.sleep(0.01)
                if time.monotonic() - checked > 1.0:
                    checked = time.monotonic()
                    slots = self._threads()
                    self._watchdog(live, seen, on_record, waiting)
        except BaseException:  # interrupted: the cluster should not go on with our work
            self.client.cancel([f for f, _ in live.values()])
            raise

    def _executing(self, key) -> bool | None:
        """Whether a worker thread runs ``key`` now; None when the workers do not answer in 5 s.

        Asked from a daemon thread: a worker stuck while holding the GIL cannot answer.
        """
        answer: list = []

        def ask():
            try:
                answer.append(any(key in v for v in self.client.call_stack(keys=[key]).values()))
            except Exception:
                answer.append(None)

        th = threading.Thread(target=ask, daemon=True)
        th.start()
        th.join(5.0)
        return answer[0] if answer else None

    def _threads(self) -> int:
        try:
            return max(1, sum(self.client.nthreads().values()))
        except Exception:  # the scheduler is busy: keep going with one chunk at a time
            return 1

    def _collect(self, f, chunk, on_record, waiting) -> None:
        from distributed.client import FutureCancelledError
        from distributed.scheduler import KilledWorker

        try:
            records = f.result()
        except KilledWorker:
            if f.key in self._innocent:  # its worker was restarted for another chunk's hang
                self._innocent.discard(f.key)
                waiting.appendleft(chunk)
            elif len(chunk) > 1:  # find the culprit: one pair per task
                waiting.extendleft([t] for t in reversed(chunk))
            else:
                on_record(
                    failure_record(chunk[0], "crash", "killed its Dask worker (KilledWorker)")
                )
            return
        except (FutureCancelledError, Exception) as exc:
            msg = " ".join(f"{type(exc).__name__}: {exc}".split())[:500]
            for t in chunk:
                on_record(failure_record(t, "error", msg))
            return
        finally:
            f.release()
        for r in records:
            on_record(r)

    def _watchdog(self, live, seen, on_record, waiting) -> None:
        """Restart the worker of a chunk far past its time limits: a hang the limit missed.

        The budget is twice the chunk's limits plus the grace: generous, since the clock starts
        when the scheduler reports the chunk processing (this also counts the transfer).
        """
        now = time.monotonic()
        try:
            processing = self.client.processing()
        except Exception:  # the scheduler is busy or away: check again later
            return
        for addr, keys in processing.items():
            for key in keys:
                if key not in live:
                    continue
                start = seen.setdefault(key, now)
                f, chunk = live[key]
                budget = 2 * len(chunk) * self.settings.time_limit + self.settings.kill_grace
                if now - start <= budget:
                    continue
                if self._executing(key) is False:  # still unpacking (a new worker's imports)
                    seen[key] = now
                    continue
                del live[key]
                f.cancel()
                self._innocent.update(k for k in keys if k in live)
                try:
                    self.client.restart_workers([addr], raise_for_error=False)
                except Exception:  # no nanny: the worker stays stuck, the sweep goes on
                    pass
                if len(chunk) == 1:
                    on_record(
                        failure_record(
                            chunk[0],
                            "timeout",
                            f"still running after {now - start:.1f} s, past the time limit"
                            f" {self.settings.time_limit:g} s: Dask worker restarted",
                            now - start,
                        )
                    )
                else:
                    waiting.extendleft([t] for t in reversed(chunk))
        for key in [k for k in seen if k not in live]:
            del seen[key]

    def close(self) -> None:
        self.client.close()
