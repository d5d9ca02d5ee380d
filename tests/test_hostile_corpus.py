"""A generated hostile-input corpus, run as the command line in-process (tests/hostile_harness.py).

Four families, each one parametrized test whose cases are generated, deterministically, from
the formats themselves:

1. ``scenario``: a small valid scenario (horizon 1, start [0, 0, 0], goal [2, 0, 0], one disc)
   in one of a few contexts (robot, diff-drive, car, free time, polygons and walls), each of
   its keys given each of a list of hostile values (wrong types, TOML dates, NaN, infinities,
   0, negatives, huge, non-integers, wrong lengths, empty), tables given as values, keys
   misspelt, required keys left out; run as ``solve FILE --quiet --json out.json``.
2. ``options``: every ``solve`` option and every planner setting of ``--option KEY=VALUE``
   (nested ones too: ``shooting={"root": {"tol": V}}``) given hostile values, and hostile
   output paths.
3. ``result``: a result written by ``solve --json``, every field (top level and nested) damaged
   one way or another, read by ``export --csv``, ``plot --out`` and ``solve RESULT``; and the
   file cut short (JSON and NPZ).
4. ``store``: a sweep's results file (JSON Lines) with one line damaged, read by ``report``.

Every case: no traceback, no hang; bad input exits 2 with exactly one line ``error: ...`` and
leaves every file as it was (no output written); valid input exits 0 or 1 and leaves its inputs
as they were. A damaged result file or store is refused unless the damage is listed as harmless
below, with the reason. Case counts (``test_the_corpus_is_large_enough`` keeps them):
scenario 890, options 579, result 1082, store 283: 2834 in all.
"""

# ruff: noqa: E501
from __future__ import annotations

import copy
import json
from dataclasses import fields, is_dataclass

import pytest
from tests.hostile_harness import check_bad_or_fine, run_cli

from leapfrog_planner.planning.leapfrog import LeapfrogSettings
from leapfrog_planner.planning.settings import PlannerSettings

# ============================================================================ 1. scenario files


class Raw(str):
    """TOML (or JSON) text put in as it is."""


