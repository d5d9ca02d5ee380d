"""Kinematic car (bicycle model): the heading turns with the speed and the steering angle.

``turn_assist`` adds a turn rate the car does not have (``a omega`` in the heading equation, at
the cost ``omega^2 / 2``): with it the car can turn in place like a unicycle, which is how the
planner starts (from paths made for turning robots) before continuing it to 0, the car itself.
"""

import sympy as sp

from .aid import PlanningAid
from .base import VehicleModel


def car() -> VehicleModel:
    x, y, th, delta = sp.symbols("x y theta delta", real=True)
    v, sigma, w = sp.symbols("v sigma omega", real=True)
    wheelbase = sp.Symbol("L", positive=True)
    assist = sp.Symbol("a", nonnegative=True)
    return VehicleModel(
        name="car",
        states=(x, y, th, delta),
        controls=(v, sigma, w),
        dynamics=(
            v * sp.cos(th),
            v * sp.sin(th),
            v * sp.tan(delta) / wheelbase + assist * w,
            sigma,
        ),
        running_cost=(v**2 + sigma**2 + w**2) / 2,
        parameters=(wheelbase, assist),
        defaults=(0.5, 0.0),
        parameter_names=("wheelbase", "turn_assist"),
        description=(
            "kinematic car (bicycle model): states x, y, heading, steering angle delta; controls "
            "speed v, steering rate sigma (and the planning aid omega, zero for the car itself)"
        ),
        control_names=("v", "sigma", "omega"),
        # Leapfrog runs the car assisted by 1 (it turns like a unicycle), then by 0.5 when no
        # run clears the obstacles: with the goal close behind, the family of extremals from 1
        # folds before the assist reaches 0 on 6 of 40 layouts, and from 0.5 it reaches the car
        # (32 -> 38 of 40 converged; docs/tuning.md).
        aid=PlanningAid("turn_assist", (1.0, 0.5)),
    )
