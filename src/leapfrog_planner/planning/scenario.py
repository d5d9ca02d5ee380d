"""Scenarios: one planning task (end states, horizon, obstacles, robot, penalty) read from TOML.

The file format, every key, the bounds and the error messages: ``docs/scenarios.md``. Every
problem raises :class:`~leapfrog_planner.errors.ScenarioError` (a ``ValueError``) with one line,
``<source>: <key>: <problem>``; :data:`SOLVER_KEYS` lists the ``[solver]`` keys and their types.
"""

from __future__ import annotations

import os
import re
import tomllib
import unicodedata
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .. import checks
from ..compiled.kernels import model_info
from ..errors import ScenarioError, describe, short
from ..integrate.problem import ObstaclePenalty, OptimalControlProblem
from ..model import MODELS
from .scenario_checks import ScenarioCheck, key_path
from .scenario_files import decode_text, not_toml, path_exists, read_scenario_file
from .scenario_map import ScenarioMap, map_from_tables
from .scenario_time import (
    FREE,
    FreeTime,
    free_time_from_tables,
    provisional_horizon,
    too_short,
    top_speed,
)
from .scenario_toml import toml_key, toml_state, toml_value

__all__ = [
    "SOLVER_KEYS",
    "Scenario",
    "as_scenario",
    "builtin_scenarios",
    "load_scenario",
    "load_scenario_text",
    "scenario_from_dict",
]

#: Keys allowed in the optional ``[solver]`` table (planner settings, by their names) and the
#: Python type each value must have.
#: ``float`` accepts integers (converted); ``int`` rejects floats; booleans are neither.
SOLVER_KEYS: dict[str, type] = {
    "method": str,
    "partitions": int,
    "fewest_arcs": int,
    "long_route": float,
    "initial_paths": int,
    "reduce_tol": float,
    "max_sweeps": int,
}

TOP_LEVEL_KEYS = (
    "name",
    "horizon",
    "start",
    "goal",
    "waypoints",
    "robot",
    "penalty",
    "solver",
    "obstacles",
    "map",
    "polygons",
    "walls",
    "cost",
    "time",
)
REQUIRED_KEYS = ("horizon", "start", "goal")
#: The smoothing widths of bounded controls, relative to the narrowest range: Leapfrog at the
#: first, then simple shooting continued through the others (exceeding a bound by at most
#: 2.5e-9 of the range at the last).
SMOOTHING_STEPS = (0.1, 0.01, 1e-3, 1e-4)
ROBOT_KEYS = ("model", "radius", "margin")  # the [robot] keys besides the model's parameters
PENALTY_KEYS = ("weight", "exponent")
OBSTACLE_KEYS = ("center", "radius")

DEFAULT_MODEL = "unicycle"
DEFAULT_WEIGHT = 100.0
DEFAULT_EXPONENT = 2

_BUILTIN_PREFIX = "builtin:"


def _fresh_readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=float, copy=True)
    arr.setflags(write=False)
    return arr


def has_control_characters(text: str) -> bool:
    """Whether ``text`` holds a control character (tab, line break, escape, DEL, C1) or a lone
    surrogate (which no file can hold)."""
    return any(unicodedata.category(ch) in ("Cc", "Cs") for ch in text)


def _default_name(source: str) -> str:
    if source.startswith(_BUILTIN_PREFIX):
        return source[len(_BUILTIN_PREFIX) :]
    if source.startswith("<") or not source.strip():
        return "scenario"
    stem = "".join("_" if has_control_characters(ch) else ch for ch in Path(source).stem)
    return stem or "scenario"


# --------------------------------------------------------------------------- the scenario


