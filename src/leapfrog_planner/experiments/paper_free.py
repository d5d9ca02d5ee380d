"""The paper's four cases with the final time free, at several prices of time
(``leapfrog paper --time-weights 0.1,1,10``): the T each chooses, its cost, Pontryagin's
free-time condition ``k + H = 0`` and the time of the plan, as ``free_time.md`` and
``free_time.csv``."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from ..errors import SettingsError, describe
from ..planning.planner import plan
from ..planning.results import PlanResult
from ..planning.scenario import load_scenario
from ..planning.scenario_time import TIME_WEIGHT_RANGE, FreeTime
from .paper import ExperimentEvent


@dataclass(frozen=True)
class FreeTimeRow:
    case: int
    time_weight: float
    result: PlanResult
    time_s: float


def time_weights(text: str) -> tuple[float, ...]:
    """``"0.1,1,10"`` as prices of time, each finite and inside the allowed range."""
    out = []
    for part in text.split(","):
        try:
            k = float(part)
        except ValueError:
            raise SettingsError(f"time weights: expected numbers, got {describe(part)}") from None
        lo, hi = TIME_WEIGHT_RANGE
        if not (math.isfinite(k) and lo <= k <= hi):
            raise SettingsError(f"time weights: each must lie in [{lo:g}, {hi:g}], got {part!r}")
        out.append(k)
    return tuple(out)


def run_free_time(
    cases: tuple[int, ...],
    weights: tuple[float, ...],
    progress: Callable[[ExperimentEvent], None] | None = None,
) -> list[FreeTimeRow]:
    """One free-time plan of each case at each price of time, in order."""
    rows = []
    total = len(cases) * len(weights)
    for case in cases:
        for k in weights:
            if progress is not None:
                progress(ExperimentEvent(len(rows), total, f"case {case}, k = {k:g}"))
            sc = dataclasses.replace(load_scenario(f"paper-case-{case}"), free_time=FreeTime(k))
            t = time.perf_counter()
            r = plan(sc)
            rows.append(FreeTimeRow(case, k, r, time.perf_counter() - t))
    if progress is not None:
        progress(ExperimentEvent(total, total, ""))
    return rows


_HEADER = ("case", "k", "status", "T", "cost J", "k T", "k + H", "min clearance", "time (ms)")


def _cells(row: FreeTimeRow) -> tuple[str, ...]:
    r, f = row.result, row.result.free_time
    clearance = "n/a" if r.min_clearance is None else f"{r.min_clearance:.4f}"
    return (
        str(row.case), f"{row.time_weight:g}", str(r.status), f"{f.horizon:.7f}",
        f"{r.cost:.8f}", f"{f.time_cost:.6f}", f"{f.condition:.1e}", clearance,
        f"{1e3 * row.time_s:.0f}",
    )  # fmt: skip


def free_time_markdown(rows: list[FreeTimeRow]) -> str:
    lines = [
        "# The paper's cases with the final time free",
        "",
        "The cost is the integral of k + (v^2 + omega^2)/2 + P over [0, T], T chosen by the",
        "planner; at a free-time optimum the Hamiltonian of that cost vanishes (k + H = 0, H of",
        "the effort and the penalty). The time is the whole plan, in this process.",
        "",
        "| " + " | ".join(_HEADER) + " |",
        "|" + "---|" * len(_HEADER),
    ]
    lines += ["| " + " | ".join(_cells(row)) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def free_time_csv(rows: list[FreeTimeRow]) -> str:
    return "\n".join([",".join(_HEADER)] + [",".join(_cells(row)) for row in rows]) + "\n"
