"""A model's planning aid: a parameter that widens the model while Leapfrog runs.

The car cannot turn in place, and the initial paths are made for robots that can. Its model
carries a turn rate the car does not have, weighted by its parameter ``turn_assist``: with the
assist at 1 the car turns like a unicycle and Leapfrog can follow those paths; afterwards each
extremal is continued to the robot's own value (0: the car itself). Plain data, read from the
generated module, so that a warm start never imports SymPy.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlanningAid:
    """``parameter`` is set to ``values[0]`` while Leapfrog runs; a plan none of whose runs
    reaches a collision-free extremal runs its paths again at the next value (the family of
    extremals from the first may fold before the continuation reaches the robot's own value).
    ``turns_in_place``: the aid is what lets the model turn in place, so a robot whose own
    value is 0 is given no initial path that turns in place at an end."""

    parameter: str
    values: tuple[float, ...]
    turns_in_place: bool = True

    def __post_init__(self):
        if not self.values:
            raise ValueError(f"planning aid {self.parameter!r}: no values")

    def as_tuple(self) -> tuple:
        """The plain tuple written into the generated module (``PlanningAid(*t)`` reads it)."""
        return (self.parameter, tuple(float(v) for v in self.values), self.turns_in_place)