@dataclass(frozen=True, eq=False)
class Scenario:
    """One planning task. Construction validates everything (also via ``dataclasses.replace``).

    Arrays are read-only copies. ``model_parameters`` holds every parameter of the model (given
    values and defaults), in the model's order. Two scenarios are equal (``==``) when they
    describe the same task; ``source`` is not compared.
    """

    name: str
    horizon: float
    start: np.ndarray
    goal: np.ndarray
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    model: str = DEFAULT_MODEL
    model_parameters: dict[str, float] = field(default_factory=dict)
    weight: float = DEFAULT_WEIGHT
    exponent: int = DEFAULT_EXPONENT
    waypoints: np.ndarray | None = None
    solver: dict[str, Any] = field(default_factory=dict)
    source: str | None = None
    robot_radius: float = 0.0  # the footprint: a disc of this radius about (x, y)
    margin: float = 0.0  # clearance a converged path keeps beyond the footprint
    control_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)  # name: (lo, hi)
    map: ScenarioMap | None = None  # a ROS map, polygons, walls (planning/scenario_map.py)
    # The final time left to the planner at a price (planning/scenario_time.py); ``horizon``
    # is then where its search starts.
    free_time: FreeTime | None = None

    def __post_init__(self):
        source = None if self.source is None else str(self.source)
        c = ScenarioCheck(source if source is not None else "<scenario>")
        name = c.string(self.name, "name")
        if not name:
            c.fail("name", "expected a non-empty string")
        if has_control_characters(name):
            c.fail("name", f"control characters are not allowed, got {short(name)}")
        horizon = c.number(self.horizon, "horizon", gt=0)
        c.in_range(horizon, "horizon", checks.HORIZON_RANGE)
        model, parameters = self._check_model(c)
        names = ("x", "y", "heading", *model_info(model).states[3:])
        start = c.pose(self.start, "start", names)
        goal = c.pose(self.goal, "goal", names)
        obstacles = c.obstacles(self.obstacles)
        weight = c.number(self.weight, "penalty.weight", ge=0)
        c.in_range(weight, "penalty.weight", (0.0, checks.WEIGHT_MAX))
        exponent = c.integer(
            self.exponent, "penalty.exponent", minimum=1, maximum=checks.EXPONENT_MAX
        )
        waypoints = None
        if self.waypoints is not None:
            waypoints = c.rows(self.waypoints, 2, "waypoints", "x, y")
            if waypoints.shape[0] > checks.WAYPOINTS_MAX:
                c.fail("waypoints", f"at most {checks.WAYPOINTS_MAX}, got {waypoints.shape[0]}")
            for i, w in enumerate(waypoints):
                c.magnitude(w, f"waypoints[{i}]", checks.COORDINATE_MAX)
            if waypoints.shape[0] == 0:
                waypoints = None
        solver = self._check_solver(c)
        robot_radius = c.number(self.robot_radius, "robot.radius", ge=0)
        c.in_range(robot_radius, "robot.radius", (0.0, checks.RADIUS_RANGE[1]))
        margin = c.number(self.margin, "robot.margin", ge=0)
        c.in_range(margin, "robot.margin", (0.0, checks.COORDINATE_MAX))
        bounds = self._check_bounds(c, model)

        self._check_ends(c, start, goal, waypoints, obstacles, robot_radius, exponent)

        values = {
            "name": name,
            "horizon": horizon,
            "start": _fresh_readonly(start),
            "goal": _fresh_readonly(goal),
            "obstacles": _fresh_readonly(obstacles),
            "model": model,
            "model_parameters": parameters,
            "weight": weight,
            "exponent": exponent,
            "waypoints": None if waypoints is None else _fresh_readonly(waypoints),
            "solver": solver,
            "source": source,
            "robot_radius": robot_radius,
            "margin": margin,
            "control_bounds": bounds,
            "map": self.map,
            "free_time": self._check_free_time(c, (start, goal), model, parameters, bounds),
        }
        for k, v in values.items():
            object.__setattr__(self, k, v)

    def _check_free_time(self, c: ScenarioCheck, ends, model, parameters, bounds):
        """The free time (a :class:`FreeTime` or None), of the right type, and its longest ``T``
        long enough for the top speed of ``model`` in its ``bounds`` to cover the straight
        distance between the ``ends``."""
        free = self.free_time
        if free is None:
            return None
        if not isinstance(free, FreeTime):
            c.fail("free_time", f"expected a FreeTime or None, got {describe(free)}")
        if free.bounds is not None:
            longest = f"the longest T allowed, {free.bounds[1]:g}"
            why = too_short(*ends, top_speed(model, parameters, bounds), free.bounds[1], longest)
            if why is not None:
                c.fail("time.bounds", why)
        return free

    def _check_ends(self, c, start, goal, waypoints, obstacles, robot_radius, exponent) -> None:
        """The footprint at the start, the goal and the waypoints may not overlap an obstacle
        (nor a blocked cell of the map)."""
        points = [("start", start[:2]), ("goal", goal[:2])]
        if waypoints is not None:
            points += [(f"waypoints[{i}]", w) for i, w in enumerate(waypoints)]
        for key, p in points:
            c.outside(p, key, obstacles, robot_radius)
        if self.map is not None:
            self._check_map(c, exponent, points, robot_radius)

    def _check_map(self, c: ScenarioCheck, exponent: int, points, robot_radius: float) -> None:
        """The map, and the ends on it (``points``: start, goal, and waypoints, which a map does
        not take yet)."""
        if not isinstance(self.map, ScenarioMap):
            c.fail("map", f"expected a ScenarioMap, got {describe(self.map)}")
        if exponent < 2:
            c.fail("penalty.exponent", "must be at least 2 with a map")
        if len(points) > 2:
            c.fail("waypoints", "not supported with a map yet")
        if not self.map.placed:  # polygons and walls alone: a grid round them and the ends
            placed = c._named(self.map.around, [p for _, p in points], robot_radius)
            object.__setattr__(self, "map", placed)
        for key, p in points:
            c._named(self.map.check_point, p, key, robot_radius)

    def _check_model(self, c: ScenarioCheck) -> tuple[str, dict[str, float]]:
        model = c.string(self.model, "robot.model")
        if model not in MODELS:
            c.fail("robot.model", f"unknown model {model!r} (known: {', '.join(MODELS)})")
        info = model_info(model)
        given = {} if self.model_parameters is None else c.table(self.model_parameters, "robot")
        positive = dict(zip(info.parameters, info.positive, strict=True))
        nonnegative = dict(zip(info.parameters, info.nonnegative, strict=True))
        allowed = (*ROBOT_KEYS, *info.robot_parameters, *info.controls)
        c.known_keys(given, allowed, "robot", f" for model {model!r}")
        checked = {}
        for k, v in given.items():
            if k in ROBOT_KEYS or k in info.controls:  # only by direct construction
                c.fail(f"robot.{k}", "give it as a Scenario field, not a model parameter")
            ge = 0 if nonnegative[k] and not positive[k] else None  # the car's turn_assist
            checked[k] = c.number(v, key_path("robot", k), gt=0 if positive[k] else None, ge=ge)
            if positive[k]:
                c.in_range(checked[k], key_path("robot", k), checks.PARAMETER_RANGE)
        values = dict(zip(info.parameters, info.parameter_values(checked), strict=True))
        return model, {name: values[name] for name in info.robot_parameters}

    def _check_bounds(self, c: ScenarioCheck, model: str) -> dict[str, tuple[float, float]]:
        """``[robot] <control> = [min, max]``: finite, ``min < max``, for the model's controls."""
        controls = model_info(model).controls
        table = c.table({} if self.control_bounds is None else self.control_bounds, "robot")
        out = {}
        for name, value in table.items():
            key = key_path("robot", name)
            if name not in controls:
                c.fail(key, f"model {model!r} has no control {name!r} ({', '.join(controls)})")
            lo, hi = c.vector(value, 2, key, " [min, max]")
            c.magnitude((lo, hi), key, checks.COORDINATE_MAX)
            if not lo < hi:
                got = f"[{float(lo)!r}, {float(hi)!r}]"  # not numpy's repr, np.float64(1.0)
                c.fail(key, f"expected [min, max] with min < max, got {got}")
            out[name] = (float(lo), float(hi))
        return out

    def _check_solver(self, c: ScenarioCheck) -> dict[str, Any]:
        table = c.table({} if self.solver is None else self.solver, "solver")
        c.known_keys(table, tuple(SOLVER_KEYS), "solver")
        out: dict[str, Any] = {}
        for k, v in table.items():
            key = key_path("solver", k)
            expected = SOLVER_KEYS[k]
            if expected is bool:
                if not isinstance(v, bool | np.bool_):
                    c.fail(key, f"expected a boolean, got {describe(v)}")
                out[k] = bool(v)
            elif expected is int:
                out[k] = c.integer(v, key)
            elif expected is float:
                out[k] = c.number(v, key)
            elif expected is str:
                out[k] = c.string(v, key)
            else:  # pragma: no cover - SOLVER_KEYS only holds the types above
                raise TypeError(f"SOLVER_KEYS[{k!r}]: unsupported type {expected!r}")
        return out

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scenario):
            return NotImplemented
        return self.to_dict() == other.to_dict()

    __hash__ = None  # type: ignore[assignment]  # equal by value, and mutable-looking fields

    def __setstate__(self, state: dict[str, Any]) -> None:
        # Unpickled (or copied) arrays come back writable; keep them read-only.
        for k, v in state.items():
            if isinstance(v, np.ndarray):
                v.setflags(write=False)
            object.__setattr__(self, k, v)

    # ------------------------------------------------------------------ conversions

    def problem(self, smoothing: float | None = None) -> OptimalControlProblem:
        """The optimal control problem: model, obstacle penalty and model parameters. With
        control bounds, the bounded controls saturate smoothly with width ``smoothing``
        (default: the widest of :attr:`smoothing_widths`): parameters of the same kernels."""
        parameters = dict(self.model_parameters)
        if self.control_bounds:
            from ..model.bounds import SMOOTHING, bound_names, switch_name

            for name, (lo, hi) in self.control_bounds.items():
                parameters.update(zip(bound_names(name), (lo, hi), strict=True))
                parameters[switch_name(name)] = 1.0
            parameters[SMOOTHING] = self.smoothing_widths[0] if smoothing is None else smoothing
        info = model_info(self.model)
        world = None if self.map is None else self.map.obstacles(self.robot_radius)
        penalty = ObstaclePenalty(self.footprint_obstacles, self.weight, self.exponent, world)
        return OptimalControlProblem(info, penalty, info.parameter_values(parameters))

    @property
    def smoothing_widths(self) -> tuple[float, ...]:
        """Widths of the smoothed saturation, from the one Leapfrog works at down to the final
        one (relative to the narrowest control range; none without bounds)."""
        if not self.control_bounds:
            return ()
        span = min(hi - lo for lo, hi in self.control_bounds.values())
        return tuple(f * span for f in SMOOTHING_STEPS)

    @property
    def footprint_obstacles(self) -> np.ndarray:
        """The obstacles grown by the robot's radius: where the centre of the robot may not go
        (the obstacles themselves for a point robot). The planner works with these."""
        if not self.robot_radius:
            return self.obstacles
        grown = self.obstacles + np.array([0.0, 0.0, self.robot_radius])
        grown.setflags(write=False)
        return grown

    def to_dict(self) -> dict[str, Any]:
        """Plain Python values in the file's layout; :func:`scenario_from_dict` inverts it."""
        data: dict[str, Any] = {
            "name": self.name,
            "horizon": self.horizon if self.free_time is None else FREE,
            "start": self.start.tolist(),
            "goal": self.goal.tolist(),
        }
        if self.waypoints is not None:
            data["waypoints"] = self.waypoints.tolist()
        data["robot"] = {"model": self.model, **self.model_parameters}
        if self.robot_radius:
            data["robot"]["radius"] = self.robot_radius
        if self.margin:
            data["robot"]["margin"] = self.margin
        for name, (lo, hi) in self.control_bounds.items():
            data["robot"][name] = [lo, hi]
        data["penalty"] = {"weight": self.weight, "exponent": self.exponent}
        if self.solver:
            data["solver"] = dict(self.solver)
        data["obstacles"] = [
            {"center": [float(cx), float(cy)], "radius": float(r)} for cx, cy, r in self.obstacles
        ]
        if self.map is not None:
            if self.map.to_dict():
                data["map"] = self.map.to_dict()
            data.update(self.map.shapes_dict())
        if self.free_time is not None:
            data.update(self.free_time.to_tables())
        return data

    def to_toml(self) -> str:
        """The scenario as a TOML file; :func:`load_scenario_text` reads it back exactly."""
        d = self.to_dict()
        lines = [
            f"name = {toml_value(d['name'])}",
            f"horizon = {toml_value(d['horizon'])}",
            toml_state("start", d["start"]),
            toml_state("goal", d["goal"]),
        ]
        if "waypoints" in d:
            lines.append(f"waypoints = {toml_value(d['waypoints'])}")
        for table in ("robot", "penalty", "cost", "time", "solver", "map"):
            if table in d:
                lines += ["", f"[{table}]"]
                lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in d[table].items()]
        for key in ("obstacles", "polygons", "walls"):
            for item in d.get(key, ()):
                lines += ["", f"[[{key}]]"]
                lines += [f"{k} = {toml_value(v)}" for k, v in item.items()]
        return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- reading


