"""Vehicle models, given symbolically.

A model is its dynamics ``f(x, u)`` and its control running cost ``L_u(x, u)``, nothing more:
Pontryagin's principle is applied to it by :mod:`leapfrog_planner.model.pmp`. By convention the
first two states are the planar position ``(x, y)`` (the obstacle penalty acts on them) and the
third is the heading.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..errors import ModelError
from .aid import PlanningAid


@dataclass(frozen=True)
class VehicleModel:
    name: str
    states: tuple[sp.Symbol, ...]
    controls: tuple[sp.Symbol, ...]
    dynamics: tuple[sp.Expr, ...]
    running_cost: sp.Expr
    parameters: tuple[sp.Symbol, ...] = ()
    defaults: tuple[float, ...] = ()
    parameter_names: tuple[str, ...] = ()
    description: str = ""
    # Control names as shown to users (plots, JSON); the symbols may be terse.
    control_names: tuple[str, ...] = field(default=())
    # The controls' bounds, (index, lower, upper, switch) with parameter symbols, clipped
    # smoothly with the width ``smoothing`` where the switch is 1; set by
    # :func:`.bounds.boundable` for every control (empty in a model as its author writes it).
    control_bounds: tuple[tuple[int, sp.Symbol, sp.Symbol, sp.Symbol], ...] = ()
    smoothing: sp.Symbol | None = None
    # A parameter that widens the model while Leapfrog runs, continued to the robot's own value
    # afterwards (the car's turn assist; see :mod:`.aid`); None for models that need none.
    aid: PlanningAid | None = None

    def __post_init__(self):
        if len(self.states) < 3:
            raise ModelError(f"model {self.name!r}: needs at least 3 states (x, y, heading)")
        if len(self.dynamics) != len(self.states):
            raise ModelError(
                f"model {self.name!r}: {len(self.dynamics)} dynamics for {len(self.states)} states"
            )
        if not (len(self.parameters) == len(self.defaults) == len(self.parameter_names)):
            raise ModelError(
                f"model {self.name!r}: parameters, defaults and names differ in length"
            )
        known = set(self.states) | set(self.controls) | set(self.parameters)
        free = set().union(*(e.free_symbols for e in self.dynamics), self.running_cost.free_symbols)
        if free - known:
            names = ", ".join(sorted(str(s) for s in free - known))
            raise ModelError(f"model {self.name!r}: undeclared symbols {names}")
        if self.aid is not None and self.aid.parameter not in self.parameter_names:
            raise ModelError(
                f"model {self.name!r}: its planning aid {self.aid.parameter!r} is no parameter"
            )
        if not self.control_names:
            object.__setattr__(self, "control_names", tuple(str(u) for u in self.controls))

    @property
    def nx(self) -> int:
        return len(self.states)

    @property
    def nu(self) -> int:
        return len(self.controls)

    def fingerprint(self) -> str:
        """A stable text that changes whenever the model's mathematics changes (cache key)."""
        parts = [
            self.name,
            *(sp.srepr(s) for s in self.states),
            *(sp.srepr(u) for u in self.controls),
            *(sp.srepr(p) for p in self.parameters),
            *(sp.srepr(e) for e in self.dynamics),
            sp.srepr(self.running_cost),
            *(f"bound {i}: {' '.join(map(sp.srepr, b))}" for i, *b in self.control_bounds),
            f"aid: {self.aid.as_tuple() if self.aid else None}",
        ]
        return "\n".join(parts)
