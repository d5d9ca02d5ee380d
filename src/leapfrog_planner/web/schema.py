"""Requests of the web API: parsed and checked with the scenario parser and the shared checks,
so that a bad value gets the message the command line gives for it (``<source>: <key>:
<problem>``, one line)."""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import ScenarioError, describe, require_integer, short
from ..planning.scenario import Scenario, load_scenario_text, scenario_from_dict

#: The planner options the page sets, and their bounds (those of ``leapfrog solve``).
METHODS = ("newton", "modified-newton", "nleq-err")
OPTION_KEYS = ("method", "initial_paths", "partitions")
PARTITIONS_RANGE = (2, 1024)
INITIAL_PATHS_RANGE = (1, 32)

#: The name scenario errors of a request carry in front (a file keeps its own name).
SOURCE = "scenario"

#: A request body larger than this is refused (a scenario of 10,000 obstacles is about 600 kB).
MAX_BODY_BYTES = 2 * 2**20

#: Longest session name kept (the page's random id).
MAX_SESSION = 64


class RequestError(ScenarioError):
    """A request that cannot be served as sent: a one-line message and an HTTP status."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(" ".join(str(message).splitlines()))
        self.status = status


@dataclass(frozen=True)
class PlanRequest:
    """A scenario to plan, the planner's options, and who asked (``session``, ``seq``: a newer
    request of the same session supersedes an older one still waiting)."""

    scenario: Scenario
    options: dict[str, Any]
    session: str | None = None
    seq: int = 0
    map: Any = None  # the LoadedMap of maps.py the scenario's map was opened as, if any

    def job(
        self, kind: str, seconds: float | None = None
    ) -> tuple[str, dict, dict, str | None, float | None]:
        """What a worker process is sent: plain values only (and the image of an uploaded map,
        which its YAML file may name elsewhere), with the plan's time limit, ``seconds``."""
        image = None if self.map is None else self.map.image
        return kind, self.scenario.to_dict(), dict(self.options), image, seconds

    def toml(self) -> str:
        """The scenario file with the options in its ``[solver]`` table, an uploaded map named
        by its YAML file's name (the file beside it)."""
        text = self.scenario_with_options().to_toml()
        if self.map is None:
            return text
        from ..planning.scenario_toml import toml_value

        line = f"file = {toml_value(self.scenario.map.file)}\n"
        return text.replace(line, f"file = {toml_value(self.map.name)}\n", 1)

    def scenario_with_options(self) -> Scenario:
        """The scenario with the options in its ``[solver]`` table: its TOML file, planned by
        ``leapfrog solve``, gives what the page showed."""
        from dataclasses import replace

        return replace(self.scenario, solver={**self.scenario.solver, **self.options})


