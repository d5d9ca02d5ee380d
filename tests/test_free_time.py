"""A free final time: ``horizon = "free"`` at a price ``k`` per second.

Closed forms in free space (the optimum drives straight at the cruise speed ``v``, ``k = c v^2``
with ``c`` the model's effort of driving straight ahead), the direct method with ``T`` a variable
on the paper's cases (its Richardson-extrapolated optima are in ``data/free_time_direct.json``,
made by ``benchmarks/free_time_direct_reference.py``), Pontryagin's condition ``k + H = 0`` on
every converged answer, the bounds of ``T``, files and bad input.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.errors import ScenarioError
from leapfrog_planner.model import get_model
from leapfrog_planner.model.cruise import straight_effort
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.results import PlanResult
from leapfrog_planner.planning.scenario import load_scenario, load_scenario_text
from leapfrog_planner.planning.scenario_time import FreeTime
from leapfrog_planner.planning.status import PlanStatus

REFERENCE = json.loads((Path(__file__).parent / "data" / "free_time_direct.json").read_text())


def line(model: str = "unicycle", price: str = "cruise_speed = 1.0", extra: str = "") -> str:
    return f"""
name = "line"
horizon = "free"
start = [0, 0, 0]
goal = [3, 0, 0]
[robot]
model = "{model}"
{extra}
[cost]
{price}
"""


def condition_met(r: PlanResult) -> bool:
    f = r.free_time
    return abs(f.condition) <= 1e-8 * max(1.0, f.time_weight)


def test_the_effort_of_driving_straight_ahead():
    assert straight_effort(get_model("unicycle"), {}) == pytest.approx(0.5)
    assert straight_effort(get_model("car"), {}) == pytest.approx(0.5)
    assert straight_effort(get_model("diff-drive"), {"wheel_radius": 0.5}) == pytest.approx(4.0)


@pytest.mark.parametrize("k", [0.1, 2.0])
def test_free_space_unicycle_meets_the_closed_form(k):
    r = plan(load_scenario_text(line(price=f"time_weight = {k}")))
    assert r.status is PlanStatus.CONVERGED and condition_met(r)
    assert r.free_time.horizon == pytest.approx(3 / math.sqrt(2 * k), rel=1e-8)
    assert r.cost == pytest.approx(3 * math.sqrt(2 * k), rel=1e-8)
    assert r.cost == pytest.approx(r.energy + r.penalty + r.free_time.time_cost, rel=1e-12)
    assert r.trajectory.t[-1] == pytest.approx(r.free_time.horizon, rel=1e-12)


def test_a_cruise_speed_is_the_speed_in_free_space_for_the_differential_drive():
    text = line("diff-drive", "cruise_speed = 0.75", "wheel_radius = 0.5")
    r = plan(load_scenario_text(text))
    assert r.status is PlanStatus.CONVERGED and condition_met(r)
    assert r.free_time.horizon == pytest.approx(3 / 0.75, rel=1e-8)
    assert r.free_time.time_weight == pytest.approx(4.0 * 0.75**2)
    v = 0.5 * r.trajectory.u.sum(axis=1) / 2  # r (w_R + w_L) / 2
    assert np.allclose(v, 0.75, rtol=1e-6)


CASES = [(c["case"], c["k"]) for c in REFERENCE]
#: Cases whose direct optimum is collision-free, and a quick plan: the planner must be no
#: dearer (it is cheaper where the multistart stopped at a worse local optimum), and where they
#: found the same extremal the costs agree to 1e-6 and T to 1e-5 (the extrapolation's accuracy).
AGREE = [("paper-case-1", 1.0), ("paper-case-2", 1.0), ("paper-case-4", 1.0), ("paper-case-3", 1.0)]


def _reference(case: str, k: float) -> dict:
    return next(c for c in REFERENCE if c["case"] == case and c["k"] == k)


def _free(case: str, k: float) -> PlanResult:
    return plan(dataclasses.replace(load_scenario(case), free_time=FreeTime(k)))


@pytest.mark.parametrize("case, k", AGREE)
def test_the_paper_cases_against_the_direct_method_with_free_time(case, k):
    ref = _reference(case, k)
    r = _free(case, k)
    assert r.status is PlanStatus.CONVERGED and condition_met(r)
    assert r.min_clearance is None or r.min_clearance >= 0.0
    assert r.cost <= ref["cost"] * (1 + 1e-6)
    if r.cost >= ref["cost"] * (1 - 1e-4):  # the same extremal
        assert r.cost == pytest.approx(ref["cost"], rel=1e-6)
        assert r.free_time.horizon == pytest.approx(ref["horizon"], rel=1e-5)


def test_a_cheaper_answer_than_the_direct_multistart_is_an_optimum_of_the_direct_method_too():
    """Paper case 4 at k = 1: the planner's optimum is 18% cheaper than the multistart's. The
    direct method started from the planner's path must find it as well."""
    pytest.importorskip("casadi")
    from leapfrog_planner.planning.direct import richardson
    from leapfrog_planner.planning.direct_free import solve_direct_free

    r = _free("paper-case-4", 1.0)
    sc = load_scenario("paper-case-4")
    tr = r.trajectory
    costs, horizons = [], []
    for n in (200, 400):
        t = np.linspace(0.0, tr.t[-1], n + 1)
        guess = np.column_stack([np.interp(t, tr.t, tr.x[:, i]) for i in range(3)])
        d = solve_direct_free(
            sc.start, sc.goal, sc.obstacles, 1.0, horizon_guess=tr.t[-1], intervals=n,
            multistart=False, guesses=[guess], weight=sc.weight, exponent=sc.exponent,
        )  # fmt: skip
        assert d.success
        costs.append(d.cost)
        horizons.append(d.horizon)
    assert richardson(*costs) == pytest.approx(r.cost, rel=1e-6)
    assert richardson(*horizons) == pytest.approx(r.free_time.horizon, rel=1e-5)
    assert r.cost < 0.9 * _reference("paper-case-4", 1.0)["cost"]


