"""The command-line interface, run as a real subprocess (``python -m leapfrog_planner.cli``).

Bad input of every kind must give exit code 2 and exactly one line on stderr naming the problem
(never a traceback); a solver failure gives exit code 1 and still writes its files. Each
invocation costs a Python start-up and the package import (~1.5 s), so the invocations of a
table are started together (a few at a time) in a module fixture and the tests read the
results.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from leapfrog_planner.errors import LeapfrogError
from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario import load_scenario

WORKERS = 4
TIMEOUT = 300


def cli_env() -> dict[str, str]:
    env = dict(os.environ)
    for k in ("FORCE_COLOR", "TTY_COMPATIBLE", "TTY_INTERACTIVE"):
        env.pop(k, None)
    # rich's width for a pipe: 80 columns, where the long messages below would wrap.
    env.update(COLUMNS="80", PYTHONIOENCODING="utf-8", NO_COLOR="1")
    return env


@dataclass(frozen=True)
class Run:
    returncode: int
    stdout: str
    stderr: str
    cwd: Path


def run_cli(args: list[str], cwd: Path) -> Run:
    p = subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", *args],
        cwd=cwd,
        env=cli_env(),
        capture_output=True,
        encoding="utf-8",
        timeout=TIMEOUT,
    )
    return Run(p.returncode, p.stdout, p.stderr, cwd)


def not_compile_notices(stderr: str) -> list[str]:
    """The lines of ``stderr`` other than the notices of compiling kernels."""
    return [x for x in stderr.splitlines() if not re.match(r"compil(ing|ed) the \S+ kernels", x)]


def run_all(jobs: dict[str, tuple[list[str], Path]]) -> dict[str, Run]:
    with ThreadPoolExecutor(WORKERS) as pool:
        futures = {k: pool.submit(run_cli, args, cwd) for k, (args, cwd) in jobs.items()}
        return {k: f.result() for k, f in futures.items()}


def test_module_runs_main():
    """``python -m leapfrog_planner.cli`` (used below) must call ``run``, as the script does."""
    import leapfrog_planner.cli as cli

    text = (Path(cli.__file__).parent / "__main__.py").read_text()
    assert re.search(r"^from \. import run\n\nrun\(\)$", text, re.M)
    (script,) = entry_points(group="console_scripts", name="leapfrog")
    assert script.value == "leapfrog_planner.cli:run"


# --------------------------------------------------------------------------- bad input

BASE = """horizon = 1.0
start = [0.0, 0.0, 0.0]
goal = [2.0, 0.0, 0.0]
"""
NO_HORIZON = BASE.replace("horizon = 1.0\n", "")
OBSTACLE = """
[[obstacles]]
center = [{cx}, {cy}]
radius = {r}
"""


@dataclass(frozen=True)
class Bad:
    id: str
    args: tuple[str, ...]  # "{file}" stands for the scenario file
    pattern: str  # searched in the single stderr line
    toml: str | None = None  # contents of the scenario file
    xfail: str | None = None
    created: tuple[str, ...] = ()  # paths that must not exist afterwards


SOLVE = ("solve", "{file}")
BAD = [
    Bad("toml-syntax", SOLVE, r"invalid TOML.*line 1", "horizon = \n" + NO_HORIZON),
    Bad("missing-key", SOLVE, r"horizon: missing required key", NO_HORIZON),
    Bad(
        "wrong-type",
        SOLVE,
        r"horizon: expected seconds or \"free\", got 'one'",
        'horizon = "one"\n' + NO_HORIZON,
    ),
    Bad(
        "wrong-type-array",
        SOLVE,
        r"start: expected an array of 3 numbers \[x, y, heading\], got string 'origin'",
        BASE.replace("[0.0, 0.0, 0.0]", '"origin"'),
    ),
    Bad(
        "wrong-length",
        SOLVE,
        r"start: expected 3 numbers, got 2",
        BASE.replace("[0.0, 0.0, 0.0]", "[0.0, 0.0]"),
    ),
    Bad("nan", SOLVE, r"horizon: must be finite, got nan", BASE.replace("1.0", "nan")),
    Bad(
        "inf",
        SOLVE,
        r"goal\[1\]: must be finite, got inf",
        BASE.replace("[2.0, 0.0, 0.0]", "[2.0, inf, 0.0]"),
    ),
    Bad("horizon-zero", SOLVE, r"horizon: must be > 0, got 0\.0", BASE.replace("1.0", "0.0")),
    Bad("horizon-negative", SOLVE, r"horizon: must be > 0", BASE.replace("1.0", "-1.0")),
    Bad(
        "radius-zero",
        SOLVE,
        r"obstacles\[0\]\.radius: must be > 0",
        BASE + OBSTACLE.format(cx=1.0, cy=0.5, r=0.0),
    ),
    Bad(
        "start-inside",
        SOLVE,
        r"start: \(0\.0, 0\.0\) is inside obstacles\[0\]",
        BASE + OBSTACLE.format(cx=0.1, cy=0.0, r=0.5),
    ),
    Bad(
        "goal-inside",
        SOLVE,
        r"goal: \(2\.0, 0\.0\) is inside obstacles\[1\]",
        BASE + OBSTACLE.format(cx=1.0, cy=1.0, r=0.2) + OBSTACLE.format(cx=2.0, cy=0.1, r=0.5),
    ),
    Bad(
        "unknown-model",
        SOLVE,
        r"robot\.model: unknown model 'tank'",
        BASE + '\n[robot]\nmodel = "tank"\n',
    ),
    Bad("unknown-key", SOLVE, r"colour: unknown key", BASE + 'colour = "red"\n'),
    Bad(
        "unknown-key-nested",
        SOLVE,
        r"obstacles\[0\]\.centre: unknown key.*'center'",
        BASE + "\n[[obstacles]]\ncentre = [1.0, 0.5]\nradius = 0.1\n",
    ),
    Bad(
        "unknown-builtin",
        ("solve", "paper-case-9"),
        r"no scenario file or built-in named 'paper-case-9'.*paper-case-1",
    ),
    Bad("missing-file", ("solve", "nope.toml"), r"no scenario file or built-in named 'nope\.toml'"),
    Bad("unknown-option", ("solve", "paper-case-1", "--bogus"), r"No such option.*--bogus"),
    Bad("bad-method", ("solve", "paper-case-1", "--method", "foo"), r"--method.*'foo'"),
    Bad(
        "json-folder-missing",
        ("solve", "paper-case-1", "--json", "missing/out.json"),
        r"--json: folder 'missing' does not exist",
        created=("missing",),
    ),
    Bad(
        "plot-format",
        ("solve", "paper-case-1", "--plot", "out.txt"),
        r"--plot: .*\.png",
        created=("out.txt",),
    ),
    Bad(
        "solver-value-quiet",
        ("solve", "{file}", "--quiet"),
        r"\.toml: solver\.partitions: must be an integer >= 2, got 1",
        BASE + "\n[solver]\npartitions = 1\n",
    ),
    Bad(
        "solver-value",
        SOLVE,
        r"\.toml: solver\.partitions: must be an integer >= 2, got 1",
        BASE + "\n[solver]\npartitions = 1\n",
    ),
    Bad("derive-unknown-model", ("derive", "tank"), r"unknown model 'tank'"),
    Bad(
        "bounded-speed-too-slow",
        SOLVE,
        r"\.toml: horizon: the goal is 2 away and the speed at most 1\.5: it takes at least"
        r" 1\.33333 s, longer than T = 1$",
        BASE + "[robot]\nv = [-1.5, 1.5]\n",
    ),
]


@pytest.fixture(scope="module")
def bad_runs(tmp_path_factory) -> dict[str, tuple[Run, Path | None]]:
    root = tmp_path_factory.mktemp("cli-bad")
    jobs, files = {}, {}
    for b in BAD:
        cwd = root / b.id
        cwd.mkdir()
        path = None
        if b.toml is not None:
            path = cwd / f"{b.id}.toml"
            path.write_text(b.toml)
        files[b.id] = path
        jobs[b.id] = ([a.replace("{file}", str(path)) for a in b.args], cwd)
    runs = run_all(jobs)
    return {k: (runs[k], files[k]) for k in runs}


def bad_params():
    for b in BAD:
        marks = pytest.mark.xfail(strict=True, reason=b.xfail) if b.xfail else ()
        yield pytest.param(b, marks=marks, id=b.id)


@pytest.mark.parametrize("bad", list(bad_params()))
def test_bad_input_gives_exit_2_and_one_line(bad_runs, bad):
    run, path = bad_runs[bad.id]
    assert "Traceback" not in run.stderr
    assert run.returncode == 2, run.stderr
    lines = run.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("error: ")
    assert re.search(bad.pattern, lines[0]), lines[0]
    assert run.stdout == ""
    # Nothing written: only the scenario file (if any) is in the working folder.
    assert sorted(os.listdir(run.cwd)) == ([path.name] if path else [])
    for p in bad.created:
        assert not (run.cwd / p).exists()
    if path is not None:
        # The whole message is the library's own one-line error, verbatim.
        with pytest.raises(LeapfrogError) as info:
            Planner(load_scenario(str(path)))
        assert lines[0] == f"error: {info.value}"


# --------------------------------------------------------------------------- normal use


@pytest.fixture(scope="module")
def good_runs(tmp_path_factory) -> dict[str, Run]:
    root = tmp_path_factory.mktemp("cli-good")
    jobs = {}
    for k in ("solve", "solve-verbose", "fail", "scenarios", "derive", "shoot"):
        (root / k).mkdir()
    jobs["solve"] = (
        [
            "solve",
            "paper-case-1",
            "--json",
            "out.json",
            "--plot",
            "out.png",
            "--npz",
            "out.npz",
            "--quiet",
        ],
        root / "solve",
    )
    jobs["solve-verbose"] = (["solve", "paper-case-1"], root / "solve-verbose")
    # A fast deterministic failure (~1 s of solving): q = 2 from the start, so no sweep, and the
    # simple shooting from the first arc's costate does not converge on case 4 (max-iterations)
    # and is not rescued by multiple shooting (--final shooting), by other paths (one path, no
    # extra ones), nor by the stages again with q = 4 (--option finer_doublings=0).
    jobs["fail"] = (
        [
            "solve",
            "paper-case-4",
            "--partitions",
            "2",
            "--final",
            "shooting",
            "--initial-paths",
            "1",
            "--option",
            "finer_doublings=0",  # (q = 4 would converge)
            "--option",
            "extra_paths=0",
            "--json",
            "f.json",
            "--plot",
            "f.png",
            "--quiet",
        ],
        root / "fail",
    )
    jobs["scenarios"] = (["scenarios"], root / "scenarios")
    jobs["derive"] = (["derive", "unicycle"], root / "derive")
    jobs["shoot"] = (
        ["shoot", "--guess", "-4.676", "3.213", "3.213", "--json", "s.json"],
        root / "shoot",
    )
    return run_all(jobs)


def load_png(path: Path) -> np.ndarray:
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
    assert float(img[..., :3].std()) > 0.0  # something is drawn
    return img


def test_solve_writes_json_npz_and_plot(good_runs):
    run = good_runs["solve"]
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    assert run.stdout == "" and run.stderr == ""  # --quiet
    d = json.loads((run.cwd / "out.json").read_text())
    assert d["status"] == "converged"
    assert abs(d["cost"] - 10.3232) / 10.3232 <= 1e-5
    assert d["method"] == "modified-newton"
    assert d["end_state_error"] <= 1e-8
    assert len(d["trajectory"]["t"]) == len(d["trajectory"]["lambda_3"]) > 100
    load_png(run.cwd / "out.png")
    with np.load(run.cwd / "out.npz") as z:
        np.testing.assert_array_equal(z["t"], d["trajectory"]["t"])
        np.testing.assert_array_equal(z["v"], d["trajectory"]["v"])
    assert sorted(os.listdir(run.cwd)) == ["out.json", "out.npz", "out.png"]


def test_solve_prints_a_summary(good_runs):
    run = good_runs["solve-verbose"]
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    assert re.search(r"status\s*\W\s*converged", run.stdout)
    assert re.search(r"cost\s*\W\s*10\.323202\b", run.stdout), run.stdout
    assert os.listdir(run.cwd) == []
    # stderr is a pipe here: no progress bar, not even a blank line; only a compile notice, on a
    # machine whose cache is cold
    assert not_compile_notices(run.stderr) == []


def test_solver_failure_gives_exit_1_and_still_writes_files(good_runs):
    run = good_runs["fail"]
    assert "Traceback" not in run.stderr
    assert run.returncode == 1, run.stderr
    assert "paper-case-4: failed" in run.stderr
    assert run.stdout == ""
    d = json.loads((run.cwd / "f.json").read_text())
    assert d["status"] == "failed" and d["optimal"] is False
    assert "final solve failed" in d["message"]
    # The best feasible motion computed is handed back: here the initial segments' arcs (q = 2),
    # from start to goal, clear of the obstacles, with its cost.
    assert d["trajectory_source"] == "Leapfrog iterate (q = 2), not optimal"
    assert "returned: the Leapfrog iterate (q = 2), not optimal" in d["message"]
    tr = d["trajectory"]
    assert [tr[k][0] for k in ("x", "y", "theta")] == [0.0, 0.0, 0.0]
    assert math.dist([tr[k][-1] for k in ("x", "y", "theta")], [2.0, 0.0, 0.0]) < 1e-4
    assert d["min_clearance"] > 0 and d["cost"] > 4.585
    load_png(run.cwd / "f.png")
    assert sorted(os.listdir(run.cwd)) == ["f.json", "f.png"]


def test_scenarios_lists_the_four_paper_cases(good_runs):
    run = good_runs["scenarios"]
    assert run.returncode == 0, run.stderr
    obstacles = {1: 0, 2: 2, 3: 3, 4: 7}
    for case, count in obstacles.items():
        name = f"paper-case-{case}"
        rows = [line for line in run.stdout.splitlines() if name in line]
        assert len(rows) == 1, run.stdout
        cells = [c.strip() for c in re.split(r"[│┃|]", rows[0]) if c.strip()]
        assert cells[0] == name and cells[-1] == str(count), cells
        assert cells[-2] == "1"  # horizon


def test_derive_prints_the_control_law(good_runs):
    run = good_runs["derive"]
    assert run.returncode == 0, run.stderr
    lines = [line.strip() for line in run.stdout.splitlines()]
    assert "v = -lambda_1*cos(theta) - lambda_2*sin(theta)" in lines
    assert "omega = -lambda_3" in lines


def test_shoot_from_a_good_guess_reaches_case_1_optimum(good_runs):
    run = good_runs["shoot"]
    assert run.returncode == 0, run.stderr
    d = json.loads((run.cwd / "s.json").read_text())
    assert d["status"] == "converged"
    assert abs(d["cost"] - 10.3232) / 10.3232 <= 1e-5
    np.testing.assert_allclose(d["costate0"], [-4.67610985, 3.21297400, 3.21297400], atol=1e-7)
    assert d["end_state_error"] <= 1e-8


def test_shoot_never_calls_an_extremal_through_an_obstacle_converged(tmp_path):
    """Simple shooting from the affine guess on a straight task converges to the straight line
    through a disc on it: the command says it collides (exit 1), with its clearance, as a
    plan's answer would be; the same task beside the disc converges."""
    args = ["shoot", "--start", "0", "0", "0", "--goal", "2", "0", "0", "--json", "s.json"]
    run = run_cli([*args, "--obstacle", "1", "0", "0.2"], tmp_path)
    assert run.returncode == 1, run.stderr
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["status"] == "collides" and d["min_clearance"] == pytest.approx(-0.2, abs=1e-6)
    assert "passes through an obstacle" in d["message"] and "collides" in run.stdout
    beside = run_cli([*args[:-2], "--json", "b.json", "--obstacle", "1", "0.5", "0.2"], tmp_path)
    assert beside.returncode == 0, beside.stderr
    d = json.loads((tmp_path / "b.json").read_text())
    assert d["status"] == "converged" and d["min_clearance"] == pytest.approx(0.3, abs=1e-3)


