"""A warm start spends its time on the plan: a ``leapfrog solve`` process imports neither SymPy
(its kernels are generated already) nor the parts of SciPy and the plotting and web libraries
that the run does not use, and ``leapfrog --help`` imports neither numba nor those."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parent.parent / "src"

#: Modules a warm plan must not import (each costs 0.1 to 0.3 s of start-up).
HEAVY = ("sympy", "scipy.optimize", "scipy.ndimage", "scipy.integrate", "matplotlib", "starlette")


def _imported(args: list[str]) -> set[str]:
    """The modules imported by the ``leapfrog`` command run with ``args`` in a new process."""
    code = (
        "import sys\n"
        "from leapfrog_planner.cli.main import main\n"
        "try:\n"
        "    main(sys.argv[1:])\n"
        "except SystemExit as e:\n"
        "    assert not e.code, e.code\n"
        "print('\\n'.join(sys.modules), file=sys.stderr)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    r = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, r.stderr
    return set(r.stderr.split())


@pytest.mark.parametrize("scenario", ["paper-case-4", "paper-case-1"])
def test_a_warm_solve_imports_nothing_it_does_not_use(scenario):
    _imported(["solve", scenario, "--quiet"])  # compiles, the first time on a machine
    modules = _imported(["solve", scenario, "--quiet"])
    assert "numba" in modules  # the check sees what was imported
    loaded = sorted(m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY))
    assert loaded == []


def test_help_imports_neither_numba_scipy_sympy_nor_the_plots_or_the_server():
    for args in (["--help"], ["solve", "--help"], ["serve", "--help"]):
        modules = _imported(args)
        assert "click" in modules
        assert not {"numba", "scipy", "sympy", "matplotlib", "uvicorn"} & modules, args


def test_a_warm_start_only_loads_the_kernels_with_one_plain_plan_per_method(monkeypatch):
    """Where the kernels are in the disk cache (the compiled loops are: a process of their own
    compiled them with the rest), warming up runs one small plan per method; the
    multiple-shooting final solves and the planning functions' pre-pass run only where
    something may compile: a fresh cache, or compiling in this process."""
    import leapfrog_planner.planning.warmup as warmup
    from leapfrog_planner.compiled import background

    plans, prepasses = [], []

    def plan(sc, method=None, final=None, **other):
        plans.append({"method": method} if final is None else {"method": method, "final": final})

    monkeypatch.setattr(warmup, "plan", plan)
    monkeypatch.setattr(warmup, "_planning_functions", lambda *a: prepasses.append(a))
    monkeypatch.setenv(background.ENV, "1")
    everything = [{"method": "newton"}, {"method": "newton", "final": "multiple-shooting"}]
    for ready, here, expected in [
        (True, False, everything[:1]),  # a warm start
        (True, True, everything),  # compiling here (the benchmarks): nothing tells
        (False, False, everything),  # a fresh cache: the loops compile in the background
    ]:
        plans.clear(), prepasses.clear()
        monkeypatch.setattr(warmup, "loops_ready", lambda flow, ready=ready: ready)
        warmup.warm_up("unicycle", ["newton"], here=here)
        assert plans == expected, (ready, here)
        assert len(prepasses) == (0 if expected == everything[:1] else 1), (ready, here)
    plans.clear()
    monkeypatch.setattr(warmup, "loops_ready", lambda flow: True)
    warmup.warm_up("unicycle")
    assert plans == [{"method": m} for m in ("modified-newton", "newton", "nleq-err")]


#: Warms up as a warm ``leapfrog solve`` does, then plans paper case 4 with the final solve of
#: argv[1]; prints the warm-up's plans and how many pieces of machine code the plan added.
WARM_THEN_PLAN = """
import gc, sys
from numba.core.dispatcher import Dispatcher
import leapfrog_planner.planning.warmup as warmup
from leapfrog_planner.planning.planner import Planner

plans, real = [], warmup.plan
warmup.plan = lambda sc, **options: (plans.append(options), real(sc, **options))[1]
planner = Planner("builtin:paper-case-4", final=sys.argv[1])
warmup.warm_up("unicycle", [planner.settings.leapfrog.method])
def machine_code():
    return {(id(d), s) for d in gc.get_objects() if isinstance(d, Dispatcher) for s in d.overloads}
before = machine_code()
planner.plan()
print(len(plans), len(machine_code() - before))
"""


@pytest.mark.parametrize("final", ["auto", "multiple-shooting"])
def test_after_a_warm_starts_warm_up_the_plan_loads_no_machine_code(final):
    """The lean warm-up of a warm start loads everything a plan uses, also its
    multiple-shooting final solve: the plan's reported time includes no loading."""
    from leapfrog_planner.planning.warmup import warm_up

    warm_up("unicycle", ["modified-newton"])  # the suite compiles here what is missing
    env = {**os.environ, "PYTHONPATH": str(SRC), "LEAPFROG_COMPILE_IN_BACKGROUND": "1"}
    r = subprocess.run(
        [sys.executable, "-c", WARM_THEN_PLAN, final],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["1", "0"]  # one plain warm-up plan; the plan added nothing


def test_a_look_into_the_disk_cache_compiles_generates_and_starts_nothing(tmp_path, monkeypatch):
    """``in_disk_cache`` (what ``leapfrog serve``'s solver asks of its other models): true where
    a warm-up would only load the model's kernels; in an empty cache false, and the look leaves
    no generated module behind and starts no compile in the background."""
    from leapfrog_planner.compiled import background
    from leapfrog_planner.planning.warmup import in_disk_cache, warm_up

    warm_up("unicycle", here=True)  # the suite compiles here what is missing
    monkeypatch.setenv(background.ENV, "1")
    assert in_disk_cache("unicycle")
    empty = tmp_path / "cache"
    code = "from leapfrog_planner.planning.warmup import in_disk_cache as c; print(c('car'))"
    env = {**os.environ, "PYTHONPATH": str(SRC), "LEAPFROG_CACHE_DIR": str(empty)}
    env[background.ENV] = "1"
    r = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert (r.returncode, r.stdout) == (0, "False\n"), r.stderr
    assert [p.name for p in empty.rglob("*") if p.is_file()] == []