def scenario_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Scenario:
    """A scenario from a parsed file (nested tables and arrays, as :func:`tomllib.loads` gives)."""
    source = str(source)
    c = ScenarioCheck(source)
    if not isinstance(data, Mapping):
        c.fail("", f"expected a table of scenario keys, got {describe(data)}")
    c.table(data, "(top level)")
    c.known_keys(data, TOP_LEVEL_KEYS, "")
    for key in REQUIRED_KEYS:
        if key not in data:
            c.fail(key, "missing required key")

    robot = c.table(data.get("robot", {}), "robot")
    model = robot.get("model", DEFAULT_MODEL)
    controls = model_info(model).controls if model in MODELS else ()
    parameters = {k: v for k, v in robot.items() if k not in ROBOT_KEYS and k not in controls}
    bounds = {k: v for k, v in robot.items() if k in controls}

    penalty = c.table(data.get("penalty", {}), "penalty")
    c.known_keys(penalty, PENALTY_KEYS, "penalty")

    obstacles = _discs_from_tables(c, data.get("obstacles", []))
    table = c.table(data["map"], "map") if "map" in data else None
    world = c._named(
        map_from_tables, table, data.get("polygons"), data.get("walls"), _folder(source)
    )
    scenario = Scenario(
        name=data.get("name", _default_name(source)),
        horizon=1.0 if data["horizon"] == FREE else _seconds(c, data["horizon"]),
        start=data["start"],
        goal=data["goal"],
        obstacles=obstacles,
        model=model,
        model_parameters=parameters,
        weight=penalty.get("weight", DEFAULT_WEIGHT),
        exponent=penalty.get("exponent", DEFAULT_EXPONENT),
        waypoints=data.get("waypoints"),
        solver=c.table(data.get("solver", {}), "solver"),
        source=source,
        robot_radius=robot.get("radius", 0.0),
        margin=robot.get("margin", 0.0),
        control_bounds=bounds,
        map=world,
    )
    return _free_time(c, data, scenario)


