"""A hostile-input corpus: what a user may type, wrongly or at the extremes, run as the CLI.

Every case runs the command line's entry point in this process (as tests/hostile_harness.py
does for the generated corpus: a subprocess would add a second or two of start-up to each), in a
fresh folder of its own; a hang ends the run. Bad input must end with exit 2 and exactly one line
on stderr that names the fault, never a traceback; valid but extreme input ends with exit 0 or 1.
No case may change a file that is not one of its outputs.
"""

# ruff: noqa: E501  (one case per line: the table reads as a list)
from __future__ import annotations

import os
import socket
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from tests.hostile_harness import Outcome, run_cli
from tests.test_cli import cli_env

TIMEOUT = 120  # seconds for the full disk's subprocess

BASE = """horizon = 1.0
start = [0.0, 0.0, 0.0]
goal = [2.0, 0.0, 0.0]
[[obstacles]]
center = [1.0, 0.1]
radius = 0.2
"""


def toml(**replace: str) -> str:
    """BASE with whole lines replaced: ``toml(horizon="horizon = 1e308")``."""
    lines = BASE.splitlines()
    for key, line in replace.items():
        lines = [line if ln.split(" =")[0] == key else ln for ln in lines]
    return "\n".join(lines) + "\n"


def penalty(text: str) -> str:
    return BASE.replace("[[obstacles]]", f"[penalty]\n{text}\n[[obstacles]]")


FIFO, SOCKET, DIRECTORY, SYMLINK_TO_FIFO = "<fifo>", "<socket>", "<directory>", "<link:fifo>"


@dataclass(frozen=True)
class Case:
    args: tuple[str, ...]
    files: dict[str, str | bytes] = field(default_factory=dict)
    codes: tuple[int, ...] = (2,)
    says: str = ""  # a fragment of the one-line message


LONG = "a" * 250 + ".json"
DEEP = "x = " + "[" * 5000 + "]" * 5000 + "\n"

