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
alarm signal can interrupt them).
"""

from __future__ import annotations

import math
import multiprocessing as mp
import time
from collections import deque
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from .sweep import (
    PairTask,
    SweepError,
    SweepSettings,
    failure_record,
    init_local_worker,
    run_task,
)


def _context():
    # forkserver: workers are forked from a clean, thread-free server (the sweep's own process
    # runs the progress display's thread; forking it would be unsafe).
    methods = mp.get_all_start_methods()
    return mp.get_context("forkserver" if "forkserver" in methods else "spawn")


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
        try:
            while pending or suspects or inflight:
                if suspects:
                    if not inflight:
                        t = suspects.popleft()
                        started[t.index] = 0.0
                        inflight[pool.submit(run_task, t)] = (t, time.monotonic(), True)
                else:
                    while pending and len(inflight) < self.workers:
                        t = pending.popleft()
                        started[t.index] = 0.0
                        inflight[pool.submit(run_task, t)] = (t, time.monotonic(), False)
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
                if broken or overdue:
                    # Every pair still in flight fails with the pool; collect them all.
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
        if self.settings.chunk_size:
            return int(self.settings.chunk_size)
        threads = max(1, sum(self.client.nthreads().values()))
        return max(1, min(64, math.ceil(n / (4 * threads))))

    def run(self, tasks: list[PairTask], on_record) -> None:
        from distributed import as_completed
        from distributed.client import FutureCancelledError
        from distributed.scheduler import KilledWorker

        from .sweep import run_chunk

        live: dict = {}  # key -> (future, chunk)

        def submit(chunk):
            f = self.client.submit(run_chunk, chunk, pure=False)
            live[f.key] = (f, chunk)
            return f

        try:
            k = self.chunk_size(len(tasks))
            ac = as_completed(
                [submit(tasks[i : i + k]) for i in range(0, len(tasks), k)],
                loop=self.client.loop,  # our client is not the process's default one
                with_results=False,
            )
            for f in ac:
                _, chunk = live.pop(f.key)
                try:
                    records = f.result()
                except KilledWorker:
                    if len(chunk) > 1:  # find the culprit: one pair per task
                        for t in chunk:
                            ac.add(submit([t]))
                    else:
                        on_record(
                            failure_record(
                                chunk[0], "crash", "killed its Dask worker (KilledWorker)"
                            )
                        )
                    continue
                except (FutureCancelledError, Exception) as exc:
                    msg = " ".join(f"{type(exc).__name__}: {exc}".split())[:500]
                    for t in chunk:
                        on_record(failure_record(t, "error", msg))
                    continue
                finally:
                    f.release()
                for r in records:
                    on_record(r)
        except BaseException:  # interrupted: the cluster should not go on with our work
            self.client.cancel([f for f, _ in live.values()])
            raise

    def close(self) -> None:
        self.client.close()