def test_where_the_direct_optimum_crosses_a_disc_the_answer_does_not():
    """Paper case 3 at k = 10: time is so dear that the direct optimum drives through the
    centre of a disc (clearance -0.15). The planner's answer keeps clear of it, or says it
    collides; it is never a converged path through the disc."""
    ref = _reference("paper-case-3", 10.0)
    assert ref["min_clearance"] < -0.1
    r = _free("paper-case-3", 10.0)
    assert r.status in (PlanStatus.CONVERGED, PlanStatus.COLLIDES)
    if r.status is PlanStatus.CONVERGED:
        assert r.min_clearance >= 0.0 and condition_met(r)
        assert r.cost > ref["cost"]  # dearer than the path through the disc, as it must be


@pytest.mark.parametrize("index", [0, 5])
def test_an_answer_is_no_dearer_than_a_fixed_horizon_plan_at_its_t(index):
    """Random layouts of the general preset at a cruise speed of 1 (headings within 45 degrees
    of the line): converged, k + H = 0, collision-free, and no dearer than what the planner
    finds with the horizon fixed at the T chosen (on layout 5 that fixed plan returns a dearer
    extremal than the one continued in T, which the answer keeps)."""
    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one

    sc = generate_one(GeneratorSpec.preset("general", seed=1), index)
    r = plan(dataclasses.replace(sc, free_time=FreeTime(0.5, 1.0)))
    assert r.status is PlanStatus.CONVERGED and condition_met(r)
    assert r.min_clearance >= 0.0
    T = r.free_time.horizon
    fixed = plan(dataclasses.replace(sc, horizon=T))
    assert r.cost <= fixed.cost + 0.5 * T + 1e-9


