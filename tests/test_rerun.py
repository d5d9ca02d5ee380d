"""Results that re-run: a result records its scenario and the settings used (one truth: the
scenario's [solver] table agrees with them) and its provenance; ``plan(result)``,
``Planner.from_result`` and ``leapfrog solve RESULT`` re-plan it and give the recorded answer bit
for bit; every kind of result validates against the published JSON Schema; older schemas load.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from datetime import datetime

import jsonschema
import numpy as np
import pytest
from tests.test_cli import cli_env

from leapfrog_planner.errors import SettingsError
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.rerun import reproduction
from leapfrog_planner.planning.result_files import ResultFileError, is_result_file, plain
from leapfrog_planner.planning.result_schema import result_schema
from leapfrog_planner.planning.results import PlanResult
from leapfrog_planner.planning.scenario import load_scenario, load_scenario_text
from leapfrog_planner.planning.settings import PlannerSettings

_BASE = """name = "{name}"
horizon = {horizon}
start = {start}
goal = {goal}
{extra}
[robot]
model = "{model}"
{robot}
[penalty]
weight = {weight}
{obstacles}
"""
_DISC = "[[obstacles]]\ncenter = [1.0, {y}]\nradius = 0.2\n"
_ASIDE = _DISC.format(y=0.3)  # a disc beside the straight line


def _toml(name, model="unicycle", horizon="1.0", start="[0.0, 0.0, 0.0]",
          goal="[2.0, 0.0, 0.0]", extra="", robot="", weight=100.0,
          obstacles=_ASIDE) -> str:  # fmt: skip
    return _BASE.format(**locals())


_FAST_FAILURE = dict(
    partitions=2, final="shooting", initial_paths=1, extra_paths=0, finer_doublings=0
)

#: Every kind of result, each a plan of well under a second: (scenario, options, status).
KINDS = {
    "converged": (_toml("converged"), {}, "converged"),
    "failed": ("paper-case-4", _FAST_FAILURE, "failed"),
    # No penalty (weight 0) and a disc on the straight line: the extremal goes through it.
    "collides": (
        _toml("collides", weight=0.0, obstacles=_DISC.format(y=0.0)),
        {"initial_paths": 1},
        "collides",
    ),  # fmt: skip
    "diff-drive": (_toml("diff-drive", model="diff-drive"), {}, "converged"),
    "car": (
        _toml(
            "car",
            model="car",
            start="[0.0, 0.0, 0.0, 0.0]",
            goal="[1.0, 0.5, 0.0, 0.0]",
            robot="wheelbase = 0.4",
            obstacles="",
        ),
        {},
        "converged",
    ),  # fmt: skip
    "bounds": (
        _toml("bounds", robot="v = [0.0, 3.0]\nomega = [-4, 4]", obstacles=_DISC.format(y=0.1)),
        {},
        "converged",
    ),  # fmt: skip
    "waypoints": (
        _toml("waypoints", horizon="2.0", extra="waypoints = [[1.0, 0.6]]"),
        {},
        "converged",
    ),  # fmt: skip
    "free-time": (
        _toml(
            "free-time",
            horizon='"free"',
            obstacles="[cost]\ncruise_speed = 1.0\n" + _DISC.format(y=0.3),
        ),
        {},
        "converged",
    ),  # fmt: skip
}


def _scenario(text: str):
    return load_scenario(text) if "\n" not in text else load_scenario_text(text, "kind.toml")


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict[str, tuple[PlanResult, object]]:
    """Each kind planned once and saved as JSON: (the result, the file)."""
    folder = tmp_path_factory.mktemp("kinds")
    out = {}
    for kind, (text, options, _) in KINDS.items():
        r = plan(_scenario(text), **options)
        r.save_json(folder / f"{kind}.json")
        out[kind] = (r, folder / f"{kind}.json")
    return out


def _cli(args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", *args],
        cwd=cwd, env=cli_env(), capture_output=True, encoding="utf-8", timeout=300,
    )  # fmt: skip


def _same_cost(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


# --------------------------------------------------------------------------- every kind


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_of_result_reruns_from_its_json_bit_for_bit(results, kind):
    r, path = results[kind]
    assert str(r.status) == KINDS[kind][2], r.message
    loaded = PlanResult.load(path)
    again = plan(loaded)
    check = reproduction(loaded, again)
    assert check.reproduces, check.summary()
    assert str(again.status) == str(r.status) and _same_cost(again.cost, r.cost)
    np.testing.assert_array_equal(again.trajectory.x, r.trajectory.x)
    assert "bit for bit" in check.summary() and str(r.status) in check.summary()


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_of_result_validates_against_the_schema(results, kind):
    _, path = results[kind]
    jsonschema.Draft202012Validator(result_schema()).validate(json.loads(path.read_text()))


def test_the_schema_is_a_valid_schema_and_refuses_what_the_loader_refuses(results):
    schema = result_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    d = json.loads(results["converged"][1].read_text())
    validator = jsonschema.Draft202012Validator(schema)
    for damage in (
        lambda d: d.pop("provenance"),
        lambda d: d.update(status="fine"),
        lambda d: d.update(sweeps=-1),
        lambda d: d["settings"].update(partitons=16),  # an unknown setting
        lambda d: d.update(schema=2),
    ):
        bad = json.loads(json.dumps(d))
        damage(bad)
        assert not validator.is_valid(bad)


def test_leapfrog_schema_prints_the_schema_or_writes_it(tmp_path):
    p = _cli(["schema"], tmp_path)
    assert p.returncode == 0 and json.loads(p.stdout) == result_schema()
    p = _cli(["schema", "--out", "s.json"], tmp_path)
    assert p.returncode == 0 and json.loads((tmp_path / "s.json").read_text()) == result_schema()


# --------------------------------------------------------------------------- settings


def test_settings_come_back_from_their_json_values():
    s = PlannerSettings.from_options(partitions=16, initial_paths=5, time_limit=30.0)
    d = json.loads(json.dumps(plain(s)))
    assert PlannerSettings.from_dict(d) == s
    assert PlannerSettings.from_dict({}) == PlannerSettings()


@pytest.mark.parametrize(
    "data, says",
    [
        ({"partitons": 16}, "partitons: unknown option"),
        ({"leapfrog": {"partitions": 1}}, "partitions"),
        ({"leapfrog": {"shooting": {"root": {"tols": 1}}}}, "leapfrog.shooting.root.tols"),
        ({"initial_paths": "three"}, "initial_paths"),
        ([1, 2], "settings: expected a table"),
    ],
)
def test_bad_settings_are_one_line_errors(data, says):
    with pytest.raises(SettingsError, match=says) as info:
        PlannerSettings.from_dict(data)
    assert "\n" not in str(info.value)


def test_a_planner_takes_the_recorded_settings(results):
    r, _ = results["converged"]
    p = Planner(r.task, settings=PlannerSettings.from_dict(r.settings))
    assert p.settings == Planner.from_result(r).settings == PlannerSettings.from_dict(r.settings)


# --------------------------------------------------------------------------- one truth


def test_the_recorded_scenario_and_settings_agree(tmp_path):
    """After `solve room.toml --partitions 16 --initial-paths 5` the file's scenario says 16 and
    5 as its settings do: planning result.task plans with them."""
    text = _toml("room", obstacles=_DISC.format(y=0.3)) + "[solver]\npartitions = 8\n"
    (tmp_path / "room.toml").write_text(text)
    args = ["solve", "room.toml", "--partitions", "16", "--initial-paths", "5", "--quiet"]
    p = _cli([*args, "--json", "r.json"], tmp_path)
    assert p.returncode == 0, p.stderr
    d = json.loads((tmp_path / "r.json").read_text())
    assert d["scenario_file"]["solver"]["partitions"] == d["settings"]["leapfrog"]["partitions"]
    assert d["scenario_file"]["solver"]["initial_paths"] == d["settings"]["initial_paths"] == 5
    r = PlanResult.load(tmp_path / "r.json")
    s = Planner(r.task).settings
    assert (s.leapfrog.partitions, s.initial_paths) == (16, 5)
    assert s.solver_table() == r.task.solver


def test_an_older_file_with_a_stale_solver_table_reruns_with_its_settings(results, tmp_path):
    """Schema 2 wrote the scenario's own [solver] table beside the settings used: the settings
    rule."""
    d = json.loads(results["converged"][1].read_text())
    d["schema"] = 2
    d.pop("provenance")
    d["settings"]["leapfrog"]["partitions"] = 16
    d["scenario_file"]["solver"] = {"partitions": 8, "initial_paths": 3}
    (tmp_path / "old.json").write_text(json.dumps(d))
    old = PlanResult.load(tmp_path / "old.json")
    assert old.provenance is None
    assert Planner.from_result(old).settings.leapfrog.partitions == 16
    # Written before long routes were planned with more partitions: re-run as it was planned.
    assert d["settings"].pop("long_route") == 64.0
    (tmp_path / "older.json").write_text(json.dumps(d))
    assert Planner.from_result(PlanResult.load(tmp_path / "older.json")).settings.long_route == 0
    # Written before a few extra paths ran whatever their estimate: re-run as it was planned.
    assert d["settings"].pop("min_extra_paths") == PlannerSettings().min_extra_paths > 0
    (tmp_path / "oldest.json").write_text(json.dumps(d))
    oldest = Planner.from_result(PlanResult.load(tmp_path / "oldest.json"))
    assert oldest.settings.min_extra_paths == 0


def test_a_rerun_of_bad_recorded_settings_names_the_file_and_the_scenario(results, tmp_path):
    """``solve RESULT`` whose settings are not settings: one line that names the file (the
    scenario's name alone did not say which file), as replan and the API name the scenario."""
    r, path = results["converged"]
    d = json.loads(path.read_text())
    d["settings"]["leapfrog"]["partitions"] = 1
    (tmp_path / "bad.json").write_text(json.dumps(d))
    p = _cli(["solve", "bad.json", "--quiet"], tmp_path)
    assert p.returncode == 2 and p.stderr.count("\n") == 1, p.stderr
    said = f"error: bad.json: {r.scenario}: the recorded settings: leapfrog.partitions: must be"
    assert p.stderr.startswith(said), p.stderr
    with pytest.raises(SettingsError, match=f"^{r.scenario}: the recorded settings: leapfrog"):
        Planner.from_result(PlanResult.load(tmp_path / "bad.json"))


# --------------------------------------------------------------------------- provenance


def test_every_result_says_how_it_was_made(results):
    r, path = results["converged"]
    prov = json.loads(path.read_text())["provenance"]
    assert set(prov["versions"]) == {"leapfrog-planner", "numba", "numpy", "scipy"}
    assert all(prov["versions"].values()) and prov["python"] and prov["platform"]
    assert datetime.fromisoformat(prov["date"]).utcoffset().total_seconds() == 0
    assert prov["call"].startswith("plan(") and "kind.toml" not in prov["call"]
    assert Planner(r.task).plan().provenance["call"] == "Planner.plan"
    assert plan(r).provenance["call"].startswith("plan(<result of")


def test_provenance_is_no_part_of_the_answer(results):
    r, _ = results["converged"]
    again = plan(r)
    assert again.provenance["call"] != r.provenance["call"]  # another call, the same answer
    assert reproduction(r, again).reproduces


def test_plan_of_a_result_takes_no_options(results):
    with pytest.raises(SettingsError, match="recorded settings"):
        plan(results["converged"][0], partitions=4)


# --------------------------------------------------------------------------- older schemas


#: The keys schema 1 wrote (its results.py before schema 2), the history's and alternatives'.
_SCHEMA_1 = (
    "schema status message scenario model method final_solver initial_path optimal "
    "trajectory_source weight cost energy penalty min_clearance clearance end_state_error "
    "max_costate_jump max_dH_du hamiltonian_variation costate0 wall_time_s sweeps "
    "newton_iterations f_evals timing history alternatives trajectory"
).split()
_HISTORY_1 = "sweep q cost max_costate_jump newton_iterations f_evals failures rejected time_s"
_ALTERNATIVE_1 = "label status cost sweeps weight message".split()


def _as_schema_1(d: dict) -> dict:
    old = {k: d[k] for k in _SCHEMA_1}
    old["schema"] = 1
    old["history"] = [{k: h[k] for k in _HISTORY_1.split()} for h in d["history"]]
    old["alternatives"] = [{k: a[k] for k in _ALTERNATIVE_1} for a in d["alternatives"]]
    drop = ("running_cost", "hamiltonian", "at_step")
    old["trajectory"] = {k: v for k, v in d["trajectory"].items() if k not in drop}
    return old


def test_a_schema_1_file_loads_with_defaults_and_cannot_rerun(results, tmp_path):
    r, path = results["diff-drive"]
    (tmp_path / "one.json").write_text(json.dumps(_as_schema_1(json.loads(path.read_text()))))
    old = PlanResult.load(tmp_path / "one.json")
    assert (old.state_names, old.control_names) == (r.state_names, r.control_names)
    assert old.cost == r.cost and old.status == r.status
    np.testing.assert_array_equal(old.trajectory.x, r.trajectory.x)
    assert old.task is None and old.settings is None and old.provenance is None
    assert old.search == () and old.free_time is None and old.cost_increases == 0
    assert all(a.trajectory is None for a in old.alternatives)
    with pytest.raises(ResultFileError, match="cannot be re-run"):
        Planner.from_result(old)
    p = _cli(["solve", "one.json"], tmp_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "cannot be re-run" in p.stderr


def test_a_newer_schema_is_refused_in_one_line(results, tmp_path):
    d = json.loads(results["converged"][1].read_text())
    d["schema"] = 4
    (tmp_path / "new.json").write_text(json.dumps(d))
    with pytest.raises(ResultFileError, match="result schema 4; this version reads schemas 1"):
        PlanResult.load(tmp_path / "new.json")


# --------------------------------------------------------------------------- the command


def test_solve_of_a_result_reruns_it_and_says_it_reproduces(results, tmp_path):
    r, path = results["converged"]
    r.save_npz(tmp_path / "r.npz")
    (tmp_path / "r.json").write_bytes(path.read_bytes())
    for name in ("r.json", "r.npz"):
        p = _cli(["solve", name, "--quiet", "--json", f"again-{name}.json"], tmp_path)
        assert p.returncode == 0, p.stderr
        line = f"converged: reproduces the recorded answer: converged, cost {r.cost:.8g}"
        assert p.stdout.strip() == f"{line} (bit for bit)", p.stdout
        prov = json.loads((tmp_path / f"again-{name}.json").read_text())["provenance"]
        assert prov["call"] == f"leapfrog solve {name} --quiet --json again-{name}.json"
    p = _cli(["solve", "r.json"], tmp_path)  # with the table, the line comes last
    assert p.returncode == 0 and p.stdout.strip().splitlines()[-1].endswith("(bit for bit)")


def test_solve_of_a_result_says_when_it_differs(results, tmp_path):
    d = json.loads(results["converged"][1].read_text())
    d["cost"] = d["cost"] * (1 + 1e-15)
    (tmp_path / "tampered.json").write_text(json.dumps(d))
    p = _cli(["solve", "tampered.json", "--quiet"], tmp_path)
    assert p.returncode == 3, (p.stdout, p.stderr)
    assert "differs from the recorded answer: cost" in p.stdout and "recorded" in p.stdout


def test_solve_of_a_failed_result_reproduces_it_and_exits_1(results, tmp_path):
    (tmp_path / "f.json").write_bytes(results["failed"][1].read_bytes())
    p = _cli(["solve", "f.json", "--quiet"], tmp_path)
    assert p.returncode == 1 and "reproduces the recorded answer: failed" in p.stdout


def test_a_result_is_recognised_by_its_content_not_its_name(results, tmp_path):
    (tmp_path / "looks.toml").write_bytes(results["converged"][1].read_bytes())
    assert is_result_file(tmp_path / "looks.toml")
    (tmp_path / "room.toml").write_text(_toml("room"))
    assert not is_result_file(tmp_path / "room.toml")
    assert not is_result_file("paper-case-1") and not is_result_file(tmp_path)
    p = _cli(["solve", "looks.toml", "--quiet"], tmp_path)
    assert p.returncode == 0 and "reproduces" in p.stdout


def test_planning_options_are_refused_with_a_result(results, tmp_path):
    (tmp_path / "r.json").write_bytes(results["converged"][1].read_bytes())
    for extra in (["--partitions", "16"], ["--option", "extra_paths=1"], ["--horizon", "2"]):
        p = _cli(["solve", "r.json", *extra], tmp_path)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "planning options are not accepted" in p.stderr
