"""Seeded random scenarios for statistics over many environments.

``GeneratorSpec(n=100, obstacles=(3, 10), seed=1)`` describes a set; ``generate(spec)`` yields
its scenarios and ``write_scenarios(spec, folder)`` writes them as TOML files. Scenario ``i``
depends only on ``(seed, i)`` (its own ``numpy.random.default_rng([seed, i])``), so the first
ten scenarios of a set of 100 are those of a set of 10, and any subset can be rebuilt alone.

Each scenario: obstacles are discs with centres uniform in the workspace box and radii uniform
in ``radius``, at least ``obstacle_gap`` apart (edge to edge); start and goal positions are
uniform in the box, at least ``min_distance`` apart and at least ``clearance`` from every
obstacle edge; headings are the start-to-goal direction plus a uniform angle in
``[-heading_spread, heading_spread]``; the horizon is uniform in ``horizon`` (drawn last, and only
when the range is not a single value, so that a fixed horizon leaves the other draws as they
were). A draw that violates a constraint is redrawn (rejection sampling, at most
``max_attempts`` times per item; then :class:`GeneratorError`).

Presets (:data:`PRESETS`, ``GeneratorSpec.preset(name, **overrides)``):

- ``default``: the distribution of the built-in statistics: 3 to 10 obstacles of radius 0.05 to
  0.2 in a 2 x 2 room, start and goal at least 1 apart, headings within 45 degrees of the
  start-to-goal direction, horizon 1.
- ``general``: what a user meets: headings uniform in every direction (a goal behind the robot, a
  goal heading that points back), 1 to 9 obstacles of radius 0.08 to 0.4 in a 3 x 3 room, start
  and goal at least 1 apart, horizon uniform in 0.5 to 3.
- ``metric``: a room at a robot's scale, in metres and seconds: 10 x 10 m, 2 to 12 discs of
  radius 0.3 to 1.5 m, start and goal at least 3 m apart and 0.1 m clear of the discs, headings
  uniform, the horizon 1 to 1.5 s per metre of the straight line (about 1 m/s).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._atomic import write_text_atomic
from ..errors import SettingsError, require_integer
from ..planning.scenario import Scenario
from ..planning.scenario_time import FreeTime

__all__ = [
    "PRESETS",
    "GeneratorError",
    "GeneratorSpec",
    "generate",
    "generate_one",
    "parse_range",
    "map_scenarios",
    "write_scenarios",
]


class GeneratorError(SettingsError):
    """The constraints leave (almost) no room: a scenario could not be drawn."""


def parse_range(text: str, kind=int) -> tuple:
    """``"3..10"`` -> ``(3, 10)``; ``"7"`` -> ``(7, 7)``. Bounds are inclusive."""
    m = re.fullmatch(r"\s*([^.\s]+(?:\.\d*)?)\s*(?:\.\.\s*(\S+)\s*)?", str(text))
    try:
        if m is None:
            raise ValueError
        lo = kind(m.group(1))
        hi = kind(m.group(2)) if m.group(2) is not None else lo
    except ValueError:
        raise SettingsError(f"expected a value or a range LO..HI, got {text!r}") from None
    return lo, hi


#: The longest name prefix: its files' names (``<prefix>-s<seed>-<index>.toml``) then stay
#: within the 255 bytes a file name may have.
PREFIX_MAX = 200


def check_prefix(prefix) -> str:
    """A scenario name prefix: letters, digits, ``_``, ``-`` or ``.``, at most
    :data:`PREFIX_MAX` of them."""
    if not isinstance(prefix, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", prefix):
        raise SettingsError(f"prefix must be letters, digits, '_', '-' or '.', got {prefix!r:.60}")
    if len(prefix) > PREFIX_MAX:
        raise SettingsError(f"prefix: at most {PREFIX_MAX} characters, got {len(prefix)}")
    return prefix


@dataclass(frozen=True)
class GeneratorSpec:
    """A reproducible set of random scenarios. Every field is validated on construction."""

    n: int = 100
    seed: int = 0
    obstacles: tuple[int, int] = (3, 10)  # inclusive range; (7, 7) for exactly seven
    workspace: tuple[float, float, float, float] = (0.0, 0.0, 2.0, 2.0)  # xmin, ymin, xmax, ymax
    radius: tuple[float, float] = (0.05, 0.2)
    min_distance: float = 1.0  # between start and goal positions
    clearance: float = 0.05  # of start and goal from every obstacle edge
    obstacle_gap: float = 0.0  # edge to edge between obstacles; 0: may touch, never overlap
    heading_spread: float = math.pi / 4  # headings: goal direction +- this (radians)
    horizon: tuple[float, float] = (1.0, 1.0)  # inclusive range; a number means exactly that
    # Seconds per metre of the straight line from start to goal, an inclusive range: when
    # given, the horizon is drawn from it times that distance (``horizon`` is then unused).
    pace: tuple[float, float] | None = None
    # A free final time at a cruise speed drawn from this inclusive range (the unicycle's price
    # of time, v^2 / 2 per second): the horizon drawn is then only where the search starts.
    cruise_speed: tuple[float, float] | None = None
    prefix: str = "random"  # scenario names: f"{prefix}-s{seed}-{i:05d}"
    max_attempts: int = 1000

    def __post_init__(self):
        def real(name, v, lo=None, strict=False):
            if isinstance(v, bool) or not math.isfinite(float(v)):
                raise SettingsError(f"{name} must be a finite number, got {v!r}")
            if lo is not None and (float(v) <= lo if strict else float(v) < lo):
                raise SettingsError(f"{name} must be {'>' if strict else '>='} {lo}, got {v!r}")
            return float(v)

        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        set_("n", require_integer("n", self.n, 0))
        set_("seed", require_integer("seed", self.seed, 0))
        if len(self.obstacles) != 2:
            raise SettingsError(f"obstacles must be (min, max), got {self.obstacles!r}")
        lo, hi = (require_integer("obstacles", v, 0) for v in self.obstacles)
        if lo > hi:
            raise SettingsError(f"obstacles: min {lo} > max {hi}")
        set_("obstacles", (lo, hi))
        if len(self.workspace) != 4:
            raise SettingsError(f"workspace must be (xmin, ymin, xmax, ymax), got {self.workspace}")
        ws = tuple(real("workspace", v) for v in self.workspace)
        if not (ws[2] > ws[0] and ws[3] > ws[1]):
            raise SettingsError(f"workspace must have xmax > xmin and ymax > ymin, got {ws}")
        set_("workspace", ws)
        if len(self.radius) != 2:
            raise SettingsError(f"radius must be (min, max), got {self.radius!r}")
        r = tuple(real("radius", v, 0.0, strict=True) for v in self.radius)
        if r[0] > r[1]:
            raise SettingsError(f"radius: min {r[0]} > max {r[1]}")
        set_("radius", r)
        set_("min_distance", real("min_distance", self.min_distance, 0.0))
        diag = math.hypot(ws[2] - ws[0], ws[3] - ws[1])
        if self.min_distance >= diag:
            raise SettingsError(
                f"min_distance {self.min_distance} is not below the workspace diagonal {diag:.4g}"
            )
        set_("clearance", real("clearance", self.clearance, 0.0))
        set_("obstacle_gap", real("obstacle_gap", self.obstacle_gap, 0.0))
        set_("heading_spread", real("heading_spread", self.heading_spread, 0.0))
        horizon = self.horizon if isinstance(self.horizon, tuple | list) else (self.horizon,) * 2
        if len(horizon) != 2:
            raise SettingsError(f"horizon must be T or (min, max), got {self.horizon!r}")
        h = tuple(real("horizon", v, 0.0, strict=True) for v in horizon)
        if h[0] > h[1]:
            raise SettingsError(f"horizon: min {h[0]} > max {h[1]}")
        set_("horizon", h)
        for name, unit in (("pace", " seconds per metre"), ("cruise_speed", "")):
            value = getattr(self, name)
            if value is not None:
                if len(value) != 2:
                    raise SettingsError(f"{name} must be (min, max){unit}, got {value!r}")
                lo, hi = (real(name, v, 0.0, strict=True) for v in value)
                if lo > hi:
                    raise SettingsError(f"{name}: min {lo} > max {hi}")
                set_(name, (lo, hi))
        check_prefix(self.prefix)
        set_("max_attempts", require_integer("max_attempts", self.max_attempts))

    def name(self, i: int) -> str:
        return f"{self.prefix}-s{self.seed}-{i:05d}"

    @classmethod
    def preset(cls, name: str, **overrides) -> GeneratorSpec:
        """The spec of preset ``name`` (see :data:`PRESETS`), with ``overrides`` on top."""
        if name not in PRESETS:
            raise SettingsError(f"unknown preset {name!r} (known: {', '.join(PRESETS)})")
        return cls(**{**PRESETS[name], **overrides})


#: Named distributions (see the module notes); fields not given keep the class defaults.
PRESETS: dict[str, dict] = {
    "default": {},
    "general": {
        "obstacles": (1, 9),
        "workspace": (0.0, 0.0, 3.0, 3.0),
        "radius": (0.08, 0.4),
        "min_distance": 1.0,
        "heading_spread": math.pi,
        "horizon": (0.5, 3.0),
        "prefix": "general",
    },
    "metric": {
        "obstacles": (2, 12),
        "workspace": (0.0, 0.0, 10.0, 10.0),
        "radius": (0.3, 1.5),
        "min_distance": 3.0,
        "clearance": 0.1,
        "heading_spread": math.pi,
        "pace": (1.0, 1.5),
        "prefix": "metric",
    },
}


def generate_one(spec: GeneratorSpec, i: int) -> Scenario:
    """Scenario ``i`` of ``spec``: a function of ``(spec, i)`` only, not of ``spec.n``."""
    rng = np.random.default_rng([spec.seed, int(i)])
    x0, y0, x1, y1 = spec.workspace
    lo, hi = spec.obstacles
    m = int(rng.integers(lo, hi + 1))

    def point():
        return np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])

    obstacles: list[tuple[float, float, float]] = []
    for j in range(m):
        for _ in range(spec.max_attempts):
            c, r = point(), rng.uniform(*spec.radius)
            if all(
                math.hypot(c[0] - a, c[1] - b) >= r + rb + spec.obstacle_gap
                for a, b, rb in obstacles
            ):
                obstacles.append((float(c[0]), float(c[1]), float(r)))
                break
        else:
            raise GeneratorError(
                f"{spec.name(i)}: no room for obstacle {j} after {spec.max_attempts} attempts"
                " (fewer or smaller obstacles, a smaller gap or a larger workspace)"
            )

    def free(p):
        return all(math.hypot(p[0] - a, p[1] - b) >= r + spec.clearance for a, b, r in obstacles)

    for _ in range(spec.max_attempts):
        s, g = point(), point()
        if np.hypot(*(g - s)) >= spec.min_distance and free(s) and free(g):
            break
    else:
        raise GeneratorError(
            f"{spec.name(i)}: no start and goal {spec.min_distance} apart and"
            f" {spec.clearance} clear of the obstacles after {spec.max_attempts} attempts"
        )
    direction = math.atan2(g[1] - s[1], g[0] - s[0])
    th0, th1 = direction + rng.uniform(-1.0, 1.0, size=2) * spec.heading_spread
    lo, hi = spec.horizon if spec.pace is None else spec.pace
    horizon = lo if lo == hi else float(rng.uniform(lo, hi))
    if spec.pace is not None:
        horizon *= float(np.hypot(*(g - s)))
    free = None
    if spec.cruise_speed is not None:  # drawn last: the other draws stay as they were
        lo, hi = spec.cruise_speed
        v = lo if lo == hi else float(rng.uniform(lo, hi))
        free = FreeTime(v * v / 2, v)
    return Scenario(
        name=spec.name(i),
        horizon=horizon,
        start=[float(s[0]), float(s[1]), float(th0)],
        goal=[float(g[0]), float(g[1]), float(th1)],
        obstacles=np.array(obstacles, dtype=float).reshape(-1, 3),
        free_time=free,
    )


def generate(spec: GeneratorSpec, indices=None) -> Iterator[Scenario]:
    """The scenarios of ``spec`` in order (or those at ``indices``)."""
    for i in range(spec.n) if indices is None else indices:
        yield generate_one(spec, i)


def write_scenarios(spec: GeneratorSpec, folder, *, overwrite: bool = False) -> list[Path]:
    """Write ``<name>.toml`` per scenario into ``folder`` (created); each file atomically.

    An existing file with other content is an error unless ``overwrite``; one with the same
    content is left alone, so writing the same set twice is harmless.
    """
    return write_all(list(generate(spec)), folder, overwrite=overwrite)


def write_all(scenarios: list[Scenario], folder, *, overwrite: bool = False) -> list[Path]:
    """Write ``<name>.toml`` per scenario into ``folder`` (created); each file atomically (see
    :func:`write_scenarios`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for sc in scenarios:
        path = folder / f"{sc.name}.toml"
        text = sc.to_toml()
        if path.exists() and not overwrite:
            if path.read_text(encoding="utf-8") != text:
                raise GeneratorError(f"{path} exists with other content (overwrite to replace)")
        else:
            write_text_atomic(path, text)
        paths.append(path)
    return paths


#: Queries on a map: the robot's radius (m), the speed that sets the horizon from the query's
#: shortest path (m/s), and the penalty's weight (a horizon of tens of seconds: see the README).
MAP_RADIUS, MAP_SPEED, MAP_WEIGHT = 0.2, 0.5, 1.0


def map_scenarios(
    map_file, n: int, seed: int = 0, *, radius: float = MAP_RADIUS, speed: float = MAP_SPEED,
    weight: float = MAP_WEIGHT, min_distance: float = 3.0, clearance: float | None = None,
    prefix: str = "map",
) -> list[Scenario]:  # fmt: skip
    """``n`` random queries on the map of ``map_file`` by the ROS 2 navigation stack's
    planner-benchmark protocol (:func:`..world.queries.random_queries`: start and goal in free
    space at ``clearance`` from the blocked cells, more than ``min_distance`` apart, headings
    uniform, connected for a robot of ``radius``), each a scenario whose horizon is its shortest
    path at ``speed``. Deterministic in ``seed``."""
    from ..planning.scenario_map import ScenarioMap
    from ..world.queries import random_queries

    check_prefix(prefix)
    world = ScenarioMap(str(map_file))
    clear = world.obstacles(radius).cells
    queries = random_queries(clear, n, seed, radius, clearance, min_distance)
    return [
        Scenario(
            name=f"{prefix}-s{seed}-{i:05d}",
            horizon=max(q.shortest / speed, 1e-3),
            start=list(q.start),
            goal=nearest_turn(q.start, q.goal),
            weight=weight,
            robot_radius=radius,
            map=world,
        )  # fmt: skip
        for i, q in enumerate(queries)
    ]


def nearest_turn(start, goal) -> list[float]:
    """``goal`` with its heading moved by whole turns to within half a turn of the start's: the
    same pose, the turn a robot means (headings are not wrapped: ``theta + 2 pi`` would be
    another end state, one more loop)."""
    out = [float(v) for v in goal]
    turn = float(goal[2]) - float(start[2])
    out[2] = float(start[2]) + (turn + math.pi) % (2.0 * math.pi) - math.pi
    return out