def test_a_family_still_getting_cheaper_is_followed_to_its_free_time_optimum():
    """General layout 53 at a cruise speed of 1: the cheapest extremal of the plan at the first
    horizon (T = 1.6) heads for an optimum (6.25286 at T = 4.443) cheaper than IPOPT's
    multistart (6.2565 at T = 4.49); the continuation in T used to stop short of it (its solves
    ran out while it was still getting cheaper) and the search settled on a dearer family's
    6.6733. The roots found from that plan include one that meets k + H = 0 and is no dearer
    than IPOPT's."""
    from leapfrog_planner._blas import single_threaded_blas
    from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
    from leapfrog_planner.planning.fixed_horizons import FixedHorizons
    from leapfrog_planner.planning.free_time import _family_roots

    sc = generate_one(GeneratorSpec.preset("general", seed=1), 53)
    sc = dataclasses.replace(sc, free_time=FreeTime(0.5, 1.0))
    plans = FixedHorizons(Planner(sc))
    with single_threaded_blas():  # as in a plan (threads fight over two cores: 10x slower)
        first = plans.plan_at(1.59659)
        assert first.status is PlanStatus.CONVERGED
        roots = _family_roots(plans, sc, first, [], math.inf)
    met = [r for r in roots if abs(0.5 + r.point.H) <= 1e-8 and r.point.clearance >= 0]
    assert met and min(r.total(0.5) for r in met) <= 6.2565


def test_a_family_cut_off_at_its_solve_cap_is_continued_while_it_heads_below_the_best_root():
    """A family whose continuation ran out of solves while it still heads below the cheapest
    root found is given more (as often as it needs, up to EXTENSIONS times), and its root is
    kept."""
    from types import SimpleNamespace

    from leapfrog_planner.planning.free_time import _extended
    from leapfrog_planner.planning.time_family import OutOfSolves

    class Family:
        def __init__(self, heading: float, solves: int):
            self.heading, self.needed, self.allowed = heading, solves, 0

        def predicted(self) -> float:
            return self.heading

        def allow(self, solves: int) -> None:
            self.allowed += solves

        def solve(self):
            if self.allowed < self.needed:
                raise OutOfSolves("out of solves")
            return SimpleNamespace(total=lambda k: self.heading, clearance=1.0, T=2.0), ""

    sc = load_scenario_text(line())
    found = SimpleNamespace(point=SimpleNamespace(clearance=1.0), total=lambda k: 5.0)
    cheaper, dearer = Family(4.0, 45), Family(6.0, 1)
    roots = _extended([(cheaper, None, None), (dearer, None, None)], [found], sc, None)
    assert [r.point.total(0.5) for r in roots] == [4.0]


def test_an_answer_continued_from_an_alternative_is_told_as_that_path_s_run():
    """A family continued in ``T`` may come from one of the plan's alternatives, not its answer
    (general layout 14 of seed 1 at a cruise of 1: its answer continues a reversing path round
    a disc, where the plan's answer was a three-point turn). The result then names that path
    and its initial cost, shows no sweeps or junctions of another path, and lists the plan's
    answer among the alternatives in its place."""
    from leapfrog_planner.planning.free_time import _from_path

    r = plan("paper-case-4")
    assert len(r.alternatives) >= 2 and r.history
    path = r.alternatives[1]
    told = _from_path(r, path)
    assert (told.initial_path, told.initial_cost) == (path.label, path.initial_cost)
    assert told.history == () and len(told.initial_junctions[0]) == 0
    assert path not in told.alternatives and len(told.alternatives) == len(r.alternatives)
    answer = told.alternatives[0]
    assert (answer.label, answer.cost, answer.trajectory) == (r.initial_path, r.cost, r.trajectory)
    assert _from_path(r, None) is r  # continued from the answer: as it was


@pytest.mark.parametrize("method", ["modified-newton", "newton", "nleq-err"])
def test_the_continuation_in_t_solves_at_the_final_accuracy_with_the_local_step(method):
    """The continuation in T solves each horizon from a prediction to the final solves'
    tolerances, with the local problems' step: a failing prediction ends after a line search
    of 2^-3 (then a shorter step in T), not 2^-20 (general 17: 8.0 s -> 4.7 s)."""
    from leapfrog_planner.planning.fixed_horizons import FixedHorizons
    from leapfrog_planner.roots import ModifiedNewtonStep

    planner = Planner(load_scenario_text(line()), method=method)
    settings = planner.settings.leapfrog
    continued, final = FixedHorizons(planner).shooting, settings.final_solves()
    assert (continued.root, continued.integrator) == (final.root, final.integrator)
    assert continued.method == settings.local_step()
    if method == "modified-newton":
        assert continued.method == ModifiedNewtonStep(max_halvings=3)


