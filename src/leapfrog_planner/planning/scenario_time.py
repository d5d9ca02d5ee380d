"""A free final time in a scenario: ``horizon = "free"`` and a price on time.

The cost becomes ``J = integral of [k + L + P] dt`` over ``[0, T]`` with ``T`` free. ``k`` is
given in the ``[cost]`` table, either as ``time_weight = k`` or as ``cruise_speed = v``: the
speed at which the optimum travels where no obstacle is near, ``k = c v^2`` with ``c`` the
model's effort of driving straight ahead (:mod:`..model.cruise`: 1/2 for the unicycle and the
car, ``1 / r^2`` for the differential drive). An optional ``[time]`` table gives a ``guess``
of ``T`` and ``bounds = [lo, hi]``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import checks
from ..errors import ModelError
from .scenario_checks import ScenarioCheck

COST_KEYS = ("time_weight", "cruise_speed")
TIME_KEYS = ("guess", "bounds")
FREE = "free"
#: The widest ratio of a time weight to its reference (10^6 and 10^-6 of a cruise at 1).
TIME_WEIGHT_RANGE = (1e-9, 1e9)


@dataclass(frozen=True)
class FreeTime:
    """The price of time and what the user said of ``T``: the weight ``k`` of each second,
    the cruise speed it was given as (None when given as a weight), a guess and bounds."""

    time_weight: float
    cruise_speed: float | None = None
    guess: float | None = None
    bounds: tuple[float, float] | None = None

    def to_tables(self) -> dict[str, dict[str, Any]]:
        """The ``[cost]`` and ``[time]`` tables of a scenario file."""
        cost = (
            {"cruise_speed": self.cruise_speed}
            if self.cruise_speed is not None
            else {"time_weight": self.time_weight}
        )
        time: dict[str, Any] = {}
        if self.guess is not None:
            time["guess"] = self.guess
        if self.bounds is not None:
            time["bounds"] = list(self.bounds)
        return {"cost": cost, "time": time} if time else {"cost": cost}

    def limits(self) -> tuple[float, float]:
        """The range ``T`` is searched in: the bounds given, within the horizons a scenario
        may have."""
        lo, hi = self.bounds if self.bounds is not None else (0.0, math.inf)
        return max(lo, checks.HORIZON_RANGE[0]), min(hi, checks.HORIZON_RANGE[1])


def free_time_from_tables(
    c: ScenarioCheck, cost: Mapping | None, time: Mapping | None, effort: float
) -> FreeTime:
    """The free time of a scenario whose horizon is ``"free"``: its ``[cost]`` and ``[time]``
    tables checked; ``effort`` is the model's effort of driving straight ahead."""
    cost = c.table({} if cost is None else cost, "cost")
    c.known_keys(cost, COST_KEYS, "cost")
    given = [k for k in COST_KEYS if k in cost]
    if not given:
        c.fail("cost", "a free horizon needs a price of time: time_weight or cruise_speed")
    if len(given) > 1:
        c.fail("cost", "give time_weight or cruise_speed, not both")
    speed = None
    if "cruise_speed" in cost:
        speed = c.number(cost["cruise_speed"], "cost.cruise_speed", gt=0)
        c.in_range(speed, "cost.cruise_speed", (0.0, checks.COORDINATE_MAX))
        weight = effort * speed**2
    else:
        weight = c.number(cost["time_weight"], "cost.time_weight", gt=0)
    lo, hi = TIME_WEIGHT_RANGE
    if not lo <= weight <= hi:  # the key given, named: a cruise speed's weight is the model's
        key = "cost.time_weight" if speed is None else "cost.cruise_speed"
        c.fail(key, f"the price of time {weight:.3g} per second is outside [{lo:g}, {hi:g}]")
    time = c.table({} if time is None else time, "time")
    c.known_keys(time, TIME_KEYS, "time")
    guess = bounds = None
    if "bounds" in time:
        b = c.vector(time["bounds"], 2, "time.bounds", " [shortest, longest]")
        for v, key in zip(b, ("shortest", "longest"), strict=True):
            c.in_range(c.number(v, f"time.bounds {key}", gt=0), "time.bounds", checks.HORIZON_RANGE)
        if not b[0] < b[1]:
            c.fail("time.bounds", f"expected shortest < longest, got {b[0]:g} and {b[1]:g}")
        bounds = (float(b[0]), float(b[1]))
    if "guess" in time:
        guess = c.number(time["guess"], "time.guess", gt=0)
        c.in_range(guess, "time.guess", checks.HORIZON_RANGE)
        if bounds is not None and not bounds[0] <= guess <= bounds[1]:
            c.fail("time.guess", f"{guess:g} is outside the bounds [{bounds[0]:g}, {bounds[1]:g}]")
    return FreeTime(float(weight), None if speed is None else float(speed), guess, bounds)


