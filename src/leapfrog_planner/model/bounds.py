"""Bounds on the controls: a model variant whose minimising control saturates smoothly.

With ``lo <= u_i <= hi`` the control minimising the Hamiltonian is the unconstrained one clipped
to the bounds, which has corners: Newton's method on the shooting equations needs smooth ones.
The variant clips with a smooth function of width ``eps`` (a parameter, like the bounds):

    clip_eps(s) = (lo + hi) / 2 + (sqrt((s - lo)^2 + eps^2) - sqrt((s - hi)^2 + eps^2)) / 2

which is ``s`` well inside the bounds and the bound well outside, is strictly increasing, and
exceeds a bound by at most ``eps^2 / (4 (hi - lo))``. It is the exact minimiser of a Hamiltonian
whose control cost is a convex barrier that tends to ``1/2 u^2`` inside the bounds as
``eps -> 0``; the planner solves at a coarse ``eps`` and continues it down (see the planner).
The bounds and ``eps`` are parameters of the generated code, so new bounds never recompile.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from ..errors import ModelError

if TYPE_CHECKING:
    from .base import VehicleModel

#: Name of the smoothing width among a bounded model's parameters.
SMOOTHING = "control_smoothing"


def smooth_clip(s, lo, hi, eps):
    """``clip_eps(s)`` of the module docstring (works on SymPy expressions and floats)."""
    import sympy as sp  # SymPy only when a model is derived: the planner imports this module

    sqrt = sp.sqrt if isinstance(s, sp.Basic) else (lambda a: a**0.5)
    return (lo + hi) / 2 + (sqrt((s - lo) ** 2 + eps**2) - sqrt((s - hi) ** 2 + eps**2)) / 2


def bound_names(control: str) -> tuple[str, str]:
    return f"{control}_min", f"{control}_max"


def bounded_model(model: VehicleModel, controls: tuple[str, ...]) -> VehicleModel:
    """``model`` with the named controls bounded; its parameters gain ``<u>_min``, ``<u>_max``
    per bounded control and :data:`SMOOTHING` (defaults -1, 1 and 0.1)."""
    import sympy as sp

    known = dict(zip(model.control_names, model.controls, strict=True))
    unknown = [c for c in controls if c not in known]
    if unknown or not controls:
        raise ModelError(
            f"model {model.name!r}: no control {unknown[0] if unknown else '(none given)'!r}"
            f" to bound (controls: {', '.join(model.control_names)})"
        )
    symbols, names, defaults, bounds = [], [], [], []
    for c in model.control_names:
        if c not in controls:
            continue
        lo_name, hi_name = bound_names(c)
        lo, hi = sp.Symbol(lo_name, real=True), sp.Symbol(hi_name, real=True)
        symbols += [lo, hi]
        names += [lo_name, hi_name]
        defaults += [-1.0, 1.0]
        bounds.append((model.controls.index(known[c]), lo, hi))
    eps = sp.Symbol(SMOOTHING, positive=True)
    return replace(
        model,
        name=f"{model.name}-bounded-{'-'.join(c for c in model.control_names if c in controls)}",
        parameters=(*model.parameters, *symbols, eps),
        defaults=(*model.defaults, *defaults, 0.1),
        parameter_names=(*model.parameter_names, *names, SMOOTHING),
        description=f"{model.description}; bounded: {', '.join(controls)}",
        control_bounds=tuple(bounds),
        smoothing=eps,
    )
