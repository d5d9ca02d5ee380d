"""The sweep report against a small results file whose statistics are computed by hand."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import matplotlib.image as mpimg
import pytest

from leapfrog_planner.batch.report import build_report, save_report
from leapfrog_planner.batch.store import read_records


def _rec(scenario, method, cost, t, it, failure=None):
    return {
        "scenario": scenario,
        "method": method,
        "status": "failed" if cost is None else "converged",
        "failure": failure if cost is None else None,
        "cost": cost,
        "wall_time_s": t,
        "newton_iterations": it,
    }


# s1 tie; s2 B cheaper (A's ratio 1.2); s3 only A; s4 neither; s5 only B.
RECORDS = [
    _rec("s1", "A", 2.0, 0.1, 10),
    _rec("s1", "B", 2.0, 0.2, 12),
    _rec("s2", "A", 3.0, 0.3, 20),
    _rec("s2", "B", 2.5, 0.1, 8),
    _rec("s3", "A", 1.0, 0.2, 5),
    _rec("s3", "B", None, 0.5, 30, "solver"),
    _rec("s4", "A", None, 1.0, None, "timeout"),
    _rec("s4", "B", None, 0.4, 40, "solver"),
    _rec("s5", "A", None, 0.6, 50, "solver"),
    _rec("s5", "B", 4.0, 0.2, 9),
]


def wilson(k, n, z=1.959963984540054):
    """Wilson score interval, written out (not scipy's)."""
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return centre - half, centre + half


@pytest.fixture
def results(tmp_path):
    path = tmp_path / "results.jsonl"
    text = "".join(json.dumps(r) + "\n" for r in RECORDS)
    path.write_text(text + '{"scenario": "s6", "meth')  # a torn last line is ignored
    return path


def test_per_method_numbers(results):
    rep = build_report(read_records(results))
    assert (rep.runs, rep.scenarios) == (10, 5)
    a, b = rep.method("A"), rep.method("B")
    assert (a.runs, a.converged, a.success_rate) == (5, 3, 0.6)
    assert (b.runs, b.converged, b.success_rate) == (5, 3, 0.6)
    lo, hi = wilson(3, 5)
    assert a.ci_low == pytest.approx(lo, abs=1e-9) and a.ci_high == pytest.approx(hi, abs=1e-9)
    assert (round(lo, 4), round(hi, 4)) == (0.2307, 0.8824)
    assert a.failures == {"solver": 1, "timeout": 1} and b.failures == {"solver": 2}
    # Best per scenario: s1 2.0, s2 2.5, s3 1.0, s5 4.0. A: ratios 1, 1.2, 1. B: all 1.
    assert a.best_found == 2 and b.best_found == 3
    assert a.cost_ratio.median == 1.0 and a.cost_ratio.max == pytest.approx(1.2)
    assert b.cost_ratio.max == 1.0
    assert sorted(rep.cost_ratios["A"]) == pytest.approx([1.0, 1.0, 1.2])
    assert a.cheaper_seen == b.cheaper_seen == 0  # these records predate the field
    # Times of all runs: A 0.1 0.3 0.2 1.0 0.6, B 0.2 0.1 0.5 0.4 0.2.
    assert a.time_s.median == pytest.approx(0.3) and a.time_s.mean == pytest.approx(0.44)
    assert b.time_s.median == pytest.approx(0.2) and b.time_s.mean == pytest.approx(0.28)
    assert a.time_converged_s.median == pytest.approx(0.2)
    assert a.total_time_s == pytest.approx(2.2)
    # Iterations: A 10 20 5 50 (one run without), B 12 8 30 40 9.
    assert (a.iterations.n, a.iterations.median, a.iterations.mean) == (4, 15.0, 21.25)
    assert (b.iterations.median, b.iterations.mean) == (12.0, pytest.approx(19.8))


def test_paired_numbers(results):
    p = build_report(read_records(results)).pair("A", "B")
    assert (p.scenarios, p.both_converged, p.only_a, p.only_b, p.neither) == (5, 2, 1, 1, 1)
    assert p.mcnemar_p == pytest.approx(1.0)  # one discordant each way
    assert (p.a_cheaper, p.b_cheaper, p.cost_ties) == (0, 1, 1)
    assert p.cost_wilcoxon_p == pytest.approx(1.0)  # a single non-zero difference
    assert (p.a_faster, p.b_faster) == (1, 1)
    assert p.median_time_ratio == pytest.approx((0.5 + 3.0) / 2)


def test_lopsided_pair_is_significant():
    recs = []
    for i in range(12):  # A always solves; B fails on 10 of 12 and is slower everywhere
        recs.append(_rec(f"s{i}", "A", 1.0, 0.1, 5))
        recs.append(_rec(f"s{i}", "B", 1.0 if i < 2 else None, 0.2 + 0.01 * i, 9, "solver"))
    p = build_report(recs).pair("A", "B")
    assert (p.only_a, p.only_b) == (10, 0)
    assert p.mcnemar_p == pytest.approx(2 * 0.5**10)


def test_markdown_and_figures(results, tmp_path):
    rep = build_report(read_records(results))
    md = rep.to_markdown()
    assert "| A | 5 | 3 | 60.0% | [23.1%, 88.2%] | solver 1, timeout 1 |" in md
    assert "| A | B | 5 | 2 | 1 | 1 | 1 | 1.000 | 0 | 1 | 1 |" in md
    written = save_report(rep, tmp_path / "rep")
    names = sorted(p.name for p in written)
    assert names == ["cost_ratio_ecdf.png", "report.md", "success.png", "time_ecdf.png"]
    assert (tmp_path / "rep" / "report.md").read_text() == md
    for p in written:
        if p.suffix == ".png":
            assert mpimg.imread(p).shape[0] > 100


def test_cli_report(results, tmp_path):
    cmd = [sys.executable, "-m", "leapfrog_planner.cli", "report"]
    r = subprocess.run(
        [*cmd, str(results), "--out", str(tmp_path / "o")], capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "o" / "success.png").is_file()
    assert "# Sweep report" in (tmp_path / "o" / "report.md").read_text()
    # The terminal gets a short summary: a line per method and per pair, not the tables.
    assert "converged" in r.stdout and "Holm" in r.stdout and "|" not in r.stdout
    assert len(r.stdout.splitlines()) <= 12
    bad = subprocess.run([*cmd, str(tmp_path / "none.jsonl")], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "none.jsonl" in bad.stderr
    garbage = tmp_path / "g.jsonl"
    garbage.write_text('{"scenario": "a", "method": "m", "status": "converged"}\nnot json\n{}\n')
    bad = subprocess.run([*cmd, str(garbage)], capture_output=True, text=True)
    assert bad.returncode == 2 and "line 2" in bad.stderr and bad.stderr.count("\n") == 1


def test_a_converged_record_through_an_obstacle_is_not_a_success():
    recs = [
        {"scenario": "a", "method": "m", "status": "converged", "cost": 1.0, "min_clearance": -0.1},
        {"scenario": "b", "method": "m", "status": "converged", "cost": 2.0, "min_clearance": 0.1},
        {"scenario": "c", "method": "m", "status": "converged", "cost": 3.0, "min_clearance": None},
        {"scenario": "d", "method": "m", "status": "failed", "failure": "collides", "cost": None},
    ]
    m = build_report(recs).methods[0]
    assert (m.runs, m.converged) == (4, 2)
    assert m.failures == {"collides": 2}


def test_holm_adjusts_step_down_and_leaves_nan_out():
    """Hand-computed: p = 0.01, 0.04, 0.03, 0.005 (m = 4): sorted 0.005 x 4 = 0.02, 0.01 x 3 =
    0.03, 0.03 x 2 = 0.06, 0.04 x 1 = 0.04 -> 0.06 (non-decreasing)."""
    from leapfrog_planner.batch.report import holm

    adj = holm([0.01, 0.04, float("nan"), 0.03, 0.005])
    assert adj[0] == pytest.approx(0.03) and adj[4] == pytest.approx(0.02)
    assert adj[3] == pytest.approx(0.06) and adj[1] == pytest.approx(0.06)
    assert math.isnan(adj[2])
    assert holm([0.9, 0.8]) == [1.0, 1.0]
    assert holm([]) == []


def test_converged_runs_that_saw_a_cheaper_motion_are_counted():
    """A Leapfrog record with ``cheaper_motion`` (a collision-free motion cheaper than its
    extremal): counted for converged runs, shown in the cost table."""
    recs = [_rec("s1", "A", 2.0, 0.1, 10), _rec("s2", "A", 3.0, 0.1, 10)]
    recs[1]["cheaper_motion"] = 1.5
    recs.append({**_rec("s3", "A", None, 0.1, 10, "solver"), "cheaper_motion": 1.0})
    rep = build_report(recs)
    assert rep.method("A").cheaper_seen == 1  # the failed run's is not counted
    assert "| A | 2 | 2 | 1 |" in rep.to_markdown()
