"""The sweep's results file: JSON Lines, append-only, safe against a kill at any moment.

One line per finished (scenario, method) pair. A line is written with a single ``os.write`` on a
descriptor opened with ``O_APPEND`` and followed by ``fsync``: after a crash or ``SIGKILL`` the
file holds whole lines plus at most one torn last line (a write cut short by power loss or a full
disk). Readers ignore a final line without its newline; :meth:`ResultStore.open` cuts it off
before appending, so the file stays valid JSON Lines.

While a sweep writes, it holds an exclusive ``flock`` on the file: a second sweep on the same file
fails at once instead of interleaving lines.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
from collections.abc import Iterable
from pathlib import Path

from .._atomic import write_atomic
from ..checks import finite_number
from ..errors import LeapfrogError

__all__ = ["ResultStore", "StoreError", "read_records", "record_key", "strip_timings"]


class StoreError(LeapfrogError, ValueError):
    """A results file that cannot be used (a bad line in the middle, locked by another sweep)."""


def record_key(rec: dict) -> tuple[str, str]:
    """What identifies a pair in the file: scenario name and method."""
    return rec["scenario"], rec["method"]


def strip_timings(rec: dict) -> dict:
    """The record without its timing fields (names ending in ``_s``) and host details."""
    return {k: v for k, v in rec.items() if not k.endswith("_s") and k not in ("worker",)}


#: What a sweep records of a pair that failed (batch/tasks.py), and a record's statuses.
FAILURES = ("solver", "collides", "timeout", "crash", "error")
STATUSES = ("converged", "failed")
#: A record's fields by what they hold (batch/tasks.py writes them); a field not named here
#: is free. Each may be null or absent, but the names and the status.
_NAMES = ("scenario", "method")  # text on one line, not empty
_NUMBERS = ("cost", "min_clearance", "end_state_error", "cheaper_motion")  # finite
_TIMES = ("wall_time_s", "task_time_s", "warmup_s")  # finite, >= 0
_COUNTS = ("newton_iterations", "f_evals", "sweeps", "obstacles")  # integers >= 0
_TEXT = ("message", "final_solver", "scenario_hash", "settings_hash", "worker")


def record_fault(rec) -> str | None:
    """What is wrong with a sweep record (a line of the results file), or None: the report and
    a resumed sweep read these fields as what :func:`..batch.tasks` writes there."""
    if not isinstance(rec, dict):
        return "not a sweep record (a JSON object)"
    for key in (*_NAMES, "status"):
        if key not in rec:
            return f"not a sweep record (no {key})"
    for key in _NAMES:
        v = rec[key]
        if not isinstance(v, str) or not v or any(ord(c) < 32 or ord(c) == 127 for c in v):
            return f"{key}: expected a name on one line, got {_kind(v)}"
    if rec["status"] not in STATUSES:
        return f"status: expected converged or failed, got {_kind(rec['status'])}"
    if rec.get("failure") is not None and rec["failure"] not in FAILURES:
        return (
            f"failure: expected one of {', '.join(FAILURES)} or null, got {_kind(rec['failure'])}"
        )
    for key in (*_NUMBERS, *_TIMES, *_COUNTS):
        v = rec.get(key)
        if v is None:
            continue
        number = finite_number(v)
        if key in _COUNTS and not (isinstance(v, int) and number and v >= 0):
            return f"{key}: expected a count, got {_kind(v)}"
        if not number or (key in _TIMES and v < 0):
            return (
                f"{key}: expected a finite number{' >= 0' if key in _TIMES else ''}, got {_kind(v)}"
            )
    for key in _TEXT:
        if rec.get(key) is not None and not isinstance(rec[key], str):
            return f"{key}: expected text, got {_kind(rec[key])}"
    return None


def _kind(v) -> str:
    text = json.dumps(v) if not isinstance(v, float) or math.isfinite(v) else repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _parse(data: bytes, source: str) -> tuple[list[dict], int]:
    """Records of the complete lines and the byte length they take (a torn tail excluded);
    a line that is no record (:func:`record_fault`) or a pair recorded twice is a
    :class:`StoreError`."""
    end = data.rfind(b"\n") + 1
    records, seen = [], set()
    for n, line in enumerate(data[:end].split(b"\n")[:-1], start=1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except (ValueError, UnicodeDecodeError) as exc:  # JSONDecodeError, 5000 digits
            raise StoreError(
                f"{source}: line {n} is not JSON ({getattr(exc, 'msg', exc)})"
            ) from None
        except RecursionError:
            raise StoreError(f"{source}: line {n} is not JSON (nested too deeply)") from None
        fault = record_fault(rec)
        if fault is not None:
            raise StoreError(f"{source}: line {n}: {fault}")
        if record_key(rec) in seen:
            raise StoreError(f"{source}: line {n}: pair {record_key(rec)} appears twice")
        seen.add(record_key(rec))
        records.append(rec)
    return records, end


def read_records(path) -> list[dict]:
    """Every complete record in ``path`` (a torn final line is ignored), in file order."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return []
    except OSError as exc:
        raise StoreError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return _parse(data, str(path))[0]


class ResultStore:
    """Open with :meth:`open` (a context manager); :meth:`append` writes one record."""

    def __init__(self, path, fd: int, records: list[dict]):
        self.path = Path(path)
        self._fd = fd
        self.records = records  # everything in the file, including what this session appends
        self.done = {record_key(r) for r in records}

    @classmethod
    def open(cls, path) -> ResultStore:
        path = Path(path)
        try:
            fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o666)
        except OSError as exc:
            raise StoreError(f"{path}: cannot open ({exc.strerror or exc})") from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise StoreError(f"{path}: another sweep is writing to this file") from None
            size = os.fstat(fd).st_size
            data = os.pread(fd, size, 0) if size else b""
            records, end = _parse(data, str(path))
            if end < len(data):  # a torn last line: cut it so that appends start on a new line
                os.ftruncate(fd, end)
                os.fsync(fd)
        except BaseException:
            os.close(fd)
            raise
        return cls(path, fd, records)

    def append(self, rec: dict) -> None:
        key = record_key(rec)
        if key in self.done:
            raise StoreError(f"{self.path}: pair {key} is already recorded")
        line = (json.dumps(rec, allow_nan=False, separators=(",", ":")) + "\n").encode()
        n = os.write(self._fd, line)  # O_APPEND: one write puts the line at the end, whole
        if n != len(line):  # only on a full disk; the next open cuts the torn tail
            raise StoreError(f"{self.path}: short write ({n} of {len(line)} bytes)")
        os.fsync(self._fd)
        self.records.append(rec)
        self.done.add(key)

    def rewrite_sorted(self, order: Iterable[tuple[str, str]]) -> None:
        """Replace the file, atomically, by the same records in ``order`` (then the rest).

        Completion order depends on timing; a finished sweep rewrites the file in task order so
        that equal sweeps give equal files. The store is closed afterwards.
        """
        rank = {k: i for i, k in enumerate(order)}
        recs = sorted(
            self.records, key=lambda r: (rank.get(record_key(r), len(rank)), record_key(r))
        )
        text = "".join(json.dumps(r, allow_nan=False, separators=(",", ":")) + "\n" for r in recs)

        def write(tmp):
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())

        write_atomic(self.path, write)
        self.records = recs
        self.close()  # our descriptor (and lock) is on the replaced file: no appends after this

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)  # releases the lock
            self._fd = -1

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
