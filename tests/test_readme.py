"""The README cannot lie: every command and every Python snippet in it runs here, in a temporary
folder that holds the README's scenario file as ``room.toml``.

Commands run as written, except that the sizes of the long experiments are cut (``SHRINK``:
fewer repetitions and scenarios, so that the suite stays within its time budget) and the few
that cannot run in a test are excused by name with the reason (``EXCUSED``). A README command
that is neither run nor excused fails the test that lists them, so a new one cannot slip by.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from tests.serving import free_port, wait_ready
from tests.test_cli import cli_env

README = Path(__file__).resolve().parents[1] / "README.md"
WORKERS = 4
TIMEOUT = 600

#: (pattern, replacement) applied to a command before it runs: the same command, smaller.
SHRINK = [
    (r"--repeat \d+", "--repeat 1"),
    (r"--n (100|500)\b", "--n 3"),
    (r"^(leapfrog bench --out bench-out)$", r"\1 --random 0 --case 1 --repeat 1"),
    (r"--work-precision --random 3", "--work-precision --random 0 --case 1"),
    (r"--case 4 --random 0", "--case 1 --random 0 --repeat 1"),
]  # fmt: skip

#: Commands that cannot run in a test, by a fragment of their text, and why.
EXCUSED = {
    "pip install": "installing is what the test run itself did (.ci/run runs these commands)",
    "python -m pytest": "the test suite itself",
    "--scheduler tcp://host:8786": "needs a running Dask cluster at that address",
}


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def readme_commands() -> list[str]:
    """Every shell command of the README's bash blocks, continuation lines joined and comments
    dropped, ``a && b`` split in two."""
    out = []
    for block in _blocks("bash"):
        text = block.replace("\\\n", " ")
        for line in text.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line and not line.startswith("#"):
                out += [part.strip() for part in line.split("&&")]
    return out


def _excused(command: str) -> str | None:
    return next((why for frag, why in EXCUSED.items() if frag in command), None)


def _shrunk(command: str) -> str:
    for pattern, replacement in SHRINK:
        command = re.sub(pattern, replacement, command)
    return command


def _serve(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``leapfrog serve`` runs until it is stopped: start it on a free port, wait until its
    solver processes are ready, load the page, stop it (Ctrl-C) and take its exit code."""
    port = free_port()
    argv = [sys.executable, "-m", "leapfrog_planner.cli", *args[1:], "--port", str(port)]
    proc = subprocess.Popen(argv, cwd=cwd, env=cli_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, encoding="utf-8")  # fmt: skip
    url, page = f"http://127.0.0.1:{port}", ""
    try:
        not_ready = wait_ready(proc, url, TIMEOUT)
        if not_ready is None:
            with urllib.request.urlopen(url, timeout=10) as r:
                page = r.read().decode()
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    if "<title>leapfrog planner" in page and proc.returncode in (0, 130):
        return subprocess.CompletedProcess(argv, 0, out, err)
    why = f"{not_ready or ''}; exit {proc.returncode}, page {page[:200]!r}"
    return subprocess.CompletedProcess(argv, 1, out, f"{err}\n{why}")


def _run(command: str, cwd: Path) -> subprocess.CompletedProcess:
    args = shlex.split(_shrunk(command))
    assert args[0] == "leapfrog", command
    if args[1] == "serve":
        return _serve(args, cwd)
    return subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", *args[1:]],
        cwd=cwd,
        env=cli_env(),
        capture_output=True,
        encoding="utf-8",
        timeout=TIMEOUT,
    )


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("readme")
    (toml,) = _blocks("toml")
    (d / "room.toml").write_text(toml, encoding="utf-8")
    return d


def _ordered(commands: list[str]) -> list[list[str]]:
    """Commands in waves: one that reads a file another writes runs after it (solve before plot,
    export and the re-run of its result; generate before the sweeps of its folder; sweeps before
    report)."""
    writes = r"leapfrog (solve (?!\S+\.(json|npz)\b)|generate|sweep --n)"
    first = [c for c in commands if re.match(writes, c)]
    second = [c for c in commands if c not in first and not c.startswith("leapfrog report")]
    third = [c for c in commands if c.startswith("leapfrog report")]
    return [first, second, third]


@pytest.fixture(scope="module")
def runs(folder) -> dict[str, subprocess.CompletedProcess]:
    todo = [c for c in readme_commands() if not _excused(c)]
    done = {}
    for wave in _ordered(todo):
        with ThreadPoolExecutor(WORKERS) as pool:
            # Each sweep writes its own results file; the two sweeps of one file run in turn.
            futures = {}
            for c in wave:
                futures[c] = pool.submit(_run, c, folder)
                if "--out results.jsonl" in c:
                    futures[c].result()
            done.update({c: f.result() for c, f in futures.items()})
    return done


def test_every_readme_command_is_run_or_excused_with_a_reason():
    commands = readme_commands()
    assert len(commands) >= 20
    assert all(c.startswith("leapfrog ") or _excused(c) for c in commands), commands
    used = {frag for frag in EXCUSED if any(frag in c for c in commands)}
    assert used == set(EXCUSED), f"excuses without a command: {set(EXCUSED) - used}"


@pytest.mark.parametrize("command", [c for c in readme_commands() if not _excused(c)])
def test_readme_command_runs(runs, command):
    p = runs[command]
    assert "Traceback" not in p.stderr, p.stderr[-2000:]
    assert p.returncode == 0, (p.returncode, p.stderr[-1000:])


def test_readme_outputs_exist(runs, folder):
    for name in ("case4.png", "case4.json", "case4.csv", "case4.yaml", "case4.gif", "out.npz"):
        assert (folder / name).stat().st_size > 0, name
    assert (folder / "report" / "report.md").is_file()


@pytest.mark.parametrize("index", range(len(_blocks("python"))))
def test_readme_python_snippet_runs(index, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = _blocks("python")[index]
    exec(compile(code, f"README.md python block {index + 1}", "exec"), {"__name__": "readme"})


def test_the_readme_does_not_point_to_documents_a_user_cannot_see():
    text = README.read_text(encoding="utf-8")
    assert not re.search(r"\bspec\b", text.replace("generator spec", ""))
    assert "issue" not in text.lower()


def test_the_quick_start_is_two_commands():
    quick = README.read_text(encoding="utf-8").split("## Quick start")[1].split("\n## ")[0]
    assert len(re.findall(r"```bash\n", quick)) == 2
    assert os.environ.get("CI_SKIP_README") is None  # no switch to turn this file off