def test_a_first_horizon_shorter_than_the_top_speed_allows_is_not_planned():
    """The estimate that picks the first horizon does not see a bound on the speed: on general
    layout 3 with |v| <= 1.5 it chose 0.84 s where the shortest initial path needs 1.11 s, and
    the plan there failed after 31 s before the retry at 1.6 times it converged. A horizon
    shorter than the top speed allows is now skipped for the next retry (the last is always
    planned). 3 m at |v| <= 1.5: 2 s at least."""
    from types import SimpleNamespace

    from leapfrog_planner.planning.free_time import RETRIES, _first_plan, least_time

    sc = load_scenario_text(line())
    assert least_time(sc, 3.0) == 0.0  # no bound: nothing is skipped
    sc = dataclasses.replace(sc, control_bounds={"v": (-1.5, 1.5)})
    assert least_time(sc, 3.0) == 2.0
    asked = []

    class Plans:
        def plan_at(self, T, deadline=math.inf):
            asked.append(T)
            task = SimpleNamespace(horizon=T)
            ok = PlanStatus.CONVERGED
            return SimpleNamespace(status=ok, task=task, trajectory=None, optimal=False, cost=1.0)

    assert RETRIES == (1.6, 2.5)
    for T0, planned in ((2.0, 2.0), (1.5, 2.4), (1.0, 2.5), (0.5, 1.25)):
        asked.clear()
        _first_plan(Plans(), sc, T0, math.inf, 2.0)
        assert asked == [pytest.approx(planned)]


def test_a_bound_on_t_holds_and_is_reported():
    text = line(price="cruise_speed = 1.0") + "[time]\nbounds = [0.5, 2.0]\n"
    r = plan(load_scenario_text(text))  # the free optimum, 3 s, is beyond the longest
    assert r.status is PlanStatus.CONVERGED
    assert r.free_time.horizon == pytest.approx(2.0) and r.free_time.bound == "longest"
    assert r.free_time.condition < 0  # a longer T would be cheaper
    assert "longest bound" in r.message


def test_the_time_limit_bounds_the_whole_search_not_each_plan():
    """A time limit is the free-time search's, not each of its fixed-horizon plans' (each
    plan had the whole limit: 0.5 s asked, 12 s taken, on a random layout). Past it, nothing
    more is planned or continued: the first plan (cut short itself) is all the search made,
    and the answer says so, with the best path it has."""
    sc = dataclasses.replace(load_scenario("paper-case-4"), free_time=FreeTime(1.0))
    r = Planner(sc, time_limit=1e-3).plan()
    assert [s.source for s in r.free_time.steps] == ["plan"]
    assert "cut the search short" in r.message
    assert r.trajectory is not None
    full = plan(sc)
    assert len(full.free_time.steps) > 1 and "cut the search short" not in full.message


def test_the_wall_time_of_a_free_time_answer_is_the_whole_search_s(monkeypatch):
    """Where the search starts is part of it (on a real map, the paths and their estimates
    at nine horizons took seconds that the answer's wall time left out)."""
    import time

    from leapfrog_planner.planning.fixed_horizons import FixedHorizons

    first_horizon = FixedHorizons.first_horizon

    def slow(self):
        time.sleep(0.5)
        return first_horizon(self)

    monkeypatch.setattr(FixedHorizons, "first_horizon", slow)
    t = time.perf_counter()
    r = plan(load_scenario_text(line()))
    assert 0.5 <= r.wall_time_s <= time.perf_counter() - t


def test_a_guess_starts_the_search_and_the_answer_does_not_depend_on_it():
    costs = []
    for guess in (0.5, 20.0):
        r = plan(load_scenario_text(line() + f"[time]\nguess = {guess}\n"))
        assert r.status is PlanStatus.CONVERGED and condition_met(r)
        costs.append(r.cost)
    assert costs[0] == pytest.approx(costs[1], rel=1e-9)