def toml_value(v) -> str:
    if isinstance(v, Raw):
        return str(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + " }"


def _tables(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def to_toml(d: dict) -> str:
    lines = [
        f"{json.dumps(k)} = {toml_value(v)}"
        for k, v in d.items()
        if not isinstance(v, dict) and not _tables(v)
    ]
    for k, v in d.items():
        if isinstance(v, dict) and not isinstance(v, Raw):
            lines += [f"[{k}]"] + [f"{json.dumps(kk)} = {toml_value(x)}" for kk, x in v.items()]
        elif _tables(v):
            for item in v:
                lines += [f"[[{k}]]"] + [
                    f"{json.dumps(kk)} = {toml_value(x)}" for kk, x in item.items()
                ]
    return "\n".join(lines) + "\n"


BASE = {
    "horizon": 1.0,
    "start": [0.0, 0.0, 0.0],
    "goal": [2.0, 0.0, 0.0],
    "waypoints": [[1.0, 0.6]],
    "penalty": {"weight": 100.0, "exponent": 2},
    "solver": {
        "method": "modified-newton",
        "partitions": 8,
        "initial_paths": 1,
        "reduce_tol": 1e-3,
        "max_sweeps": 60,
    },
    "obstacles": [{"center": [1.0, 0.1], "radius": 0.2}],
}
_NO_WAYPOINTS = {k: v for k, v in BASE.items() if k != "waypoints"}
CONTEXTS = {
    "fixed": BASE,
    "robot": {
        **BASE,
        "robot": {
            "model": "unicycle",
            "radius": 0.05,
            "margin": 0.01,
            "v": [-3.0, 3.0],
            "omega": [-10.0, 10.0],
        },
    },
    "diff-drive": {
        **BASE,
        "robot": {"model": "diff-drive", "wheel_radius": 1.0, "axle_length": 2.0},
    },
    "car": {
        **BASE,
        "start": [0.0, 0.0, 0.0, 0.0],
        "goal": [2.0, 0.0, 0.0, 0.0],
        "robot": {"model": "car", "wheelbase": 0.5, "turn_assist": 0.0},
    },
    "free": {
        **BASE,
        "horizon": "free",
        "cost": {"cruise_speed": 2.0},
        "time": {"guess": 1.0, "bounds": [0.5, 4.0]},
    },
    "time-weight": {**BASE, "horizon": "free", "cost": {"time_weight": 2.0}},
    "shapes": {
        **_NO_WAYPOINTS,
        "map": {"length": 0.2, "resolution": 0.05},
        "polygons": [{"points": [[3.0, 3.0], [4.0, 3.0], [3.5, 4.0]]}],
        "walls": [{"points": [[0.0, 2.0], [2.0, 2.0]], "thickness": 0.1}],
    },
}
#: The keys substituted, by context, with the length of a vector (0: a number or string; -1:
#: rows of [x, y]).
KEYS = {
    "fixed": {
        ("name",): 0, ("horizon",): 0, ("start",): 3, ("goal",): 3, ("waypoints",): -1,
        ("penalty", "weight"): 0, ("penalty", "exponent"): 0,
        ("obstacles", 0, "center"): 2, ("obstacles", 0, "radius"): 0,
        ("solver", "method"): 0, ("solver", "partitions"): 0, ("solver", "initial_paths"): 0,
        ("solver", "reduce_tol"): 0, ("solver", "max_sweeps"): 0,
    },
    "robot": {("robot", "model"): 0, ("robot", "radius"): 0, ("robot", "margin"): 0, ("robot", "v"): 2, ("robot", "omega"): 2},
    "diff-drive": {("robot", "wheel_radius"): 0, ("robot", "axle_length"): 0},
    "car": {("robot", "wheelbase"): 0, ("robot", "turn_assist"): 0, ("start",): 4, ("goal",): 4},
    "free": {("horizon",): 0, ("cost", "cruise_speed"): 0, ("time", "guess"): 0, ("time", "bounds"): 2},
    "time-weight": {("cost", "time_weight"): 0},
    "shapes": {
        ("polygons", 0, "points"): -1, ("walls", 0, "points"): -1, ("walls", 0, "thickness"): 0,
        ("map", "length"): 0, ("map", "resolution"): 0,
    },
}  # fmt: skip
VALUES = {
    "string": '"abc"', "empty-string": '""', "true": "true", "int-array": "[1, 2]",
    "empty-array": "[]", "table": "{ a = 1 }", "datetime": "1979-05-27T07:32:00Z",
    "date": "1979-05-27", "time": "07:32:00", "nan": "nan", "inf": "+inf", "-inf": "-inf",
    "zero": "0", "-0.0": "-0.0", "negative": "-1", "1e308": "1e308", "1e-300": "1e-300",
    "10**30": "1" + "0" * 30, "2.5": "2.5", "int64-min": "-9223372036854775808",
}  # fmt: skip


def vector_values(n: int) -> dict[str, str]:
    z = ["0.5"] * n
    return {
        "short": "[" + ", ".join(z[:-1]) + "]", "long": "[" + ", ".join([*z, "0.5"]) + "]",
        "strings": "[" + ", ".join(['"a"'] * n) + "]", "bools": "[" + ", ".join(["true"] * n) + "]",
        "nan-inside": "[" + ", ".join(["nan", *z[1:]]) + "]", "inf-inside": "[" + ", ".join([*z[:-1], "inf"]) + "]",
        "1e308-inside": "[" + ", ".join(["1e308", *z[1:]]) + "]", "nested": "[[" + ", ".join(z) + "]]",
        "mixed": '[1, "a"]', "tables": "[{ x = 1 }]", "reversed-range": "[" + ", ".join(f"{n - i}.0" for i in range(n)) + "]",
    }  # fmt: skip


ROW_VALUES = {
    "flat": "[0.5, 0.5]", "short-row": "[[0.5]]", "ragged": "[[3.0, 3.0], [4.0]]",
    "string-rows": '[["a", "b"], ["c", "d"]]', "nan-row": "[[nan, 0.0], [1.0, 1.0], [1.0, 0.0]]",
    "inf-row": "[[inf, 0.0], [1.0, 1.0]]", "1e308-row": "[[1e308, 0.0], [1.0, 1.0], [0.0, 1.0]]",
    "one-row": "[[3.0, 3.0]]", "same-point": "[[3.0, 3.0], [3.0, 3.0], [3.0, 3.0]]",
    "table-rows": "[{ x = 1 }]", "three-numbers": "[[3.0, 3.0, 3.0], [4.0, 4.0, 4.0]]",
}  # fmt: skip

MISSPELT = {
    "fixed": [(), "horizn"], "robot": [("robot",), "raduis"], "diff-drive": [("robot",), "wheel-radius"],
    "car": [("robot",), "wheel_base"], "free": [("time",), "gues"], "time-weight": [("cost",), "time-weight"],
    "shapes": [("map",), "lenght"],
}  # fmt: skip
MORE_MISSPELT = [
    ("fixed", ("penalty",), "wieght"), ("fixed", ("solver",), "partitons"),
    ("fixed", ("obstacles", 0), "centre"), ("shapes", ("polygons", 0), "point"),
    ("shapes", ("walls", 0), "thicknes"), ("fixed", (), "Horizon"), ("fixed", (), "obstacle"),
    ("fixed", ("solver",), "time_limit"), ("robot", ("robot",), "Radius"), ("fixed", (), "é"),
]  # fmt: skip
WHOLE = {
    "string": '"abc"',
    "number": "1",
    "array": "[1, 2]",
    "empty-array": "[]",
    "datetime": "1979-05-27T07:32:00Z",
}
TABLES = {
    "fixed": ["penalty", "solver", "obstacles", "waypoints"], "robot": ["robot"],
    "free": ["cost", "time"], "shapes": ["map", "polygons", "walls"],
}  # fmt: skip
MISSING = [
    ("fixed", ("horizon",)), ("fixed", ("start",)), ("fixed", ("goal",)),
    ("fixed", ("obstacles", 0, "center")), ("fixed", ("obstacles", 0, "radius")),
    ("shapes", ("walls", 0, "thickness")), ("shapes", ("polygons", 0, "points")),
    ("free", ("cost",)), ("free", ("cost", "cruise_speed")), ("robot", ("robot", "model")),
]  # fmt: skip


def _put(d: dict, path: tuple, value, delete: bool = False) -> dict:
    d = copy.deepcopy(d)
    *head, last = path
    inner = d
    for p in head:
        inner = inner[p]
    if delete:
        del inner[last]
    else:
        inner[last] = value
    return d


def _name(path: tuple) -> str:
    return ".".join(f"[{p}]" if isinstance(p, int) else p for p in path).replace(".[", "[")


def scenario_cases() -> dict[str, tuple[str, str]]:
    """id: (TOML text, a word the message must hold if the case is refused)."""
    cases = {}
    for ctx, keys in KEYS.items():
        base = CONTEXTS[ctx]
        for path, n in keys.items():
            values = dict(VALUES)
            values.update(vector_values(n) if n > 0 else ROW_VALUES if n < 0 else {})
            for vname, text in values.items():
                cases[f"{ctx}:{_name(path)}={vname}"] = (
                    to_toml(_put(base, path, Raw(text))),
                    str(path[-1]),
                )
    for ctx, prefix, word in [(c, *MISSPELT[c]) for c in MISSPELT] + MORE_MISSPELT:
        d = copy.deepcopy(CONTEXTS[ctx])
        inner = d
        for p in prefix:
            inner = inner[p]
        inner[word] = 1
        cases[f"{ctx}:unknown {_name((*prefix, word))}"] = (to_toml(d), "unknown")
    for ctx, tables in TABLES.items():
        for table in tables:
            for vname, text in WHOLE.items():
                cases[f"{ctx}:{table} as {vname}"] = (
                    to_toml(_put(CONTEXTS[ctx], (table,), Raw(text))),
                    table,
                )
    for ctx, path in MISSING:
        cases[f"{ctx}:no {_name(path)}"] = (
            to_toml(_put(CONTEXTS[ctx], path, None, delete=True)),
            str(path[-1]),
        )
    return cases


SCENARIO_CASES = scenario_cases()


@pytest.mark.parametrize("case", list(SCENARIO_CASES))
def test_scenario(case, tmp_path):
    text, word = SCENARIO_CASES[case]
    args = ["solve", "s.toml", "--quiet", "--json", "out.json", "--time-limit", "5"]
    out = run_cli(args, tmp_path, {"s.toml": text})
    if check_bad_or_fine(out) == "refused":
        assert word.lower() in out.lines[0].lower(), (
            f"the message does not name {word!r}: {out.lines[0]}"
        )


# ============================================================================ 2. solve options


def _setting_keys(cls, prefix=()) -> list[tuple[str, ...]]:
    out = []
    for f in fields(cls):
        default = f.default if f.default is not f.default_factory else None
        value = getattr(cls(), f.name) if default is None or is_dataclass(default) else default
        if is_dataclass(value):
            out += _setting_keys(type(value), (*prefix, f.name))
        else:
            out.append((*prefix, f.name))
    return out


def _nested_json(path: tuple[str, ...], value: str) -> str:
    text = value
    for key in reversed(path[1:]):
        text = "{" + json.dumps(key) + ": " + text + "}"
    return f"{path[0]}={text}"


OPTION_VALUES = {
    "word": "abc", "empty": "", "nan": "NaN", "inf": "Infinity", "-inf": "-Infinity",
    "negative": "-1", "zero": "0", "1e308": "1e308", "10**30": "1" + "0" * 30, "2.5": "2.5",
    "true": "true", "null": "null", "array": "[1, 2]", "table": "{}", "quoted": '"x"',
}  # fmt: skip
NESTED_VALUES = {
    k: OPTION_VALUES[k]
    for k in ("word", "nan", "inf", "negative", "zero", "1e308", "null", "table")
}
NAMED = [
    "--method",
    "--partitions",
    "--initial-paths",
    "--final",
    "--time-limit",
    "--horizon",
    "--cruise-speed",
    "--time-weight",
    "--dpi",
    "--map",
]
NAMED_VALUES = {
    "word": "abc", "empty": "", "nan": "nan", "inf": "inf", "negative": "-1", "zero": "0",
    "1e308": "1e308", "10**30": "1" + "0" * 30, "2.5": "2.5", "free": "free", "space": " ",
    "dash": "-", "folder": ".", "dev-null": "/dev/null", "the-scenario": "s.toml",
}  # fmt: skip
PATHS = {
    "empty": "", "dot": ".", "dotdot": "..", "root": "/", "dev-null": "/dev/null", "dev-full": "/dev/full",
    "the-scenario": "s.toml", "a-folder/": "d/", "no-folder": "no/x.x", "proc": "/proc/x.x",
    "dash": "-", "long": "a" * 300, "trailing-slash": "x.x/", "home-tilde": "~/no/x.x",
}  # fmt: skip


def option_cases() -> dict[str, list[str]]:
    """id: the arguments after ``solve s.toml --quiet --time-limit 5``."""
    cases = {}
    for path in _setting_keys(PlannerSettings) + [
        ("leapfrog", *p) for p in _setting_keys(LeapfrogSettings)
    ]:
        path = path[1:] if path[0] == "leapfrog" else path
        values = OPTION_VALUES if len(path) == 1 else NESTED_VALUES
        for vname, text in values.items():
            cases[f"--option {'.'.join(path)}={vname}"] = ["--option", _nested_json(path, text)]
    for option in NAMED:
        for vname, text in NAMED_VALUES.items():
            extra = ["--plot", "p.png"] if option == "--dpi" else []
            cases[f"{option} {vname}"] = [option, text, *extra]
    for option, suffix in (("--json", ".json"), ("--npz", ".npz"), ("--plot", ".png")):
        for pname, text in PATHS.items():
            cases[f"{option} {pname}"] = [option, text.replace(".x", suffix)]
    return cases


OPTION_CASES = option_cases()


@pytest.mark.parametrize("case", list(OPTION_CASES))
def test_options(case, tmp_path):
    (tmp_path / "d").mkdir(parents=True)
    scenario = to_toml(BASE)
    args = ["solve", "s.toml", "--quiet", "--time-limit", "5", *OPTION_CASES[case]]
    out = run_cli(args, tmp_path, {"s.toml": scenario})
    check_bad_or_fine(out)


# ============================================================================ 3. result files

#: The damages done to a value of a result file: a JSON value, or ``Raw`` JSON text.
DAMAGES = {
    "null": None, "string": "abc", "true": True, "table": {}, "empty-array": [],
    "negative": -1, "2.5": 2.5, "10**400": 10**400, "nan": Raw("NaN"), "1e999": Raw("1e999"),
    "deleted": ..., "reversed": "<reversed>", "null-inside": "<null inside>",
}  # fmt: skip
#: ... and those tried on each path by ``plot`` and ``solve RESULT`` (each reads the file the
#: same way as ``export``, which tries them all).
PLOT_DAMAGES = ("null", "string", "nan", "deleted")
SOLVE_DAMAGES = ("string", "deleted")
_REQUIRED_COLUMNS = ("t", "x", "y", "theta", "v", "omega", "lambda_1", "lambda_2", "lambda_3")
_OPTIONAL_COLUMNS = ("running_cost", "hamiltonian", "at_step")  # null: not known there
#: Schema-valid damage that is still damage, refused by every command: the schema leaves a
#: trajectory's columns free ({} is none), the reader needs them whole, equally long, finite,
#: in forward time; a converged answer has a cost.
REFUSED = {
    ("cost", "null"),
    *((f"{tr}.{c}", d) for tr in ("trajectory", "alternatives[0].trajectory") for c in _REQUIRED_COLUMNS for d in ("deleted", "null-inside", "empty-array")),
    *((f"{tr}.{c}", "empty-array") for tr in ("trajectory", "alternatives[0].trajectory") for c in _OPTIONAL_COLUMNS),
    ("trajectory.t", "reversed"), ("alternatives[0].trajectory.t", "reversed"),
    ("initial_junctions.t", "null-inside"), ("history[0].junction_t", "null-inside"),
    ("state_names", "empty-array"), ("control_names", "empty-array"),  # the columns unnamed
    ("trajectory", "table"),  # {}: no trajectory, nothing to draw or export
}  # fmt: skip


def _expected_refused(text: str, path: tuple, damage: str, command: str) -> bool:
    """Whether the damaged file must be refused: it breaks ``leapfrog schema`` (jsonschema's
    reading of it, every number finite), or its scenario is not one (the scenario's keys are the
    scenario loader's to check, as the schema says), or the damage is in :data:`REFUSED`; and
    for ``solve RESULT``, which re-plans with them, settings that are not settings. Anything
    else is harmless: the file says something else, but in its own terms (a message, a time,
    a cost that is a number), and is drawn and exported as it says."""
    from leapfrog_planner.errors import LeapfrogError
    from leapfrog_planner.planning.scenario import scenario_from_dict

    if not _schema_valid(text) or (_name(path), damage) in REFUSED:
        return True
    data = json.loads(text)
    try:
        scenario_from_dict(data["scenario_file"])
        if command == "solve":
            PlannerSettings.from_dict(data["settings"])
    except LeapfrogError:
        return True
    return False


def _paths(d: dict) -> list[tuple]:
    """The paths damaged: every top-level key, and the keys of the nested tables (of a list,
    its first item)."""
    out = []
    for k, v in d.items():
        out.append((k,))
        inner = v[0] if isinstance(v, list) and v and isinstance(v[0], dict) else v
        prefix = (k, 0) if inner is not v else (k,)
        if isinstance(inner, dict) and k not in ("free_time",):
            for kk, vv in inner.items():
                out.append((*prefix, kk))
                if isinstance(vv, dict) and kk in ("trajectory", "leapfrog", "robot", "versions"):
                    out += [(*prefix, kk, kkk) for kkk in list(vv)[:6]]
    return out


def _damaged(d: dict, path: tuple, damage: str) -> str | None:
    """The JSON text of ``d`` with ``path`` damaged (None: the damage does not apply)."""
    d = copy.deepcopy(d)
    *head, last = path
    inner = d
    for p in head:
        inner = inner[p]
    value = DAMAGES[damage]
    old = inner[last]
    if value is ...:
        del inner[last]
    elif value == "<reversed>" or value == "<null inside>":
        if not isinstance(old, list) or len(old) < 2:
            return None
        inner[last] = old[::-1] if value == "<reversed>" else [None, *old[1:]]
    else:
        inner[last] = Raw("@@raw@@") if isinstance(value, Raw) else value
    text = json.dumps(d)
    return text.replace('"@@raw@@"', str(value)) if isinstance(value, Raw) else text


@pytest.fixture(scope="module")
def saved_result(tmp_path_factory):
    """A result of the base scenario, small (41 samples), with another path and a search."""
    folder = tmp_path_factory.mktemp("result")
    args = [
        "solve",
        "s.toml",
        "--quiet",
        "--json",
        "r.json",
        "--npz",
        "r.npz",
        "--option",
        "samples=41",
    ]
    out = run_cli(
        args, folder, {"s.toml": to_toml(_NO_WAYPOINTS | {"solver": {"initial_paths": 3}})}
    )
    assert out.code == 0, out.stderr
    return json.loads((folder / "r.json").read_text()), (folder / "r.npz").read_bytes()


def _result_case_ids() -> dict[str, tuple]:
    """id: (path, damage, command); the paths are those of a result of this version (its keys
    do not depend on the plan), read off a small template of its layout."""
    cases = {}
    for path in _paths(RESULT_LAYOUT):
        value = RESULT_LAYOUT
        for p in path:
            value = value[p]
        for damage in DAMAGES:
            if damage in ("reversed", "null-inside") and not isinstance(value, list):
                continue
            for command in ("export", "plot", "solve"):
                if (
                    command == "plot"
                    and damage not in PLOT_DAMAGES
                    or command == "solve"
                    and damage not in SOLVE_DAMAGES
                ):
                    continue
                cases[f"{command} {_name(path)}={damage}"] = (path, damage, command)
    return cases


_COLUMNS = {
    k: [0, 0]
    for k in (
        "t",
        "x",
        "y",
        "theta",
        "v",
        "omega",
        "lambda_1",
        "lambda_2",
        "lambda_3",
        "running_cost",
        "hamiltonian",
        "at_step",
    )
}
RESULT_LAYOUT = {
    **dict.fromkeys(["schema", "status", "message", "scenario", "model", "method", "final_solver", "initial_path", "optimal", "trajectory_source", "weight", "wall_time_s", "sweeps", "newton_iterations", "f_evals", "cost_increases", "state_names", "control_names", "cheaper_motion", "cost", "energy", "penalty", "initial_cost", "min_clearance", "end_state_error", "max_costate_jump", "max_dH_du", "hamiltonian_variation"], 0),
    **dict.fromkeys(["state_names", "control_names", "costate0", "clearance"], [0, 0]),
    "timing": dict.fromkeys(["initial_path_s", "sweeps_s", "final_s", "validation_s"], 0),
    "history": [{**dict.fromkeys(["sweep", "q", "cost", "max_costate_jump", "newton_iterations", "f_evals", "failures", "rejected", "time_s"], 0), "junction_t": [0, 0], "junction_X": [0, 0]}],
    "initial_junctions": {"t": [0, 0], "X": [0, 0]},
    "alternatives": [{**dict.fromkeys(["label", "status", "cost", "initial_cost", "sweeps", "weight", "message"], 0), "trajectory": _COLUMNS}],
    "search": [dict.fromkeys(["stage", "reason", "label", "partitions", "weight", "aid", "status", "cost", "sweeps", "time_s", "message"], 0)],
    "free_time": None,
    "scenario_file": {**dict.fromkeys(["name", "horizon", "penalty", "solver"], 0), **dict.fromkeys(["start", "goal", "obstacles"], [0, 0]), "robot": {"model": 0}},
    "settings": {**dict.fromkeys(["initial_paths", "extra_paths", "candidate_paths", "margin", "samples", "threads", "finer_doublings", "time_limit"], 0), "leapfrog": dict.fromkeys(["method", "local", "partitions", "max_sweeps", "sweeps_per_level", "reduce_tol"], 0)},
    "provenance": {**dict.fromkeys(["python", "platform", "date", "call"], 0), "versions": {"leapfrog-planner": 0}},
    "replan": None,
    "trajectory": _COLUMNS,
}  # fmt: skip
RESULT_CASES = _result_case_ids()


def _schema_valid(text: str) -> bool:
    """The oracle: the damaged file against ``leapfrog schema`` (jsonschema's reading of it),
    every number finite as a double (the writer writes no NaN or infinity: null)."""
    jsonschema = pytest.importorskip("jsonschema")
    from leapfrog_planner.planning.result_schema import result_schema

    def finite(v):
        if isinstance(v, dict):
            return all(finite(x) for x in v.values())
        if isinstance(v, list):
            return all(finite(x) for x in v)
        if isinstance(v, float):
            return v - v == 0.0
        if isinstance(v, int) and not isinstance(v, bool):
            return abs(v) < 2.0**1023
        return True

    data = json.loads(text)
    return finite(data) and jsonschema.Draft202012Validator(result_schema()).is_valid(data)


@pytest.mark.parametrize("case", list(RESULT_CASES))
def test_result(case, saved_result, tmp_path):
    path, damage, command = RESULT_CASES[case]
    base, _ = saved_result
    text = _damaged(base, path, damage)
    if text is None:
        pytest.skip("the damage does not apply to this value")
    args = {
        "export": ["export", "r.json", "--csv", "x.csv"],
        "plot": ["plot", "r.json", "--out", "x.png"],
        "solve": ["solve", "r.json", "--quiet", "--json", "again.json"],
    }[command]
    out = run_cli(args, tmp_path, {"r.json": text})
    got = check_bad_or_fine(out, fine=(0, 1, 3) if command == "solve" else (0,))
    refused = _expected_refused(text, path, damage, command)
    assert got == ("refused" if refused else "ran"), (
        out.lines,
        "damaged" if refused else "harmless",
    )
    if got == "refused":  # the file named, or what a re-plan or an export misses in it
        assert any(w in out.lines[0] for w in ("r.json", "settings", "no trajectory")), out.lines[0]


@pytest.mark.parametrize("suffix", ["json", "npz"])
@pytest.mark.parametrize("share", [0.0, 0.01, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 0.999])
def test_a_result_cut_short_is_refused(saved_result, tmp_path, suffix, share):
    """A file half-written (a copy cut short): refused by every command, nothing drawn."""
    text, npz = saved_result
    data = json.dumps(text).encode() if suffix == "json" else npz
    cut = data[: int(len(data) * share)]
    for command in (
        ["export", "r", "--csv", "x.csv"],
        ["plot", "r", "--out", "x.png"],
        ["solve", "r", "--quiet"],
    ):
        out = run_cli(command, tmp_path / command[0], {"r": cut})
        if share == 0.0 and command[0] == "solve":  # an empty file is no result: a scenario
            assert out.code == 2 and "missing required key" in out.stderr
        assert check_bad_or_fine(out) == "refused", out.lines


# ============================================================================ 4. sweep stores


def _store_record(scenario: str, method: str, cost) -> dict:
    """A record as a sweep writes it (batch/tasks.py)."""
    return {
        "scenario": scenario, "method": method, "status": "failed" if cost is None else "converged",
        "failure": "solver" if cost is None else None, "message": "ok", "cost": cost,
        "min_clearance": 0.1, "end_state_error": 1e-12, "newton_iterations": 10, "f_evals": 20,
        "sweeps": 3, "final_solver": "shooting", "cheaper_motion": None, "obstacles": 1,
        "scenario_hash": "ab12", "settings_hash": "cd34", "wall_time_s": 0.5, "task_time_s": 0.6,
        "warmup_s": 0.0, "worker": "host:1",
    }  # fmt: skip


STORE = [_store_record("s1", "newton", 2.0), _store_record("s1", "modified-newton", 2.5),
         _store_record("s2", "newton", None), _store_record("s2", "modified-newton", 3.0)]  # fmt: skip
#: The damaged record is the second line's; what each field must be (the report reads them):
#: scenario and method text; status converged or failed; failure one of the sweep's or null;
#: the numbers finite or null, times and counts not negative, counts integers; the rest is
#: free (a message, hashes, the worker: kept as they are, harmless).
FREE_FIELDS = ("message", "scenario_hash", "settings_hash", "worker", "final_solver")
STORE_DAMAGES = {
    "null": None, "string": "abc", "empty-string": "", "true": True, "table": {}, "array": [1],
    "negative": -1, "2.5": 2.5, "10**400": 10**400, "nan": Raw("NaN"), "inf": Raw("Infinity"),
    "1e999": Raw("1e999"), "deleted": ...,
}  # fmt: skip
#: Values a field may hold, so harmless there: null where a number may be unknown, a number
#: for a number, a string for the free fields, any value for fields the report does not read.
STORE_HARMLESS = {
    **{(f, d): "free text" for f in FREE_FIELDS for d in ("string", "empty-string")},
    **{(f, d): "may be absent or unknown" for f in FREE_FIELDS for d in ("null", "deleted")},
    **{(f, d): "a number, or unknown" for f in ("cost", "min_clearance", "end_state_error", "cheaper_motion") for d in ("null", "negative", "2.5", "deleted")},
    **{(f, d): "a time or count left out" for f in ("wall_time_s", "task_time_s", "warmup_s", "newton_iterations", "f_evals", "sweeps", "obstacles") for d in ("null", "deleted")},
    **{(f, "2.5"): "a time" for f in ("wall_time_s", "task_time_s", "warmup_s")},
    ("failure", "deleted"): "a failure's kind left out: counted as the solver's",
    ("failure", "null"): "no failure: the record converged (or is counted as the solver's)",
}  # fmt: skip
#: Whole lines: (the line's bytes, whether it is refused).
STORE_LINES = {
    "not json": (b"not json", True), "an array": (b"[1, 2]", True), "a number": (b"3", True),
    "a string": (b'"s1"', True), "empty object": (b"{}", True), "null": (b"null", True),
    "nested 100000 deep": (b"[" * 100_000 + b"]" * 100_000, True),
    "an object 100000 deep": (b'{"a":' * 100_000 + b"1" + b"}" * 100_000, True),
    "invalid utf-8": (b'{"scenario": "\xff", "method": "m", "status": "failed"}', True),
    "a NUL byte": (b"\0", True), "a BOM": (b"\xef\xbb\xbf" + json.dumps(STORE[1]).encode(), True),
    "a duplicate pair": (json.dumps(STORE[0]).encode(), True),
    "blank": (b"   ", False), "CRLF": (json.dumps(STORE[1]).encode() + b"\r", False),
    "a huge number": (json.dumps({**STORE[1], "cost": 1}).encode().replace(b'"cost": 1', b'"cost": ' + b"9" * 5000), True),
    "a megabyte string": (json.dumps({**STORE[1], "message": "m" * 2**20}).encode(), False),
    "an unknown field": (json.dumps({**STORE[1], "colour": "red"}).encode(), False),
    "scenario named with markup": (json.dumps({**STORE[1], "scenario": "[/] [bold]x"}).encode(), False),
    "scenario with a line break": (json.dumps({**STORE[1], "scenario": "a\nb"}).encode(), True),
    "status unknown": (json.dumps({**STORE[1], "status": "maybe"}).encode(), True),
    "failure unknown": (json.dumps({**STORE[1], "failure": "meteor"}).encode(), True),
}  # fmt: skip


def _store_text(line: bytes) -> bytes:
    lines = [json.dumps(r).encode() for r in STORE]
    lines[1] = line
    return b"\n".join(lines) + b"\n"


def store_cases() -> dict[str, tuple[bytes, bool]]:
    """id: (the file's bytes, whether ``report`` must refuse it)."""
    cases = {}
    for field in STORE[1]:
        for damage, value in STORE_DAMAGES.items():
            rec = dict(STORE[1])
            if value is ...:
                del rec[field]
            else:
                rec[field] = Raw("@@raw@@") if isinstance(value, Raw) else value
            line = json.dumps(rec).replace('"@@raw@@"', str(value)).encode()
            cases[f"{field}={damage}"] = (_store_text(line), (field, damage) not in STORE_HARMLESS)
    for name, (line, refused) in STORE_LINES.items():
        cases[f"line {name}"] = (_store_text(line), refused)
    cases["a torn last line"] = (
        _store_text(json.dumps(STORE[1]).encode()) + b'{"scenario": "s3", "meth',
        False,
    )
    cases["empty file"] = (b"", True)
    cases["only blank lines"] = (b"\n\n\n", True)
    return cases


STORE_CASES = store_cases()


@pytest.mark.parametrize("case", list(STORE_CASES))
def test_store(case, tmp_path):
    data, refused = STORE_CASES[case]
    out = run_cli(["report", "r.jsonl"], tmp_path, {"r.jsonl": data})
    got = check_bad_or_fine(out, fine=(0,))
    assert got == ("refused" if refused else "ran"), (out.lines, out.stdout[-500:])


@pytest.mark.parametrize(
    "case", ["cost=string", "cost=nan", "wall_time_s=negative", "line a NUL byte", "status=null"]
)
def test_a_damaged_store_writes_no_report(case, tmp_path):
    """``report --out``: a damaged store is refused before the folder gets a file."""
    data, _ = STORE_CASES[case]
    out = run_cli(["report", "r.jsonl", "--out", "rep"], tmp_path, {"r.jsonl": data})
    assert out.code == 2 and len(out.lines) == 1, out.stderr
    assert not any(k.startswith("rep/") for k in out.after), out.after


def test_the_corpus_is_large_enough():
    counts = {
        "scenario": len(SCENARIO_CASES),
        "options": len(OPTION_CASES),
        "result": len(RESULT_CASES),
        "store": len(STORE_CASES),
    }
    assert sum(counts.values()) >= 500, counts
