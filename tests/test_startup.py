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
