"""Bounds on the controls: every model's controls can saturate smoothly, switched on by data.

With ``lo <= u_i <= hi`` the control minimising the Hamiltonian is the unconstrained one clipped
to the bounds, which has corners: Newton's method on the shooting equations needs smooth ones.
A bounded control is clipped with a smooth function of width ``eps``:

    clip_eps(s) = (lo + hi) / 2 + (sqrt((s - lo)^2 + eps^2) - sqrt((s - hi)^2 + eps^2)) / 2

which is ``s`` well inside the bounds and the bound well outside, is strictly increasing, and
exceeds a bound by at most ``eps^2 / (4 (hi - lo))``. It is the exact minimiser of a Hamiltonian
whose control cost is a convex barrier that tends to ``1/2 u^2`` inside the bounds as
``eps -> 0``; the planner solves at a coarse ``eps`` and continues it down (see the planner).

Whether a control is bounded, its bounds and ``eps`` are parameters of the generated code (see
:func:`boundable`): one kernel set per model serves every scenario, bounded or not. The generated
code computes the unconstrained control ``s`` and then, at run time, ``u = s`` and its slope
``du/ds = 1`` for a free control, ``u = clip_eps(s)`` and its slope for a bounded one.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from .._jit import njit

if TYPE_CHECKING:
    from .base import VehicleModel

#: Name of the smoothing width among a model's parameters.
SMOOTHING = "control_smoothing"


@njit(cache=True, inline="always")
def saturate(s: float, lo: float, hi: float, on: float, eps: float) -> tuple[float, float]:
    """The control and its slope ``du/ds`` at the unconstrained control ``s``: ``clip_eps(s)``
    of the module docstring where ``on`` is not 0, else ``s`` itself (slope 1)."""
    if on == 0.0:
        return s, 1.0
    a = math.sqrt((s - lo) * (s - lo) + eps * eps)
    b = math.sqrt((s - hi) * (s - hi) + eps * eps)
    return 0.5 * (lo + hi) + 0.5 * (a - b), 0.5 * ((s - lo) / a - (s - hi) / b)


def bound_names(control: str) -> tuple[str, str]:
    """The parameters holding a control's lower and upper bound."""
    return f"{control}_min", f"{control}_max"


def switch_name(control: str) -> str:
    """The parameter that bounds a control when 1 (0: the control is free)."""
    return f"{control}_bounded"


def bound_parameters(controls) -> tuple[str, ...]:
    """The parameters :func:`boundable` adds for the named controls (in its order)."""
    return (*(n for c in controls for n in (*bound_names(c), switch_name(c))), SMOOTHING)


def boundable(model: VehicleModel) -> VehicleModel:
    """``model`` with every control boundable: its parameters gain, per control, ``<u>_min``,
    ``<u>_max`` and the switch ``<u>_bounded`` (defaults -1, 1 and 0: free), then
    :data:`SMOOTHING` (default 0.1). The planner sets them from a scenario's bounds."""
    if model.control_bounds:  # already boundable
        return model
    import sympy as sp  # SymPy only when a model is derived: the planner imports this module

    symbols, bounds = [], []
    for i, c in enumerate(model.control_names):
        lo_name, hi_name = bound_names(c)
        lo, hi = sp.Symbol(lo_name, real=True), sp.Symbol(hi_name, real=True)
        on = sp.Symbol(switch_name(c), nonnegative=True)
        symbols += [lo, hi, on]
        bounds.append((i, lo, hi, on))
    eps = sp.Symbol(SMOOTHING, positive=True)
    return replace(
        model,
        parameters=(*model.parameters, *symbols, eps),
        defaults=(*model.defaults, *([-1.0, 1.0, 0.0] * model.nu), 0.1),
        parameter_names=(*model.parameter_names, *bound_parameters(model.control_names)),
        control_bounds=tuple(bounds),
        smoothing=eps,
    )
