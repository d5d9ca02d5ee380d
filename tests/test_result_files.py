"""Result files stand alone: saved with their scenario and settings, loaded back field for field,
drawn and exported with nothing else; the trajectory at any time and on a uniform grid."""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from dataclasses import fields, replace

import numpy as np
import pytest
from tests.test_cli import cli_env

from leapfrog_planner.planning.export import ExportError, motion_columns, ros_path, write_csv
from leapfrog_planner.planning.planner import plan
from leapfrog_planner.planning.result_files import ResultFileError
from leapfrog_planner.planning.results import PlanResult
from leapfrog_planner.planning.scenario import load_scenario
from leapfrog_planner.planning.settings import PlannerSettings


@pytest.fixture(scope="module")
def case4():
    return plan("paper-case-4", threads=1)


@pytest.fixture(scope="module")
def saved(case4, tmp_path_factory):
    folder = tmp_path_factory.mktemp("results")
    case4.save_json(folder / "r.json")
    case4.save_npz(folder / "r.npz")
    return folder


def _same(a, b):
    if isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
    elif isinstance(a, tuple) and a and isinstance(a[0], np.ndarray):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)
    elif isinstance(a, float) and math.isnan(a):
        assert math.isnan(b)
    else:
        assert a == b


@pytest.mark.parametrize("name", ["r.json", "r.npz"])
def test_a_saved_result_loads_back_field_for_field(case4, saved, name):
    r = PlanResult.load(saved / name)
    for f in fields(PlanResult):
        a, b = getattr(case4, f.name), getattr(r, f.name)
        if f.name == "trajectory":
            for g in ("t", "x", "u", "lam", "cost", "hamiltonian"):
                np.testing.assert_array_equal(getattr(a, g), getattr(b, g))
        elif f.name == "history":
            assert len(a) == len(b)
            for h, k in zip(a, b, strict=True):
                assert (h.q, h.cost, h.f_evals) == (k.q, k.cost, k.f_evals)
                np.testing.assert_array_equal(h.X, k.X)
        elif f.name == "alternatives":
            assert [x.label for x in a] == [x.label for x in b]
            for x, y in zip(a, b, strict=True):
                assert x.cost == y.cost and x.status == y.status
                np.testing.assert_array_equal(x.trajectory.x, y.trajectory.x)
        else:
            _same(a, b)
    # The scenario planned, its [solver] table written from the settings used (one truth).
    assert replace(r.task, solver={}) == load_scenario("paper-case-4")
    assert r.task.solver == PlannerSettings.from_dict(r.settings).solver_table()
    assert r.settings["leapfrog"]["method"] == "modified-newton"


def test_a_json_result_is_indented_with_each_column_on_one_line(case4, saved):
    lines = (saved / "r.json").read_text(encoding="utf-8").splitlines()
    assert lines[1] == ' "schema": 3,'  # the tables indented, one key to a line
    answer = lines[lines.index(' "trajectory": {') :]
    row = next(line for line in answer if line.startswith('  "t": ['))
    column = json.loads(row.split(": ", 1)[1].rstrip(","))
    assert column == case4.trajectory.t.tolist()  # every time of the answer, on one line


def test_the_other_optima_are_kept_as_trajectories(case4):
    assert case4.alternatives
    for alt in case4.alternatives:
        if math.isfinite(alt.cost):
            assert alt.trajectory is not None
            assert alt.trajectory.x[-1] == pytest.approx(case4.task.goal, abs=1e-6)


def test_the_trajectory_at_any_time_matches_a_denser_solve(case4):
    """PCHIP through 1001 rows against the same extremal sampled at 4001 rows."""
    dense = plan("paper-case-4", threads=1, samples=4001)
    t = dense.trajectory.t
    mid = t[1:-1:7]
    got = case4.at(mid)
    for i, name in enumerate(case4.state_names):
        np.testing.assert_allclose(got[name], dense.trajectory.x[1:-1:7, i], rtol=0, atol=1e-8)
    at_rows = case4.at(case4.trajectory.t[::50])
    np.testing.assert_array_equal(at_rows["x"], case4.trajectory.x[::50, 0])
    with pytest.raises(ExportError, match="times must lie in"):
        case4.at(1.5)


