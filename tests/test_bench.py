"""``leapfrog bench``: peers on the same problems, the issue's ratios, the profile split."""

from __future__ import annotations

import csv
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from leapfrog_planner.cli.main import main
from leapfrog_planner.errors import SettingsError
from leapfrog_planner.experiments import bench, peers
from leapfrog_planner.experiments.bench import BenchSettings, run_bench, target_ratios
from leapfrog_planner.experiments.profiling import PARTS
from leapfrog_planner.planning.direct import DirectResult, arc_end_state, cached_transcription
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.scenario import load_scenario


def run(argv) -> int:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    return exc.value.code


def test_case4_mnm_converges_and_agrees_with_plan():
    """The issue's check: MNM converges on case 4 in the benchmark, at the planner's cost."""
    settings = BenchSettings(cases=(4,), random=0, solvers=("leapfrog-mnm",), repeat=1)
    res = run_bench(BenchSettings(**{**settings.__dict__, "profile": False}))
    o = res.outcome("paper-case-4", "leapfrog-mnm")
    assert o.success and o.end_state_error <= 1e-8
    ref = plan("paper-case-4")
    assert o.cost == pytest.approx(ref.cost, rel=1e-9)
    (floor,) = res.floors
    assert floor.success and floor.cost == pytest.approx(o.cost, rel=1e-9)
    (line,) = target_ratios(res)  # no direct rows: only the floor ratio
    assert line.kind == "floor" and line.ratio == pytest.approx(o.time_s / floor.time_s)


@pytest.fixture(scope="module")
def bench_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "out"
    argv = ["bench", "--out", str(out), "--case", "1", "--random", "1", "--repeat", "1"]
    assert run([*argv, "--quiet"]) == 0
    return out


