"""Tests of scenario files: the built-in paper cases, validation messages and round trips."""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
import textwrap

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from conftest import CASES
from leapfrog_planner import checks
from leapfrog_planner.errors import ScenarioError, SettingsError, require_integer
from leapfrog_planner.integrate.problem import OptimalControlProblem
from leapfrog_planner.planning.scenario import (
    SOLVER_KEYS,
    Scenario,
    builtin_scenarios,
    load_scenario,
    load_scenario_text,
    scenario_from_dict,
)

PI = math.pi

# Spec section 5, typed in independently of the TOML files.
# The paper's cases, transcribed once from the spec in conftest.
PAPER_CASES = {c.name: (c.start, c.goal, c.obstacles) for c in CASES.values()}

BASE = """\
horizon = 1.0
start = [0.0, 0.0, 0.0]
goal = [2.0, 0.0, 0.0]
"""

OBSTACLE = """
[[obstacles]]
center = [1.0, 0.0]
radius = 0.5
"""

FULL = """\
name = "everything"
horizon = 2.5
start = [0, 0, 0]
goal = [4, 1, -1.5707963267948966]
waypoints = [[1.0, 1.0], [3, -1]]

[robot]
model = "diff-drive"
wheel_radius = 0.5
axle_length = 1.25

[penalty]
weight = 50
exponent = 3

[solver]
method = "mnm"
partitions = 8
initial_paths = 3
reduce_tol = 1e-9
max_sweeps = 40

[[obstacles]]
center = [2.0, 0.0]
radius = 0.5

[[obstacles]]
center = [2.0, 2.0]
radius = 0.25
"""


# --------------------------------------------------------------------------- built-ins


def test_builtin_names():
    assert builtin_scenarios() == list(PAPER_CASES)


@pytest.mark.parametrize("name", list(PAPER_CASES))
def test_builtin_values_match_spec(name):
    start, goal, obstacles = PAPER_CASES[name]
    s = load_scenario(name)
    assert s.name == name
    assert s.source == f"builtin:{name}"
    assert s.horizon == 1.0
    assert s.weight == 100.0
    assert s.exponent == 2
    assert s.model == "unicycle"
    assert s.model_parameters == {}
    assert s.waypoints is None
    assert s.solver == {}
    # Exact equality: headings are written with full double precision.
    np.testing.assert_array_equal(s.start, start)
    np.testing.assert_array_equal(s.goal, goal)
    assert s.obstacles.shape == (len(obstacles), 3)
    np.testing.assert_array_equal(s.obstacles, np.reshape(obstacles, (-1, 3)))


