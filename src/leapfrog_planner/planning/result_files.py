"""Result files: a plan saved with everything needed to read it alone, loaded back, resampled.

A JSON or NPZ file holds the result, the scenario planned and the planner's settings, so that
``PlanResult.load(path)`` gives back a result whose figures and exports need nothing else. The
JSON keys are documented in :mod:`.results`; an NPZ file holds the same JSON (without the
trajectory) in its ``result_json`` entry and the trajectory columns as arrays.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from dataclasses import asdict, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import json_text, write_atomic, write_text_atomic
from ..errors import LeapfrogError
from ..integrate.flow import Trajectory
from .leapfrog import SweepRecord
from .result_schema import SCHEMA, schema_fault
from .scenario import scenario_from_dict
from .status import FreeTimeReport, PathOutcome, PlanStatus, RunRecord, TimeStep

#: The schemas this version reads: 1 (no scenario, settings or junctions: it cannot be re-run),
#: 2 (no provenance) and 3. A key an older schema lacks is read as its default (see
#: :func:`upgraded`).
READS = (1, 2, 3)


class ResultFileError(LeapfrogError, ValueError):
    """A result file that cannot be read (not one of ours, a newer schema, damaged)."""


def _num(v) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


def plain(value: Any) -> Any:
    """Settings as JSON values: dataclasses as tables, anything else JSON cannot hold as text."""
    if is_dataclass(value) and not isinstance(value, type):
        return {k: plain(v) for k, v in asdict(value).items()}
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    return repr(value)


# --------------------------------------------------------------------------- trajectories


def trajectory_columns(tr: Trajectory | None, states, controls) -> dict[str, np.ndarray]:
    """A trajectory as named columns of equal length: ``t``, the states, the controls, the
    costates ``lambda_1``..., ``running_cost`` (accumulated from ``t[0]``), ``hamiltonian`` and
    ``at_step`` (1 where the integrator stepped, 0 on the rows interpolated between its steps,
    whose Hamiltonian carries the interpolation's error)."""
    if tr is None:
        return {}
    cols = {"t": tr.t}
    cols.update({n: tr.x[:, i] for i, n in enumerate(states)})
    cols.update({n: tr.u[:, i] for i, n in enumerate(controls)})
    cols.update({f"lambda_{i + 1}": tr.lam[:, i] for i in range(tr.lam.shape[1])})
    cols["running_cost"] = tr.cost
    cols["hamiltonian"] = tr.hamiltonian
    cols["at_step"] = np.asarray(tr.at_step, dtype=float)
    return cols


class DamagedColumns(ValueError):
    """A trajectory's columns that do not make one (a column missing, not numbers, or of
    another length than the others): the message says which, in words."""


def trajectory_from_columns(
    cols: dict, states, controls, where: str = "trajectory"
) -> Trajectory | None:
    """The trajectory of named columns (:func:`trajectory_columns`), None for none; raises
    :class:`DamagedColumns` (``where``: which trajectory, for its message)."""
    if not cols:
        return None
    nx = len(states)
    names = ["t", *states, *controls, *(f"lambda_{i + 1}" for i in range(nx))]
    missing = [n for n in names if n not in cols]
    if missing:
        raise DamagedColumns(f"{where} has no column {', '.join(missing)}")
    optional = [n for n in ("running_cost", "hamiltonian", "at_step") if n in cols]
    c = {n: _column(cols, n, where) for n in (*names, *optional)}
    rows = {n: a.size for n, a in c.items()}
    if len(set(rows.values())) > 1:
        odd = next(n for n in c if rows[n] != rows["t"])
        raise DamagedColumns(
            f"{where} columns of different lengths: t has {rows['t']} rows, {odd} has {rows[odd]}"
        )
    t, nan = c["t"], np.full(c["t"].size, np.nan)
    u = np.column_stack([c[n] for n in controls])
    return Trajectory(
        t=t,
        x=np.column_stack([c[n] for n in states]),
        lam=np.column_stack([c[f"lambda_{i + 1}"] for i in range(nx)]),
        u=u,
        cost=c.get("running_cost", nan),
        hamiltonian=c.get("hamiltonian", nan),
        dH_du=np.full_like(u, np.nan),  # not saved: max_dH_du holds its check
        at_step=c.get("at_step", np.zeros(t.size)) == 1.0,
    )


def _column(cols: dict, name: str, where: str) -> np.ndarray:
    try:
        a = np.asarray(cols[name], dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.ndim != 1:
        raise DamagedColumns(f"{where} column {name} is not a list of numbers")
    return a


def _columns_json(cols: dict[str, np.ndarray]) -> dict[str, list]:
    return {k: [_num(v) for v in np.asarray(a, dtype=float).tolist()] for k, a in cols.items()}


# --------------------------------------------------------------------------- to and from a dict


#: The result's numbers, saved as they are (non-finite ones as null).
_NUMBERS = (
    "cheaper_motion", "cost", "energy", "penalty", "initial_cost", "min_clearance",
    "end_state_error", "max_costate_jump", "max_dH_du", "hamiltonian_variation",
)  # fmt: skip
_PLAIN = (
    "message", "scenario", "model", "method", "final_solver", "initial_path", "optimal",
    "trajectory_source", "weight", "wall_time_s", "sweeps", "newton_iterations", "f_evals",
    "cost_increases",
)  # fmt: skip
_TIMING = {
    "initial_path_s": "time_initial_path_s",
    "sweeps_s": "time_sweeps_s",
    "final_s": "time_final_s",
    "validation_s": "time_validation_s",
}


def _history_json(h: SweepRecord) -> dict:
    return {
        **{f.name: getattr(h, f.name) for f in fields(SweepRecord) if f.name not in ("t", "X")},
        "cost": _num(h.cost),
        "max_costate_jump": _num(h.max_costate_jump),
        "junction_t": np.asarray(h.t).tolist(),
        "junction_X": np.asarray(h.X).tolist(),
    }


def _alternative_json(a: PathOutcome, names) -> dict:
    return {
        "label": a.label,
        "status": str(a.status),
        "cost": _num(a.cost),
        "initial_cost": _num(a.initial_cost),
        "sweeps": a.sweeps,
        "weight": a.weight,
        "message": a.message,
        "trajectory": _columns_json(trajectory_columns(a.trajectory, *names)),
    }


def _record_json(rec: RunRecord) -> dict:
    d = {f.name: getattr(rec, f.name) for f in fields(RunRecord)}
    return {**d, "status": str(rec.status), "cost": _num(rec.cost)}


def _free_time_json(f: FreeTimeReport | None) -> dict | None:
    if f is None:
        return None
    d = {k: getattr(f, k) for k in ("time_weight", "cruise_speed", "horizon", "bound")}
    steps = [{**{k: _num(getattr(s, k)) for k in _STEP[:3]}, "source": s.source} for s in f.steps]
    return {**d, "condition": _num(f.condition), "steps": steps}


def _free_time(d: dict | None) -> FreeTimeReport | None:
    if d is None:
        return None
    steps = tuple(
        TimeStep(*(_float(s[k]) for k in _STEP[:3]), source=str(s["source"])) for s in d["steps"]
    )
    speed = d["cruise_speed"]
    return FreeTimeReport(
        float(d["time_weight"]), None if speed is None else float(speed), float(d["horizon"]),
        _float(d["condition"]), str(d["bound"]), steps,
    )  # fmt: skip


_STEP = ("horizon", "hamiltonian", "cost", "source")


def result_to_dict(r) -> dict:
    """Every field of ``r`` as JSON values (non-finite numbers as null)."""
    names = (r.state_names, r.control_names)
    t0, X0 = r.initial_junctions
    return {
        "schema": SCHEMA,
        "status": str(r.status),
        **{k: getattr(r, k) for k in _PLAIN},
        "state_names": list(r.state_names),
        "control_names": list(r.control_names),
        **{k: _num(getattr(r, k)) for k in _NUMBERS},
        "clearance": [_num(c) for c in r.clearance],
        "costate0": None if r.costate0 is None else r.costate0.tolist(),
        "timing": {k: getattr(r, name) for k, name in _TIMING.items()},
        "history": [_history_json(h) for h in r.history],
        "initial_junctions": {"t": np.asarray(t0).tolist(), "X": np.asarray(X0).tolist()},
        "alternatives": [_alternative_json(a, names) for a in r.alternatives],
        "search": [_record_json(rec) for rec in r.search],
        "free_time": _free_time_json(r.free_time),
        "scenario_file": None if r.task is None else r.task.to_dict(),
        "settings": r.settings,
        "provenance": r.provenance,
        "replan": r.replan,
        "trajectory": _columns_json(r.trajectory_columns()),
    }


def _float(v) -> float:
    return float("nan") if v is None else float(v)


def _history(h: dict) -> SweepRecord:
    return SweepRecord(
        **{k: v for k, v in h.items() if not k.startswith("junction_")},
        t=np.array(h["junction_t"], dtype=float),
        X=np.array(h["junction_X"], dtype=float),
    )


def _alternative(a: dict, names) -> PathOutcome:
    return PathOutcome(
        label=a["label"],
        status=PlanStatus(a["status"]),
        cost=_float(a["cost"]),
        initial_cost=_float(a["initial_cost"]),
        sweeps=a["sweeps"],
        message=a["message"],
        weight=a["weight"],
        trajectory=trajectory_from_columns(
            a["trajectory"], *names, f"the trajectory of other path {a['label']}"
        ),
    )


def _record(d: dict) -> RunRecord:
    rec = {f.name: d[f.name] for f in fields(RunRecord)}
    return RunRecord(**{**rec, "status": PlanStatus(d["status"]), "cost": _float(d["cost"])})


def result_fields(d: dict, source: str = "<dict>") -> dict[str, Any]:
    """The fields of the result :func:`result_to_dict` wrote (``PlanResult(**fields)``)."""
    if not isinstance(d, dict) or "schema" not in d or "status" not in d:
        raise ResultFileError(f"{source}: not a leapfrog result file")
    if d["schema"] not in READS or isinstance(d["schema"], bool):
        raise ResultFileError(
            f"{source}: result schema {d['schema']!r}; this version reads schemas "
            f"{', '.join(map(str, READS))} (plan the scenario again to get a file it can read)"
        )
    fault = schema_fault(d) if d["schema"] == SCHEMA else None
    if fault is not None:
        raise ResultFileError(f"{source}: damaged result file ({fault})")
    try:
        out = _fields(upgraded(d), source)
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
        if isinstance(exc, LeapfrogError):
            raise
        raise ResultFileError(f"{source}: damaged result file ({_damage(exc)})") from None
    _check_fields(out, source, d["schema"])
    return out


def _damage(exc: Exception) -> str:
    """What is wrong with a result file, from the error reading it raised: in words where it is
    known (a trajectory's columns, a key missing), else the error itself."""
    if isinstance(exc, DamagedColumns):
        return str(exc)
    if isinstance(exc, KeyError):
        return f"key {exc.args[0]!r} missing"
    return f"{type(exc).__name__}: {exc}"


def _fields(d: dict, source: str) -> dict[str, Any]:
    names = (tuple(_names(d["state_names"])), tuple(_names(d["control_names"])))
    task, ij = d["scenario_file"], d["initial_junctions"]
    return dict(
        status=PlanStatus(d["status"]),
        **{k: d[k] for k in _PLAIN if k != "sweeps"},
        state_names=names[0],
        control_names=names[1],
        **{k: _float(d.get(k)) for k in _NUMBERS if k != "min_clearance"},
        costate0=None if d["costate0"] is None else np.array(d["costate0"], dtype=float),
        trajectory=trajectory_from_columns(d["trajectory"], *names),
        clearance=np.array([_float(c) for c in d["clearance"]]),
        history=tuple(_history(h) for h in d["history"]),
        initial_junctions=(np.array(ij["t"], dtype=float), np.array(ij["X"], dtype=float)),
        **{name: d["timing"][k] for k, name in _TIMING.items()},
        alternatives=tuple(_alternative(a, names) for a in d["alternatives"]),
        task=None if task is None else scenario_from_dict(task, source),
        settings=d["settings"],
        search=tuple(_record(rec) for rec in d["search"]),
        free_time=_free_time(d["free_time"]),
        provenance=d["provenance"],
        replan=d["replan"],
    )


def upgraded(d: dict) -> dict:
    """A result of an older schema with the keys of the current one: a key it lacks gets its
    default (no scenario, settings, provenance, search or free time: ``null`` or empty; no
    junctions: empty; a count or cost not kept: 0 or ``null``; the state and control names
    read off the trajectory's columns)."""
    d = dict(d)
    if d["schema"] == 1:
        lams = [k for k in d["trajectory"] if k.startswith("lambda_")]
        derived = ("t", "running_cost", "hamiltonian", "at_step")
        cols = [k for k in d["trajectory"] if k not in derived and not k.startswith("lambda_")]
        d.setdefault("state_names", cols[: len(lams)])
        d.setdefault("control_names", cols[len(lams) :])
        d.setdefault("cost_increases", 0)
        d.setdefault("initial_junctions", {"t": [], "X": []})
        d["history"] = [{"junction_t": [], "junction_X": [], **h} for h in d["history"]]
        d["alternatives"] = [
            {"initial_cost": None, "trajectory": {}, **a} for a in d["alternatives"]
        ]
        d.setdefault("scenario_file", None)
        d.setdefault("settings", None)
    d.setdefault("search", [])
    d.setdefault("free_time", None)
    d.setdefault("provenance", None)
    d.setdefault("replan", None)  # (schema 3 before replan: an optional key)
    return d


def _names(value) -> list[str]:
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise TypeError(f"expected a list of names, got {json.dumps(value)[:40]}")
    return value


#: The largest count a result holds (sweeps, iterations, evaluations).
_COUNT_MAX = 2**53


def _check_fields(out: dict, source: str, schema: int) -> None:
    """What a result file says must make sense before anything is drawn or exported from it:
    finite trajectories whose time runs forward, a cost for a converged answer, counts that
    are counts, settings that are a table."""

    def bad(what: str):
        raise ResultFileError(f"{source}: damaged result file ({what})")

    if out["status"] is PlanStatus.CONVERGED and not math.isfinite(out["cost"]):
        bad("a converged result without a finite cost")
    for key in ("sweeps", "newton_iterations", "f_evals", "cost_increases"):
        v = out.get(key)
        if v is not None and (
            not isinstance(v, int) or isinstance(v, bool) or not 0 <= v <= _COUNT_MAX
        ):
            bad(f"{key} is not a count")
    if not isinstance(out["settings"], dict) and not (schema == 1 and out["settings"] is None):
        bad("settings is not a table")
    if not isinstance(out["provenance"], dict | None):
        bad("provenance is not a table")
    if out["replan"] not in ("warm", "full", None):
        bad("replan is not warm, full or null")
    for label, tr in [("trajectory", out["trajectory"])] + [
        (f"alternative {a.label}", a.trajectory) for a in out["alternatives"]
    ]:
        if tr is not None:
            _check_trajectory(tr, label, bad)
    junctions = [(h.t, h.X) for h in out["history"]] + [out["initial_junctions"]]
    for t, X in junctions:
        if not (np.isfinite(t).all() and np.isfinite(X).all()):
            bad("junctions that are not finite")


def _check_trajectory(tr: Trajectory, label: str, bad) -> None:
    n = tr.t.shape[0]
    if tr.t.ndim != 1 or n < 2 or any(a.shape[0] != n for a in (tr.x, tr.u, tr.lam)):
        bad(f"{label}: columns of different lengths, or fewer than 2 rows")
    if not all(np.isfinite(a).all() for a in (tr.t, tr.x, tr.u, tr.lam)):
        bad(f"{label}: a value that is not a finite number")
    if np.any(np.diff(tr.t) < 0.0):
        bad(f"{label}: time runs backwards")


# --------------------------------------------------------------------------- files


def save_json(r, path) -> None:
    write_text_atomic(path, json_text(result_to_dict(r)))


def save_npz(r, path) -> None:
    d = result_to_dict(r)
    d.pop("trajectory")
    arrays = {k: np.asarray(v) for k, v in r.trajectory_columns().items()}
    arrays["history_cost"] = np.array([h.cost for h in r.history])
    arrays["history_jump"] = np.array([h.max_costate_jump for h in r.history])
    arrays["clearance"] = r.clearance
    arrays["result_json"] = np.array(json.dumps(d, allow_nan=False))

    def write(tmp):
        with open(tmp, "wb") as fh:  # a handle: np.savez would append .npz to a file name
            np.savez(fh, **arrays)

    write_atomic(path, write)


def is_result_file(path) -> bool:
    """Whether the file ``path`` holds a saved result rather than a scenario, told by its
    content whatever its name: a zip (NPZ) or a JSON object (a TOML file never starts with
    ``{``). False for a name that is no regular file (a built-in scenario's; a FIFO is not
    opened: without a writer, opening it would wait for ever)."""
    try:
        if not os.path.isfile(path):
            return False
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    return _format_of(head) is not None


def _format_of(head: bytes) -> str | None:
    """Which kind of result file begins with the bytes ``head``: ``"npz"`` (a zip), ``"json"``
    (an object, after an optional byte-order mark) or None."""
    if head.startswith(b"PK"):
        return "npz"
    if head.removeprefix(b"\xef\xbb\xbf").lstrip().startswith(b"{"):
        return "json"
    return None


def load_result(path) -> dict[str, Any]:
    """The fields of a result saved by ``save_json`` or ``save_npz`` (told apart by the file's
    first bytes)."""
    path = Path(path)
    name = str(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(4)
        if _format_of(head) == "npz":
            with np.load(path, allow_pickle=False) as z:
                if "result_json" not in z.files:
                    raise ResultFileError(f"{name}: not a leapfrog result file")
                d = json.loads(str(z["result_json"]))
                names = (d.get("state_names", []), d.get("control_names", []))
                skip = {"result_json", "history_cost", "history_jump", "clearance"}
                cols = {k: z[k] for k in z.files if k not in skip}
                d["trajectory"] = cols if names[0] else {}
        else:
            d = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ResultFileError(f"{name}: cannot read file: {exc.strerror or exc}") from None
    except (ValueError, UnicodeDecodeError, zipfile.BadZipFile) as exc:  # JSON, zip, arrays
        raise ResultFileError(f"{name}: not a leapfrog result file ({exc})") from None
    except RecursionError:
        raise ResultFileError(f"{name}: not a leapfrog result file (nested too deeply)") from None
    return result_fields(d, name)
