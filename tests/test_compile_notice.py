"""Never waiting blind: when loading a model's kernels turns out to be compiling them, every
command says so on stderr, on a terminal and off it (a script, CI, a notebook), and how long it
took; loading them from the disk cache says nothing, however long a loaded machine takes. One
kernel set per model serves every scenario, bounded controls included. The compiling is stood
in for by a warm-up that raises numba's compile event here (a real one takes a minute)."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time

import pytest
from numba.core import event
from rich.console import Console

from leapfrog_planner.cli import warmup as cli_warmup
from leapfrog_planner.planning import warmup as planning_warmup


@pytest.fixture
def slow(monkeypatch):
    calls = []

    def warm_up(model, methods=None, here=False):
        calls.append(model)
        with event.trigger_event("numba:compile"):  # as a kernel missing from the cache does
            time.sleep(0.05)
        return 1.8

    monkeypatch.setattr(planning_warmup, "warm_up", warm_up)
    return calls


@pytest.mark.parametrize("terminal", [False, True])
def test_compiling_is_said_on_and_off_a_terminal(monkeypatch, slow, terminal):
    out = io.StringIO()
    monkeypatch.setattr(cli_warmup, "err", Console(file=out, force_terminal=terminal, width=200))
    cli_warmup.ensure_compiled(["unicycle"])
    text = out.getvalue()
    assert "compiling the unicycle kernels, once per machine" in text
    assert "compiled the unicycle kernels in 2 s" in text
    assert slow == ["unicycle"]


def test_quiet_says_nothing(monkeypatch, slow):
    out = io.StringIO()
    monkeypatch.setattr(cli_warmup, "err", Console(file=out, force_terminal=False))
    cli_warmup.ensure_compiled(["unicycle"], show=False)
    assert out.getvalue() == "" and slow == ["unicycle"]


@pytest.mark.parametrize("seconds", [0.2, 5.0])
def test_loading_cached_kernels_says_nothing(monkeypatch, seconds):
    """Also when the loading is slow (5 s on a machine busy with other work: it used to be
    said as compiling after 1.5 s)."""
    monkeypatch.setattr(planning_warmup, "warm_up", lambda *a, **k: seconds)
    out = io.StringIO()
    monkeypatch.setattr(cli_warmup, "err", Console(file=out, force_terminal=False))
    cli_warmup.ensure_compiled(["unicycle"])
    assert out.getvalue() == ""


def test_the_loops_compiling_in_the_background_are_said(monkeypatch):
    monkeypatch.setattr(planning_warmup, "warm_up", lambda *a, **k: 0.2)
    monkeypatch.setattr(cli_warmup, "_loops_compiling", lambda model: True)
    out = io.StringIO()
    monkeypatch.setattr(cli_warmup, "err", Console(file=out, force_terminal=False, width=200))
    cli_warmup.ensure_compiled(["unicycle"])
    assert "compiling the unicycle model's Newton loop in the background" in out.getvalue()
    assert "the same answers, bit for bit" in out.getvalue()


def test_a_compile_is_heard_and_a_load_from_the_disk_cache_is_not(tmp_path):
    """The notice rests on numba's compile event: a function compiled anew raises it, the same
    function loaded from its disk cache in another process does not."""
    (tmp_path / "kernel_probe.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2 * x\n"
    )
    code = (
        "from leapfrog_planner.planning.warmup import said_when_compiling\n"
        "import kernel_probe\n"
        "with said_when_compiling(lambda: print('compiling')) as first:\n"
        "    kernel_probe.twice(2)\n"
        "print(first.started)\n"
    )
    env = {"PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], env={**os.environ, **env},
            capture_output=True, text=True, check=True, timeout=120,
        ).stdout.split()
        for _ in range(2)
    ]  # fmt: skip
    assert runs == [["compiling", "True"], ["False"]]
