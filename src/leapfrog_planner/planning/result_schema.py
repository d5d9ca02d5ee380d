"""The JSON Schema of a result file (``leapfrog schema`` prints it): the keys of the current
schema (:data:`.result_files.SCHEMA`), their types and which are required. The meaning of each
key is documented in :mod:`.results`; the scenario's own keys in the scenario format's
documentation (the loader checks them)."""

from __future__ import annotations

from dataclasses import fields, is_dataclass
from functools import cache
from typing import Any

import numpy as np

from ..checks import finite_number
from .settings import PlannerSettings

#: The schema a result file of this version is written in (``"schema"`` in the file).
SCHEMA = 3

_NUMBER = {"type": ["number", "null"]}  # a number, null where it is not finite
_FINITE = {"type": "number"}
_COUNT = {"type": "integer", "minimum": 0}
_TEXT = {"type": "string"}
_STATUS = {"enum": ["converged", "collides", "failed"]}
_NUMBERS = {"type": "array", "items": _NUMBER}
_ROWS = {"type": "array", "items": {"type": "array", "items": _FINITE}}
_COLUMNS = {
    "type": "object",
    "description": "equal-length columns: t, the states, the controls, lambda_1..., "
    "running_cost, hamiltonian, at_step; {} without a trajectory",
    "additionalProperties": _NUMBERS,
}


def _table(props: dict, required: tuple | list | None = None, more: bool = False) -> dict:
    return {
        "type": "object",
        "properties": props,
        "required": list(props if required is None else required),
        "additionalProperties": more,
    }


def _settings(value) -> dict:
    """The settings' tables, field by field (a nested settings dataclass as a table of its own;
    keys left out keep their defaults, an unknown key is refused)."""
    props = {
        f.name: _settings(getattr(value, f.name)) if is_dataclass(getattr(value, f.name)) else {}
        for f in fields(value)
    }
    return _table(props, required=())


_HISTORY = _table(
    {
        "sweep": _COUNT, "q": _COUNT, "cost": _NUMBER, "max_costate_jump": _NUMBER,
        "newton_iterations": _COUNT, "f_evals": _COUNT, "failures": _COUNT, "rejected": _COUNT,
        "time_s": _FINITE, "junction_t": _NUMBERS, "junction_X": _ROWS,
    }
)  # fmt: skip
_ALTERNATIVE = _table(
    {
        "label": _TEXT, "status": _STATUS, "cost": _NUMBER, "initial_cost": _NUMBER,
        "sweeps": _COUNT, "weight": _FINITE, "message": _TEXT, "trajectory": _COLUMNS,
    }
)  # fmt: skip
_RUN = _table(
    {
        "stage": _TEXT, "reason": _TEXT, "label": _TEXT, "partitions": _COUNT,
        "weight": _FINITE, "aid": _NUMBER, "status": _STATUS, "cost": _NUMBER,
        "sweeps": _COUNT, "time_s": _FINITE, "message": _TEXT,
    }
)  # fmt: skip
_STEP = _table({"horizon": _NUMBER, "hamiltonian": _NUMBER, "cost": _NUMBER, "source": _TEXT})
_FREE_TIME = _table(
    {
        "time_weight": _FINITE, "cruise_speed": _NUMBER, "horizon": _FINITE, "bound": _TEXT,
        "condition": _NUMBER, "steps": {"type": "array", "items": _STEP},
    }
)  # fmt: skip
_SCENARIO = {
    "type": "object",
    "description": "the scenario planned, in the scenario file's layout; its solver table "
    "holds the values of the settings used",
    "properties": {
        "name": _TEXT,
        "horizon": {"oneOf": [_FINITE, {"const": "free"}]},
        "start": {"type": "array", "items": _FINITE},
        "goal": {"type": "array", "items": _FINITE},
        "solver": {"type": "object"},
    },
    "required": ["name", "horizon", "start", "goal"],
}
_PROVENANCE = _table(
    {
        "versions": {
            "type": "object",
            "description": "leapfrog-planner, numba, numpy and scipy",
            "additionalProperties": {"type": ["string", "null"]},
        },
        "python": _TEXT,
        "platform": _TEXT,
        "date": {"type": "string", "description": "UTC, ISO 8601"},
        "call": {"type": "string", "description": "the command line, or the API call"},
    }
)


