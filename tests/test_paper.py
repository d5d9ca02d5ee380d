"""``leapfrog paper``: all files written, and the table's numbers are the planner's own results."""

from __future__ import annotations

import csv
import json
import math
import re
from types import SimpleNamespace

import matplotlib.image as mpimg
import pytest

from leapfrog_planner.cli.main import main
from leapfrog_planner.errors import SettingsError
from leapfrog_planner.experiments.paper import (
    COLUMNS,
    PAPER_TABLE1,
    CaseRun,
    MethodRun,
    PaperResult,
    PaperSettings,
    comparison_markdown,
)
from leapfrog_planner.planning.planner import plan

FILES = ["table1.md", "table1.csv", "comparison.md"] + [f"fig{k}.png" for k in (1, 2, 3, 4)]


def run(argv) -> int:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    return exc.value.code


@pytest.fixture(scope="module")
def paper_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper") / "out"  # not yet there: the command creates it
    assert run(["paper", "--out", str(out), "--repeat", "1", "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def rows(paper_out):
    with open(paper_out / "table1.csv", newline="") as fh:
        return {int(r["case"]): r for r in csv.DictReader(fh)}


def test_all_files_written(paper_out):
    for name in FILES:
        assert (paper_out / name).stat().st_size > 0, name
    for k in (1, 2, 3, 4):
        img = mpimg.imread(paper_out / f"fig{k}.png")
        assert img.shape[0] > 200 and img.shape[1] > 200
        assert img[..., :3].std() > 0.05  # not a blank canvas


def test_csv_columns_and_cases(rows, paper_out):
    with open(paper_out / "table1.csv") as fh:
        assert tuple(fh.readline().strip().split(",")) == COLUMNS
    assert sorted(rows) == [1, 2, 3, 4]
    assert [int(rows[k]["obstacles"]) for k in (1, 2, 3, 4)] == [0, 2, 3, 7]


@pytest.mark.parametrize("tag", ["nm", "mnm"])
def test_table_matches_the_results_written(rows, paper_out, tag):
    """Every number in the table is the one in the result JSON of the same run."""
    for k, row in rows.items():
        res = json.loads((paper_out / f"case{k}-{tag}.json").read_text())
        assert row[f"status_{tag}"] == res["status"]
        assert int(row[f"newton_iterations_{tag}"]) == res["newton_iterations"]
        assert int(row[f"f_evals_{tag}"]) == res["f_evals"]
        assert int(row[f"sweeps_{tag}"]) == res["sweeps"]
        cost = float(row[f"cost_{tag}"])
        if res["status"] == "converged":
            assert cost == res["cost"]
            assert float(row[f"end_state_error_{tag}"]) == res["end_state_error"]
            assert float(row[f"end_state_error_{tag}"]) <= 1e-8
        else:
            assert math.isnan(cost) and res["cost"] is None
        assert 0 < float(row[f"median_time_{tag}_s"]) < 120


def test_table_matches_independent_plan_calls(rows):
    """The numbers are real runs: a fresh ``plan()`` gives the same costs and counts."""
    for k, method, tag in ((2, "modified-newton", "mnm"), (1, "newton", "nm")):
        r = plan(f"paper-case-{k}", method=method)
        assert rows[k][f"status_{tag}"] == str(r.status)
        assert float(rows[k][f"cost_{tag}"]) == pytest.approx(r.cost, rel=1e-9)
        assert int(rows[k][f"newton_iterations_{tag}"]) == r.newton_iterations


def test_markdown_shows_failures_and_the_paper(rows, paper_out):
    md = (paper_out / "table1.md").read_text()
    table = [line for line in md.splitlines() if line.startswith("| ")][1:]
    assert len(table) == 4
    for k, line in zip((1, 2, 3, 4), table, strict=True):
        cells = [c.strip() for c in line.strip("|").split("|")]
        for col, tag in ((2, "nm"), (3, "mnm")):
            failed = rows[k][f"status_{tag}"] != "converged"
            assert (cells[col] == "**failed**") == failed
            if not failed:
                assert cells[col].startswith(f"{float(rows[k][f'cost_{tag}']):.6f}")
    cmp = (paper_out / "comparison.md").read_text()
    assert "omits" in cmp or "leaves out" in cmp
    assert "independent reference optima (direct method, CasADi with IPOPT)" in cmp
    assert not re.search(r"\bspec\b", cmp + md, re.IGNORECASE)  # no document users cannot see
    for cost, t_nm, t_mnm in PAPER_TABLE1.values():
        assert f"| {cost} |" in cmp and f"| {t_nm} |" in cmp and f"| {t_mnm} |" in cmp
    t = float(rows[4]["median_time_mnm_s"])
    assert f"{PAPER_TABLE1[4][2] / t:.0f}x" in cmp


def test_case_4s_cheaper_optimum_is_the_reference_not_an_error():
    """The planner's 4.5852479 on case 4 is the optimum known; 5.663875 (the direct method
    from a straight line) is a local optimum, said as such, never a -19% error."""
    costs = {1: 10.323202, 2: 21.206207, 3: 3.274136, 4: 4.5852479}

    def method(name, cost):
        return MethodRun(name, SimpleNamespace(success=True, cost=cost), (1.0,))

    cases = tuple(
        CaseRun(k, f"paper-case-{k}", 0, method("newton", c), method("modified-newton", c))
        for k, c in costs.items()
    )
    machine = {"cores": 2, "load_average": (0.0,), "python": "3", "platform": "x"}
    md = comparison_markdown(PaperResult(PaperSettings(), cases, machine, 0.0))
    row = next(line for line in md.splitlines() if line.startswith("| 4 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[3] == "4.585248" and cells[4] == "4.5852479" and abs(float(cells[5])) < 1e-6
    assert "5.663875" in md and "a local optimum; Leapfrog finds 4.5852479, cheaper" in md


def test_mnm_converges_on_every_case(rows):
    for k in (1, 2, 3, 4):
        assert rows[k]["status_mnm"] == "converged"


@pytest.mark.parametrize(
    "args",
    [["--repeat", "0"], ["--case", "5"], ["--out", "{file}"], ["--out", "{missing}/x"]],
)
def test_bad_input_exits_2(tmp_path, capsys, args):
    (tmp_path / "f").write_text("")
    args = [a.format(file=tmp_path / "f", missing=tmp_path / "nope") for a in args]
    assert run(["paper", "--quiet", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err
    assert not (tmp_path / "nope").exists()


def test_settings_validated():
    bad_settings = (
        {"repeat": 0},
        {"repeat": 1.5},
        {"repeat": 2.0},
        {"cases": (5,)},
        {"cases": ()},
        {"cases": (1, 1)},
        {"cases": (1.0,)},
        {"cases": (True,)},
    )
    for bad in bad_settings:
        with pytest.raises(SettingsError):
            PaperSettings(**bad)
    assert PaperSettings(cases=(3, 1)).cases == (1, 3)
