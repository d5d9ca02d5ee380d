"""Never waiting blind: when loading a model's kernels turns out to be compiling them, every
command says so on stderr, on a terminal and off it (a script, CI, a notebook), and how long it
took. One kernel set per model serves every scenario, bounded controls included. The compiling
is stood in for by a slow warm-up here (a real one takes a minute)."""

from __future__ import annotations

import io
import time

import pytest
from rich.console import Console

from leapfrog_planner.cli import warmup as cli_warmup
from leapfrog_planner.planning import warmup as planning_warmup


@pytest.fixture
def slow(monkeypatch):
    calls = []

    def warm_up(model, methods=None, here=False):
        calls.append(model)
        time.sleep(cli_warmup.COMPILING_AFTER_S + 0.3)
        return cli_warmup.COMPILING_AFTER_S + 0.3

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


def test_loading_cached_kernels_says_nothing(monkeypatch):
    monkeypatch.setattr(planning_warmup, "warm_up", lambda *a, **k: 0.2)
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