def result_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a result file of the current schema."""
    props = {
        "schema": {"const": SCHEMA},
        "status": _STATUS,
        "message": _TEXT,
        "scenario": _TEXT,
        "model": _TEXT,
        "method": _TEXT,
        "final_solver": {"enum": ["shooting", "multiple-shooting", None]},
        "initial_path": _TEXT,
        "optimal": {"type": "boolean"},
        "trajectory_source": _TEXT,
        "weight": _FINITE,
        "wall_time_s": _FINITE,
        **{k: _COUNT for k in ("sweeps", "newton_iterations", "f_evals", "cost_increases")},
        "state_names": {"type": "array", "items": _TEXT},
        "control_names": {"type": "array", "items": _TEXT},
        **{
            k: _NUMBER
            for k in (
                "cheaper_motion",
                "cost",
                "energy",
                "penalty",
                "initial_cost",
                "min_clearance",
                "end_state_error",
                "max_costate_jump",
                "max_dH_du",
                "hamiltonian_variation",
            )
        },  # fmt: skip
        "clearance": _NUMBERS,
        "costate0": {"oneOf": [{"type": "null"}, {"type": "array", "items": _FINITE}]},
        "timing": _table(
            {k: _FINITE for k in ("initial_path_s", "sweeps_s", "final_s", "validation_s")}
        ),
        "history": {"type": "array", "items": _HISTORY},
        "initial_junctions": _table({"t": _NUMBERS, "X": _ROWS}),
        "alternatives": {"type": "array", "items": _ALTERNATIVE},
        "search": {"type": "array", "items": _RUN},
        "free_time": {"oneOf": [{"type": "null"}, _FREE_TIME]},
        "scenario_file": _SCENARIO,
        "settings": _settings(PlannerSettings()),
        "provenance": _PROVENANCE,
        "replan": {
            "enum": ["warm", "full", None],
            "description": "how replan made it (warm from the previous answer, or a full plan);"
            " optional: a file of this schema written before it has no such key",
        },
        "trajectory": _COLUMNS,
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": f"leapfrog-planner result (schema {SCHEMA})",
        "description": "A plan saved by `leapfrog solve --json` or PlanResult.save_json; an NPZ "
        "file holds the same JSON, less the trajectory, in its result_json entry.",
        **_table(props, required=[k for k in props if k != "replan"]),
    }


@cache
def _validator():
    from jsonschema import Draft202012Validator  # only when a result file is read

    return Draft202012Validator(result_schema())


def schema_fault(data) -> str | None:
    """Where a result file's JSON ``data`` first breaks :func:`result_schema` (as jsonschema
    reads it), in one short line, or None. A number must also be finite wherever it is (the
    writer writes null for NaN; JSON's 1e999 or 10**400 are beyond a double), which a JSON
    Schema cannot say. The trajectories' columns, the bulk of a file (a dozen columns of a
    thousand numbers, and as many for each alternative: jsonschema took 0.6 to 0.9 s over paper
    case 4's 2.4 MB), are checked here when they hold plain numbers and left out of the rest."""
    data, fault = _columns_apart(data)
    if fault is not None:
        return fault
    error = next(iter(_validator().iter_errors(data)), None)
    if error is None:
        return _not_finite(data, "")
    where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path)
    if error.validator == "required":
        key = next(k for k in error.validator_value if k not in error.instance)
        return f"key {(where + '.' + key).lstrip('.')!r} missing"
    if error.validator == "type":
        kinds = error.validator_value
        kinds = [kinds] if isinstance(kinds, str) else kinds
        message = f"expected {' or '.join(kinds)}, got {_json_kind(error.instance)}"
    else:
        message = " ".join(error.message.split())
        message = message if len(message) <= 120 else message[:117] + "..."
    return f"{where.lstrip('.') or 'the file'}: {message}"


def _columns_apart(data) -> tuple[Any, str | None]:
    """``data`` with each trajectory column (of the answer and of its alternatives) that holds
    only numbers emptied, and the first such number that is not finite; a column holding
    anything else is left for the schema. An empty column meets the schema as a full one of
    numbers does (an array of numbers or null)."""
    if not isinstance(data, dict):
        return data, None
    out = dict(data)
    fault = None
    if isinstance(out.get("trajectory"), dict):
        out["trajectory"], fault = _numbers_apart(out["trajectory"], "trajectory")
    alternatives = out.get("alternatives")
    if isinstance(alternatives, list):
        out["alternatives"] = [dict(a) if isinstance(a, dict) else a for a in alternatives]
        for i, a in enumerate(out["alternatives"]):
            if isinstance(a, dict) and isinstance(a.get("trajectory"), dict):
                where = f"alternatives[{i}].trajectory"
                a["trajectory"], found = _numbers_apart(a["trajectory"], where)
                fault = fault or found
    return out, fault


def _numbers_apart(columns: dict, where: str) -> tuple[dict, str | None]:
    out, fault = {}, None
    for name, col in columns.items():
        if isinstance(col, np.ndarray):  # an NPZ file's: checked as a column when read
            out[name] = []
        elif isinstance(col, list) and all(type(v) is float or type(v) is int for v in col):
            bad = next((i for i, v in enumerate(col) if not finite_number(v)), None)
            if bad is not None and fault is None:
                fault = f"{where}.{name}[{bad}]: a number that is not finite"
            out[name] = []
        else:
            out[name] = col
    return out, fault


def _json_kind(value) -> str:
    if isinstance(value, bool):
        return "a boolean"
    kinds = {dict: "an object", list: "an array", str: "a string", type(None): "null"}
    return kinds.get(type(value), "a number")


def _not_finite(value, where: str) -> str | None:
    """The first number of ``value`` that is not finite, or beyond a double: where it is."""
    if isinstance(value, dict):
        items = ((f"{where}.{k}" if where else str(k), v) for k, v in value.items())
    elif isinstance(value, list):
        items = ((f"{where}[{i}]", v) for i, v in enumerate(value))
    elif isinstance(value, int | float) and not isinstance(value, bool):
        ok = finite_number(value)
        return None if ok else f"{where or 'the file'}: a number that is not finite"
    else:
        return None
    return next(filter(None, (_not_finite(v, at) for at, v in items)), None)
