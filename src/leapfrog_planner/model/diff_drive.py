"""Differential drive with the wheel angular speeds as controls."""

import sympy as sp

from .base import VehicleModel


def diff_drive() -> VehicleModel:
    x, y, th = sp.symbols("x y theta", real=True)
    wr, wl = sp.symbols("omega_R omega_L", real=True)
    r, b = sp.symbols("r b", positive=True)
    v = r * (wr + wl) / 2
    w = r * (wr - wl) / b
    return VehicleModel(
        name="diff-drive",
        states=(x, y, th),
        controls=(wr, wl),
        dynamics=(v * sp.cos(th), v * sp.sin(th), w),
        running_cost=(wr**2 + wl**2) / 2,
        parameters=(r, b),
        # r = 1, b = 2 make v and omega the mean and half-difference of the wheel speeds, so the
        # running cost is v^2 + omega^2: twice the unicycle's, which keeps results comparable.
        defaults=(1.0, 2.0),
        parameter_names=("wheel_radius", "axle_length"),
        description="differential drive; controls: right and left wheel angular speeds",
        control_names=("omega_R", "omega_L"),
    )
