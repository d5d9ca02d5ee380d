"""A fresh machine's first plan does not wait for the compiled Newton loops: it runs the Python
loop (the same iterates, bit for bit) while one process of its own compiles them into the disk
cache, and later plans load them from there."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time
from types import SimpleNamespace

import numba
import numpy as np
import pytest

from conftest import CASES
from leapfrog_planner import Flow, plan
from leapfrog_planner.bvp import shooting
from leapfrog_planner.compiled import background
from leapfrog_planner.compiled.kernels import cached_entry_point, load_kernels

KERNEL = """
from numba import njit


@njit(cache=True)
def add_one(x):
    return x + 1.0
"""


def _import(path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # as the kernel modules are imported
    spec.loader.exec_module(module)
    return module


def test_a_cached_entry_point_is_loaded_from_the_disk_cache_never_compiled(tmp_path):
    path = tmp_path / f"kernel_{os.getpid()}.py"
    path.write_text(KERNEL)
    module = _import(path)
    assert cached_entry_point(module.add_one, (1.0,)) is None
    assert module.add_one.signatures == []  # nothing was compiled
    subprocess.run(  # another process compiles it into the disk cache
        [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(tmp_path)!r}); "
         f"import {path.stem} as m; m.add_one(1.0)"],
        check=True, timeout=120,
    )  # fmt: skip
    entry = cached_entry_point(module.add_one, (1.0,))
    assert entry is not None and entry(1.0) == 2.0
    assert module.add_one(2.0) == 3.0 and len(module.add_one.signatures) == 1


def test_the_typical_loop_calls_have_the_types_of_a_plans_calls():
    """Whether the loops are ready is asked with typical arguments: after a plan that ran the
    compiled loops, numba has machine code for exactly those types (else the answer would be
    'not ready' for ever, and every plan would run the Python loop)."""
    plan("builtin:paper-case-1", initial_paths=1)
    flow = Flow(CASES[3].problem())
    for kernel, args in shooting.typical_loop_calls(flow):
        assert cached_entry_point(kernel, args) is not None, kernel
        assert tuple(numba.typeof(a) for a in args) in kernel.overloads


def _trajectory(r) -> np.ndarray:
    return np.column_stack([np.asarray(v, float) for v in r.trajectory_columns().values()])


def test_until_the_loops_are_compiled_a_plan_runs_the_python_loop_to_the_same_bits(monkeypatch):
    reference = plan("builtin:paper-case-1")  # the compiled loops (this suite compiles them)
    monkeypatch.setenv(background.ENV, "1")
    monkeypatch.setattr(shooting, "_READY", set())
    monkeypatch.setattr(shooting, "_NEXT_LOOK", {})
    monkeypatch.setattr(shooting, "_STARTED", set())
    monkeypatch.setattr(shooting, "cached_entry_point", lambda kernel, args: None)  # fresh
    started, compiled = [], []
    monkeypatch.setattr(background, "start", lambda model, K: started.append((model, K)) or True)
    monkeypatch.setattr(shooting, "compiled_newton", lambda *a: compiled.append(a))
    monkeypatch.setattr(shooting.LocalShooter, "_loop", lambda *a: compiled.append(a))
    r = plan("builtin:paper-case-1")
    assert compiled == []  # the Python loop throughout
    assert started == [("unicycle", load_kernels("unicycle"))]  # once in a process
    assert r.status == reference.status == "converged"
    assert r.cost == reference.cost
    np.testing.assert_array_equal(_trajectory(r), _trajectory(reference))
    # and the same work: both loops skip J where convergence is predicted
    assert (r.f_evals, r.newton_iterations) == (reference.f_evals, reference.newton_iterations)


def test_a_block_under_here_and_the_environment_compile_in_this_process(monkeypatch):
    monkeypatch.setenv(background.ENV, "1")
    assert background.in_background()
    with background.here():
        assert not background.in_background()
    assert background.in_background()
    monkeypatch.setenv(background.ENV, "0")
    assert not background.in_background()


@pytest.fixture
def kernels(tmp_path):
    """A stand-in for a generated kernel module: its lock file goes beside it."""
    return SimpleNamespace(__file__=str(tmp_path / "lfp_model_0123.py"))


def test_the_lock_says_whether_a_background_compile_runs(kernels):
    lock = background.lock_path(kernels)
    assert lock.name == "lfp_model_0123.compiling"
    assert not background.running(kernels)  # none
    lock.write_text(f"{os.getpid()}\n")
    assert background.running(kernels)  # a live process
    gone = subprocess.Popen(["true"])
    gone.wait()
    lock.write_text(f"{gone.pid}\n")
    assert not background.running(kernels)  # its process died
    lock.write_text("")
    assert background.running(kernels)  # just created: its process id is being written
    old = time.time() - background.STALE_S - 1
    os.utime(lock, (old, old))
    assert not background.running(kernels)  # stale
    background.finished(kernels)
    assert not lock.exists()


def test_one_background_compile_at_a_time(monkeypatch, kernels):
    spawned = []
    real = subprocess.Popen

    def popen(argv, env, **kw):  # a live stand-in for `leapfrog warmup MODEL`
        spawned.append((argv, env[background.ENV]))
        return real(["sleep", "60"])

    monkeypatch.setattr(background.subprocess, "Popen", popen)
    try:
        assert background.start("unicycle", kernels)
        assert background.start("unicycle", kernels)  # already under way
        assert background.running(kernels)
    finally:
        pid = int(background.lock_path(kernels).read_text())
        os.kill(pid, 9)
        os.waitpid(pid, 0)
    assert len(spawned) == 1
    argv, compile_here = spawned[0]
    assert argv[-4:] == ["-m", "leapfrog_planner.cli", "warmup", "unicycle"]
    assert compile_here == "0"  # the background process compiles them itself
    assert not background.running(kernels)  # its process is gone: the lock is stale
