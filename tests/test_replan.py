"""``replan``: the moved task of a receding-horizon loop solved warm from the previous answer,
validated as every answer is, else planned in full; the result says which."""

from __future__ import annotations

import json

import jsonschema
import numpy as np
import pytest

import leapfrog_planner as lp
from leapfrog_planner.errors import ScenarioError, SettingsError
from leapfrog_planner.planning.result_schema import result_schema

SAME = 1e-8


@pytest.fixture(scope="module")
def planned():
    cache = {}

    def get(case: str, **options):
        key = (case, tuple(sorted(options.items())))
        if key not in cache:
            cache[key] = lp.plan(case, **options)
        return cache[key]

    return get


def _moved_along(result, fraction: float) -> dict:
    """The robot drove ``fraction`` of the way along ``result``: its state there, the time left."""
    T = result.task.horizon
    at = result.at(fraction * T)
    start = np.array([float(np.asarray(at[n])) for n in result.state_names])
    return {"start": start, "horizon": (1.0 - fraction) * T}


@pytest.mark.parametrize("case", [f"paper-case-{i}" for i in range(1, 5)])
def test_a_small_move_is_solved_warm_to_the_cold_plans_answer(planned, case):
    previous = planned(case)
    assert previous.success
    r = lp.replan(previous, **_moved_along(previous, 0.05))
    assert r.replan == "warm", r.message
    assert r.success and r.optimal and r.trajectory_source == "extremal"
    assert r.min_clearance is None or r.min_clearance >= r.task.margin
    assert r.task.horizon == pytest.approx(0.95 * previous.task.horizon)
    cold = lp.plan(r.task)
    assert cold.success and cold.replan is None
    assert abs(r.cost - cold.cost) <= SAME * max(1.0, abs(cold.cost))
    assert np.allclose(r.trajectory.x[-1], r.task.goal, atol=1e-6)


def test_the_goal_moved_far_is_planned_in_full(planned):
    previous = planned("paper-case-1")
    r = lp.replan(previous, goal=[1.0, 0.0, 0.0])
    assert r.replan == "full" and r.success
    assert "re-planned in full (the goal moved" in r.message
    assert np.array_equal(r.task.goal, [1.0, 0.0, 0.0])


def test_an_obstacle_onto_the_path_is_planned_in_full(planned):
    previous = planned("paper-case-1")
    middle = previous.at(0.5 * previous.task.horizon)
    disc = [float(np.asarray(middle["x"])), float(np.asarray(middle["y"])), 0.2]
    r = lp.replan(previous, obstacles=[disc])
    assert r.replan == "full"
    assert "an obstacle lies on the previous path" in r.message
    assert r.success and r.min_clearance >= 0.0


def test_a_failed_result_falls_back_to_a_full_plan(planned):
    fast = dict(partitions=2, final="shooting", initial_paths=1, extra_paths=0)
    previous = planned("paper-case-4", finer_doublings=0, **fast)
    assert previous.trajectory is None or not previous.optimal
    r = lp.replan(previous, start=[0.0, 0.01, 0.0])
    assert r.replan == "full"
    assert "the previous result has no extremal" in r.message


@pytest.mark.parametrize(
    "args, error, says",
    [
        ({"start": [0.0, 0.0]}, ScenarioError, "start"),
        ({"goal": [[1.0, 2.0, 0.0]]}, ScenarioError, "goal"),
        ({"obstacles": [1.0, 2.0]}, ScenarioError, "obstacles"),
    ],
)
def test_bad_arguments_are_one_line_errors(planned, args, error, says):
    with pytest.raises(error) as info:
        lp.replan(planned("paper-case-1"), **args)
    assert says in str(info.value) and "\n" not in str(info.value)


def test_a_previous_that_is_not_a_result_is_refused():
    with pytest.raises(SettingsError, match="expected a PlanResult") as info:
        lp.replan({"start": [0, 0, 0]})
    assert "\n" not in str(info.value)


def test_the_json_round_trip_keeps_how_it_was_replanned(planned, tmp_path):
    previous = planned("paper-case-2")
    warm = lp.replan(previous, **_moved_along(previous, 0.05))
    full = lp.replan(previous, goal=[0.5, 3.5, 0.0])
    for r, how in ((warm, "warm"), (full, "full")):
        path = tmp_path / f"{how}.json"
        r.save_json(path)
        data = json.loads(path.read_text())
        assert data["replan"] == how
        jsonschema.validate(data, result_schema())
        back = lp.PlanResult.load(path)
        assert back.replan == how and back.cost == r.cost and back.status == r.status
    # A file of the same schema written before the key existed still loads (and validates).
    data = previous.to_dict()
    assert data.pop("replan") is None
    jsonschema.validate(data, result_schema())
    (tmp_path / "older.json").write_text(json.dumps(data))
    assert lp.PlanResult.load(tmp_path / "older.json").replan is None


def test_a_warm_result_re_runs_as_a_plan_of_its_task(planned):
    previous = planned("paper-case-3")
    warm = lp.replan(previous, **_moved_along(previous, 0.05))
    again = lp.plan(warm)
    assert again.success and abs(again.cost - warm.cost) <= SAME * max(1.0, abs(warm.cost))
