"""Process hygiene of the command line: Ctrl-C ends with one line and exit 130 (never a
traceback or a crash), a killed sweep leaves no process behind, and nothing is left in the
temporary directory."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from tests.test_cli import cli_env

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="signals and prctl: Linux")


def _start(args, tmp_path):
    env = {**cli_env(), "TMPDIR": str(tmp_path / "tmp")}
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return subprocess.Popen(
        [sys.executable, "-m", "leapfrog_planner.cli", *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: what it leaves behind is findable
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
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


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGHUP])
def test_a_killed_sweep_leaves_no_process_and_no_temporary_folder(tmp_path, sig):
    """Its forkserver, resource tracker and workers die with it (they used to stay, 400 MB)."""
    p = _start(["sweep", "--n", "5000", "--out", "r.jsonl", "--quiet"], tmp_path)
    time.sleep(4.0)  # the workers are running pairs
    assert (tmp_path / "r.jsonl").exists()
    os.kill(p.pid, sig)
    p.communicate(timeout=30)
    assert p.returncode == -sig
    assert _wait_gone(p.pid), "processes of the sweep's group outlived it"
    leftovers = [n for n in os.listdir(tmp_path / "tmp") if not n.startswith("pymp-")]
    assert leftovers == []


@pytest.mark.parametrize("delay", [1.0, 1.5, 2.0, 2.5, 3.0])
def test_a_sweep_killed_while_its_pool_starts_leaves_no_process(tmp_path, delay):
    """Killed while its forkserver or workers were still starting (before they asked to die
    with their parent), they stayed and held the caller's pipes: measured at 2 s."""
    p = _start(["sweep", "--n", "5000", "--out", "r.jsonl", "--quiet"], tmp_path)
    time.sleep(delay)
    os.kill(p.pid, signal.SIGTERM)
    p.communicate(timeout=30)
    assert p.returncode == -signal.SIGTERM
    assert _wait_gone(p.pid), "processes of the sweep's group outlived it"


def test_a_finished_sweep_leaves_nothing_in_the_temporary_directory(tmp_path):
    p = _start(["sweep", "--n", "2", "--out", "r.jsonl", "--quiet"], tmp_path)
    p.communicate(timeout=300)
    assert p.returncode == 0
    assert os.listdir(tmp_path / "tmp") == []
