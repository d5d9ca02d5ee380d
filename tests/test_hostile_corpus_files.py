"""The generated hostile-input corpus, continued (tests/test_hostile_corpus.py says how it is
run and what each case must keep): the files the tool writes, read back damaged.

3. ``result``: a result written by ``solve --json``, every field (top level and nested) damaged
   one way or another (null, wrong types, NaN and infinities as raw JSON, numbers beyond a
   double, reversed and emptied arrays, keys deleted), read by ``export --csv``, ``plot
   --out`` and ``solve RESULT``; and the JSON and NPZ files cut short.
4. ``store``: a sweep's results file (JSON Lines) with one line damaged, read by ``report``.
"""

# ruff: noqa: E501
from __future__ import annotations

import copy
import json

import pytest
from tests.hostile_harness import check_bad_or_fine, run_cli
from tests.test_hostile_corpus import (
    NO_WAYPOINTS,
    OPTION_CASES,
    SCENARIO_CASES,
    Raw,
    key_name,
    to_toml,
)

from leapfrog_planner.planning.settings import PlannerSettings

# ============================================================================ 3. result files

#: The damages done to a value of a result file: a JSON value, or ``Raw`` JSON text.
DAMAGES = {
    "null": None, "string": "abc", "true": True, "table": {}, "empty-array": [],
    "negative": -1, "2.5": 2.5, "10**400": 10**400, "nan": Raw("NaN"), "1e999": Raw("1e999"),
    "deleted": ..., "reversed": "<reversed>", "null-inside": "<null inside>",
}  # fmt: skip
#: ... and those tried on each path by ``plot`` and ``solve RESULT`` (each reads the file the
#: same way as ``export``, which tries them all).
PLOT_DAMAGES = ("string", "deleted")
SOLVE_DAMAGES = ("string", "deleted")
#: ... on the paths at most this deep; deeper ones (``alternatives[0].trajectory.x`` is 3 deep)
#: get export alone, with these damages (the suite's time is bounded).
NESTED = 2
DEEP_DAMAGES = ("null", "string", "true", "nan", "deleted", "reversed")
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

    if not _schema_valid(text) or (key_name(path), damage) in REFUSED:
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
        args, folder, {"s.toml": to_toml(NO_WAYPOINTS | {"solver": {"initial_paths": 3}})}
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
                    or len(path) > NESTED
                    and (command != "export" or damage not in DEEP_DAMAGES)
                ):
                    continue
                cases[f"{command} {key_name(path)}={damage}"] = (path, damage, command)
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
    **{(f, "string"): "another name" for f in ("scenario", "method")},
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
    "a NUL byte": (b"\0", True), "a BOM": (b"\xef\xbb\xbf" + json.dumps(STORE[1]).encode(), False),  # JSON reads it whole
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
    """The four families' generated cases (the module docstrings give the counts)."""
    counts = {
        "scenario": len(SCENARIO_CASES),
        "options": len(OPTION_CASES),
        "result": len(RESULT_CASES),
        "store": len(STORE_CASES),
    }
    assert counts == {"scenario": 692, "options": 702, "result": 1491, "store": 284}, counts
