"""Leapfrog's settings: validated on construction; the measurements behind each default are in
``docs/tuning.md``."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from ...bvp.shooting import ShootingSettings
from ...errors import SettingsError, require_integer
from ...integrate.flow import IntegratorSettings
from ...roots import STRATEGIES, ModifiedNewtonStep, NewtonStep, NleqErrStep, RootSettings

FINAL_MODES = ("auto", "shooting", "multiple-shooting")
#: More junctions than this buy no accuracy and cost seconds per sweep (10,000 took 28 s and
#: landed on a worse extremal than 8).
MAX_PARTITIONS = 1024

#: The local problems' step for each method: MNM's line search stops at 2^-3 there (a step eight
#: times shorter than Newton's that still fails means the local problem is failing from this
#: guess, and Leapfrog handles that). NM and NLEQ-ERR as they are.
LOCAL_STEPS = {
    "newton": NewtonStep(),
    "modified-newton": ModifiedNewtonStep(max_halvings=3),
    "nleq-err": NleqErrStep(),
}
_STEP_TYPES = (NewtonStep, ModifiedNewtonStep, NleqErrStep)


@dataclass(frozen=True)
class LeapfrogSettings:
    """How Leapfrog runs. ``method`` names the Newton method of every solve; ``local`` is the
    step object of the local problems (default: :data:`LOCAL_STEPS` of the method), e.g.
    ``ModifiedNewtonStep(max_halvings=10)`` for a longer line search there."""

    method: str = "modified-newton"
    local: object | None = None
    partitions: int = 8  # initial q
    # Levels are halved while the halved level keeps at least this many arcs; above 2, the
    # last level is the final solves' (simple shooting from its first arc, then multiple
    # shooting over its arcs): at long horizons arcs merged further are too long to solve.
    fewest_arcs: int = 2
    max_sweeps: int = 60  # over all levels
    sweeps_per_level: int = 10
    reduce_tol: float = 1e-3  # q is halved below this relative decrease per sweep...
    jump_tol: float = 1e-6  # ...or below this relative costate jump
    final: str = "auto"  # "shooting", "multiple-shooting", or both in turn
    # When the final solves fail, the last level with q > 2 (or at fewest_arcs) is swept on (at
    # most this many more sweeps, 20 times as many on a level of more than 4 arcs, until its
    # costate jump is below final_retry_jump or a sweep no longer lowers the cost) and they are
    # tried again: on a long route's fewest arcs Leapfrog converges slowly (docs/tuning.md).
    final_retry_sweeps: int = 10
    final_retry_jump: float = 1e-4
    # Multiple shooting's arcs: those of the last level with q > 2, then every arc split in
    # two, at most this many times (4, 8, 16 arcs from a level of 4).
    final_refinements: int = 2
    # Where Newton's multiple shooting over the last level fails, Levenberg-Marquardt from the
    # same start, at most this many trial points (0: none; docs/tuning.md).
    final_least_squares: int = 200
    max_split_depth: int = 4  # a failing initial segment is split in two at most this deep
    max_refinements: int = 2  # levels that end with a failing local problem are refined
    attempt_iterations: int = 10  # per attempt at a local problem before the next strategy
    attempt_stall_window: int = 3  # an attempt whose |F| has not halved in 3 is cut short
    two_arc_attempt: bool = True  # a failed warm start is retried as two arcs (sweeps)
    continuation_first_step: float = 0.25  # of the parameter's range (weight or end state)
    continuation_min_step: float = 1.0 / 64
    continuation_steps: int = 24  # steps tried before a continuation counts as failed
    # The sweeps' warm starts run as one compiled call where the local shooter is compiled;
    # False runs every junction from Python (the same arithmetic: the tests compare the two).
    fused_sweeps: bool = True
    # Local problems: |F| <= 1e-5 at rtol 1e-7, at most 25 iterations and 200 integrator steps.
    shooting: ShootingSettings = field(
        default_factory=lambda: ShootingSettings(
            samples=0,
            root=RootSettings(tol=1e-5, max_iterations=25, divergence=1e3),
            integrator=IntegratorSettings(rtol=1e-7, atol=1e-7, max_steps=200),
        )
    )
    # The final simple (and multiple) shooting: |F| <= 1e-10 at rtol 1e-12, stalled when |F|
    # is not 10% below the largest of its 4 norms before, flows of at most 5000 steps.
    final_shooting: ShootingSettings = field(
        default_factory=lambda: ShootingSettings(
            samples=0,
            root=RootSettings(max_iterations=25, divergence=1e3, stall_window=4, stall_factor=0.9),
            integrator=IntegratorSettings(max_steps=5000),
        )
    )

    def __post_init__(self):
        if self.method not in STRATEGIES:
            raise SettingsError(f"unknown method {self.method!r} (known: {', '.join(STRATEGIES)})")
        if self.local is not None and not isinstance(self.local, _STEP_TYPES):
            raise SettingsError(
                "local must be a step object (NewtonStep, ModifiedNewtonStep, NleqErrStep),"
                f" got {self.local!r}"
            )
        require_integer("partitions", self.partitions, 2, MAX_PARTITIONS)
        require_integer("fewest_arcs", self.fewest_arcs, 2, MAX_PARTITIONS)
        require_integer("max_sweeps", self.max_sweeps, 1, 1000)
        require_integer("sweeps_per_level", self.sweeps_per_level, 1, 1000)
        if not (self.reduce_tol > 0 and self.jump_tol > 0 and self.final_retry_jump > 0):
            raise SettingsError("reduce_tol, jump_tol and final_retry_jump must be > 0")
        require_integer("final_retry_sweeps", self.final_retry_sweeps, 0, 1000)
        require_integer("final_refinements", self.final_refinements, 0, 6)
        require_integer("final_least_squares", self.final_least_squares, 0, 100_000)
        if self.final not in FINAL_MODES:
            raise SettingsError(
                f"final must be one of {', '.join(FINAL_MODES)}, got {self.final!r}"
            )
        require_integer("attempt_iterations", self.attempt_iterations, 1, 1000)
        require_integer("attempt_stall_window", self.attempt_stall_window, 0, 1000)
        for name in ("two_arc_attempt", "fused_sweeps"):
            if not isinstance(getattr(self, name), bool):
                raise SettingsError(f"{name} must be true or false, got {getattr(self, name)!r}")
        require_integer("continuation_steps", self.continuation_steps, 1, 1000)
        if not 0 < self.continuation_min_step <= self.continuation_first_step <= 1:
            raise SettingsError(
                "need 0 < continuation_min_step <= continuation_first_step <= 1, got "
                f"{self.continuation_min_step} and {self.continuation_first_step}"
            )
        require_integer("max_refinements", self.max_refinements, 0, 6)
        require_integer("max_split_depth", self.max_split_depth, 0, 12)

    def local_step(self):
        """The step object of the local problems."""
        return self.local if self.local is not None else LOCAL_STEPS[self.method]

    def local_solves(self) -> ShootingSettings:
        """The local problems' shooting settings: this run's method, no dense output."""
        return replace(self.shooting, samples=0, method=self.method)

    def final_solves(self) -> ShootingSettings:
        """The final solves' shooting settings: this run's method, no dense output."""
        return replace(self.final_shooting, samples=0, method=self.method)

    def continued_solves(self) -> ShootingSettings:
        """The solves that follow a family of extremals from a nearby one (the free-time
        search's continuation in ``T``): the final solves' accuracy with the local problems'
        step. Their guess is a prediction; where a step eight times shorter than Newton's still
        fails, the prediction was not near enough, and the continuation takes a shorter step
        (a longer line search, 2^-20, only made the failures slow: ``docs/tuning.md``)."""
        return replace(self.final_solves(), method=self.local_step())

    def bounds_solves(self) -> ShootingSettings:
        """The solves of the continuation to bounded controls (the smoothing of the clip
        narrowed step by step): ``final_shooting`` with its method's local step (MNM: the line
        search stops at 2^-3), so that a step that fails is halved sooner. The car's turn assist
        is continued with ``final_shooting`` itself: there the shorter search changed answers
        (``docs/tuning.md``)."""
        method = self.final_shooting.method
        step = LOCAL_STEPS[method] if isinstance(method, str) else method
        return replace(self.final_shooting, method=step)
