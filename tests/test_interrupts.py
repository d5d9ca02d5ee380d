"""Process hygiene of the command line: Ctrl-C ends with one line and exit 130 (never a
traceback or a crash), a killed sweep leaves no process behind, and nothing is left in the
temporary directory."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from tests.test_cli import cli_env

from leapfrog_planner.batch.engines import forkserver_fits

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="signals and prctl: Linux")


def _default_signals():
    """The command's signals as a terminal gives them, whatever this run inherited (under
    ``nohup`` SIGHUP is ignored, and a sweep then rightly outlives it)."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


def _start(args, tmp_path, tmpdir=None):
    """``leapfrog ARGS`` in ``tmp_path``, with ``tmpdir`` (default ``tmp_path/tmp``) its
    temporary directory."""
    tmpdir = tmpdir or tmp_path / "tmp"
    tmpdir.mkdir(exist_ok=True)
    env = {**cli_env(), "TMPDIR": str(tmpdir)}
    return subprocess.Popen(
        [sys.executable, "-m", "leapfrog_planner.cli", *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: what it leaves behind is findable
        preexec_fn=_default_signals,
    )


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


def _wait_gone(pgid: int, seconds: float = 10.0) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if not _group_alive(pgid):
            return True
        time.sleep(0.1)
    return False


@pytest.mark.parametrize(
    "args, delay",
    [
        (["solve", "paper-case-1", "--quiet"], 0.15),  # while Python imports the command
        (["solve", "paper-case-1", "--quiet"], 0.35),  # (numba, SciPy, click: 0.05-0.7 s)
        (["paper", "--out", "p", "--repeat", "20", "--quiet"], 0.5),  # while loading kernels
        (["paper", "--out", "p", "--repeat", "20", "--quiet"], 2.5),  # while planning
        (["sweep", "--n", "5000", "--out", "r.jsonl", "--quiet"], 3.0),  # workers running
    ],
)
def test_ctrl_c_gives_one_line_and_exit_130(tmp_path, args, delay):
    p = _start(args, tmp_path)
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, (p.returncode, err[-2000:])
    assert err.strip().splitlines() == ["interrupted"], err[-2000:]
    assert _wait_gone(p.pid)
    assert os.listdir(tmp_path / "tmp") == []


def _first_result(p, path, seconds: float = 120.0) -> None:
    """Wait until the sweep has written a result: its workers are running pairs."""
    end = time.monotonic() + seconds
    while time.monotonic() < end and p.poll() is None:
        if path.exists() and path.read_text().count("\n") >= 1:
            return
        time.sleep(0.05)
    raise AssertionError(f"no result after {seconds} s (exit {p.poll()})")


def _ended(p, seconds: float = 30.0) -> None:
    """``p`` ended and its pipes closed; if not, what of its group is left (then killed)."""
    try:
        p.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        left = subprocess.run(
            ["ps", "-o", "pid,ppid,stat,etime,cmd", "-g", str(p.pid)],
            capture_output=True, text=True,
        ).stdout  # fmt: skip
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        raise AssertionError(f"the sweep's pipes stayed open {seconds} s:\n{left}") from None


@pytest.fixture
def short_tmp():
    """A temporary directory of a short path, room for the forkserver's socket whatever the
    test run's own temporary directory (a test's ``tmp_path`` may be too long for it)."""
    folder = Path(tempfile.mkdtemp(prefix="lfp-", dir="/tmp"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGHUP])
def test_a_killed_sweep_leaves_no_process_and_no_temporary_folder(tmp_path, short_tmp, sig):
    """Its forkserver, resource tracker and workers die with it (they used to stay, 400 MB)."""
    p = _start(["sweep", "--n", "5000", "--out", "r.jsonl", "--quiet"], tmp_path, short_tmp)
    _first_result(p, tmp_path / "r.jsonl")
    os.kill(p.pid, sig)
    _ended(p)
    assert p.returncode == -sig
    assert _wait_gone(p.pid), "processes of the sweep's group outlived it"
    leftovers = [n for n in os.listdir(short_tmp) if not n.startswith("pymp-")]
    assert leftovers == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a Linux death signal")
def test_a_process_whose_parent_died_while_it_started_exits():
    """The death signal a sweep's forkserver and workers ask for does not look back: a parent
    that died before the request (a sweep killed while its pool started: its forkserver and a
    worker stayed, holding the caller's pipes) is caught by comparing it with the one
    expected."""
    code = (
        "import os, sys, time\n"
        "from leapfrog_planner.batch.orphans import die_with_parent\n"
        "die_with_parent(int(sys.argv[1]))\n"
        "print('alive', flush=True)\n"
    )
    run = [sys.executable, "-c", code]
    gone = subprocess.run([*run, str(os.getpid() + 10**6)], capture_output=True, text=True)
    assert gone.returncode == 1 and gone.stdout == ""
    kept = subprocess.run([*run, str(os.getpid())], capture_output=True, text=True)
    assert kept.returncode == 0 and kept.stdout == "alive\n"


@pytest.mark.parametrize("length", ["short", "long"])
def test_a_finished_sweep_leaves_nothing_in_the_temporary_directory(tmp_path, short_tmp, length):
    """In a temporary directory of a short path the workers come from the forkserver; under one
    too long for its socket they are spawned (the forkserver failed: "AF_UNIX path too long")."""
    tmpdir = short_tmp if length == "short" else short_tmp / ("t" * 100)
    assert forkserver_fits(str(tmpdir)) == (length == "short")
    p = _start(["sweep", "--n", "2", "--out", "r.jsonl", "--quiet"], tmp_path, tmpdir)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, err[-3000:]
    assert '"status":"converged"' in (tmp_path / "r.jsonl").read_text()
    assert os.listdir(tmpdir) == []


def _run_python(code: str, cwd) -> subprocess.CompletedProcess:
    """``python -c code scenarios`` in ``cwd``, as the command runs."""
    return subprocess.run(
        [sys.executable, "-c", code, "scenarios"],
        cwd=cwd,
        env=cli_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )


def _assert_interrupted(p: subprocess.CompletedProcess) -> None:
    assert p.returncode == 130, (p.returncode, p.stderr[-2000:])
    assert p.stderr.strip().splitlines() == ["interrupted"], p.stderr[-2000:]


@pytest.mark.parametrize("where", ["import", "command"])
def test_a_swallowed_ctrl_c_still_ends_as_interrupted(tmp_path, where):
    """CPython may swallow the KeyboardInterrupt of a Ctrl-C (raised inside a ``__hash__`` or a
    property that C code calls: seen in numba's import, about 1 run of 10 with Ctrl-C 0.15 s
    into ``leapfrog solve``, which then ended with exit 0). The handler remembers the Ctrl-C;
    after the imports and after the command, a remembered one ends the run as interrupted.
    Here the swallowed Ctrl-C is simulated by remembering it as the handler does."""
    code = {
        "import": (
            "import leapfrog_planner.cli as c; from leapfrog_planner.cli.ctrl_c import"
            " remember_ctrl_c; remember_ctrl_c(); c.run()"
        ),
        "command": (
            "from leapfrog_planner.cli.ctrl_c import remember_ctrl_c;"
            " from leapfrog_planner.cli.main import run; remember_ctrl_c(); run()"
        ),
    }[where]
    _assert_interrupted(_run_python(code, tmp_path))


#: A Ctrl-C whose KeyboardInterrupt CPython cannot raise: it arrives in a weakref callback (as
#: in the import system's module-lock cleanup) run while the command is imported.
_UNRAISABLE = (
    "import sys, weakref\n"
    "import leapfrog_planner.cli as c\n"
    "from leapfrog_planner.cli.ctrl_c import on_ctrl_c\n"
    "class Box: pass\n"
    "held = [Box()]\n"
    "ref = weakref.ref(held[0], lambda r: on_ctrl_c(2, None))\n"
    "class Finder:\n"
    "    def find_spec(self, name, path=None, target=None):\n"
    "        if name == 'leapfrog_planner.cli.main':\n"
    "            held.clear()\n"
    "sys.meta_path.insert(0, Finder())\n"
    "c.run()"
)


def test_a_ctrl_c_that_python_can_only_report_ends_with_one_line(tmp_path):
    """A KeyboardInterrupt raised in a callback cannot propagate: CPython reports it as
    "Exception ignored in ..." with a traceback (seen once in CI, Ctrl-C 0.15 s into
    ``leapfrog solve``, in importlib's module-lock cleanup). The handler remembers the Ctrl-C,
    so the run ends as interrupted, with one line and nothing of CPython's report."""
    _assert_interrupted(_run_python(_UNRAISABLE, tmp_path))


#: A ``scenarios`` command that fails with RuntimeError, as a class created while a Ctrl-C's
#: KeyboardInterrupt is raised fails; {cause}: the KeyboardInterrupt as its cause, or not.
_WRAPPED = (
    "import leapfrog_planner.cli.ctrl_c as c, leapfrog_planner.cli.main as m\n"
    "def boom(*a, **k):\n"
    "    try:\n"
    "        raise {error}\n"
    "    except BaseException as e:\n"
    "        raise RuntimeError('Error calling __set_name__') from e\n"
    "m.cli.commands['scenarios'].callback = boom\n"
    "if {remembered}: c.remember_ctrl_c()\n"
    "m.run()"
)


@pytest.mark.parametrize("error, remembered", [("KeyboardInterrupt", False), ("ValueError", True)])
def test_a_ctrl_c_wrapped_in_another_error_ends_as_interrupted(tmp_path, error, remembered):
    """A KeyboardInterrupt raised while a class is created reaches the command as a
    RuntimeError ("Error calling __set_name__", its cause the KeyboardInterrupt: seen once in
    the suite, Ctrl-C 0.35 s into ``leapfrog solve``, which then printed a traceback and exit 1).
    An error caused by a Ctrl-C, or any error after a remembered one, ends as interrupted; the
    same error without a Ctrl-C is still a traceback."""
    code = _WRAPPED.format(error=error, remembered=remembered)
    _assert_interrupted(_run_python(code, tmp_path))

    plain = _run_python(_WRAPPED.format(error="ValueError", remembered=False), tmp_path)
    assert plain.returncode == 1 and "RuntimeError" in plain.stderr, plain.stderr[-2000:]