def test_solve_warms_up_only_the_method_it_plans_with(monkeypatch):
    """A plan with one local method loads that method's kernels and its multiple-shooting final
    solve (0.07 s less for `leapfrog solve` than all three methods); `leapfrog warmup` and the
    sweeps load every method."""
    import leapfrog_planner.planning.warmup as warmup

    seen = []
    monkeypatch.setattr(warmup, "plan", lambda sc, **options: seen.append(options))
    warmup.warm_up("unicycle", ["newton"])
    assert [o.get("method") for o in seen] == ["newton", "newton"]
    assert [o.get("final") for o in seen] == [None, "multiple-shooting"]
    seen.clear()
    warmup.warm_up("unicycle")
    assert {o.get("method") for o in seen} >= {"modified-newton", "newton", "nleq-err"}
    assert any(o.get("final") == "multiple-shooting" for o in seen)


def test_a_file_named_like_a_builtin_is_used_and_the_note_says_how_to_get_the_builtin(tmp_path):
    (tmp_path / "paper-case-1").write_text(load_scenario("paper-case-1").to_toml())
    run = run_cli(["solve", "paper-case-1", "--quiet"], tmp_path)
    assert run.returncode == 0, run.stderr
    assert not_compile_notices(run.stderr) == [
        "note: the file paper-case-1, not the built-in scenario (builtin:paper-case-1 is that one)"
    ]
    # A result saved under the name is re-run (it records its scenario), with the same note.
    run = run_cli(["solve", "builtin:paper-case-1", "--quiet", "--json", "paper-case-1"], tmp_path)
    assert run.returncode == 0, run.stderr
    run = run_cli(["solve", "paper-case-1", "--quiet"], tmp_path)
    assert run.returncode == 0, run.stderr
    assert "reproduces the recorded answer" in run.stdout + run.stderr
    assert not_compile_notices(run.stderr)[0].startswith("note: the file paper-case-1, not the")
    (tmp_path / "paper-case-1").write_text('{"schema": 2, "status": "converged"}')
    run = run_cli(["solve", "paper-case-1", "--quiet"], tmp_path)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert not_compile_notices(run.stderr)[1].startswith("error: paper-case-1: damaged result file")


