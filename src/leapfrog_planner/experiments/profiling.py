"""Where the time of one Leapfrog solve goes: integration, linear algebra, initial path, Python.

:func:`profile_split` plans a scenario once under :mod:`cProfile` and once under light timers,
and splits the wall time into exclusive parts:

- ``integration``: inside ``Flow._run``, the call of the compiled flow kernel (all of them,
  the final re-integration at rtol 1e-12 included), and the compiled Newton loops of simple
  and multiple shooting (their flows and their small linear algebra, one compiled call;
  Leapfrog's local solves call them through ``LocalShooter._loop``, and its sweeps'
  warm-started ones through ``LocalShooter.warm_sweep``, with the junctions' half flows);
- ``linear_algebra``: the Python Newton loop's compiled ``newton_correction`` and
  ``linear_solve`` (where the compiled loop does not run), ``numpy.linalg``
  (solve, svd, lstsq, norm) and the affine guess's ``scipy.linalg`` calls (expm, solve);
- ``initial_path``: building the initial feasible paths (``Planner.initial_paths``);
- ``validation``: the rest of ``results.validate``: dense output, penalty and Pontryagin checks;
- ``python``: everything else (the Newton loop, Leapfrog's bookkeeping, result objects).

The timers wrap those functions for one run and are restored afterwards; a category nested in
another is subtracted from its parent, so the parts add up to the wall time. cProfile's
overhead inflates the Python share, so the split is taken from the timers; cProfile supplies the
list of the most expensive functions.
"""

from __future__ import annotations

import cProfile
import io
import pstats
import threading
import time
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass

import numpy as np

__all__ = ["ProfileSplit", "WorkCount", "count_work", "profile_split"]

PARTS = ("integration", "linear_algebra", "initial_path", "validation", "python")


@dataclass(frozen=True)
class ProfileSplit:
    scenario: str
    method: str
    wall_s: float  # of the timed run
    parts_s: dict  # PARTS -> seconds, exclusive, summing to wall_s
    calls: dict  # category -> number of wrapped calls
    integrations: int  # flow integrations, inside the compiled Newton loops included
    steps: int  # accepted integrator steps of all integrations (validation included)
    jacobian_calls: int  # integrations that also carried the variational equations
    top_functions: str  # cProfile's most expensive functions (cumulative), as text

    def fraction(self, part: str) -> float:
        return self.parts_s[part] / self.wall_s


@dataclass(frozen=True)
class WorkCount:
    """What a call computed, in units that do not depend on the machine's speed."""

    value: object  # the call's return value
    steps: int  # accepted integrator steps of all integrations (validation included)
    integrations: int  # flow integrations, inside the compiled Newton loops included
    jacobian_calls: int  # integrations that also carried the variational equations


def count_work(fn, *args, **kwargs) -> WorkCount:
    """Call ``fn(*args, **kwargs)`` and count its integrator work (the same counters as
    :func:`profile_split`). Deterministic, unlike wall time: the benchmarks compare versions of
    the code by it on a noisy machine. The counters patch module attributes for the duration of
    the call, so nothing else in the process may plan meanwhile (threads inside the call are
    counted)."""
    clock = _Clock()
    with _patched(clock):
        value = fn(*args, **kwargs)
    return WorkCount(value, clock.steps, clock.integrations, clock.jacobian_calls)