def parse_json(body: bytes, limit: int = MAX_BODY_BYTES) -> Any:
    if len(body) > limit:
        raise RequestError(f"request: larger than {limit // 2**20} MB", 413)
    try:
        return json.loads(body.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise RequestError(f"request: not UTF-8 text (at byte {e.start})") from None
    except (ValueError, RecursionError) as e:
        raise RequestError(f"request: not valid JSON ({e})") from None


def _object(value: Any, key: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise RequestError(f"{key}: expected a JSON object, got {describe(value)}")
    return value


def _known(table: Mapping, allowed, key: str) -> None:
    for k in table:
        if k not in allowed:
            raise RequestError(
                f"{key}: unknown key {short(str(k))} (allowed: {', '.join(allowed)})"
            )


def parse_options(value: Any) -> dict[str, Any]:
    """``method``, ``initial_paths`` and ``partitions``, each optional, within the command
    line's bounds."""
    options = _object({} if value is None else value, "options")
    _known(options, OPTION_KEYS, "options")
    out: dict[str, Any] = {}
    if "method" in options:
        method = options["method"]
        if method not in METHODS:
            raise RequestError(
                f"options.method: unknown method {describe(method)} (known: {', '.join(METHODS)})"
            )
        out["method"] = method
    for key, (lo, hi) in (("initial_paths", INITIAL_PATHS_RANGE), ("partitions", PARTITIONS_RANGE)):
        if key in options:
            out[key] = require_integer(f"options.{key}", options[key], lo, hi, error=RequestError)
    return out


def parse_scenario(value: Any, source: str = SOURCE) -> Scenario:
    """A scenario in the layout of a scenario file (as ``Scenario.to_dict`` gives it)."""
    try:
        return scenario_from_dict(value, source)
    except ScenarioError as e:
        raise RequestError(str(e)) from None
    except RecursionError:
        raise RequestError(f"{source}: values nested too deeply") from None


def _with_map(raw: Any, maps) -> tuple[Scenario, Any]:
    """The scenario of a request, its map (``{"id", "unknown", "length"}``: a map opened on
    the page) taken from ``maps``, a :class:`~.maps.MapStore`."""
    if not (isinstance(raw, Mapping) and "map" in raw):
        return parse_scenario(raw), None
    from dataclasses import replace

    scenario = parse_scenario({k: v for k, v in raw.items() if k != "map"})
    if maps is None:
        raise RequestError("scenario: map: this server does not keep maps")
    loaded, unknown, length = maps.request(raw["map"])
    try:
        world = maps.scenario_map(loaded, unknown, length, scenario.robot_radius)
        return replace(scenario, map=world), loaded
    except ScenarioError as e:
        text = str(e)
        raise RequestError(text if text.startswith(SOURCE) else f"{SOURCE}: {text}") from None


def parse_plan(data: Any, maps=None) -> PlanRequest:
    """``{"scenario": {...}, "options": {...}, "session": "...", "seq": 3}``; a scenario's map
    is one opened on the page, named by its id in ``maps`` (a :class:`~.maps.MapStore`)."""
    data = _object(data, "request")
    _known(data, ("scenario", "options", "session", "seq"), "request")
    if "scenario" not in data:
        raise RequestError("request: scenario: missing required key")
    scenario, loaded = _with_map(data["scenario"], maps)
    options = parse_options(data.get("options"))
    session = data.get("session")
    if session is not None and not (isinstance(session, str) and 0 < len(session) <= MAX_SESSION):
        raise RequestError(f"request: session: expected a short string, got {describe(session)}")
    seq = require_integer("request: seq", data.get("seq", 0), 0, 2**53, error=RequestError)
    return PlanRequest(scenario, options, session, seq, loaded)


_SAFE_NAME = re.compile(r"[^A-Za-z0-9._-]+")


def file_name(name: str, suffix: str) -> str:
    """A file name for a download: the scenario's name with anything unusual replaced."""
    stem = _SAFE_NAME.sub("-", name).strip("-.")[:80] or "scenario"
    return stem + suffix


def parse_toml(data: Any) -> tuple[Scenario, dict | None]:
    """``{"toml": "<file text>", "name": "room.toml"}``: a scenario file opened on the page, its
    errors named after the file as the command line names them. Its ``[map]`` table is given
    back apart, the file's name without its folder (the server does not read the files of the
    user's machine: the page opens the map itself)."""
    data = _object(data, "request")
    _known(data, ("toml", "name"), "request")
    text, name = data.get("toml"), data.get("name", "scenario.toml")
    if not isinstance(text, str):
        raise RequestError(f"request: toml: expected a string, got {describe(text)}")
    if not isinstance(name, str) or not name.strip():
        raise RequestError(f"request: name: expected a file name, got {describe(name)}")
    source = name.strip()[:200]
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError):
        data = None  # the loader says what is wrong
    try:
        if not (isinstance(data, dict) and isinstance(data.get("map"), dict)):
            return load_scenario_text(text, source), None
        world = data.pop("map")
        scenario = scenario_from_dict(data, source)
    except ScenarioError as e:
        raise RequestError(str(e)) from None
    except RecursionError:
        raise RequestError(f"{source}: values nested too deeply") from None
    file = world.get("file")
    kept = {k: world[k] for k in ("unknown", "length") if k in world}
    if isinstance(file, str):
        kept["file"] = file.replace("\\", "/").rsplit("/", 1)[-1]
    return scenario, kept