ENCLOSED = """name = "enclosed"
horizon = 5.0
start = [0.0, 0.0, 0.0]
goal  = [3.0, 0.0, 0.0]
[robot]
radius = 0.1
[[walls]]
points = [[2.5, -0.5], [3.5, -0.5], [3.5, 0.5], [2.5, 0.5], [2.5, -0.5]]
thickness = 0.1
"""


@pytest.mark.parametrize("horizon", ["5.0", "free"])
def test_a_goal_walled_off_is_said_plainly_and_planned_once(tmp_path, horizon):
    """Walls alone (no map) keep start and goal apart: exit 1, a table that says no motion was
    found (not "the none", no rows of nan), a message that names the walls, not a map; with a
    free final time one horizon is planned, not three that cannot succeed."""
    text = ENCLOSED.replace("5.0", '"free"') + "[cost]\ncruise_speed = 1.0\n"
    text = ENCLOSED if horizon == "5.0" else text
    (tmp_path / "enclosed.toml").write_text(text)
    run = run_cli(["solve", "enclosed.toml", "--json", "r.json"], tmp_path)
    assert run.returncode == 1, run.stderr
    assert "returned" in run.stdout and "no motion (none was found)" in run.stdout
    for wrong in ("the none", "nan", "no obstacles", "initial path none"):
        assert wrong not in run.stdout, run.stdout
    quiet = run_cli(["solve", "enclosed.toml", "--quiet"], tmp_path)
    assert quiet.returncode == 1 and "on the map" not in quiet.stdout + quiet.stderr
    said = quiet.stdout + "\n".join(not_compile_notices(quiet.stderr))
    assert said.strip() == (
        "enclosed: failed: start (0, 0) and goal (3, 0) are not connected around the walls"
        " for a robot of radius 0.1"
    )
    from leapfrog_planner.planning.results import PlanResult

    r = PlanResult.load(tmp_path / "r.json")
    if horizon == "free":
        assert len(r.free_time.steps) == 1


def test_an_output_folder_made_by_another_command_at_the_same_moment_is_used(tmp_path, monkeypatch):
    """Two commands sharing an output folder (a script that runs two benches at once) both
    check it, find it missing and create it: the second finds it made and goes on."""
    from leapfrog_planner.cli.common import output_folder

    out = tmp_path / "bench-out"
    real_exists = Path.exists

    def made_meanwhile(path, *args, **kwargs):
        if path == out:
            out.mkdir(exist_ok=True)  # the other command, between this one's check and mkdir
            return False
        return real_exists(path, *args, **kwargs)

    monkeypatch.setattr(Path, "exists", made_meanwhile)
    assert output_folder(str(out), "--out") == out
    assert out.is_dir()
