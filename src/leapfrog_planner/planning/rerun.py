"""Results that re-run: what a plan records of how it was made (the scenario, the settings, the
provenance), and whether planning the recorded task again gives the recorded answer.

A result's ``task`` and ``settings`` are one source of truth: the ``[solver]`` table of the
recorded scenario is written from the settings the plan used, so planning ``result.task`` uses
the same method, partitions, initial paths, sweeps and tolerance, and :meth:`.Planner.from_result`
uses every setting. The ``provenance`` (versions, platform, date, the call) is metadata: an
answer is compared without it (:func:`reproduction`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import platform
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from .. import __version__
from ..errors import SettingsError
from .result_files import ResultFileError, plain
from .results import PlanResult
from .scenario import Scenario, scenario_from_dict
from .settings import PlannerSettings

#: The packages whose versions a result records, besides this one.
RECORDED_PACKAGES = ("numba", "numpy", "scipy")


@functools.cache
def _machine() -> tuple[dict[str, str | None], str, str]:
    """The versions, the Python version and the platform: the same all along a process."""
    versions: dict[str, str | None] = {"leapfrog-planner": __version__}
    for name in RECORDED_PACKAGES:
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            versions[name] = None
    return versions, platform.python_version(), platform.platform()


def provenance(call: str) -> dict[str, str | dict]:
    """Where and how a result was made: the versions of this package and of numba, NumPy and
    SciPy, the Python version and the platform, the date (UTC, ISO 8601) and ``call`` (the
    command line, or the API call)."""
    versions, python, system = _machine()
    return {
        "versions": dict(versions),
        "python": python,
        "platform": system,
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "call": call,
    }


def recorded(result: PlanResult, settings: PlannerSettings, call: str) -> PlanResult:
    """``result`` as a plan with ``settings`` records it: its scenario's ``[solver]`` table
    written from those settings, the settings as JSON values, and its provenance."""
    task = result.task
    if task is not None:
        task = dataclasses.replace(task, solver=settings.solver_table())
    return dataclasses.replace(
        result, task=task, settings=plain(settings), provenance=provenance(call)
    )


def with_call(result: PlanResult, call: str) -> PlanResult:
    """``result`` with ``call`` as the call its provenance records."""
    prov = {**(result.provenance or provenance(call)), "call": call}
    return dataclasses.replace(result, provenance=prov)


def call_of(scenario, options: dict) -> str:
    """The call ``plan(scenario, **options)`` as its provenance records it."""
    if isinstance(scenario, PlanResult):
        return f"plan(<result of {scenario.scenario!r}>)"
    given = repr(str(scenario)) if not isinstance(scenario, Scenario) else f"<{scenario.name!r}>"
    return f"plan({', '.join([given, *(f'{k}={v!r}' for k, v in options.items())])})"


def recorded_task(result: PlanResult, options=None) -> tuple[Scenario, PlannerSettings]:
    """The scenario and the settings ``result`` records, as a file holds them (a free final
    time as the file's tables, whatever ``T`` was chosen); the settings rule over the
    scenario's ``[solver]`` table (an older file's table may be stale). A result re-plans with
    its recorded settings: other ``options`` are refused."""
    if options:
        raise SettingsError(
            f"plan(result): a result re-plans with its recorded settings; got options"
            f" {', '.join(sorted(options))} (plan result.task to change them)"
        )
    if result.task is None or result.settings is None:
        raise ResultFileError(
            f"{result.scenario}: the result records no scenario or no settings (an older "
            "schema): it cannot be re-run"
        )
    data = result.task.to_dict()
    data.pop("solver", None)
    task = scenario_from_dict(data, result.task.source or "<result>")
    return task, recorded_settings(result)


def recorded_settings(result: PlanResult) -> PlannerSettings:
    """The planner's settings ``result`` records, checked as settings (a
    :class:`SettingsError` that names the result's scenario). A result written before a
    setting existed planned as its value 0 does: ``long_route`` (every route a short one),
    ``min_extra_paths`` (the extra paths only those the estimate gate let through) and
    Leapfrog's ``final_least_squares`` (no Levenberg-Marquardt after a failed Newton)."""
    try:
        recorded = {"long_route": 0.0, "min_extra_paths": 0, **result.settings}
        if isinstance(recorded.get("leapfrog"), dict):
            recorded["leapfrog"] = {"final_least_squares": 0, **recorded["leapfrog"]}
        return PlannerSettings.from_dict(recorded)
    except SettingsError as e:
        raise SettingsError(f"{result.scenario}: the recorded settings: {e}") from None


@dataclass(frozen=True)
class Reproduction:
    """A re-run's answer against the recorded one: the same status, the same cost bit for bit
    and the same trajectory (every row of every column) make it reproduce."""

    recorded: PlanResult
    rerun: PlanResult
    same_status: bool
    same_cost: bool
    same_trajectory: bool

    @property
    def reproduces(self) -> bool:
        return self.same_status and self.same_cost and self.same_trajectory

    def summary(self) -> str:
        """One line: whether it reproduces, with the cost."""
        new, old = self.rerun, self.recorded
        if self.reproduces:
            what = f"{new.status}, cost {_cost(new.cost)}"
            return f"reproduces the recorded answer: {what} (bit for bit)"
        parts = []
        if not self.same_status:
            parts.append(f"status {new.status} against {old.status} recorded")
        if not self.same_cost:
            a, b = _cost(new.cost), _cost(old.cost)
            if a == b:
                a, b = repr(new.cost), repr(old.cost)
            parts.append(f"cost {a} against {b} recorded")
        if not self.same_trajectory:
            parts.append("another trajectory" + ("" if parts else f" at cost {_cost(new.cost)}"))
        return "differs from the recorded answer: " + ", ".join(parts)


def _cost(cost: float) -> str:
    return "none" if not math.isfinite(cost) else f"{cost:.8g}"


def _same_float(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def _same_trajectory(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return all(
        np.shape(getattr(a, k)) == np.shape(getattr(b, k))
        and np.array_equal(getattr(a, k), getattr(b, k))
        for k in ("t", "x", "u", "lam")
    )


def reproduction(recorded_result: PlanResult, rerun: PlanResult) -> Reproduction:
    """Whether ``rerun`` gives ``recorded_result``'s answer (provenance and timings aside)."""
    return Reproduction(
        recorded=recorded_result,
        rerun=rerun,
        same_status=rerun.status == recorded_result.status,
        same_cost=_same_float(rerun.cost, recorded_result.cost),
        same_trajectory=_same_trajectory(rerun.trajectory, recorded_result.trajectory),
    )