def test_a_free_time_result_and_scenario_round_trip(tmp_path):
    sc = load_scenario_text(line() + "[time]\nguess = 2.5\nbounds = [1, 10]\n")
    assert load_scenario_text(sc.to_toml()) == sc
    assert sc.free_time == FreeTime(0.5, 1.0, 2.5, (1.0, 10.0))
    r = plan(sc)
    path = tmp_path / "r.json"
    r.save_json(path)
    back = PlanResult.load(path)
    assert back.free_time == r.free_time and back.cost == r.cost
    # (the recorded scenario's [solver] table is the settings used: tests/test_rerun.py)
    task = dataclasses.replace(back.task, solver={})
    assert task == sc.__class__(**{**_fields(sc), "horizon": r.free_time.horizon})


def _fields(sc) -> dict:
    return {f.name: getattr(sc, f.name) for f in dataclasses.fields(sc)}


def test_the_same_input_gives_the_same_answer():
    a, b = (_free("paper-case-2", 1.0) for _ in range(2))
    assert a.cost == b.cost and a.free_time == b.free_time


@pytest.mark.parametrize(
    "text, needle",
    [
        (line(price="time_weight = 0"), "cost.time_weight: must be > 0"),
        (line(price="time_weight = -1"), "cost.time_weight: must be > 0"),
        (line(price="time_weight = nan"), "cost.time_weight"),
        (line(price="time_weight = 1e12"), "outside"),
        (line(price="cruise_speed = 0"), "cost.cruise_speed: must be > 0"),
        (
            line(price="cruise_speed = 1\ntime_weight = 1"),
            "cost: give time_weight or cruise_speed, not both",
        ),
        (line(price=""), "needs a price of time: time_weight or cruise_speed"),
        (line(price="speed = 1"), "speed"),
        (line() + "[time]\nbounds = [2, 1]\n", "shortest < longest"),
        (line() + "[time]\nbounds = [0, 1]\n", "time.bounds"),
        (line() + "[time]\nbounds = [1, 2]\nguess = 5\n", "outside the bounds"),
        (line() + "[time]\nbest = 5\n", "time"),
        (
            line().replace('horizon = "free"', "horizon = 2"),
            'cost: a price of time needs horizon = "free"',
        ),
        (
            "horizon = 2\nstart = [0, 0, 0]\ngoal = [3, 0, 0]\n[time]\nguess = 1\n",
            'time: a guess or bounds of T needs horizon = "free"',
        ),
        (
            line().replace('horizon = "free"', 'horizon = "Free"'),
            """horizon: expected seconds or "free", got 'Free'""",
        ),
    ],
)
def test_bad_free_time_input_is_one_line(text, needle):
    with pytest.raises(ScenarioError) as e:
        load_scenario_text(text, "f.toml")
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_a_goal_out_of_reach_within_the_longest_t_is_refused_at_once():
    """Speed at most 1 m/s, 10 m to go, at most 2 s: no T allowed reaches the goal."""
    text = line(extra="v = [-1.0, 1.0]").replace("goal = [3, 0, 0]", "goal = [10, 0, 0]")
    with pytest.raises(ScenarioError) as e:
        load_scenario_text(text + "[time]\nbounds = [0.5, 2.0]\n", "f.toml")
    assert "it takes at least 10 s, longer than the longest T allowed, 2" in str(e.value)


def test_a_fixed_horizon_too_short_for_the_bounded_speed_is_refused_before_planning():
    """2 m to go at most 1.5 m/s in T = 1: one line, from the same check as the free time's,
    before anything is planned (it used to plan for seconds and fail)."""
    text = "horizon = 1.0\nstart = [0, 0, 0]\ngoal = [2, 0, 0]\n[robot]\nv = [-1.5, 1.5]\n"
    sc = load_scenario_text(text, "b.toml")  # a valid task description; no plan can meet it
    with pytest.raises(ScenarioError) as e:
        Planner(sc)
    assert str(e.value) == (
        "b.toml: horizon: the goal is 2 away and the speed at most 1.5: it takes at least"
        " 1.33333 s, longer than T = 1"
    )
    assert Planner(dataclasses.replace(sc, horizon=1.4)).scenario.horizon == 1.4
    free = load_scenario_text(text.replace("1.0", '"free"') + "[cost]\ncruise_speed = 1.0\n")
    assert Planner(free).scenario.free_time is not None  # its T is the planner's to choose


