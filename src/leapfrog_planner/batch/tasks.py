"""What a sweep's workers run: the (scenario, method) pairs, the built-in methods, and the
record of each pair. A pair never raises: its failures become records (see :func:`run_task`)."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from ..bvp.shooting import ShootingSettings, solve_shooting
from ..compiled.kernels import model_info
from ..errors import LeapfrogError, SettingsError, require_integer
from ..planning.direct import solve_direct
from ..planning.direct_free import solve_direct_free
from ..planning.direct_map import solve_direct_map
from ..planning.planner import Planner, PlannerSettings
from ..planning.results import VALIDATION, validate
from ..planning.runs import END_STATE_TOLERANCE
from ..planning.scenario import Scenario
from .orphans import die_with_parent, expected_parent
from .store import FAILURES

PLANNER_METHODS = ("newton", "modified-newton", "nleq-err")
BUILTIN_METHODS = (*PLANNER_METHODS, "shooting", "direct")
#: Mesh of the ``direct`` method.
DIRECT_INTERVALS = 100
#: The sweep's planner defaults (see the module docstring); overridden by ``SweepSettings.planner``.
# threads=1: the sweep already runs one pair per core; path threads would only oversubscribe.
DEFAULT_PLANNER_OPTIONS = {"initial_paths": 1, "threads": 1}


class SweepError(LeapfrogError, ValueError):
    """A sweep that cannot start: bad scenarios, a results file from another sweep, no cluster."""


class TaskTimeout(BaseException):  # noqa: N818 - BaseException: no solver may swallow it
    """Raised inside a worker when a pair exceeds its time limit."""


@dataclass(frozen=True)
class SweepMethod:
    """A user-defined method: ``run(scenario, options) -> dict`` of record fields.

    The dict needs ``status`` (``"converged"`` or ``"failed"``) and may hold ``message``, ``cost``,
    ``min_clearance`` and the other numeric fields. ``run`` must be picklable (a module-level
    function) since it travels to worker processes.
    """

    name: str
    run: Callable[[Scenario, dict], dict]


@dataclass(frozen=True)
class SweepSettings:
    methods: tuple = ("newton", "modified-newton")  # names or SweepMethod objects
    planner: tuple[tuple[str, object], ...] = ()  # planner options over DEFAULT_PLANNER_OPTIONS
    time_limit: float = 60.0  # seconds per pair
    # A worker still busy this long after its pair's time limit (a hang that ignores the limit,
    # e.g. inside compiled code) is killed; the pair is recorded as a timeout.
    kill_grace: float = 10.0
    workers: int = 2
    scheduler: str | None = None  # a Dask scheduler address; None: local processes
    chunk_size: int | None = None  # pairs per Dask task; None: about 8 tasks per worker thread
    sort: bool = True  # rewrite the file in task order once every pair is done

    def __post_init__(self):
        methods = tuple(self.methods if not isinstance(self.methods, str) else (self.methods,))
        if not methods:
            raise SettingsError("methods: give at least one method")
        names = []
        for m in methods:
            if isinstance(m, SweepMethod):
                names.append(m.name)
            elif m in BUILTIN_METHODS:
                names.append(m)
            else:
                raise SettingsError(f"unknown method {m!r} (known: {', '.join(BUILTIN_METHODS)})")
        if len(set(names)) != len(names):
            raise SettingsError(f"methods: a method is listed twice ({', '.join(names)})")
        if "direct" in names and importlib.util.find_spec("casadi") is None:
            raise SettingsError(
                "method 'direct' needs CasADi: pip install 'leapfrog-planner[bench]'"
            )
        object.__setattr__(self, "methods", methods)
        planner = dict(self.planner.items() if isinstance(self.planner, dict) else self.planner)
        if "method" in planner:
            raise SettingsError("planner options: give the method in methods, not as an option")
        object.__setattr__(self, "planner", tuple(sorted(planner.items())))
        self.planner_settings("modified-newton")  # unknown options fail here, before any work
        for name in ("time_limit", "kill_grace"):
            v = getattr(self, name)
            if isinstance(v, bool) or not (isinstance(v, int | float) and v > 0 and v < math.inf):
                raise SettingsError(f"{name} must be a positive number of seconds, got {v!r}")
        object.__setattr__(self, "workers", require_integer("workers", self.workers))
        if self.chunk_size is not None:
            object.__setattr__(self, "chunk_size", require_integer("chunk_size", self.chunk_size))

    @property
    def method_names(self) -> tuple[str, ...]:
        return tuple(m.name if isinstance(m, SweepMethod) else m for m in self.methods)

    def options(self) -> dict:
        return {**DEFAULT_PLANNER_OPTIONS, **dict(self.planner)}

    def planner_settings(self, method: str):
        return PlannerSettings.from_options(**self.options(), method=method)


@dataclass(frozen=True)
class PairTask:
    """One (scenario, method) pair as it travels to a worker."""

    index: int  # position in the sweep's task order
    scenario: Scenario
    method: str | SweepMethod
    options: tuple[tuple[str, object], ...]
    time_limit: float
    scenario_hash: str
    settings_hash: str

    @property
    def method_name(self) -> str:
        return self.method.name if isinstance(self.method, SweepMethod) else self.method

    @property
    def key(self) -> tuple[str, str]:
        return self.scenario.name, self.method_name


# --------------------------------------------------------------------------- hashing


def scenario_hash(sc: Scenario) -> str:
    text = json.dumps(sc.to_dict(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def settings_hash(method, settings: SweepSettings) -> str:
    if isinstance(method, SweepMethod):
        fn = method.run
        what = f"custom:{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', fn)!s}"
    elif method == "shooting":
        what = f"shooting:{ShootingSettings()!r}:{VALIDATION!r}"
    elif method == "direct":
        what = f"direct:N{DIRECT_INTERVALS}:{settings.planner_settings('modified-newton')!r}"
    else:
        what = f"leapfrog:{settings.planner_settings(method)!r}"
    return hashlib.sha256(what.encode()).hexdigest()[:16]


# --------------------------------------------------------------------------- in the worker

_WARM: set[str] = set()  # models whose kernels this process has loaded (and warmed)
# In local worker processes: a shared array where each pair notes when it really started
# (after start-up and warm-up), so the sweep's watchdog measures the pair, not the queue.
_STARTED = None


def init_local_worker(started) -> None:
    global _STARTED
    _STARTED = started
    # With the forkserver (its preload set SERVER before forking this worker), and so with the
    # sweep; a spawned worker's parent is the sweep itself.
    server = getattr(sys.modules.get(f"{__package__}._forkserver_preload"), "SERVER", None)
    die_with_parent(server if server is not None else expected_parent())


def _warm_up(model: str) -> float:
    """Load and exercise ``model``'s compiled kernels once per process; the seconds it took."""
    if model in _WARM:
        return 0.0
    t = time.perf_counter()
    extra = [0.0] * (model_info(model).nx - 3)  # a model's further states (the car's steering)
    sc = Scenario(
        name="warm-up",
        horizon=1.0,
        start=[0.0, 0.0, 0.0, *extra],
        goal=[1.0, 0.0, 0.0, *extra],
        obstacles=[[0.5, 0.05, 0.1]],
        model=model,
    )
    Planner(sc, initial_paths=1, samples=11).plan()
    _WARM.add(model)
    return time.perf_counter() - t