class _Clock:
    """Exclusive time per category: a nested category's time is taken off its parent's."""

    def __init__(self):
        self.total = dict.fromkeys(PARTS[:-1], 0.0)
        self.calls = dict.fromkeys(PARTS[:-1], 0)
        self._local = threading.local()  # a stack per thread: nesting is per thread
        self._lock = threading.Lock()
        self.steps = self.jacobian_calls = self.integrations = 0

    @property
    def stack(self) -> list[list]:  # [category, time spent in nested categories]
        if not hasattr(self._local, "stack"):
            self._local.stack = []
        return self._local.stack

    def counted_run(self, run):
        """``Flow._run`` that also counts steps and integrations with sensitivities."""

        def counted(flow, t0, z0, t1, seed, *args, **kwargs):
            out = run(flow, t0, z0, t1, seed, *args, **kwargs)
            with self._lock:
                self.steps += int(out[2])
                self.integrations += 1
                self.jacobian_calls += seed.shape[1] > 0
            return out

        return counted

    def counted_newton(self, run):
        """``shooting.compiled_newton`` that also counts its steps, integrations and Jacobian
        evaluations."""

        def counted(system, *args, **kwargs):
            root, last, steps = run(system, *args, **kwargs)
            # A multiple-shooting evaluation integrates each arc (counted so also when an arc fails
            # and the rest are skipped: an overcount of a few on failing attempts).
            arcs = system.ends[2].size - 1
            with self._lock:
                self.steps += int(steps)
                self.integrations += root.f_evals * arcs
                self.jacobian_calls += root.jac_evals * arcs
            return root, last, steps

        return counted

    def counted_outcome(self, integrations: str):
        """A wrapper for a compiled call that returns a kernel record with ``steps`` and
        ``jacobians`` (``LocalShooter._loop``, ``LocalShooter.warm_sweep``) and also counts
        them, with its field ``integrations``."""

        def wrapper(run):
            def counted(*args, **kwargs):
                out = run(*args, **kwargs)
                with self._lock:
                    self.steps += int(out.steps)
                    self.integrations += int(getattr(out, integrations))
                    self.jacobian_calls += int(out.jacobians)
                return out

            return counted

        return wrapper

    def wrap(self, category, fn):
        def timed(*args, **kwargs):
            self.stack.append([category, 0.0])
            t = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                dt = time.perf_counter() - t
                stack = self.stack
                _, nested = stack.pop()
                with self._lock:
                    self.total[category] += dt - nested
                    self.calls[category] += 1
                if stack:
                    stack[-1][1] += dt

        return timed


@contextmanager
def _patched(clock: _Clock):
    from ..bvp import shooting
    from ..integrate.flow import Flow
    from ..planning import planner as planner_mod
    from ..planning import runner as runner_mod
    from ..roots import loop

    targets = [
        (Flow, "_run", "integration"),
        (shooting, "compiled_newton", "integration"),
        (shooting.LocalShooter, "_loop", "integration"),
        (shooting.LocalShooter, "warm_sweep", "integration"),
        (loop, "newton_correction", "linear_algebra"),
        (loop, "linear_solve", "linear_algebra"),
        (planner_mod.Planner, "initial_paths", "initial_path"),
        (runner_mod, "validate_arcs", "validation"),
        (shooting, "expm", "linear_algebra"),
        (shooting, "solve", "linear_algebra"),
    ] + [(np.linalg, name, "linear_algebra") for name in ("solve", "svd", "lstsq", "norm")]
    counters = {  # the wrapped functions that also count integrator work
        "_run": clock.counted_run,
        "compiled_newton": clock.counted_newton,
        # the compiled loop integrates once per evaluation (F alone where convergence is
        # predicted); the warm sweep counts its integrations
        "_loop": clock.counted_outcome("f_evals"),
        "warm_sweep": clock.counted_outcome("integrations"),
    }
    with ExitStack() as stack:
        for owner, name, category in targets:
            original = getattr(owner, name)
            stack.callback(setattr, owner, name, original)
            fn = counters.get(name, lambda f: f)(original)
            setattr(owner, name, clock.wrap(category, fn))
        yield


def profile_split(
    scenario="paper-case-4", method: str = "modified-newton", top: int = 15
) -> ProfileSplit:
    """Profile one ``Planner.plan()`` (after a warm-up run) of ``scenario`` with ``method``.

    The initial paths run one after the other (``threads=1``): with the planner's parallel
    threads the parts would overlap in time and could not add up to the wall time.
    """
    from ..planning.planner import Planner

    planner = Planner(scenario, method=method, threads=1)
    planner.plan()  # warm-up: kernels loaded, caches filled
    prof = cProfile.Profile()
    prof.enable()
    planner.plan()
    prof.disable()
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("cumulative").print_stats(top)

    clock = _Clock()
    with _patched(clock):
        t = time.perf_counter()
        planner.plan()
        wall = time.perf_counter() - t
    parts = dict(clock.total)
    parts["python"] = wall - sum(parts.values())
    return ProfileSplit(
        scenario=planner.scenario.name,
        method=method,
        wall_s=wall,
        parts_s=parts,
        calls=dict(clock.calls),
        integrations=clock.integrations,
        steps=clock.steps,
        jacobian_calls=clock.jacobian_calls,
        top_functions=buf.getvalue(),
    )
