"""The planner's settings: validated, frozen, built from flat options or a scenario's
``[solver]`` table (the measurements behind the defaults: ``docs/tuning.md``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, is_dataclass, replace

from .. import checks
from ..errors import ScenarioError, SettingsError, describe, did_you_mean, require_integer, short
from .leapfrog import LeapfrogSettings


@dataclass(frozen=True)
class PlannerSettings:
    """The planner's settings (the measurements behind the defaults: ``docs/tuning.md``)."""

    initial_paths: int = 3  # paths tried, of least estimated cost (see Planner.initial_paths)
    # Paths run after those, while estimated within a factor of the cheapest, each stopped
    # when it turns out far dearer than the extremals found (see search.py); 0: none.
    extra_paths: int = 5
    # Of those, this many run whatever their estimate (the next-ranked ones where the factor
    # leaves fewer): an estimate can be more than ten times a path's optimum (search.py).
    min_extra_paths: int = 1
    candidate_paths: int = 8  # homotopy classes planned, from which those are picked
    margin: float = 0.02  # obstacle inflation of the initial paths
    samples: int = 1001  # points of the returned dense trajectory
    # Initial paths run in parallel threads (the compiled flow releases the GIL): 0 means one
    # per path, all at once; 1 runs them one after the other. Results do not depend on it.
    threads: int = 0
    # A plan whose answer falls short (no extremal at all, or a collision-free Leapfrog iterate
    # cheaper than the best extremal) runs its stages again with the partitions doubled, this
    # many times at most: at long horizons the arcs of q = 8 are too long for a stiff penalty.
    finer_doublings: int = 1
    # A route on a map at least this many of its penalty's length scales long (the shortest
    # initial path's length) starts at 32 partitions at least, halved down to 16 arcs at least
    # (docs/tuning.md); 0: never.
    long_route: float = 64.0
    # Seconds a plan may take (None: no limit). Past it no new run or sweep starts: the plan
    # ends with the best answer found so far, and says that the limit cut it short.
    time_limit: float | None = None
    leapfrog: LeapfrogSettings = LeapfrogSettings()

    def __post_init__(self):
        require_integer("initial_paths", self.initial_paths, 1, 32)
        require_integer("extra_paths", self.extra_paths, 0, 32)
        require_integer("min_extra_paths", self.min_extra_paths, 0, 32)
        require_integer("candidate_paths", self.candidate_paths, 1, 64)
        require_integer("threads", self.threads, 0, 256)
        require_integer("finer_doublings", self.finer_doublings, 0, 7)
        route = checks.real(self.long_route, "long_route", error=SettingsError)
        checks.in_range(route, "long_route", 0.0, 1e9, error=SettingsError)
        if not 0 <= self.margin <= 1e6:
            raise SettingsError(f"margin must be between 0 and 1e6, got {self.margin!r}")
        require_integer("samples", self.samples, 2, 1_000_000)
        if self.time_limit is not None:
            limit = self.time_limit
            if (
                isinstance(limit, bool)
                or not isinstance(limit, int | float)
                or not 0 < limit <= 1e7
            ):
                raise SettingsError(
                    f"time_limit: expected seconds, > 0 and at most 1e7, got {describe(limit)}"
                )

    @classmethod
    def from_options(cls, base: PlannerSettings | None = None, **options) -> PlannerSettings:
        """Settings from flat options (``method``, ``partitions``, ``initial_paths``, ...).

        Keys of :class:`LeapfrogSettings` and of this class are accepted; anything else is an error.
        """
        base = base or cls()
        own = {f.name for f in fields(cls)} - {"leapfrog"}
        lf = {f.name for f in fields(LeapfrogSettings)}
        unknown = sorted(set(options) - own - lf, key=str)
        if unknown:
            raise SettingsError(
                f"unknown option {short(unknown[0])} ({did_you_mean(unknown[0], own | lf)}"
                f"known: {', '.join(sorted(own | lf))})"
            )
        lf_opts = {k: v for k, v in options.items() if k in lf}
        leapfrog = updated(base.leapfrog, lf_opts, "")
        return updated(base, {k: v for k, v in options.items() if k in own}, "", leapfrog=leapfrog)

    @classmethod
    def from_dict(cls, data: Mapping) -> PlannerSettings:
        """Settings from their JSON values (a result's ``settings``): each key checked as an
        option is, nested tables (``leapfrog``, ``leapfrog.shooting.root``) by their own fields;
        an unknown key is an error, a key left out keeps its default."""
        if not isinstance(data, Mapping):
            raise SettingsError(f"settings: expected a table, got {describe(data)}")
        return updated(cls(), data, "")

    def solver_table(self) -> dict:
        """The values of a scenario's ``[solver]`` keys in these settings: a scenario with this
        table plans with them."""
        from .scenario import SOLVER_KEYS  # the keys are the settings' own names

        own = {f.name for f in fields(self)}
        return {key: getattr(self if key in own else self.leapfrog, key) for key in SOLVER_KEYS}

    @classmethod
    def of_scenario(cls, scenario, base: PlannerSettings | None = None, **options):
        """The settings of ``scenario``'s ``[solver]`` table over ``base``, with ``options`` on
        top; a bad value in the file is the file's error, which names it."""
        from_file = dict(scenario.solver)  # the [solver] keys are the settings' names
        for name in from_file:
            try:
                cls.from_options(base, **{name: from_file[name]})
            except SettingsError as e:  # "partitions: must be ..." -> "solver.partitions: ..."
                source = scenario.source or scenario.name
                why = str(e).removeprefix(f"{name}: ")
                raise ScenarioError(f"{source}: solver.{name}: {why}") from None
        return cls.from_options(base, **{**from_file, **options})


def updated(base, options: Mapping, prefix: str, **ready):
    r"""The settings dataclass ``base`` with ``options`` (a mapping of its fields) put in: a
    nested settings field takes a table of its own fields, put into its value in ``base``
    (``shooting={"root": {"tol": 1e-6}}`` changes that tolerance only); ``ready`` are values
    already checked. Unknown keys, wrong types and values out of range are one-line
    :class:`SettingsError`\ s named by their path (``shooting.root.tol``)."""
    known = {f.name for f in fields(base)}
    values = dict(ready)
    for key, value in options.items():
        path = f"{prefix}{key}"
        if key not in known:
            raise SettingsError(
                f"{path}: unknown option ({did_you_mean(key, known)}"
                f"known: {', '.join(sorted(known))})"
            )
        inner = getattr(base, key)
        if is_dataclass(inner) and not isinstance(value, type(inner)):
            if not isinstance(value, Mapping):
                raise SettingsError(
                    f"{path}: expected a table of {', '.join(f.name for f in fields(inner))},"
                    f" got {describe(value)}"
                )
            value = updated(inner, value, f"{path}.")
        values[key] = value
    try:
        return replace(base, **values)
    except SettingsError as e:
        raise SettingsError(f"{prefix}{e}" if prefix else str(e)) from None
    except (TypeError, ValueError, OverflowError) as e:  # a value of the wrong kind
        what = ", ".join(f"{prefix}{k} = {describe(v)}" for k, v in options.items())
        raise SettingsError(f"{what}: not accepted ({type(e).__name__})") from None