@contextmanager
def _time_limit(seconds: float):
    """Raise :class:`TaskTimeout` after ``seconds`` (SIGALRM; only in a process's main thread)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(
        signal, "setitimer"
    ):
        yield
        return

    def on_alarm(signum, frame):
        raise TaskTimeout(f"time limit {seconds:g} s exceeded")

    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _num(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def _run_planner(sc: Scenario, method: str, options: dict, deadline: float) -> dict:
    def check(_event):  # threads (Dask workers) get no SIGALRM: check at every progress event
        if time.perf_counter() > deadline:
            raise TaskTimeout("time limit exceeded")

    r = Planner(sc, progress=check, **options, method=method).plan()
    return {
        "status": "converged" if r.success else "failed",
        "failure": "collides" if r.status == "collides" else None,
        "message": r.message,
        "cost": _num(r.cost),
        "min_clearance": _num(r.min_clearance),
        "end_state_error": _num(r.end_state_error),
        "newton_iterations": int(r.newton_iterations),
        "f_evals": int(r.f_evals),
        "sweeps": r.sweeps,
        "final_solver": r.final_solver,
        "cheaper_motion": _num(r.cheaper_motion),
        "wall_time_s": r.wall_time_s,
    }


def _run_shooting(sc: Scenario, options: dict) -> dict:

    t = time.perf_counter()
    problem = sc.problem()
    settings = ShootingSettings(method="modified-newton", samples=0)
    res = solve_shooting(problem, 0.0, sc.start, sc.horizon, sc.goal, settings=settings)
    v = validate(problem, 0.0, sc.start, sc.horizon, sc.goal, res.costate0) if res.success else None
    ok = v is not None and math.isfinite(v.cost) and v.end_state_error <= END_STATE_TOLERANCE
    clearance = v.clearance if v is not None else np.zeros(0)
    return {
        "status": "converged" if ok else "failed",
        "message": res.message if v is None or ok else "re-integration misses the goal",
        "cost": _num(v.cost) if ok else None,
        "min_clearance": _num(clearance.min()) if ok and clearance.size else None,
        "end_state_error": _num(v.end_state_error if v is not None else res.end_state_error),
        "newton_iterations": int(res.root.iterations),
        "f_evals": int(res.root.f_evals),
        "sweeps": None,
        "final_solver": "shooting",
        "wall_time_s": time.perf_counter() - t,
    }


def _run_direct(sc: Scenario, options: dict) -> dict:
    t = time.perf_counter()
    paths = max(3, int(options.get("initial_paths", 1)))
    planner = Planner(sc, **{**options, "initial_paths": paths})
    s = np.linspace(0.0, 1.0, DIRECT_INTERVALS + 1)
    guesses = [np.column_stack(path.curve(s)) for path in planner.initial_paths()]
    if sc.map is not None:  # the same penalty, the map's field included
        r = solve_direct_map(sc, intervals=DIRECT_INTERVALS, guesses=guesses)
    else:
        r = _solve_direct(sc, guesses)
    return _direct_record(sc, r, t)


def _solve_direct(sc: Scenario, guesses):
    bounds = tuple(sc.control_bounds.get(c) for c in model_info(sc.model).controls)
    common = dict(
        weight=sc.weight,
        exponent=sc.exponent,
        intervals=DIRECT_INTERVALS,
        model=sc.model,
        guesses=guesses,
        control_bounds=bounds if any(bounds) else None,
        **sc.model_parameters,
    )
    # the robot's centre among the obstacles grown by its radius
    ends, obstacles = (sc.start, sc.goal), sc.footprint_obstacles
    if sc.free_time is None:
        return solve_direct(*ends, sc.horizon, obstacles, **common)
    f = sc.free_time
    return solve_direct_free(
        *ends, obstacles, f.time_weight, horizon_guess=sc.horizon, horizon_bounds=f.bounds, **common
    )


def _direct_record(sc: Scenario, r, t: float) -> dict:
    clear = r.min_clearance >= sc.margin
    ok = r.success and math.isfinite(r.cost) and clear
    message = r.message if clear else f"{r.message}; the path collides ({r.min_clearance:.3g})"
    return {
        "status": "converged" if ok else "failed",
        "failure": "collides" if r.success and not clear else None,
        "message": message,
        "cost": _num(r.cost) if r.success else None,
        "min_clearance": _num(r.min_clearance) if sc.obstacles.size or sc.map is not None else None,
        "end_state_error": _num(r.end_state_error),
        "newton_iterations": int(r.iterations),
        "f_evals": None,
        "sweeps": None,
        "final_solver": f"ipopt-N{DIRECT_INTERVALS}",
        "wall_time_s": time.perf_counter() - t,
    }


def _plain(v):
    """A JSON value: numpy scalars as Python numbers, non-finite as null, others as text."""
    if v is None or isinstance(v, bool | str):
        return v
    if isinstance(v, int | np.integer):
        return int(v)
    if isinstance(v, float | np.floating):
        return _num(v)
    return str(v)


_RECORD_FIELDS = (
    "message",
    "cost",
    "min_clearance",
    "end_state_error",
    "newton_iterations",
    "f_evals",
    "sweeps",
    "final_solver",
    "cheaper_motion",
)


def _record(task: PairTask, out: dict, failure: str | None, task_time: float, warm: float):
    status = out.get("status", "failed")
    if status not in ("converged", "failed"):
        status, failure, out = "failed", "error", {"message": f"bad status {status!r}"}
    if status == "failed" and failure is None:
        failure = out.get("failure") if out.get("failure") in FAILURES else "solver"
    rec = {
        "scenario": task.scenario.name,
        "method": task.method_name,
        "status": status,
        "failure": failure,
    }
    for k in _RECORD_FIELDS:
        rec[k] = _plain(out.get(k))
    rec["obstacles"] = int(task.scenario.obstacles.shape[0])
    rec["scenario_hash"] = task.scenario_hash
    rec["settings_hash"] = task.settings_hash
    rec["wall_time_s"] = _num(out.get("wall_time_s", task_time))
    rec["task_time_s"] = task_time
    rec["warmup_s"] = warm
    rec["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return rec


def failure_record(task: PairTask, failure: str, message: str, task_time: float = 0.0) -> dict:
    """The record of a pair that produced no answer (timeout, crash, error)."""
    return _record(task, {"status": "failed", "message": message}, failure, task_time, 0.0)


def run_task(task: PairTask) -> dict:
    """Run one pair; never raises (except on interpreter shutdown): failures become records."""
    t0 = time.perf_counter()
    warm = 0.0
    try:
        if not isinstance(task.method, SweepMethod):  # own methods may not use our kernels
            warm = _warm_up(task.scenario.model)
        t0 = time.perf_counter()  # the limit and task time exclude the one-off warm-up
        if _STARTED is not None:
            _STARTED[task.index] = time.monotonic()  # system-wide clock on Linux
        deadline = t0 + task.time_limit
        options = dict(task.options)
        with _time_limit(task.time_limit):
            if isinstance(task.method, SweepMethod):
                out = dict(task.method.run(task.scenario, options))
            elif task.method == "shooting":
                out = _run_shooting(task.scenario, options)
            elif task.method == "direct":
                out = _run_direct(task.scenario, options)
            else:
                out = _run_planner(task.scenario, task.method, options, deadline)
        return _record(task, out, None, time.perf_counter() - t0, warm)
    except TaskTimeout as exc:
        return _record(task, {"message": str(exc)}, "timeout", time.perf_counter() - t0, warm)
    except Exception as exc:  # a solver bug must not stop the sweep: record it
        msg = " ".join(f"{type(exc).__name__}: {exc}".split())[:500]
        return _record(task, {"message": msg}, "error", time.perf_counter() - t0, warm)


def run_chunk(tasks: list[PairTask]) -> list[dict]:
    """Run pairs one after another in this worker (one Dask task per chunk: low overhead)."""
    return [run_task(t) for t in tasks]