CASES: dict[str, Case] = {
    # ---------------------------------------------------------------- syntax and encoding
    "empty file": Case(("solve", "s.toml"), {"s.toml": ""}, says="missing required key"),
    "binary garbage": Case(("solve", "s.toml"), {"s.toml": bytes(range(256)) * 4}),
    "latin-1 text": Case(("solve", "s.toml"), {"s.toml": "name = 'caf\xe9'\n".encode("latin-1")}),
    "unterminated string": Case(("solve", "s.toml"), {"s.toml": 'name = "x\n' + BASE}),
    "duplicate key": Case(("solve", "s.toml"), {"s.toml": BASE + "horizon = 2.0\n"}),
    "nested 5000 deep": Case(("solve", "s.toml"), {"s.toml": DEEP}, says="nested too deeply"),
    "unknown key": Case(("solve", "s.toml"), {"s.toml": BASE + "colour = 1\n"}),
    "obstacles a string": Case(("solve", "s.toml"), {"s.toml": BASE.split("[[")[0] + "obstacles = 'x'\n"}),
    "empty name": Case(("solve", "s.toml"), {"s.toml": 'name = ""\n' + BASE}),
    # ---------------------------------------------------------------- types and magnitudes
    "horizon string": Case(("solve", "s.toml"), {"s.toml": toml(horizon='horizon = "1"')}),
    "horizon boolean": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = true")}),
    "horizon nan": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = nan")}),
    "horizon inf": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = inf")}),
    "horizon negative": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = -1.0")}),
    "horizon 1e308": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = 1e308")}, says="horizon"),
    "horizon 1e-300": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = 1e-300")}),
    "horizon 10**30": Case(("solve", "s.toml"), {"s.toml": toml(horizon="horizon = " + "1" + "0" * 30)}),
    "start two numbers": Case(("solve", "s.toml"), {"s.toml": toml(start="start = [0.0, 0.0]")}),
    "start strings": Case(("solve", "s.toml"), {"s.toml": toml(start='start = ["a", "b", "c"]')}),
    "start x 1e308": Case(("solve", "s.toml"), {"s.toml": toml(start="start = [1e308, 0.0, 0.0]")}),
    "start heading 1e308": Case(("solve", "s.toml"), {"s.toml": toml(start="start = [0.0, 0.0, 1e308]")}),
    "goal heading -inf": Case(("solve", "s.toml"), {"s.toml": toml(goal="goal = [2.0, 0.0, -inf]")}),
    "goal inside obstacle": Case(("solve", "s.toml"), {"s.toml": toml(goal="goal = [1.0, 0.1, 0.0]")}, says="inside"),
    "radius zero": Case(("solve", "s.toml"), {"s.toml": toml(radius="radius = 0.0")}),
    "radius 1e-300": Case(("solve", "s.toml"), {"s.toml": toml(radius="radius = 1e-300")}, says="radius"),
    "radius 1e308": Case(("solve", "s.toml"), {"s.toml": toml(radius="radius = 1e308")}),
    "center 1e308": Case(("solve", "s.toml"), {"s.toml": toml(center="center = [1e308, 0.0]")}),
    "exponent 10**30": Case(("solve", "s.toml"), {"s.toml": penalty("exponent = " + "1" + "0" * 30)}),
    "exponent 10**18": Case(("solve", "s.toml"), {"s.toml": penalty("exponent = 1000000000000000000")}, says="exponent"),
    "exponent 0": Case(("solve", "s.toml"), {"s.toml": penalty("exponent = 0")}),
    "exponent 2.0": Case(("solve", "s.toml"), {"s.toml": penalty("exponent = 2.0")}),
    "weight negative": Case(("solve", "s.toml"), {"s.toml": penalty("weight = -1.0")}),
    "weight 1e300": Case(("solve", "s.toml"), {"s.toml": penalty("weight = 1e300")}),
    "unknown model": Case(("solve", "s.toml"), {"s.toml": BASE + "[robot]\nmodel = 'tank'\n"}),
    "wheel radius 1e-300": Case(("solve", "s.toml"), {"s.toml": BASE + "[robot]\nmodel = 'diff-drive'\nwheel_radius = 1e-300\n"}),
    "solver partitions 100000": Case(("solve", "s.toml"), {"s.toml": BASE + "[solver]\npartitions = 100000\n"}, says="partitions"),
    "solver partitions string": Case(("solve", "s.toml"), {"s.toml": BASE + "[solver]\npartitions = '8'\n"}),
    "solver method unknown": Case(("solve", "s.toml"), {"s.toml": BASE + "[solver]\nmethod = 'bisection'\n"}),
    "solver max_sweeps 10**9": Case(("solve", "s.toml"), {"s.toml": BASE + "[solver]\nmax_sweeps = 1000000000\n"}),
    "waypoint inside obstacle": Case(("solve", "s.toml"), {"s.toml": "waypoints = [[1.0, 0.1]]\n" + BASE}),
    "20000 obstacles": Case(("solve", "s.toml"), {"s.toml": BASE.split("[[")[0] + "[[obstacles]]\ncenter = [5.0, 5.0]\nradius = 0.1\n" * 20000}, says="at most"),
    "file of 17 MB": Case(("solve", "s.toml"), {"s.toml": BASE + "#" * (17 * 2**20) + "\n"}, says="larger than"),
    # ---------------------------------------------------------------- special files as input
    "no such scenario": Case(("solve", "nothing.toml"), says="no scenario file"),
    "a folder as scenario": Case(("solve", "d"), {"d": DIRECTORY}, says="directory"),
    "a FIFO without writer": Case(("solve", "f"), {"f": FIFO}),
    "a socket as scenario": Case(("solve", "sock"), {"sock": SOCKET}),
    "/dev/zero as scenario": Case(("solve", "/dev/zero"), says="larger than"),
    "/dev/null as scenario": Case(("solve", "/dev/null")),
    "a 300-character name": Case(("solve", "b" * 300 + ".toml")),
    # ---------------------------------------------------------------- options
    "--partitions 100000": Case(("solve", "s.toml", "--partitions", "100000"), {"s.toml": BASE}),
    "--partitions 0": Case(("solve", "s.toml", "--partitions", "0"), {"s.toml": BASE}),
    "--initial-paths 1000": Case(("solve", "s.toml", "--initial-paths", "1000"), {"s.toml": BASE}),
    "--method unknown": Case(("solve", "s.toml", "--method", "bisection"), {"s.toml": BASE}),
    "solve --option bogus=1": Case(("solve", "s.toml", "--option", "bogus=1"), {"s.toml": BASE}, says="bogus"),
    "solve --option finer_doublings=99": Case(("solve", "s.toml", "--option", "finer_doublings=99"), {"s.toml": BASE}),
    "solve --option partitions=8.0": Case(("solve", "s.toml", "--option", "partitions=8.0"), {"s.toml": BASE}, says="partitions: expected an integer >= 2, got number 8.0"),
    "solve --option partitions=true": Case(("solve", "s.toml", "--option", "partitions=true"), {"s.toml": BASE}, says="partitions: expected an integer >= 2, got boolean true"),
    "solve --option without =": Case(("solve", "s.toml", "--option", "partitions"), {"s.toml": BASE}),
    "solve --option shooting=1": Case(("solve", "s.toml", "--option", "shooting=1"), {"s.toml": BASE}, says="shooting: expected a table"),
    "solve --option shooting integrator a string": Case(("solve", "s.toml", "--option", 'shooting={"integrator": "x"}'), {"s.toml": BASE}, says="shooting.integrator: expected a table"),
    "solve --option final_shooting root misspelt": Case(("solve", "s.toml", "--option", 'final_shooting={"rooot": {}}'), {"s.toml": BASE}, says="did you mean 'root'"),
    "solve --option shooting root tol negative": Case(("solve", "s.toml", "--option", 'shooting={"root": {"tol": -1}}'), {"s.toml": BASE}, says="shooting.root.tol"),
    "solve --option shooting rtol a string": Case(("solve", "s.toml", "--option", 'shooting={"integrator": {"rtol": "a"}}'), {"s.toml": BASE}, says="shooting.integrator.rtol"),
    "solve --option initial_paths of 5000 digits": Case(("solve", "s.toml", "--option", "initial_paths=" + "9" * 5000), {"s.toml": BASE}, says="initial_paths"),
    "solve --option partitons": Case(("solve", "s.toml", "--option", "partitons=16"), {"s.toml": BASE}, says="did you mean 'partitions'"),
    "solve --option nested 5000 deep": Case(("solve", "s.toml", "--option", "shooting=" + "[" * 5000 + "]" * 5000), {"s.toml": BASE}, says="shooting"),
    "generate --prefix of 300 characters": Case(("generate", "--n", "2", "--out", "g", "--prefix", "p" * 300), says="prefix: at most 200"),
    "generate --prefix with a slash": Case(("generate", "--n", "2", "--out", "g", "--prefix", "../x"), says="prefix must be"),
    "name with markup": Case(("solve", "s.toml", "--quiet"), {"s.toml": 'name = "[/] [link=x]y[/link] :smile:"\n' + BASE}, codes=(0,)),
    "name with an escape sequence": Case(("solve", "s.toml"), {"s.toml": 'name = "a\\u001b[2Jb"\n' + BASE}, says="name: control characters"),
    "polygon of two points": Case(("solve", "s.toml"), {"s.toml": BASE + "[[polygons]]\npoints = [[3, 3], [4, 3]]\n"}, says="polygons[0].points"),
    "wall without thickness": Case(("solve", "s.toml"), {"s.toml": BASE + "[[walls]]\npoints = [[3, 3], [4, 3]]\n"}, says="walls[0].thickness: missing"),
    "goal inside a polygon": Case(("solve", "s.toml"), {"s.toml": BASE + "[[polygons]]\npoints = [[1.5, -1], [2.5, -1], [2, 1]]\n"}, says="goal: (2.0, 0.0) is inside a polygon"),
    "shoot --horizon inf": Case(("shoot", "--horizon", "inf")),
    "shoot --horizon nan": Case(("shoot", "--horizon", "nan")),
    "shoot --horizon -1": Case(("shoot", "--horizon", "-1")),
    "shoot --start 1e308": Case(("shoot", "--start", "1e308", "0", "0")),
    "shoot start in obstacle": Case(("shoot", "--start", "0", "0", "0", "--obstacle", "0", "0", "1"), says="inside"),
    "shoot --guess inf": Case(("shoot", "--guess", "inf", "0", "0")),
    "sweep --option partitions=100000": Case(("sweep", "s.toml", "--out", "r.jsonl", "--option", "partitions=100000"), {"s.toml": BASE}),
    "sweep --option partitions=abc": Case(("sweep", "s.toml", "--out", "r.jsonl", "--option", "partitions=abc"), {"s.toml": BASE}),
    "sweep --option bogus=1": Case(("sweep", "s.toml", "--out", "r.jsonl", "--option", "bogus=1"), {"s.toml": BASE}),
    "sweep --workers 0": Case(("sweep", "s.toml", "--out", "r.jsonl", "--workers", "0"), {"s.toml": BASE}),
    "sweep --time-limit -1": Case(("sweep", "s.toml", "--out", "r.jsonl", "--time-limit", "-1"), {"s.toml": BASE}),
    "generate --n -1": Case(("generate", "--n", "-1", "--out", "g")),
    "report of garbage": Case(("report", "r.jsonl"), {"r.jsonl": "not json\n"}),
    "report of a folder": Case(("report", "d"), {"d": DIRECTORY}),
    # ---------------------------------------------------------------- output paths
    "--json is the scenario": Case(("solve", "s.toml", "--json", "s.toml"), {"s.toml": BASE}, says="input"),
    "--npz is the scenario": Case(("solve", "s.toml", "--npz", "s.toml"), {"s.toml": BASE}, says="input"),
    "--plot is the scenario": Case(("solve", "s.png", "--plot", "s.png"), {"s.png": BASE}, says="input"),
    "--json a FIFO": Case(("solve", "s.toml", "--json", "f"), {"s.toml": BASE, "f": FIFO}, says="regular"),
    "--json a socket": Case(("solve", "s.toml", "--json", "sock"), {"s.toml": BASE, "sock": SOCKET}),
    "--json a link to a FIFO": Case(("solve", "s.toml", "--json", "l"), {"s.toml": BASE, "f": FIFO, "l": SYMLINK_TO_FIFO}),
    "--json a folder": Case(("solve", "s.toml", "--json", "d"), {"s.toml": BASE, "d": DIRECTORY}, says="folder"),
    "--json under /proc": Case(("solve", "s.toml", "--json", "/proc/x.json"), {"s.toml": BASE}),
    "--npz under /proc": Case(("solve", "s.toml", "--npz", "/proc/x.npz"), {"s.toml": BASE}),
    "--plot under /proc": Case(("solve", "s.toml", "--plot", "/proc/x.png"), {"s.toml": BASE}),
    "--json in no folder": Case(("solve", "s.toml", "--json", "no/x.json"), {"s.toml": BASE}),
    "--json name too long": Case(("solve", "s.toml", "--json", LONG), {"s.toml": BASE}, says="too long"),
    "--json empty": Case(("solve", "s.toml", "--json", ""), {"s.toml": BASE}),
    "--json and --npz the same": Case(("solve", "s.toml", "--json", "a", "--npz", "a"), {"s.toml": BASE}, says="same file"),
    "--plot wrong suffix": Case(("solve", "s.toml", "--plot", "x.txt"), {"s.toml": BASE}),
    "shoot --json a FIFO": Case(("shoot", "--json", "f"), {"f": FIFO}),
    "sweep --out is the scenario": Case(("sweep", "s.toml", "--out", "s.toml"), {"s.toml": BASE}, says="input"),
    "sweep --out a folder": Case(("sweep", "s.toml", "--out", "d"), {"s.toml": BASE, "d": DIRECTORY}),
    "sweep --out under /proc": Case(("sweep", "s.toml", "--out", "/proc/r.jsonl"), {"s.toml": BASE}),
    "report --out a file": Case(("report", "r.jsonl", "--out", "s.toml"), {"r.jsonl": "", "s.toml": BASE}),
    "report --out under /proc": Case(("report", "r.jsonl", "--out", "/proc/rep"), {"r.jsonl": ""}),
    "generate --out a file": Case(("generate", "--n", "1", "--out", "s.toml"), {"s.toml": BASE}),
    "generate --out under /proc": Case(("generate", "--n", "1", "--out", "/proc/g")),
    "paper --out under /proc": Case(("paper", "--out", "/proc/p")),
    "bench --out under /proc": Case(("bench", "--out", "/proc/b")),
    "bench --out a FIFO": Case(("bench", "--out", "f"), {"f": FIFO}),
    # ---------------------------------------------------------------- valid, at the bounds
    "horizon at its lower bound": Case(("solve", "s.toml", "--quiet"), {"s.toml": toml(horizon="horizon = 0.001")}, codes=(0, 1)),
    "horizon at its upper bound": Case(("solve", "s.toml", "--quiet", "--initial-paths", "1"), {"s.toml": toml(horizon="horizon = 10000.0")}, codes=(0, 1)),
    "weight at its bound": Case(("solve", "s.toml", "--quiet", "--initial-paths", "1"), {"s.toml": penalty("weight = 1e12")}, codes=(0, 1)),
    "exponent at its bound": Case(("solve", "s.toml", "--quiet", "--initial-paths", "1"), {"s.toml": penalty("exponent = 16")}, codes=(0, 1)),
    "heading of 100 turns": Case(("solve", "s.toml", "--quiet", "--initial-paths", "1"), {"s.toml": toml(goal="goal = [2.0, 0.0, 628.3185307179587]")}, codes=(0, 1)),
    "partitions at their bound": Case(("solve", "s.toml", "--quiet", "--initial-paths", "1", "--partitions", "1024"), {"s.toml": BASE}, codes=(0, 1)),
}  # fmt: skip