def test_the_wheels_of_a_differential_drive_bound_its_speed_as_v_bounds_the_unicycle_s():
    """Wheels of radius 0.1 at most 8 rad/s: at most 0.8 m/s straight ahead. 2 m in T = 2
    is out of reach, and so is a free T of at most 2 s: both refused in one line before
    anything is planned, as a bound on ``v`` is (the wheels were not counted: the fixed plan
    ran and failed). The first horizon a free search tries is no shorter than 2 m at 0.8 m/s."""
    wheels = 'model = "diff-drive"\nwheel_radius = 0.1\nomega_R = [-8, 8]\nomega_L = [-8, 8]\n'
    text = f"horizon = 2.0\nstart = [0, 0, 0]\ngoal = [2, 0, 0]\n[robot]\n{wheels}"
    with pytest.raises(ScenarioError) as e:
        Planner(load_scenario_text(text, "dd.toml"))
    assert str(e.value) == (
        "dd.toml: horizon: the goal is 2 away and the speed at most 0.8: it takes at least"
        " 2.5 s, longer than T = 2"
    )
    free = text.replace("2.0", '"free"', 1) + "[cost]\ncruise_speed = 0.5\n"
    with pytest.raises(ScenarioError, match="it takes at least 2.5 s, longer than the longest"):
        load_scenario_text(free + "[time]\nbounds = [0.5, 2.0]\n", "dd.toml")
    from leapfrog_planner.planning.free_time import least_time

    assert least_time(load_scenario_text(free), 2.0) == pytest.approx(2.5)


def test_a_model_s_cruise_is_derived_once_per_parameters():
    """The cruise (SymPy, milliseconds) is remembered per model and parameter values: every
    bounded plan asks for its top speed before it starts."""
    from leapfrog_planner.model.cruise import _cruise, cruise

    dd = get_model("diff-drive")
    first = cruise(dd, {"wheel_radius": 0.1})
    misses = _cruise.cache_info().misses
    assert cruise(get_model("diff-drive"), {"wheel_radius": 0.1}) is first
    assert _cruise.cache_info().misses == misses
    assert cruise(dd, {"wheel_radius": 0.2}).effort == pytest.approx(25.0)  # 1 / r^2
    assert first.effort == pytest.approx(100.0)


def test_the_top_straight_speed_of_bounded_controls():
    from leapfrog_planner.model.cruise import top_straight_speed

    uni, dd = get_model("unicycle"), get_model("diff-drive")
    assert top_straight_speed(uni, {}, {"v": (0.0, 0.8)}) == pytest.approx(0.8)
    assert top_straight_speed(uni, {}, {"v": (-1.5, 0.5)}) == pytest.approx(1.5)  # in reverse
    assert top_straight_speed(uni, {}, {"omega": (-1.0, 1.0)}) is None  # speed unbounded
    wheels = {"omega_R": (-8.0, 8.0), "omega_L": (-8.0, 4.0)}  # both wheels at v / r
    assert top_straight_speed(dd, {"wheel_radius": 0.1}, wheels) == pytest.approx(0.8)
    wheels["omega_R"] = (-2.0, 8.0)
    assert top_straight_speed(dd, {"wheel_radius": 0.1}, wheels) == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("robot", "price", "needle"),
    [
        ("v = [0.0, 1.0]", "cruise_speed = 1.0", "a cruise speed of 1 is at or above the top"),
        ("v = [0.0, 0.8]", "cruise_speed = 1.5", "above the top speed 0.8 the control bounds"),
        ("v = [0.0, 0.8]", "time_weight = 0.5", "a price of time of 0.5 per second (a cruise"),
        ('model = "diff-drive"\nwheel_radius = 0.1\nomega_R = [-8.0, 8.0]', "cruise_speed = 1",
         "above the top speed 0.8"),
    ],
)  # fmt: skip
def test_a_price_of_time_that_asks_for_the_top_speed_or_more_is_refused_at_once(
    robot, price, needle
):
    """Where the price of time asks the robot to cruise at or above the top speed its bounds
    allow, the optimum drives at that top speed, on the bounds, where no T meets the free-time
    condition: the planner refuses it in one line, at once (it searched for minutes and
    failed, or converged on a dearer route that does not reach the bounds: 5.54 against
    IPOPT's 4.29 on a layout of one disc); the scenario itself is a valid description."""
    text = f'horizon = "free"\nstart = [0, 0, 0]\ngoal = [2, 0, 0]\n[robot]\n{robot}\n'
    sc = load_scenario_text(f"{text}[cost]\n{price}\n", "fast.toml")
    with pytest.raises(ScenarioError) as e:
        Planner(sc)
    message = str(e.value)
    assert needle in message and message.startswith("fast.toml: cost.") and "\n" not in message
    assert "ask for a cruise speed below" in message