def test_arrays_are_read_only():
    s = load_scenario_text(FULL)
    copies = (s, pickle.loads(pickle.dumps(s)), copy.deepcopy(s))
    assert all(c == s for c in copies)
    for arr in (a for c in copies for a in (c.start, c.goal, c.obstacles, c.waypoints)):
        with pytest.raises(ValueError):
            arr[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.horizon = 2.0


# --------------------------------------------------------------------------- defaults


def test_minimal_file_gets_defaults():
    s = load_scenario_text(BASE)
    assert s.name == "scenario"
    assert s.source == "<string>"
    assert s.horizon == 1.0 and isinstance(s.horizon, float)
    assert s.model == "unicycle"
    assert s.model_parameters == {}
    assert s.weight == 100.0
    assert s.exponent == 2
    assert s.obstacles.shape == (0, 3)
    assert s.waypoints is None
    assert s.solver == {}


def test_integers_accepted_as_numbers():
    s = load_scenario_text("horizon = 2\nstart = [0, 0, 0]\ngoal = [1, 2, 3]\n")
    assert s.horizon == 2.0 and isinstance(s.horizon, float)
    assert s.goal.dtype == np.float64
    np.testing.assert_array_equal(s.goal, [1.0, 2.0, 3.0])


def test_default_name_from_file(tmp_path):
    path = tmp_path / "my-room.toml"
    path.write_text(BASE)
    s = load_scenario(path)
    assert s.name == "my-room"
    assert s.source == str(path)
    assert load_scenario(str(path)) == s


def test_diff_drive_defaults_filled_in():
    s = load_scenario_text(BASE + '[robot]\nmodel = "diff-drive"\nwheel_radius = 0.5\n')
    assert s.model_parameters == {"wheel_radius": 0.5, "axle_length": 2.0}


# --------------------------------------------------------------------------- problem


def robot_parameters(problem) -> tuple[float, ...]:
    return tuple(problem.parameter(n) for n in problem.model.robot_parameters)


def test_problem_diff_drive():
    s = load_scenario_text(FULL)
    p = s.problem()
    assert isinstance(p, OptimalControlProblem)
    assert p.model.name == "diff-drive"
    assert robot_parameters(p) == (0.5, 1.25)
    assert p.penalty.weight == 50.0
    assert p.penalty.exponent == 3
    np.testing.assert_array_equal(p.obstacles, [[2.0, 0.0, 0.5], [2.0, 2.0, 0.25]])


def test_problem_paper_case():
    s = load_scenario("paper-case-4")
    p = s.problem()
    assert p.model.name == "unicycle"
    assert robot_parameters(p) == ()
    assert p.penalty.weight == 100.0 and p.penalty.exponent == 2
    np.testing.assert_array_equal(p.obstacles, s.obstacles)
    # Penalty is W at an obstacle centre.
    assert p.penalty(s.obstacles[0, :2]) == pytest.approx(100.0, rel=1e-3)


def test_problem_wheel_radius_only():
    s = load_scenario_text(BASE + '[robot]\nmodel = "diff-drive"\nwheel_radius = 0.5\n')
    assert robot_parameters(s.problem()) == (0.5, 2.0)


def test_problem_bounds_are_parameters_of_the_same_kernels():
    s = load_scenario_text(BASE + '[robot]\nmodel = "diff-drive"\nwheel_radius = 0.5\n')
    bounded = dataclasses.replace(s, control_bounds={"omega_L": (-2.0, 3.0)})
    free, p = s.problem(), bounded.problem()
    assert p.model.kernels is free.model.kernels  # one kernel set: bounds compile nothing
    assert robot_parameters(p) == robot_parameters(free) == (0.5, 2.0)
    on = {n: p.parameter(n) for n in ("omega_L_min", "omega_L_max", "omega_L_bounded")}
    assert on == {"omega_L_min": -2.0, "omega_L_max": 3.0, "omega_L_bounded": 1.0}
    assert p.parameter("omega_R_bounded") == free.parameter("omega_L_bounded") == 0.0


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("name", list(PAPER_CASES))
def test_builtin_round_trip(name):
    s = load_scenario(name)
    assert load_scenario_text(s.to_toml()) == s
    assert scenario_from_dict(s.to_dict()) == s


def test_full_round_trip():
    s = load_scenario_text(FULL)
    assert s.waypoints.shape == (2, 2)
    assert s.solver == {
        "method": "mnm",
        "partitions": 8,
        "initial_paths": 3,
        "reduce_tol": 1e-9,
        "max_sweeps": 40,
    }
    text = s.to_toml()
    assert "# -pi/2" in text
    back = load_scenario_text(text)
    assert back == s
    np.testing.assert_array_equal(back.waypoints, s.waypoints)
    assert back.solver == s.solver
    assert type(back.solver["reduce_tol"]) is float
    assert scenario_from_dict(s.to_dict()) == s


def test_equality_is_not_vacuous():
    s = load_scenario_text(FULL)
    assert s != dataclasses.replace(s, goal=[4.0, 1.0, 0.0])
    assert s != dataclasses.replace(s, solver={})
    assert s != dataclasses.replace(s, model_parameters={"wheel_radius": 0.5})
    assert s == dataclasses.replace(s, source="elsewhere")  # source is not compared


def test_direct_construction_validates():
    s = Scenario("direct", 1, [0, 0, 0], [1, 0, 0], obstacles=[[0.5, 1.0, 0.2]])
    assert s.obstacles.shape == (1, 3)
    with pytest.raises(ScenarioError, match=r"^<scenario>: horizon: must be > 0"):
        dataclasses.replace(s, horizon=0.0)
    with pytest.raises(ScenarioError, match=r"start: .* inside obstacles\[0\]"):
        dataclasses.replace(s, start=[0.5, 1.0, 0.0])


def test_tricky_name_round_trip():
    name = 'a "quoted" \\ name [/] [link=x] with ünïcödé 🚗'
    s = Scenario(name, 1.0, [0, 0, 0], [1, 0, 0])
    assert load_scenario_text(s.to_toml()).name == name


@pytest.mark.parametrize("bad", ["tab\there", "new\nline", "esc\x1b[2J", "del\x7f", "\x01"])
def test_a_name_with_control_characters_is_refused(bad):
    """A name reaches terminals, file names and plots: no escape sequences or line breaks."""
    with pytest.raises(ScenarioError, match="name: control characters are not allowed"):
        Scenario(bad, 1.0, [0, 0, 0], [1, 0, 0])


# Anything within the documented bounds (checks.py) round-trips.
finite = st.floats(-checks.COORDINATE_MAX, checks.COORDINATE_MAX)
heading = st.floats(-checks.HEADING_MAX, checks.HEADING_MAX)
positive = st.floats(*checks.PARAMETER_RANGE)
point = st.tuples(finite, finite)


def _inside(p, obstacles):
    return any(math.hypot(p[0] - cx, p[1] - cy) < r for cx, cy, r in obstacles)


@st.composite
def scenarios(draw):
    obstacles = draw(
        st.lists(st.tuples(finite, finite, st.floats(checks.RADIUS_RANGE[0], 10.0)), max_size=4),
    )
    start = draw(st.tuples(finite, finite, heading))
    goal = draw(st.tuples(finite, finite, heading))
    waypoints = draw(st.none() | st.lists(point, min_size=1, max_size=3))
    for p in [start, goal, *(waypoints or [])]:
        assume(not _inside(p, obstacles))
    model = draw(st.sampled_from(["unicycle", "diff-drive"]))
    params = {}
    if model == "diff-drive":
        params = draw(st.dictionaries(st.sampled_from(["wheel_radius", "axle_length"]), positive))
    values = {
        str: st.text(st.characters(blacklist_categories=("Cs",)), max_size=10),
        int: st.integers(-(2**63), 2**63 - 1),
        float: finite,
    }
    solver = draw(
        st.fixed_dictionaries({}, optional={k: values[t] for k, t in SOLVER_KEYS.items()})
    )
    return Scenario(
        name=draw(
            st.text(st.characters(blacklist_categories=("Cs", "Cc")), min_size=1, max_size=20)
        ),
        horizon=draw(st.floats(*checks.HORIZON_RANGE)),
        start=start,
        goal=goal,
        obstacles=obstacles,
        model=model,
        model_parameters=params,
        weight=draw(st.floats(0.0, checks.WEIGHT_MAX)),
        exponent=draw(st.integers(1, checks.EXPONENT_MAX)),
        waypoints=waypoints,
        solver=solver,
    )


@settings(max_examples=150, deadline=None)
@given(scenarios())
def test_random_scenarios_round_trip(s):
    assert load_scenario_text(s.to_toml()) == s
    assert scenario_from_dict(s.to_dict()) == s


# --------------------------------------------------------------------------- bad input

ROBOT_DD = '[robot]\nmodel = "diff-drive"\n'

# (id, file text, substrings the message must contain)
BAD = [
    ("syntax", BASE + "oops = [1, 2\n", ["<string>: invalid TOML", "end of document, line 4"]),
    ("syntax-mid", "horizon = 1\nstart = [0, 0 0]\n" + BASE, ["invalid TOML", "line 2"]),
    ("syntax-bare-word", BASE + "name = hello\n", ["invalid TOML", "line 4"]),
    ("missing-horizon", "start = [0, 0, 0]\ngoal = [1, 0, 0]\n", ["horizon: missing"]),
    ("missing-start", "horizon = 1\ngoal = [1, 0, 0]\n", ["start: missing"]),
    ("missing-goal", "horizon = 1\nstart = [1, 0, 0]\n", ["goal: missing"]),
    ("missing-center", BASE + "[[obstacles]]\nradius = 1.0\n", ["obstacles[0].center: missing"]),
    ("missing-radius", BASE + "[[obstacles]]\ncenter = [5, 5]\n", ["obstacles[0].radius: missing"]),
    ("horizon-string", BASE.replace("1.0", '"1.0"'), ["horizon: expected seconds or", "'1.0'"]),
    ("horizon-bool", BASE.replace("1.0", "true"), ["horizon: expected a number", "boolean true"]),
    ("start-string", BASE.replace("start = [0.0,", 'start = ["0",'), ["start[0]: expected a num"]),
    ("start-bool", BASE.replace("start = [0.0,", "start = [false,"), ["start[0]", "boolean false"]),
    ("start-scalar", BASE.replace("start = [0.0, 0.0, 0.0]", "start = 0"), ["start: expected an"]),
    (
        "start-short",
        BASE.replace("[0.0, 0.0, 0.0]", "[0.0, 0.0]"),
        ["start: expected 3 numbers, got 2"],
    ),
    (
        "goal-long",
        BASE.replace("2.0, 0.0, 0.0]", "2.0, 0.0, 0.0, 1.0]"),
        ["goal: expected 3 numbers, got 4"],
    ),
    (
        "start-nan",
        BASE.replace("start = [0.0,", "start = [nan,"),
        ["start[0]: must be finite", "nan"],
    ),
    ("goal-inf", BASE.replace("goal = [2.0", "goal = [-inf"), ["goal[0]: must be finite", "-inf"]),
    ("horizon-inf", BASE.replace("1.0", "inf"), ["horizon: must be finite"]),
    ("horizon-zero", BASE.replace("1.0", "0"), ["horizon: must be > 0", "0.0"]),
    ("horizon-negative", BASE.replace("1.0", "-1.5"), ["horizon: must be > 0", "-1.5"]),
    ("radius-zero", BASE + OBSTACLE.replace("0.5", "0"), ["obstacles[0].radius: must be > 0"]),
    ("radius-negative", BASE + OBSTACLE.replace("0.5", "-0.1"), ["obstacles[0].radius", "-0.1"]),
    ("radius-nan", BASE + OBSTACLE.replace("0.5", "nan"), ["obstacles[0].radius: must be fin"]),
    ("radius-string", BASE + OBSTACLE.replace("0.5", '"big"'), ["obstacles[0].radius", "'big'"]),
    (
        "center-short",
        BASE + OBSTACLE.replace("[1.0, 0.0]", "[1.0]"),
        ["obstacles[0].center: expected 2 numbers", "got 1"],
    ),
    (
        "center-nan",
        BASE + OBSTACLE + OBSTACLE.replace("[1.0, 0.0]", "[1.0, nan]"),
        ["obstacles[1].center[1]: must be finite"],
    ),
    (
        "start-in-obstacle",
        BASE
        + OBSTACLE.replace("[1.0, 0.0]", "[5, 5]")
        + OBSTACLE.replace("[1.0, 0.0]", "[0.1, 0]"),
        ["start: (0.0, 0.0) is inside obstacles[1]", "radius 0.5"],
    ),
    (
        "goal-in-obstacle",
        BASE + OBSTACLE.replace("[1.0, 0.0]", "[2.2, 0.1]"),
        ["goal: (2.0, 0.0) is inside obstacles[0]"],
    ),
    (
        "waypoint-in-obstacle",
        BASE.replace("horizon", "waypoints = [[1, 3], [1, 0.2]]\nhorizon") + OBSTACLE,
        ["waypoints[1]: (1.0, 0.2) is inside obstacles[0]"],
    ),
    ("waypoint-short", "waypoints = [[1]]\n" + BASE, ["waypoints[0]: expected 2 numbers"]),
    ("waypoint-nan", "waypoints = [[1, nan]]\n" + BASE, ["waypoints[0][1]: must be finite"]),
    ("waypoints-scalar", "waypoints = 3\n" + BASE, ["waypoints: expected an array"]),
    ("unknown-model", BASE + '[robot]\nmodel = "tank"\n', ["robot.model: unknown model 'tank'"]),
    ("model-not-string", BASE + "[robot]\nmodel = 1\n", ["robot.model: expected a string"]),
    ("unknown-top-key", BASE + "obstacle = []\n", ["obstacle: unknown key", "'obstacles'"]),
    ("unknown-top-key-2", "T = 1\n" + BASE, ["T: unknown key"]),
    (
        "unknown-robot-param",
        BASE + "[robot]\nwheel_radius = 0.5\n",
        ["robot.wheel_radius: unknown key for model 'unicycle'"],
    ),
    (
        "unknown-dd-param",
        BASE + ROBOT_DD + "wheel_radios = 1\n",
        ["robot.wheel_radios", "'wheel_radius'"],
    ),
    ("dd-param-zero", BASE + ROBOT_DD + "axle_length = 0\n", ["robot.axle_length: must be > 0"]),
    (
        "dd-param-string",
        BASE + ROBOT_DD + 'wheel_radius = "1"\n',
        ["robot.wheel_radius: expected a"],
    ),
    ("unknown-penalty-key", BASE + "[penalty]\nweigth = 1\n", ["penalty.weigth: unknown key"]),
    (
        "unknown-obstacle-key",
        BASE + OBSTACLE + "centre = [0, 0]\n",
        ["obstacles[0].centre: unknown"],
    ),
    ("unknown-solver-key", BASE + "[solver]\nsweeps = 3\n", ["solver.sweeps: unknown key"]),
    (
        "exponent-float",
        BASE + "[penalty]\nexponent = 2.5\n",
        ["penalty.exponent: expected an integer"],
    ),
    ("exponent-2.0", BASE + "[penalty]\nexponent = 2.0\n", ["penalty.exponent", "number 2.0"]),
    ("exponent-string", BASE + '[penalty]\nexponent = "2"\n', ["penalty.exponent", "string '2'"]),
    ("exponent-bool", BASE + "[penalty]\nexponent = true\n", ["penalty.exponent", "boolean true"]),
    (
        "exponent-zero",
        BASE + "[penalty]\nexponent = 0\n",
        ["penalty.exponent: must be an integer >= 1"],
    ),
    ("weight-negative", BASE + "[penalty]\nweight = -1\n", ["penalty.weight: must be >= 0"]),
    ("weight-inf", BASE + "[penalty]\nweight = inf\n", ["penalty.weight: must be finite"]),
    ("weight-bool", BASE + "[penalty]\nweight = false\n", ["penalty.weight", "boolean false"]),
    (
        "solver-float-int",
        BASE + "[solver]\npartitions = 2.5\n",
        ["solver.partitions: expected an int"],
    ),
    ("solver-method-int", BASE + "[solver]\nmethod = 3\n", ["solver.method: expected a string"]),
    (
        "solver-tol-bool",
        BASE + "[solver]\nreduce_tol = true\n",
        ["solver.reduce_tol", "boolean true"],
    ),
    ("solver-not-table", "solver = 3\n" + BASE, ["solver: expected a table"]),
    ("robot-not-table", 'robot = "diff-drive"\n' + BASE, ["robot: expected a table"]),
    ("penalty-not-table", "penalty = 100\n" + BASE, ["penalty: expected a table"]),
    (
        "obstacles-single-table",
        BASE + "[obstacles]\ncenter = [5, 5]\nradius = 1\n",
        ["obstacles: expected an array of tables"],
    ),
    ("obstacles-rows", "obstacles = [[5, 5, 1]]\n" + BASE, ["obstacles[0]: expected a table"]),
    ("name-number", "name = 3\n" + BASE, ["name: expected a string"]),
    ("name-empty", 'name = ""\n' + BASE, ["name: expected a non-empty string"]),
]


@pytest.mark.parametrize(("text", "expected"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input(text, expected):
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(text)
    message = str(info.value)
    assert "\n" not in message and "\r" not in message
    assert message.startswith("<string>: ")
    for part in expected:
        assert part in message, message


def test_error_is_value_error_and_names_file(tmp_path):
    path = tmp_path / "paper.toml"
    path.write_text(BASE.replace("[0.0, 0.0, 0.0]", "[0.0, 0.0]"))
    with pytest.raises(ValueError, match=r"paper\.toml: start: expected 3 numbers, got 2$"):
        load_scenario(path)


def test_syntax_error_from_file_names_file_and_line(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("horizon = 1\nstart = [0, 0, 0\ngoal = [1, 0, 0]\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: invalid TOML")
    assert "line 3" in message and "\n" not in message


def test_non_utf8_file(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(BASE.encode() + 'name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"latin1\.toml: not UTF-8 text \(byte 0xe9"):
        load_scenario(path)


def test_utf8_bom_accepted(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + BASE.encode())
    assert load_scenario(path).horizon == 1.0


def test_directory_is_not_a_scenario(tmp_path):
    with pytest.raises(ScenarioError, match="is a directory") as info:
        load_scenario(tmp_path)
    assert "\n" not in str(info.value)


def test_unknown_name_lists_builtins():
    with pytest.raises(ScenarioError) as info:
        load_scenario("paper-case-9")
    message = str(info.value)
    assert "no scenario file or built-in named 'paper-case-9'" in message
    assert "paper-case-1, paper-case-2, paper-case-3, paper-case-4" in message
    assert "\n" not in message


def test_existing_file_wins_over_builtin(tmp_path, monkeypatch):
    (tmp_path / "paper-case-1").write_text(BASE)
    monkeypatch.chdir(tmp_path)
    s = load_scenario("paper-case-1")
    assert s.source == "paper-case-1"
    np.testing.assert_array_equal(s.goal, [2.0, 0.0, 0.0])


def test_a_result_file_given_as_a_scenario_says_so_and_how_to_reach_the_builtin(
    tmp_path, monkeypatch
):
    """`solve paper-case-4 --json paper-case-4` leaves a result file of the built-in's name."""
    (tmp_path / "paper-case-4").write_text('{"schema": 2, "status": "converged", "cost": 4.6}')
    (tmp_path / "r.json").write_text('{"schema": 2, "status": "converged", "cost": 4.6}')
    (tmp_path / "other.json").write_text('{"horizon": 1.0}')
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ScenarioError) as info:
        load_scenario("paper-case-4")
    assert str(info.value) == (
        "paper-case-4: a planning result (JSON), not a scenario (TOML); paper-case-4 is also a"
        " built-in scenario: builtin:paper-case-4 loads it"
    )
    assert info.value.__cause__ is None and info.value.__suppress_context__
    with pytest.raises(ScenarioError, match=r"^r\.json: a planning result \(JSON\), not a sce"):
        load_scenario("r.json")
    with pytest.raises(ScenarioError, match=r"^other\.json: JSON, not TOML"):
        load_scenario("other.json")
    builtin = load_scenario("builtin:paper-case-4")
    assert builtin.source == "builtin:paper-case-4" and builtin.name == "paper-case-4"
    monkeypatch.chdir(tmp_path.parent)
    assert builtin == load_scenario("paper-case-4")


@pytest.mark.parametrize(
    "content",
    [
        b"horizon = [",  # the TOML parser's error
        b"\xff\xfe",  # the decoder's
        b"horizon = 1.0\nstart = [0, 0, 0]\ngoal = [1, 0, 0]\n[robot]\nradius = -1\n",  # a check's
        BASE.encode() + b"\n[[obstacles]]\ncenter = [0.0, 0.0]\nradius = 0.1\n",
    ],
)
def test_a_scenario_error_shows_one_traceback_not_a_chain(tmp_path, content):
    import traceback

    from leapfrog_planner import plan

    (tmp_path / "s.toml").write_bytes(content)
    with pytest.raises(ScenarioError) as info:
        plan(tmp_path / "s.toml")
    e = info.value
    assert e.__cause__ is None and e.__suppress_context__
    assert "".join(traceback.format_exception(e)).count("Traceback") == 1


def test_bad_dict_input():
    with pytest.raises(ScenarioError, match=r"^<dict>: expected a table"):
        scenario_from_dict([1, 2, 3])
    data = load_scenario("paper-case-2").to_dict()
    data["obstacles"][1]["radius"] = -1.0
    with pytest.raises(ScenarioError, match=r"^x\.json: obstacles\[1\]\.radius: must be > 0"):
        scenario_from_dict(data, "x.json")


def test_multiline_text_in_message_stays_one_line():
    text = BASE + '[robot]\nmodel = "a\\nb"\n'
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(text, source="multi\nline")
    assert "\n" not in str(info.value)
    assert "robot.model" in str(info.value)


def test_toml_text_written_for_minimal_scenario():
    s = load_scenario_text(BASE)
    assert s.to_toml() == textwrap.dedent(
        """\
        name = "scenario"
        horizon = 1.0
        start = [0.0, 0.0, 0.0]
        goal = [2.0, 0.0, 0.0]

        [robot]
        model = "unicycle"

        [penalty]
        weight = 100.0
        exponent = 2
        """
    )


def test_one_integer_rule_for_every_count():
    """A count is an int or a NumPy integer (what TOML and JSON give for 3); 3.0, a boolean or
    a string is refused with a one-line message naming the key, as is a value out of range."""
    assert require_integer("n", 3) == 3 and type(require_integer("n", np.int64(3))) is int
    assert require_integer("n", 0, None) == 0
    for bad, said in [
        (3.0, "n: expected an integer >= 1, got number 3.0"),
        (True, "n: expected an integer >= 1, got boolean true"),
        (np.bool_(True), "n: expected an integer >= 1, got boolean true"),
        ("3", "n: expected an integer >= 1, got string '3'"),
        (None, "n: expected an integer >= 1, got nothing (None)"),
        (0, "n: must be an integer >= 1, got 0"),
        (10**40, "n: must be at most 9, got 1" + "0" * 26 + "..."),  # cut short
    ]:
        with pytest.raises(SettingsError) as info:
            require_integer("n", bad, 1, 9)
        assert str(info.value) == said
    with pytest.raises(ScenarioError, match="^k: "):
        require_integer("k", 2.0, error=ScenarioError)


def test_a_parameter_the_model_declares_nonnegative_is_refused_below_zero():
    """The car's ``turn_assist`` is declared nonnegative (0: the car itself): a negative one was
    accepted and planned until the time limit; 0 and positive values are the car's to plan."""
    car = "horizon = 2.0\nstart = [0.0, 0.0, 0.0, 0.0]\ngoal = [2.0, 0.0, 0.0, 0.0]\n"
    car += '[robot]\nmodel = "car"\n'
    with pytest.raises(ScenarioError, match=r"robot\.turn_assist: must be >= 0"):
        load_scenario_text(car + "turn_assist = -0.5\n")
    for value in ("0.0", "0.25"):
        sc = load_scenario_text(car + f"turn_assist = {value}\n")
        assert sc.model_parameters["turn_assist"] == float(value)
