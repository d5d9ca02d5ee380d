"""Running the command line in-process for a generated hostile-input corpus
(tests/test_hostile_corpus.py): one case in a folder of its own, its exit code, its stderr, a
traceback if any, and the folder's files before and after.

In-process runs take milliseconds where a subprocess takes a second or two to start; what a
subprocess would show is kept: stderr is captured where rich's ``err`` console writes (it finds
``sys.stderr`` at each print), and a warning Python would print (not a deprecation) counts as a
line of stderr. A hang ends the test run with every thread's stack (``faulthandler``).
"""

from __future__ import annotations

import faulthandler
import hashlib
import io
import os
import stat
import sys
import time
import traceback
import warnings
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path

from leapfrog_planner.cli.main import main

#: Seconds: a case still running then is a hang, and ends the test run. A case may compile a
#: model's kernels (a cold cache): on 2 cores loaded with two other planning processes, the
#: first cases of both workers passed 180 s doing so, and the run ended there.
HANG = 420

_QUIET = (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning)


@dataclass(frozen=True)
class Outcome:
    code: int | None  # None: an exception escaped main (a traceback)
    stderr: str
    stdout: str
    traceback: str
    seconds: float
    before: dict
    after: dict

    @property
    def lines(self) -> list[str]:
        return self.stderr.strip().splitlines()

    def new_files(self) -> set[str]:
        return set(self.after) - set(self.before)

    def changed_inputs(self) -> list[str]:
        return [k for k, v in self.before.items() if self.after.get(k) != v]


def state(folder: Path) -> dict[str, tuple]:
    """Every entry of ``folder``: its kind and, for a file, its bytes' hash and mode."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if stat.S_ISREG(st.st_mode) else ""
        out[str(p.relative_to(folder))] = (stat.S_IFMT(st.st_mode), digest, st.st_mode)
    return out


def write_files(folder: Path, files: dict[str, str | bytes]) -> None:
    for name, content in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")


def run_cli(args, folder: Path, files: dict[str, str | bytes] | None = None) -> Outcome:
    """``leapfrog ARGS`` in ``folder`` (made, with ``files`` written in it), in this process."""
    folder.mkdir(parents=True, exist_ok=True)
    write_files(folder, files or {})
    before = state(folder)
    out, err = io.StringIO(), io.StringIO()
    code, tb = None, ""
    old = os.getcwd()
    os.chdir(folder)
    t0 = time.perf_counter()
    faulthandler.dump_traceback_later(HANG, exit=True, file=sys.__stderr__)
    try:
        with warnings.catch_warnings(record=True) as caught, redirect_stdout(out):
            warnings.simplefilter("always")
            for category in _QUIET:
                warnings.simplefilter("ignore", category)
            with redirect_stderr(err):
                try:
                    main(list(args))
                    code = 0
                except SystemExit as e:
                    code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
                except BaseException:  # noqa: BLE001 - what escapes main is the finding
                    tb = traceback.format_exc()
        for w in caught:
            err.write(f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}\n")
    finally:
        faulthandler.cancel_dump_traceback_later()
        os.chdir(old)
    seconds = time.perf_counter() - t0
    return Outcome(code, err.getvalue(), out.getvalue(), tb, seconds, before, state(folder))


def check_bad_or_fine(o: Outcome, outputs=(), fine=(0, 1)) -> str:
    """The rules every case keeps, whatever its input: no traceback; exit 2 with exactly one
    line ``error: ...`` and no file written or changed; else an exit code of ``fine`` and the
    inputs left as they were. Returns ``"refused"`` or ``"ran"``."""
    assert not o.traceback, o.traceback[-3000:]
    if o.code == 2:
        assert len(o.lines) == 1 and o.lines[0].startswith("error: "), o.stderr[-1500:]
        assert o.after == o.before, f"refused, yet files changed: {o.new_files()}"
        return "refused"
    assert o.code in fine, (o.code, o.stderr[-1500:])
    assert not o.changed_inputs(), f"inputs changed: {o.changed_inputs()}"
    assert "Traceback" not in o.stderr, o.stderr[-3000:]
    return "ran"