def provisional_horizon(free: FreeTime, start: np.ndarray, goal: np.ndarray, effort: float):
    """A horizon to hold until the planner chooses one: the guess, else the straight distance
    (at least a metre's tenth) at the cruise speed, inside the bounds."""
    if free.guess is not None:
        return free.guess
    speed = math.sqrt(free.time_weight / effort)
    distance = max(float(np.hypot(*(goal[:2] - start[:2]))), 0.1)
    return float(np.clip(distance / speed, *free.limits()))


def top_speed(model, parameters: Mapping[str, float], bounds) -> float | None:
    """The top speed at which ``model`` (a built-in name or a model, with its ``parameters``)
    drives straight ahead inside its control ``bounds`` (:func:`..model.cruise.top_straight_speed`:
    the differential drive's wheels bound it too); None where no bound limits it, or for a model
    that cannot cruise."""
    if not bounds:
        return None
    from ..model import get_model
    from ..model.cruise import top_straight_speed  # SymPy, once per model and parameters

    try:
        return top_straight_speed(get_model(model), parameters, bounds)
    except ModelError:
        return None


def too_short(start, goal, top: float | None, longest: float, what: str) -> str | None:
    """Why ``longest`` seconds (``what`` names them) are too short for the top speed ``top``
    (:func:`top_speed`) to cover the straight distance from ``start`` to ``goal``; None when
    they are not, or without a top speed."""
    if top is None:
        return None
    distance = float(np.hypot(*(goal[:2] - start[:2])))
    if distance <= top * longest:
        return None
    return (
        f"the goal is {distance:.6g} away and the speed at most {top:.6g}: it takes at least"
        f" {distance / top:.6g} s, longer than {what}"
    )


def too_fast(free: FreeTime, model, parameters: Mapping[str, float], bounds) -> str | None:
    """Why the price of time ``free`` asks the bounded ``model`` (a built-in name or a model,
    with its ``parameters``) to cruise at or above the top speed its control ``bounds`` allow:
    its optimum would then drive at that top speed, on the bounds, where the costates the
    shooting solves for grow without limit and the condition that fixes ``T`` is never met (a
    search of minutes that ends in nothing, or at a dearer route that does not reach the
    bounds); None when it does not."""
    from ..model import get_model
    from ..model.cruise import cruise  # SymPy, once per model and parameters

    vehicle = get_model(model)
    try:
        straight = cruise(vehicle, parameters)
    except ModelError:  # a model that cannot cruise: its price of time is given as a weight
        return None
    top = straight.top_speed(vehicle.control_names, bounds)
    if top is None:
        return None
    speed = math.sqrt(free.time_weight / straight.effort)
    if speed < top:
        return None
    asked = (
        f"a cruise speed of {speed:g}"
        if free.cruise_speed is not None
        else f"a price of time of {free.time_weight:g} per second (a cruise speed of {speed:.4g})"
    )
    return (
        f"{asked} is at or above the top speed {top:.4g} the control bounds allow: the optimum"
        f" would drive at the top speed, which the planner cannot solve for; ask for a cruise"
        f" speed below {top:.4g}, or plan a fixed horizon"
    )


def refuse_unreachable(scenario) -> None:
    """Refuse, before anything is planned, a fixed horizon too short for the scenario's bounded
    speed (:func:`too_short`: no plan could succeed), or a free one priced to cruise at or
    above it (:func:`too_fast`: no plan could settle ``T``)."""
    free, bounds = scenario.free_time, scenario.control_bounds
    if free is None:
        key, T = "horizon", scenario.horizon
        top = top_speed(scenario.model, scenario.model_parameters, bounds)
        why = too_short(scenario.start, scenario.goal, top, T, f"T = {T:g}")
    else:
        key = "cost.cruise_speed" if free.cruise_speed is not None else "cost.time_weight"
        why = too_fast(free, scenario.model, scenario.model_parameters, bounds) if bounds else None
    if why is not None:
        ScenarioCheck(scenario.source or scenario.name).fail(key, why)
