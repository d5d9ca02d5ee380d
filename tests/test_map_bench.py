"""Leapfrog beside OMPL on a map (experiments/map_bench.py, ``leapfrog bench --map``): one cost
for both (the scorer gives Leapfrog's own cost back), and Leapfrog no dearer than OMPL."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.batch.generate import map_scenarios, nearest_turn
from leapfrog_planner.experiments.map_bench import (
    MapBenchSettings,
    curvature,
    path_cost,
    run_map_bench,
    summary,
)
from leapfrog_planner.planning.planner import Planner

pytest.importorskip("ompl")

DEPOT = Path(__file__).parent / "data" / "maps" / "depot.yaml"


def test_the_scorer_gives_leapfrogs_own_cost():
    (sc,) = map_scenarios(DEPOT, 1, seed=3)
    r = Planner(sc).plan()
    assert r.success
    tr = r.trajectory
    assert path_cost(sc.problem(), tr.t, tr.x, tr.u[:, 0], tr.u[:, 1]) == pytest.approx(
        r.cost, rel=1e-5
    )


def test_curvature_in_closed_form():
    assert curvature([1.0, 2.0], [0.5, 0.5]) == pytest.approx(0.5)
    assert curvature([1.0, 0.0], [0.0, 1.0]) == math.inf  # a turn in place
    assert curvature([-2.0, 1.0], [1.0, 0.0]) == pytest.approx(0.5)  # reversing counts too


def test_goal_headings_are_within_half_a_turn_of_the_start():
    assert nearest_turn([0, 0, 3.0], [1, 1, -3.0])[2] == pytest.approx(-3.0 + 2 * math.pi)
    assert nearest_turn([0, 0, -1.0], [1, 1, 2.0]) == [1.0, 1.0, 2.0]
    for sc in map_scenarios(DEPOT, 5, seed=1):
        assert abs(sc.goal[2] - sc.start[2]) <= math.pi + 1e-12


def test_leapfrog_is_no_dearer_than_ompl_where_both_solve():
    settings = MapBenchSettings(queries=2, seed=0, ompl_time=0.3)
    result = run_map_bench(DEPOT, settings)
    assert len(result.rows) == 4 and {r.solver for r in result.rows} == {"leapfrog", "ompl"}
    head = summary(result)
    assert head["leapfrog"]["succeeded"] == 2
    assert head["leapfrog_cheaper"] == head["both_solved"]
    for r in result.rows:
        if r.success:
            assert r.min_clearance >= 0.0 and np.isfinite(r.cost)


def test_bench_map_on_the_command_line(tmp_path):
    from tests.test_cli import run_cli

    out = run_cli(["bench", "--map", str(DEPOT), "--queries", "1", "--ompl-time", "0.2",
                   "--out", "b"], tmp_path)  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "leapfrog: 1/1 succeeded" in out.stdout
    data = json.loads((tmp_path / "b" / "bench_map.json").read_text())
    assert data["summary"]["queries"] == 1 and len(data["rows"]) == 2
    assert (tmp_path / "b" / "bench_map.md").read_text().startswith("# Leapfrog and OMPL")
    bad = run_cli(["bench", "--map", "missing.yaml", "--out", "c"], tmp_path)
    assert bad.returncode == 2 and "missing.yaml" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "c").exists()