def _seconds(c: ScenarioCheck, horizon):
    """A fixed ``horizon`` as given, checked by :class:`Scenario`; a string other than
    ``"free"`` refused here, saying that it may be."""
    if isinstance(horizon, str):
        c.fail("horizon", f'expected seconds or "{FREE}", got {horizon!r}')
    return horizon


def _free_time(c: ScenarioCheck, data: Mapping, scenario: Scenario) -> Scenario:
    """``scenario`` with the free time of its file: ``horizon = "free"`` with its ``[cost]``
    and ``[time]`` tables (else as it is, and neither table allowed)."""
    if data["horizon"] != FREE:
        for key, what in (("cost", "a price of time"), ("time", "a guess or bounds of T")):
            if key in data:
                c.fail(key, f'{what} needs horizon = "{FREE}", got {data["horizon"]!r}')
        return scenario
    from ..model import get_model
    from ..model.cruise import straight_effort

    effort = straight_effort(get_model(scenario.model), scenario.model_parameters)
    free = free_time_from_tables(c, data.get("cost"), data.get("time"), effort)
    horizon = provisional_horizon(free, scenario.start, scenario.goal, effort)
    return replace(scenario, horizon=horizon, free_time=free)


def _discs_from_tables(c: ScenarioCheck, raw) -> np.ndarray:
    """The ``[[obstacles]]`` tables as ``(m, 3)`` rows ``[cx, cy, r]``."""
    if not isinstance(raw, list | tuple):
        c.fail("obstacles", f"expected an array of tables ([[obstacles]]), got {describe(raw)}")
    if len(raw) > checks.OBSTACLES_MAX:
        c.fail("obstacles", f"at most {checks.OBSTACLES_MAX} obstacles, got {len(raw)}")
    obstacles = np.zeros((len(raw), 3))
    for j, ob in enumerate(raw):
        key = f"obstacles[{j}]"
        if not isinstance(ob, Mapping):
            c.fail(key, f"expected a table with center and radius, got {describe(ob)}")
        c.table(ob, key)
        c.known_keys(ob, OBSTACLE_KEYS, key)
        for k in OBSTACLE_KEYS:
            if k not in ob:
                c.fail(f"{key}.{k}", "missing required key")
        obstacles[j, :2] = c.vector(ob["center"], 2, f"{key}.center", " [cx, cy]")
        obstacles[j, 2] = c.number(ob["radius"], f"{key}.radius", gt=0)
    return obstacles