def test_resampling_is_uniform_and_ends_at_the_horizon(case4):
    cols = case4.resample(0.03)
    t = cols["t"]
    assert t[0] == 0.0 and t[-1] == 1.0
    assert np.allclose(np.diff(t[:-1]), 0.03)
    assert set(cols) >= {"x", "y", "theta", "v", "omega"}
    for bad in (0.0, -1.0, 2.0, float("nan")):
        with pytest.raises(ExportError):
            case4.resample(bad)


def test_the_csv_writes_each_number_shortest_and_exact(case4, tmp_path):
    """``0.03``, not ``0.029999999999999999``: the shortest text that reads back bit for bit."""
    write_csv(case4, tmp_path / "r.csv", 0.03)
    header, *rows = (tmp_path / "r.csv").read_text().splitlines()
    cols = motion_columns(case4, 0.03)  # the resampled columns and the body velocities
    assert header.split(",") == ["t", "x", "y", "theta", "v", "omega", "linear_x", "angular_z"]
    assert rows[1].split(",")[0] == "0.03" and len(rows) == len(cols["t"])
    for i, row in enumerate(rows):
        for name, cell in zip(header.split(","), row.split(","), strict=True):
            assert cell == repr(float(cell)) and float(cell) == cols[name][i]


def test_a_ros_path_has_unit_quaternions_and_stamps_from_the_start(case4):
    msg = ros_path(case4, 0.25, "odom")
    assert msg["header"]["frame_id"] == "odom" and len(msg["poses"]) == 5
    for k, pose in enumerate(msg["poses"]):
        stamp = pose["header"]["stamp"]
        assert stamp["sec"] + stamp["nanosec"] * 1e-9 == pytest.approx(0.25 * k)
        q = pose["pose"]["orientation"]
        assert q["z"] ** 2 + q["w"] ** 2 == pytest.approx(1.0)
    last = msg["poses"][-1]["pose"]
    assert last["position"]["x"] == pytest.approx(2.0, abs=1e-8)


def _cli(args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", *args],
        cwd=cwd,
        env=cli_env(),
        capture_output=True,
        encoding="utf-8",
        timeout=300,
    )


def test_a_result_file_alone_gives_its_figures_and_exports(saved, tmp_path):
    """In a folder holding only the JSON file: plot and export need nothing else. Only the
    figures asked for are written: the path figure by default, not beside other figures."""
    (tmp_path / "r.json").write_bytes((saved / "r.json").read_bytes())
    p = _cli(["plot", "r.json", "--controls", "c.png", "--animate", "a.gif"], tmp_path)
    assert p.returncode == 0, p.stderr
    for name in ("c.png", "a.gif"):
        assert (tmp_path / name).stat().st_size > 1000
    assert not (tmp_path / "r.png").exists()
    p = _cli(["plot", "r.json"], tmp_path)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "r.png").stat().st_size > 1000
    p = _cli(
        ["export", "r.json", "--csv", "r.csv", "--ros-path", "r.yaml", "--dt", "0.1"], tmp_path
    )
    assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader((tmp_path / "r.csv").open()))
    assert list(rows[0]) == [*"t x y theta v omega".split(), "linear_x", "angular_z"]
    assert len(rows) == 11
    assert float(rows[-1]["x"]) == pytest.approx(2.0, abs=1e-8)
    yaml = pytest.importorskip("yaml")
    msg = yaml.safe_load((tmp_path / "r.yaml").read_text())
    assert msg == json.loads(json.dumps(ros_path(PlanResult.load(tmp_path / "r.json"), 0.1)))


@pytest.mark.parametrize(
    "content, says",
    [
        ('{"schema": 2, "status": "conv', "not a leapfrog result file"),
        ('{"schema": 99, "status": "converged"}', "schema 99"),
        ('{"schema": 1, "status": "converged"}', "damaged result file"),
        ('{"schema": 2, "status": "converged"}', "damaged result file"),
        ("[1, 2]", "not a leapfrog result file"),
        (b"PK\x03\x04garbage", "not a leapfrog result file"),
    ],
)
def test_a_bad_result_file_is_one_line_and_exit_2(tmp_path, content, says):
    path = tmp_path / "bad.json"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(ResultFileError, match=says):
        PlanResult.load(path)
    p = _cli(["export", "bad.json", "--csv", "x.csv"], tmp_path)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert says in p.stderr and not (tmp_path / "x.csv").exists()