def test_a_cruise_just_below_the_top_speed_meets_the_closed_form():
    """2 m in free space, speed at most 1, cruise 0.95: T = 2 / 0.95 and J = 2 * 0.95 (the
    time term included), with the speed inside its bound all along."""
    text = 'horizon = "free"\nstart = [0, 0, 0]\ngoal = [2, 0, 0]\n[robot]\nv = [0.0, 1.0]\n'
    r = plan(load_scenario_text(text + "[cost]\ncruise_speed = 0.95\n"))
    assert r.status is PlanStatus.CONVERGED and condition_met(r)
    assert r.free_time.horizon == pytest.approx(2 / 0.95, rel=1e-6)
    assert r.cost == pytest.approx(2 * 0.95, rel=1e-6)
    assert np.all(r.trajectory.u[:, 0] <= 1.0 + 1e-9)


def test_the_command_line_plans_a_free_time_and_refuses_bad_input(tmp_path):
    from tests.test_cli import run_cli

    ok = run_cli(["solve", "paper-case-1", "--horizon", "free", "--cruise-speed", "1"], tmp_path)
    assert ok.returncode == 0, ok.stderr
    # free space: T and J scale as 1/sqrt(k) and sqrt(k) from k = 1 (3.212974, 6.425948)
    assert "final time" in ok.stdout and "T = 4.5438" in ok.stdout, ok.stdout
    for args, needle in [
        (["--cruise-speed", "1"], "--horizon free"),
        (["--horizon", "soon"], "expected seconds or free"),
        (["--horizon", "free"], "error: --horizon free needs a price of time: add --cruise"),
        (["--horizon", "-1"], "--horizon: must be > 0, got -1"),
        (["--horizon", "free", "--time-weight", "-1"], "--time-weight"),
        (["--horizon", "free", "--time-weight", "1", "--cruise-speed", "1"], "not both"),
    ]:
        bad = run_cli(["solve", "paper-case-1", *args], tmp_path)
        assert bad.returncode == 2, (args, bad.stderr)
        assert needle in bad.stderr and "Traceback" not in bad.stderr
        assert "\n" not in bad.stderr.strip()


def test_the_terminal_s_progress_bar_follows_a_plan(monkeypatch):
    """On a terminal, ``solve`` shows a progress bar fed by the planner's events (setting the
    planner's progress callback raised AttributeError once)."""
    import io

    from rich.console import Console

    from leapfrog_planner.cli import solve as cli_solve
    from leapfrog_planner.planning.planner import Planner

    terminal = Console(file=io.StringIO(), force_terminal=True, width=100)
    monkeypatch.setattr(cli_solve, "err", terminal)
    planner = Planner(dataclasses.replace(load_scenario("paper-case-1"), free_time=FreeTime(1.0)))
    r = cli_solve._plan_with_progress(planner)
    assert r.status is PlanStatus.CONVERGED
    assert "paper-case-1" in terminal.file.getvalue()  # the bar was drawn


def test_an_extremal_that_misses_the_free_time_condition_is_not_called_an_extremal():
    """Failed for want of ``k + H = 0``: the motion returned is the fixed horizon's extremal,
    and its source says so and that it is not optimal (it said "extremal", as an answer's)."""
    from leapfrog_planner.planning.free_time import _reported

    free = load_scenario_text(line())
    fixed = plan(dataclasses.replace(free, horizon=1.0, free_time=None))
    assert fixed.status is PlanStatus.CONVERGED and fixed.trajectory_source == "extremal"
    r = _reported(fixed, [], free, 0.0, False)  # the free optimum is at T = 3
    assert r.status is PlanStatus.FAILED and not r.optimal
    assert r.trajectory_source == "extremal of the fixed horizon T = 1, not optimal"