def test_bench_files_and_consistency(bench_out):
    for name in ("bench.md", "bench.csv", "bench.json", "bench.png"):
        assert (bench_out / name).stat().st_size > 0
    data = json.loads((bench_out / "bench.json").read_text())
    solvers = {o["solver"] for o in data["outcomes"]}
    expected = {"leapfrog-mnm", "leapfrog-mnm-1path", "leapfrog-nm", "leapfrog-nleq-err"}
    expected |= {"shooting"}
    expected |= {"bvp-line", "bvp-path"}
    if peers.casadi_available():
        expected |= {f"direct-N{n}-{g}" for n in (100, 200) for g in ("line", "path", "paths")}
    assert solvers == expected
    names = {o["scenario"] for o in data["outcomes"]}
    assert names == {"paper-case-1", peers.random_scenarios(1, 0)[0].name}
    md = (bench_out / "bench.md").read_text()
    with open(bench_out / "bench.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(data["outcomes"]) + len(data["floors"])
    for o, row in zip(data["outcomes"], rows, strict=False):
        assert row["solver"] == o["solver"] and row["scenario"] == o["scenario"]
        assert (row["success"] == "True") == o["success"]
        if o["success"]:
            assert float(row["cost"]) == o["cost"]
            assert f"| {o['solver']} | yes | {o['cost']:.6f} |" in md
        else:
            assert f"| {o['solver']} | **no** | - |" in md
    # Leapfrog finds the spec's optimum of case 1, and its result re-integrates to the goal.
    mnm = next(o for o in data["outcomes"] if o["solver"] == "leapfrog-mnm")
    assert mnm["cost"] == pytest.approx(10.32320, rel=1e-5) and mnm["end_state_error"] < 1e-8


def test_bench_ratios_and_profile(bench_out):
    data = json.loads((bench_out / "bench.json").read_text())
    kinds = {r["kind"] for r in data["ratios"]}
    assert "floor" in kinds and ("direct" in kinds) == peers.casadi_available()
    for r in data["ratios"]:
        assert r["scenario"] == "paper-case-1" and r["ratio"] > 0
    p = data["profile"]
    assert set(p["parts_s"]) == set(PARTS)
    assert sum(p["parts_s"].values()) == pytest.approx(p["wall_s"], rel=1e-9)
    assert all(v >= 0 for v in p["parts_s"].values())  # exclusive times, one thread
    assert p["parts_s"]["integration"] > 0 and p["calls"]["integration"] > 0
    assert p["steps"] >= p["integrations"] > p["jacobian_calls"] > 0
    # Every Newton evaluation is a flow timed and counted as integration, Leapfrog's local
    # solves included (they call the compiled loop directly, some evaluating F alone).
    assert p["integrations"] >= Planner(p["scenario"], threads=1).plan().f_evals
    md = (bench_out / "bench.md").read_text()
    assert "Where the time goes" in md and "Performance targets" in md and "cores" in md
    # The summary counts what the per-scenario tables show.
    n_ok = sum(o["success"] for o in data["outcomes"] if o["solver"] == "shooting")
    assert f"| shooting | {n_ok}/2 |" in md


needs_casadi = pytest.mark.skipif(not peers.casadi_available(), reason="CasADi not installed")


@needs_casadi
def test_direct_from_every_initial_path_is_the_cheapest_of_the_serial_solves():
    """``direct-N<n>-paths``: IPOPT from each of the planner's initial paths, in threads on one
    transcription each, gives the cheapest of the same solves run one after the other, bit for
    bit; ``-path`` is the first of them."""
    sc = load_scenario("paper-case-2")
    n = 40
    nodes = np.linspace(0.0, sc.horizon, n + 1)
    guesses = peers._path_guesses(sc)(nodes)
    assert len(guesses) == len(Planner(sc).initial_paths()) == 3
    tr = cached_transcription(sc.obstacles.shape[0], n)
    serial = [
        tr.solve(sc.start, sc.goal, sc.horizon, sc.obstacles, weight=sc.weight,
                 exponent=sc.exponent, guess_states=g[:, :3])
        for g in guesses
    ]  # fmt: skip
    costs = [r.cost for r in serial if r.success]
    assert len(costs) == 3 and len(set(costs)) == 3  # three distinct local optima
    both = [peers.run_direct(sc, n, "paths", repeat=1) for _ in range(2)]
    for o in both:
        assert o.solver == "direct-N40-paths" and o.success
        assert o.cost == min(costs)
        k = costs.index(min(costs))
        assert f"path {k + 1} of 3 kept (3 succeeded; iterations per path: " in o.message
    one = peers.run_direct(sc, n, "path", repeat=1)
    assert one.cost == serial[0].cost


def test_cheapest_direct_result_is_kept_and_named():
    def result(success, cost, iterations):
        return DirectResult(
            success=success,
            status="Solve_Succeeded" if success else "Maximum_Iterations_Exceeded",
            message="IPOPT",
            cost=cost,
            t=np.zeros(2),
            states=np.zeros((2, 3)),
            controls=np.zeros((1, 2)),
            min_clearance=0.0,
            iterations=iterations,
            solve_time=0.0,
        )

    r = peers._cheapest([result(True, 3.0, 5), result(False, 1.0, 9), result(True, 2.0, 7)])
    assert r.cost == 2.0 and r.iterations == 7
    assert r.message == (
        "IPOPT: path 3 of 3 kept (2 succeeded; iterations per path: "
        "5, 9 Maximum_Iterations_Exceeded, 7)"
    )
    none = peers._cheapest([result(False, 1.0, 9), result(False, 0.5, 3)])
    assert not none.success and none.iterations == 9 and "(0 succeeded;" in none.message


def test_like_for_like_pairs_are_marked_and_one_path_is_not_set_against_all():
    def outcome(solver, t):
        return peers.PeerOutcome(solver, "paper-case-2", True, 1.0, 0.0, t, (t,), "")

    outs = [outcome("leapfrog-mnm", 0.02), outcome("leapfrog-mnm-1path", 0.01)]
    outs += [outcome(f"direct-N100-{g}", 0.04) for g in ("line", "path", "paths")]
    res = bench.BenchResult(
        settings=BenchSettings(), scenarios=("paper-case-2",), outcomes=tuple(outs), floors=(),
        profile=None, notes=(), machine={}, wall_time_s=0.0,
    )  # fmt: skip
    lines = {(r.leapfrog, r.against): r for r in target_ratios(res)}
    assert set(lines) == {
        ("leapfrog-mnm", "direct-N100-line"),
        ("leapfrog-mnm", "direct-N100-path"),
        ("leapfrog-mnm", "direct-N100-paths"),
        ("leapfrog-mnm-1path", "direct-N100-line"),
        ("leapfrog-mnm-1path", "direct-N100-path"),
    }
    marked = {k for k, r in lines.items() if "(same initial paths)" in r.text}
    assert marked == {
        ("leapfrog-mnm", "direct-N100-paths"),
        ("leapfrog-mnm-1path", "direct-N100-path"),
    }
    assert lines["leapfrog-mnm", "direct-N100-paths"].ratio == pytest.approx(2.0)
    assert lines["leapfrog-mnm-1path", "direct-N100-path"].ratio == pytest.approx(4.0)


def test_measure_warms_up_then_times_the_peers_in_turn():
    """Warm-ups first (a failed one is timed once and dropped), then rounds in which every peer
    is timed once in turn (``per_round`` times for a fast one); ``more`` adds peers after the
    warm-ups, from their values."""
    calls = []

    def peer(name, success=True, per_round=1):
        def solve():
            calls.append(name)
            return SimpleNamespace(success=success, name=name, n=calls.count(name))

        def judge(value, times):
            return (value.name, value.n, len(times))

        return peers.Peer(name, solve, judge, per_round)

    def more(values):
        assert [v.name for v in values] == ["a", "bad", "b"]
        return [peer("floor", per_round=2)]

    labels = []
    out = peers.measure(
        [peer("a"), peer("bad", success=False), peer("b")], 3, more=more, progress=labels.append
    )
    assert calls == ["a", "bad", "b", "floor"] + ["a", "b", "floor", "floor"] * 3
    # judged on the last value: its call number, and the number of times
    assert [o for o, _ in out] == [("a", 4, 3), ("bad", 1, 1), ("b", 4, 3), ("floor", 7, 6)]
    assert labels == [
        "a (warm-up)", "bad (warm-up)", "b (warm-up)", "floor (warm-up)",
        "timing round 1 of 3", "timing round 2 of 3", "timing round 3 of 3",
    ]  # fmt: skip


def test_cli_solver_choices_are_the_benchmark_solvers():
    from leapfrog_planner.cli.experiments import SOLVER_CHOICES

    assert tuple(SOLVER_CHOICES) == bench.SOLVERS


def test_missing_casadi_is_said_and_rows_skipped(monkeypatch):
    monkeypatch.setattr(peers, "casadi_available", lambda: False)
    res = run_bench(
        BenchSettings(cases=(1,), random=0, solvers=("shooting", "direct"), repeat=1, profile=False)
    )
    assert res.notes == (bench.CASADI_MISSING,)
    assert "bench" in bench.CASADI_MISSING
    assert [o.solver for o in res.outcomes] == ["shooting"]
    assert bench.CASADI_MISSING in bench.bench_markdown(res)


def test_random_scenarios_seeded_and_valid():
    a = peers.random_scenarios(4, seed=3)
    b = peers.random_scenarios(2, seed=3)
    assert a[:2] == b  # scenario i depends only on (seed, i)
    assert peers.random_scenarios(1, seed=4)[0] != a[0]
    for sc in a:
        obs = sc.obstacles
        assert 2 <= len(obs) <= 5
        for p in (sc.start, sc.goal):
            assert (np.hypot(*(p[:2] - obs[:, :2]).T) - obs[:, 2]).min() >= 0.1
        assert math.hypot(*(sc.goal[:2] - sc.start[:2])) >= 1.2


def test_direct_end_state_is_exact_for_arcs():
    # Constant (v, omega) over the horizon: a circular arc, end state in closed form.
    x = arc_end_state(np.zeros(3), np.tile([1.0, np.pi], (7, 1)), 1.0)
    assert np.allclose(x, [0.0, 2 / np.pi, np.pi], atol=1e-12)


@pytest.mark.parametrize(
    "bad",
    [
        {"solvers": ("ipopt",)},
        {"repeat": 0},
        {"repeat": 2.0},
        {"cases": (7,)},
        {"cases": (True,)},
        {"meshes": (1,)},
        {"meshes": (100.0,)},
        {"random": -1},
    ],
)
def test_settings_validated(bad):
    with pytest.raises(SettingsError):
        BenchSettings(**bad)


def test_cli_bad_solver_exits_2(tmp_path, capsys):
    assert run(["bench", "--out", str(tmp_path / "o"), "--solver", "ipopt", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_work_count_is_deterministic_and_counts_every_evaluation():
    """count_work (benchmarks/bench_work.py compares code versions by it): the same counts on
    every run, paths in parallel threads included, every F evaluation counted as an
    integration, and the patched functions restored afterwards."""
    from leapfrog_planner.experiments.profiling import count_work
    from leapfrog_planner.integrate.flow import Flow

    run = Flow._run
    counts = []
    for threads in (1, 2, 1):
        planner = Planner("paper-case-3", threads=threads)
        w = count_work(planner.plan)
        assert w.value.status == "converged"
        assert w.integrations >= w.value.f_evals > 0
        assert 0 < w.jacobian_calls <= w.integrations < w.steps
        counts.append((w.steps, w.integrations, w.jacobian_calls))
    assert counts[0] == counts[1] == counts[2]
    assert Flow._run is run