def _damage(d: dict, how: str) -> str:
    """The text of the result ``d`` damaged one way (what a broken disk, a hand edit or another
    tool may leave)."""
    tr = d["trajectory"]
    edits = {
        "history [1]": lambda: d.update(history=[1]),
        "history a string": lambda: d.update(history="abc"),
        "null in the trajectory": lambda: tr["x"].__setitem__(3, None),
        "time reversed": lambda: tr.update(t=tr["t"][::-1]),
        "no cost": lambda: d.update(cost=None),
        "settings null": lambda: d.update(settings=None),
        "a count of 400 digits": lambda: d.update(newton_iterations=10**400),
        "a negative count": lambda: d.update(f_evals=-1),
        "one row": lambda: d.update(trajectory={k: v[:1] for k, v in tr.items()}),
        "nested columns": lambda: tr.update(x=[[1.0, 2.0]] * len(tr["t"])),
        "names a number": lambda: d.update(state_names=3),
        "a junction null": lambda: d["history"][0]["junction_X"][1].__setitem__(0, None),
    }
    edits[how]()
    return json.dumps(d)


@pytest.mark.parametrize(
    "how",
    ["history [1]", "history a string", "null in the trajectory", "time reversed", "no cost",
     "settings null", "a count of 400 digits", "a negative count", "one row", "nested columns",
     "names a number", "a junction null", "inf in t", "nested 100000 deep"],
)  # fmt: skip
def test_a_damaged_result_file_is_refused_not_drawn(saved, tmp_path, how):
    """The tool's own files, read back damaged: one line, exit 2, nothing drawn or written."""
    text = (saved / "r.json").read_text()
    if how == "inf in t":
        text = text.replace('"t": [0.0', '"t": [1e999', 1)
        assert "1e999" in text
    elif how == "nested 100000 deep":
        text = "[" * 100_000 + "]" * 100_000
    else:
        text = _damage(json.loads(text), how)
    (tmp_path / "bad.json").write_text(text)
    with pytest.raises(ResultFileError, match="bad.json: (damaged|not a leapfrog)"):
        PlanResult.load(tmp_path / "bad.json")
    if how not in ("history [1]", "inf in t", "nested columns"):
        return  # the command line reads files by PlanResult.load: three cases show it
    for args in (["plot", "bad.json", "--out", "x.png"], ["export", "bad.json", "--csv", "x.csv"]):
        p = _cli(args, tmp_path)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.csv").exists()


def test_repr_is_short_and_the_notebook_view_shows_table_and_path(case4):
    text = repr(case4)
    assert len(text) < 200 and "converged" in text and "4.5852479" in text
    page = case4._repr_html_()
    assert "<table>" in page and "<svg" in page and "<polyline" in page
    assert page.count("<circle") == case4.task.obstacles.shape[0]


@pytest.mark.parametrize(
    "how, says",
    [
        ("no x", "trajectory has no column x"),
        ("x short", "trajectory columns of different lengths: t has {n} rows, x has 10"),
        ("x words", "trajectory.x[0]: expected number or null, got a string"),
        ("no timing", "key 'timing' missing"),
    ],
)
def test_a_damaged_trajectory_is_said_in_words(saved, tmp_path, how, says):
    """What is wrong, in words: not NumPy's internals ("all the input array dimensions except
    for the concatenation axis must match exactly...") nor a bare "KeyError: 'x'"."""
    d = json.loads((saved / "r.json").read_text())
    tr = d["trajectory"]
    {
        "no x": lambda: tr.pop("x"),
        "x short": lambda: tr.update(x=tr["x"][:10]),
        "x words": lambda: tr.update(x=["a"] * len(tr["t"])),
        "no timing": lambda: d.pop("timing"),
    }[how]()
    (tmp_path / "bad.json").write_text(json.dumps(d))
    p = _cli(["plot", "bad.json", "--out", "x.png"], tmp_path)
    assert p.returncode == 2 and not (tmp_path / "x.png").exists()
    expected = f"damaged result file ({says.format(n=len(tr['t']))})"
    assert p.stderr.strip().splitlines()[-1] == f"error: bad.json: {expected}", p.stderr
