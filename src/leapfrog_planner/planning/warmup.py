"""Compiling a model's kernels ahead of the first plan.

numba compiles each kernel on its first call and caches the machine code on disk, so the first
plan of a model on a machine compiles for about 15 s (its compiled Newton loops half a minute
more, in the background) and every later one loads in a fraction of a second.
:func:`warm_up` makes that first call on purpose: a small plan with every local method and both
final solvers, so that no kernel is left to compile in the middle of a real plan, and a plan's
reported time never includes compiling. Where the compiled Newton loops are missing, they are
compiled in a process of their own (:mod:`..compiled.background`), unless
``LEAPFROG_COMPILE_IN_BACKGROUND=0`` (as in that process) has them compiled here.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator

import numpy as np
from numba.core import event

from ..bvp.shooting import loops_cached, loops_ready
from ..compiled import background
from ..compiled.kernels import generated, model_info
from ..compiled.linear import converges_next, dot, newton_correction, transpose_times
from ..compiled.linear import solve as linear_solve
from ..integrate.flow import Flow
from ..roots import RootSettings
from .initial_path.curve import SmoothCurve
from .planner import Planner, plan
from .scenario import Scenario

#: What warming up runs: every local method, then the multiple-shooting final solve.
MS = "multiple-shooting"
RUNS = (
    {"method": "modified-newton"},
    {"method": "newton"},
    {"method": "nleq-err"},
    {"final": MS},
)


def warm_up(model: str = "unicycle", methods=None, here: bool = False) -> float:
    """Compile (or load from the disk cache) every kernel of ``model``, or only those that the
    local ``methods`` (and their multiple-shooting final solve) use. Returns the seconds taken
    (about 20 on a fresh machine, well under one once cached). Missing compiled Newton loops
    are compiled in the background, or, with ``here``, in this process (a minute in all): what
    a command that times them needs.

    A warm start (:func:`_warm`: the kernels are in the disk cache) only loads them: one small
    plan per method, the plan's own steps in order. The multiple-shooting final solves and the
    Python Newton loop's linear algebra are run where something may compile (a fresh cache, or
    compiling in this process): once loaded, they use no machine code that the plain plans did
    not load (measured for every built-in model and method), and the Python loop does not run
    where the compiled loops are ready."""
    t0 = time.perf_counter()
    sc = _scenario(model)
    with background.here() if here else contextlib.nullcontext():
        flow = Flow(sc.problem())
        ready = loops_ready(flow)
        if not ready:  # a fresh cache: the process compiling the loops was started, and it
            # compiles the planning functions from the paths on, while this one compiles the
            # integrator and then those functions from the last on, so that each loads what
            # the other compiled (two cores at work)
            flow(0.0, np.zeros(2 * flow.nx), 1.0, sensitivity="costate")
            _after_the_paths(sc, flow)
        warm = ready and _warm(flow)
        if not warm:
            _planning_functions(sc, flow)
        for options in runs(methods, warm):
            plan(sc, threads=1, initial_paths=1, **options)
        if not background.in_background():  # the loops were compiled here, if missing
            background.finished(model_info(model).kernels)
    return time.perf_counter() - t0


def in_disk_cache(model: str) -> bool:
    """Whether :func:`warm_up` of the built-in ``model`` would find its kernels in the disk
    cache and only load them (under a second): a look that compiles nothing, generates nothing
    and starts no compile in the background."""
    if not (background.in_background() and generated(model)):
        return False
    return loops_cached(Flow(_scenario(model).problem()))


def _scenario(model: str) -> Scenario:
    """The small plan that warms ``model`` up."""
    extra = [0.0] * (model_info(model).nx - 3)  # a model's further states (the car's steering)
    return Scenario(
        name="warm-up",
        horizon=1.0,
        start=[0.0, 0.0, 0.0, *extra],
        goal=[1.0, 0.3, 0.5, *extra],
        obstacles=[[0.5, 0.25, 0.1], [0.6, -0.15, 0.08]],  # two: the tangents between discs too
        model=model,
    )


def runs(methods=None, warm: bool = False) -> list[dict]:
    """The plans of :func:`warm_up`: each of the local ``methods`` (default: all), and, unless
    ``warm``, their multiple-shooting final solves."""
    if methods is None:
        chosen = list(RUNS)
    else:
        chosen = [r for m in methods for r in ({"method": m}, {"method": m, "final": MS})]
    return [r for r in chosen if not (warm and r.get("final") == MS)]


def _warm(flow: Flow) -> bool:
    """Whether the kernels of ``flow``'s model are in the disk cache, given that its compiled
    Newton loops are ready (:func:`..bvp.shooting.loops_ready`): where they compile in a
    process of their own (the default), that process compiles them with the kernels of its
    plans, after those of the integrator and of the planning. Where they compile in this process
    (``LEAPFROG_COMPILE_IN_BACKGROUND=0``, ``here``) or the model is not a built-in one, they
    count as ready without a look: nothing tells, not warm."""
    return background.in_background() and isinstance(flow.problem.model.definition, str)


def _planning_functions(scenario: Scenario, flow: Flow) -> None:
    """Compile (or load) the compiled functions a plan needs besides the model's integrator:
    the initial paths', then those of :func:`_after_the_paths`."""
    Planner(scenario, initial_paths=1).initial_paths()
    _after_the_paths(scenario, flow)


def _after_the_paths(scenario: Scenario, flow: Flow) -> None:
    """Compile (or load) what a plan needs besides its integrator and the search of its initial
    paths, in the reverse order of a plan's (the process compiling in the background meets this
    one halfway): the Python Newton loop's linear algebra, a trajectory's samples (the answer's
    checks), the penalty along many points and the paths' curves (their ranking)."""
    nx = flow.nx
    J, F = np.eye(nx), np.ones(nx)
    newton_correction(J, F, RootSettings().max_cond)
    linear_solve(J, F)
    transpose_times(J, F)
    dot(F, F)
    converges_next(1.0, 1.0, RootSettings().tol)
    flow(0.0, np.full(2 * nx, 0.1), 1.0, samples=8)
    scenario.problem().penalty(np.zeros((2, 2)))
    curve = SmoothCurve(np.array([[0.0, 0.0], [0.5, 0.2], [1.0, 0.3]]), 0.0, 0.5)
    curve.evaluate(np.linspace(0.0, 1.0, 5))


class FirstCompile(event.Listener):
    """Calls ``say`` when the first kernel starts compiling: numba's ``numba:compile`` events
    fire where a kernel is missing from the disk cache, not where it is loaded from it (however
    slowly a loaded machine loads it). ``started`` tells whether one did."""

    def __init__(self, say: Callable[[], None]):
        self.say = say
        self.started = False

    def on_start(self, ev) -> None:
        if not self.started:
            self.started = True
            self.say()

    def on_end(self, ev) -> None:
        pass


@contextlib.contextmanager
def said_when_compiling(say: Callable[[], None]) -> Iterator[FirstCompile]:
    """While the block runs, ``say`` is called when the first kernel starts compiling (in any
    thread of this process: numba's events are global); the listener tells whether it did."""
    listener = FirstCompile(say)
    with event.install_listener("numba:compile", listener):
        yield listener