def _make(folder: Path, name: str, content) -> None:
    path = folder / name
    if content == FIFO:
        os.mkfifo(path)
    elif content == SOCKET:
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(path))
        s.close()
    elif content == DIRECTORY:
        path.mkdir()
    elif content == SYMLINK_TO_FIFO:
        path.symlink_to("f")
    elif isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8")


def _run(case: Case, folder: Path) -> Outcome:
    folder.mkdir()
    for name, content in case.files.items():
        _make(folder, name, content)
    return run_cli(case.args, folder)


@pytest.mark.parametrize("name", list(CASES))
def test_hostile_input(tmp_path, name):
    case = CASES[name]
    out = _run(case, tmp_path / "case")
    assert not out.traceback, out.traceback[-2000:]
    assert "Traceback" not in out.stderr, out.stderr[-2000:]
    assert out.code in case.codes, (out.code, out.stderr[-500:])
    if case.codes == (2,):
        assert len(out.lines) == 1 and out.lines[0].startswith("error: "), out.stderr[-500:]
        assert case.says in out.lines[0], out.lines[0]
        assert out.after == out.before, "bad input changed files"
    else:  # valid input: the files given are left as they were, outputs aside
        assert not out.changed_inputs(), out.changed_inputs()


def test_the_corpus_covers_every_command():
    commands = {case.args[0] for case in CASES.values()}
    assert commands >= {"solve", "shoot", "sweep", "generate", "report", "paper", "bench"}
    assert len(CASES) >= 90


def test_a_full_disk_after_a_plan_is_one_line_and_exit_1(tmp_path):
    """The plan is done, its output cannot be written: a failure (exit 1), not bad input, and
    no half-written file."""
    full = tmp_path / "full"
    full.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(full)],
                             capture_output=True)  # fmt: skip
    if mounted.returncode != 0:
        pytest.skip("needs root to mount a small tmpfs")
    try:
        (full / "fill").write_bytes(b"\0" * 64 * 1024)
        p = subprocess.run(
            [sys.executable, "-m", "leapfrog_planner.cli", "solve", "paper-case-1", "--quiet",
             "--json", str(full / "r.json")],
            cwd=tmp_path, env=cli_env(), capture_output=True, text=True, timeout=TIMEOUT,
        )  # fmt: skip
        assert p.returncode == 1, p.stderr
        (line,) = p.stderr.strip().splitlines()
        assert line.startswith("error: --json: cannot write") and "No space left" in line
        assert sorted(f.name for f in full.iterdir()) == ["fill"]
    finally:
        subprocess.run(["umount", str(full)], capture_output=True)