def _folder(source: str) -> str:
    """Where the files a scenario names are found: its file's folder (the working folder for
    a scenario that is not a file)."""
    if source.startswith(_BUILTIN_PREFIX) or source.startswith("<"):
        return os.getcwd()
    return os.path.dirname(os.path.abspath(source))


def load_scenario_text(text: str | bytes, source: str = "<string>") -> Scenario:
    """A scenario from TOML text; ``source`` names it in error messages and ``Scenario.source``."""
    source = str(source)
    if isinstance(text, bytes | bytearray):
        text = decode_text(bytes(text), source)
    try:
        data = tomllib.loads(text)
    except RecursionError:
        ScenarioCheck(source).fail("", "invalid TOML: values nested too deeply")
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        if "(at end of document)" in message:  # tomllib gives no line number here
            last = text.count("\n") + (0 if text.endswith("\n") else 1)
            message = message.replace("(at end of document)", f"(at end of document, line {last})")
        ScenarioCheck(source).fail("", not_toml(text) or f"invalid TOML: {message}")
    return scenario_from_dict(data, source)


def _builtin_dir():
    return resources.files("leapfrog_planner").joinpath("scenarios")


def _natural_key(name: str):
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def _load_builtin(name: str) -> Scenario:
    raw = _builtin_dir().joinpath(f"{name}.toml").read_bytes()
    return load_scenario_text(decode_text(raw, _BUILTIN_PREFIX + name), _BUILTIN_PREFIX + name)


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package (the paper's cases)."""
    try:
        entries = list(_builtin_dir().iterdir())
    except (FileNotFoundError, NotADirectoryError):  # pragma: no cover - broken install
        return []
    names = [e.name[: -len(".toml")] for e in entries if e.name.endswith(".toml") and e.is_file()]
    return sorted(names, key=_natural_key)


def load_scenario(path_or_name: str | Path) -> Scenario:
    """A scenario from a file path or, when no such file exists, a built-in name;
    ``"builtin:NAME"`` is always the built-in, even beside a file called NAME."""
    text_name = str(path_or_name)
    names = builtin_scenarios()
    name = text_name.removeprefix(_BUILTIN_PREFIX) if isinstance(path_or_name, str) else None
    if name in names and name != text_name:
        return _load_builtin(name)
    if text_name and "\0" not in text_name and path_exists(Path(path_or_name)):
        raw = read_scenario_file(Path(path_or_name), text_name)
        try:
            return load_scenario_text(decode_text(raw, text_name), text_name)
        except ScenarioError as e:
            if text_name not in names:
                raise
            also = f"{text_name} is also a built-in scenario: {_BUILTIN_PREFIX}{text_name} loads it"
            raise ScenarioError(f"{e}; {also}") from None
    if name in names:
        return _load_builtin(name)
    raise ScenarioError(
        f"no scenario file or built-in named {short(text_name, 80)}"
        f" (built-ins: {', '.join(names) or 'none'})"
    )


def as_scenario(scenario: Scenario | Mapping[str, Any] | str | Path) -> Scenario:
    """``scenario`` itself, or the scenario of a dict (the tables of a scenario file), of a file
    or of a built-in name."""
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, Mapping):
        return scenario_from_dict(scenario)
    return load_scenario(scenario)
