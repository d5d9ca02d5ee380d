"""The README cannot lie: every command and every Python snippet in it runs here, in a temporary
folder that holds the README's scenario file as ``room.toml``; so do those of the pages of docs/
that hold commands (``DOCS``).

Commands run as written, except that the sizes of the long experiments are cut (``SHRINK``:
fewer repetitions and scenarios, so that the suite stays within its time budget) and the few
that cannot run in a test are excused by name with the reason (``EXCUSED``). A command that is
neither run nor excused fails the test that lists them, so a new one cannot slip by; a command
written in two documents runs once. A page of docs/ with commands or snippets is in ``DOCS`` or
says in ``NOT_RUN`` why not. Every relative link and image of the README and of docs/ names a
file that exists, and every anchor a heading of it; the README's contents list every section, and
no table row has more cells than its header.
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

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: The documents whose bash commands and Python snippets run here: the README and these pages.
PAGES = ("serve.md", "sweeps.md", "benchmarks.md", "python.md", "ros.md")
DOCS = [README, *(ROOT / "docs" / name for name in PAGES)]
#: Pages of docs/ with bash or Python blocks that do not run here, and why.
NOT_RUN = {"scenarios.md": "its Python block loads a file of the reader's own (my-room.toml)"}
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


def _blocks(lang: str, docs: list[Path] = DOCS) -> list[tuple[str, str]]:
    """The ``lang`` code blocks of ``docs``, each with the name of its document."""
    out = []
    for doc in docs:
        text = doc.read_text(encoding="utf-8")
        out += [(_name(doc), b) for b in re.findall(rf"```{lang}\n(.*?)```", text, re.S)]
    return out


def _name(doc: Path) -> str:
    return doc.relative_to(ROOT).as_posix()


def readme_commands() -> list[tuple[str, str]]:
    """Every shell command of the documents' bash blocks with the name of its document,
    continuation lines joined and comments dropped, ``a && b`` split in two."""
    out = []
    for doc, block in _blocks("bash"):
        text = block.replace("\\\n", " ")
        for line in text.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line and not line.startswith("#"):
                out += [(doc, part.strip()) for part in line.split("&&")]
    return out


def _unique_commands() -> list:
    """Each command to run once, named by the documents that hold it."""
    where: dict[str, list[str]] = {}
    for doc, command in readme_commands():
        if not _excused(command):
            where.setdefault(command, [])
            where[command] += [doc] if doc not in where[command] else []
    return [pytest.param(c, id=f"{'+'.join(docs)}: {c}") for c, docs in where.items()]


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
    ((_, toml),) = _blocks("toml", [README])
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
    todo = [p.values[0] for p in _unique_commands()]
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
    commands = [c for _, c in readme_commands()]
    assert len(commands) >= 20
    assert all(c.startswith("leapfrog ") or _excused(c) for c in commands), commands
    used = {frag for frag in EXCUSED if any(frag in c for c in commands)}
    assert used == set(EXCUSED), f"excuses without a command: {set(EXCUSED) - used}"


def test_every_page_with_commands_runs_here_or_says_why_not():
    pages = (ROOT / "docs").glob("*.md")
    with_code = {p.name for p in pages if re.search(r"```(bash|python)\n", p.read_text())}
    assert with_code - set(NOT_RUN) == set(PAGES)
    assert set(NOT_RUN) <= with_code, "a reason for a page without commands"


@pytest.mark.parametrize("command", _unique_commands())
def test_readme_command_runs(runs, command):
    p = runs[command]
    assert "Traceback" not in p.stderr, p.stderr[-2000:]
    assert p.returncode == 0, (p.returncode, p.stderr[-1000:])


def test_readme_outputs_exist(runs, folder):
    for name in ("case4.png", "case4.json", "case4.csv", "case4.yaml", "case4.gif", "out.npz"):
        assert (folder / name).stat().st_size > 0, name
    assert (folder / "report" / "report.md").is_file()


def _snippets() -> list:
    """Every Python block of the documents, numbered within its document."""
    out, seen = [], {}
    for doc, code in _blocks("python"):
        seen[doc] = seen.get(doc, 0) + 1
        out.append(pytest.param(code, id=f"{doc} python block {seen[doc]}"))
    return out


@pytest.mark.parametrize("code", _snippets())
def test_readme_python_snippet_runs(code, request, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    name = request.node.callspec.id
    exec(compile(code, name, "exec"), {"__name__": "readme"})


def _pages() -> list[Path]:
    return [README, *sorted((ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", _pages(), ids=_name)
def test_the_documents_do_not_point_to_documents_a_user_cannot_see(page):
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"\bspec\b", text.replace("generator spec", ""))
    assert "issue" not in text.lower()


def _anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to dashes."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _prose(page: Path) -> str:
    """The page without its code blocks."""
    return re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)


def _anchors(page: Path, level: str = "#{1,6}") -> set[str]:
    return {_anchor(h) for h in re.findall(rf"^{level} (.+)$", _prose(page), re.M)}


def _links(page: Path) -> list[str]:
    """The targets of the page's links and images, outside code."""
    text = re.sub(r"`[^`\n]*`", "", _prose(page))
    return re.findall(r"\]\(([^)\s]+)\)", text)


@pytest.mark.parametrize("page", _pages(), ids=_name)
def test_every_link_and_image_names_a_file_and_a_heading_that_exist(page):
    for link in _links(page):
        if re.match(r"[a-z]+:", link):
            continue  # http, https, mailto: not checked here
        path, _, anchor = link.partition("#")
        target = (page.parent / path).resolve() if path else page
        assert target.exists(), f"{_name(page)}: {link}"
        if anchor:
            assert anchor in _anchors(target), f"{_name(page)}: {link}: no such heading"


@pytest.mark.parametrize("page", _pages(), ids=_name)
def test_every_row_of_a_table_has_the_header_s_columns(page):
    """A ``|`` inside a code span still splits a cell: the row would render askew."""
    for table in re.findall(r"(?:^\|.*\n)+", _prose(page), re.M):
        rows = table.splitlines()
        bad = [r for r in rows if len(re.findall(r"(?<!\\)\|", r)) != rows[0].count("|")]
        assert not bad, f"{_name(page)}: {bad}"


def test_the_contents_list_every_section_of_the_readme():
    text = README.read_text(encoding="utf-8")
    contents = text.split("**Contents:**")[1].split("\n\n")[0]
    listed = re.findall(r"\]\(#([^)]+)\)", contents)
    assert set(listed) <= _anchors(README)
    sections = _anchors(README, "##")
    assert sections <= set(listed), sections - set(listed)


def test_room_toml_is_written_before_a_command_uses_it():
    text = README.read_text(encoding="utf-8")
    first_use = min(text.index(b) for _, b in _blocks("bash", [README]) if "room.toml" in b)
    assert text.index("```toml\n") < first_use


def test_the_quick_start_is_two_commands_and_the_readme_is_short():
    text = README.read_text(encoding="utf-8")
    quick = text.split("## Quick start")[1].split("\n## ")[0]
    assert len(re.findall(r"```bash\n", quick)) == 2
    assert len(text.splitlines()) <= 255  # results, history and details belong in docs/
    assert os.environ.get("CI_SKIP_README") is None  # no switch to turn this file off
