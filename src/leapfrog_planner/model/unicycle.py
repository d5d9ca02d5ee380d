"""Kinematic unicycle: the standard model of a two-wheeled differential-drive robot."""

import sympy as sp

from .base import VehicleModel


def unicycle() -> VehicleModel:
    x, y, th = sp.symbols("x y theta", real=True)
    v, w = sp.symbols("v omega", real=True)
    return VehicleModel(
        name="unicycle",
        states=(x, y, th),
        controls=(v, w),
        dynamics=(v * sp.cos(th), v * sp.sin(th), w),
        running_cost=(v**2 + w**2) / 2,
        description="kinematic unicycle; controls: forward speed v and turn rate omega",
        control_names=("v", "omega"),
    )
