"""The Leapfrog algorithm itself (spec section 2): sweeps, costate jumps, reduction of ``q``.

These tests call :func:`leapfrog` directly on junctions of the planner's initial path, or plan
paper case 1 with special settings; all runs are cheap (case 1 has no obstacles). The paper-case
results and the monotone cost of every run on every case are in ``test_planner.py``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import CASES, EXTREMAL_COSTATE
from leapfrog_planner.batch.generate import GeneratorSpec, generate_one
from leapfrog_planner.bvp.shooting import solve_shooting
from leapfrog_planner.errors import SettingsError
from leapfrog_planner.planning.leapfrog import Junctions, LeapfrogSettings, SweepRecord, leapfrog
from leapfrog_planner.planning.leapfrog.final import FinalSolver
from leapfrog_planner.planning.path_ranking import PathGuide
from leapfrog_planner.planning.planner import Planner, plan
from leapfrog_planner.planning.results import validate

MNM, NM = "modified-newton", "newton"
CASE1 = CASES[1]
OPTIMUM_1 = 10.32320  # spec section 5


def rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


@pytest.fixture(scope="module")
def case1():
    """The planner of case 1 (problem, compiled flow) and its single initial path."""
    planner = Planner(CASE1.name)
    paths = [p for p in planner.initial_paths() if not p.modes.cusp]  # (and a three-point turn)
    assert len(paths) == 1 and paths[0].label == "straight"
    return planner, paths[0]


def run_case1(case1, q: int, **settings):
    planner, path = case1
    t, X = path.junctions(q, 1.0)
    records: list[SweepRecord] = []
    run = leapfrog(
        planner.problem,
        t,
        X,
        settings=LeapfrogSettings(partitions=q, **settings),
        flow=planner.flow,
        progress=records.append,
    )
    return run, records


def final_levels(monkeypatch) -> list[int]:
    """The arcs of the level each final solve of the test starts from, in order."""
    seen = []
    original = FinalSolver.solve

    def solve(self, lam0, junctions):
        seen.append(junctions.q)
        return original(self, lam0, junctions)

    monkeypatch.setattr(FinalSolver, "solve", solve)
    return seen


def final_cost(planner, costate0) -> float:
    v = validate(planner.problem, 0.0, CASE1.start, 1.0, CASE1.goal, costate0)
    assert v.end_state_error <= 1e-8
    return v.cost


# --------------------------------------------------------------------------- jump -> 0


@pytest.fixture(scope="module")
def one_level(case1):
    """q = 4 held (reduction by cost decrease at 1e-12 only, never by jump or sweep count).

    Local problems are solved as accurately as the final one (the default local accuracy, 1e-7,
    would floor the jump near 1e-4 at this cost tolerance)."""
    return run_case1(
        case1,
        4,
        reduce_tol=1e-12,
        jump_tol=1e-14,
        sweeps_per_level=300,
        max_sweeps=300,
        shooting=LeapfrogSettings().final_shooting,
    )


def test_costate_jump_goes_to_zero(one_level):
    run, records = one_level
    assert run.success, run.message
    jumps = np.array([h.max_costate_jump for h in run.history])
    assert all(h.q == 4 for h in run.history)
    assert len(jumps) >= 30
    assert jumps[0] > 0.1  # the initial piecewise extremal is far from an extremal
    assert jumps[-1] < 1e-5  # measured 3.3e-6 after 82 sweeps
    assert jumps[-1] < 1e-4 * jumps.max()  # more than four orders of magnitude
    # Steadily, not by luck at the last sweep: every 10 sweeps the jump shrinks by a factor.
    assert np.all(jumps[10:] < 0.5 * jumps[:-10])
    # The level ended because the cost stopped decreasing (relative 1e-12), not by a count.
    costs = np.array([h.cost for h in run.history])
    assert len(run.history) < 300
    assert (costs[-2] - costs[-1]) / costs[-1] < 1e-12


def test_costs_of_one_level_decrease_to_the_optimum(case1, one_level):
    planner, _ = case1
    run, records = one_level
    costs = np.array([h.cost for h in run.history])
    assert run.initial_cost > costs[0]
    assert np.all(np.diff(costs) <= 0.0)
    assert run.cost_increases == 0
    # With continuous costates the piecewise-optimal trajectory is the extremal: same cost.
    assert rel(costs[-1], final_cost(planner, run.costate0)) <= 1e-9
    assert rel(costs[-1], OPTIMUM_1) <= 1e-5


def test_junctions_converge_onto_the_final_extremal(case1, one_level):
    """After the sweeps, each junction state lies on the extremal the final shooting returns."""
    planner, _ = case1
    run, _ = one_level
    last = run.history[-1]
    z0 = np.concatenate([CASE1.start, run.costate0])
    for ti, xi in zip(last.t[1:-1], last.X[1:-1], strict=True):
        x = planner.flow(0.0, z0, float(ti)).x
        np.testing.assert_allclose(x, xi, rtol=0, atol=1e-5)


def test_progress_reports_every_sweep_record(one_level):
    run, records = one_level
    assert tuple(records) == run.history
    assert [r.sweep for r in records] == list(range(1, len(records) + 1))


def test_sweep_records_keep_the_end_states_fixed(one_level):
    run, _ = one_level
    for h in run.history:
        assert h.t.shape == (h.q + 1,) and h.X.shape == (h.q + 1, 3)
        assert h.t[0] == 0.0 and h.t[-1] == 1.0
        assert np.all(np.diff(h.t) > 0)
        np.testing.assert_array_equal(h.X[0], CASE1.start)
        np.testing.assert_array_equal(h.X[-1], CASE1.goal)
        assert h.failures == 0 and h.rejected == 0
        assert h.newton_iterations > 0 and h.f_evals >= h.newton_iterations
        assert h.time_s >= 0.0
    assert sum(h.newton_iterations for h in run.history) <= run.newton_iterations


# --------------------------------------------------------------------------- reduction of q


def test_partitions_are_halved_level_by_level(case1):
    run, _ = run_case1(case1, 8, sweeps_per_level=3)
    assert run.success, run.message
    qs = [h.q for h in run.history]
    assert qs[0] == 8 and qs[-1] > 2  # no sweep at q = 2: the final shooting does that
    levels: dict[int, int] = {}
    for a, b in zip(qs, qs[1:], strict=False):
        assert b in (a, math.ceil(a / 2)), qs
    for q in qs:
        levels[q] = levels.get(q, 0) + 1
    assert max(levels.values()) <= 3
    assert set(levels) == {8, 4}  # 8 -> 4 -> 2
    assert rel(final_cost(case1[0], run.costate0), OPTIMUM_1) <= 1e-5


def test_halving_stops_at_the_fewest_arcs_and_the_final_solve_starts_there(case1, monkeypatch):
    """``fewest_arcs = 4`` from q = 16: levels of 16, 8 and 4, never 2, and the final solves
    start from the 4-arc level (simple shooting from its first arc, multiple shooting over its
    arcs): the same extremal as the default run that halved down to 2."""
    seen = final_levels(monkeypatch)
    run, _ = run_case1(case1, 16, fewest_arcs=4, sweeps_per_level=3)
    assert run.success, run.message
    qs = [h.q for h in run.history]
    assert set(qs) == {16, 8, 4}, qs
    assert seen == [4]
    assert rel(final_cost(case1[0], run.costate0), OPTIMUM_1) <= 1e-5
    # Multiple shooting alone over those arcs reaches the same extremal.
    multi, _ = run_case1(case1, 16, fewest_arcs=4, sweeps_per_level=3, final="multiple-shooting")
    assert multi.success and multi.final_solver == "multiple-shooting", multi.message
    np.testing.assert_allclose(multi.costate0, run.costate0, rtol=1e-7, atol=1e-7)


def test_max_sweeps_caps_the_sweeps(case1):
    run, records = run_case1(case1, 8, max_sweeps=2)
    assert len(run.history) == len(records) == 2
    assert run.history[-1].cost < run.initial_cost


def test_a_run_cut_by_max_sweeps_hands_the_final_solve_the_level_it_was_sweeping(
    case1, monkeypatch
):
    """Cut by ``max_sweeps`` after a halving (q = 16, 16, then 8), the final solves start from
    the level of q = 8 it swept last, not from the one of q = 16 before its halving."""
    levels = final_levels(monkeypatch)
    run, records = run_case1(case1, 16, max_sweeps=3, sweeps_per_level=2)
    assert [r.q for r in records] == [16, 16, 8]
    assert levels == [8]
    assert run.success, run.message
    assert run.arcs.t.size - 1 == 8


def test_multiple_shooting_final_solve_reaches_the_same_extremal(case1):
    shoot, _ = run_case1(case1, 8, final="shooting")
    multi, _ = run_case1(case1, 8, final="multiple-shooting")
    assert shoot.success and multi.success, (shoot.message, multi.message)
    assert shoot.final_solver == "shooting"
    assert multi.final_solver == "multiple-shooting"
    np.testing.assert_allclose(multi.costate0, shoot.costate0, rtol=1e-7, atol=1e-7)
    planner = case1[0]
    c_shoot, c_multi = final_cost(planner, shoot.costate0), final_cost(planner, multi.costate0)
    assert rel(c_multi, c_shoot) <= 1e-8
    assert rel(c_shoot, OPTIMUM_1) <= 1e-5
    # The coarse stage (rtol 1e-7) is polished to the final tolerance at the final integrator.
    final_root = LeapfrogSettings().final_shooting.root
    assert multi.final_root.residual_norms[-1] <= final_root.tol


def test_multiple_shooting_fallback_is_converged_coarse_then_polished(monkeypatch):
    """Paper case 4's third initial path, MNM: the final simple shooting stalls, and multiple
    shooting takes over, first with the local problems' integrator, then, from its answer, with
    the final one in at most two iterations. A failing coarse stage is the fallback's failure
    (no second solve from the start)."""
    import leapfrog_planner.planning.leapfrog.final as lf

    stages, arcs = [], []
    real = lf.solve_multiple_shooting

    def spy(system, x0, method, settings, compiled):
        r = real(system, x0, method, settings, compiled)
        arcs.append(system.q)
        if system.q > 2:
            stages.append((system.flow.settings.rtol, settings.tol, r.success, r.iterations))
        return r

    monkeypatch.setattr(lf, "solve_multiple_shooting", spy)
    finals = []
    real_shooting = lf.solve_shooting
    monkeypatch.setattr(
        lf, "solve_shooting", lambda *a, **k: finals.append(real_shooting(*a, **k)) or finals[-1]
    )
    planner = Planner(CASES[4].name, threads=1)
    paths = planner.initial_paths()
    sc = planner.scenario
    t, X = paths[2].junctions(8, sc.horizon)
    run = leapfrog(planner.problem, t, X, flow=planner.flow)
    assert run.success and run.final_solver == "multiple-shooting", run.message
    # The simple shooting creeps at |F| = 0.12 with MNM steps of 2^-7: stalled after 5 iterations.
    (simple,) = finals
    assert simple.status == "stalled" and simple.root.iterations <= 5
    local, final = LeapfrogSettings().shooting, LeapfrogSettings().final_shooting
    (coarse_rtol, coarse_tol, ok1, _), (fine_rtol, fine_tol, ok2, its) = stages
    assert (coarse_rtol, coarse_tol, ok1) == (local.integrator.rtol, local.root.tol, True)
    assert (fine_rtol, fine_tol, ok2) == (final.integrator.rtol, final.root.tol, True)
    assert its <= 2
    v = validate(planner.problem, 0.0, sc.start, sc.horizon, sc.goal, run.costate0)
    assert v.end_state_error <= 1e-8
    assert rel(v.cost, 5.784293) <= 1e-6  # that path's optimum (README)

    stages.clear()
    arcs.clear()
    monkeypatch.setattr(
        lf, "solve_multiple_shooting", lambda *a: replace(spy(*a), status="stalled")
    )
    failed = leapfrog(
        planner.problem,
        t,
        X,
        flow=planner.flow,
        settings=LeapfrogSettings(
            final="multiple-shooting", final_retry_sweeps=0, final_least_squares=0
        ),
    )
    # A failed coarse stage ends that level's attempt (here without Levenberg-Marquardt after
    # it): then the refined level's (twice the junctions) is tried, coarse first too, and so
    # on: 4, 8 and 16 arcs.
    assert not failed.success and len(stages) == 3
    assert arcs == [4, 8, 16] == [4 * 2**k for k in range(LeapfrogSettings().final_refinements + 1)]
    assert all(rtol == local.integrator.rtol for rtol, *_ in stages)


def test_past_the_time_limit_the_final_solve_refines_no_more(monkeypatch):
    """The final solves of a run under way when the plan's time limit passes run from the
    level reached, but multiple shooting is not tried again on refined junctions (on an office
    maze's routes of 60 to 100 s, each refinement took 0.3 to 1.8 s, and a plan with a limit of
    5 s ended after 7.9 s; now after 5.2 to 5.8 s)."""
    import time

    import leapfrog_planner.planning.leapfrog.final as lf

    arcs = []
    real = lf.solve_multiple_shooting
    deadline = time.perf_counter() + 2.0

    def late(system, *args):
        arcs.append(system.q)
        while time.perf_counter() < deadline:  # the limit passes during the first attempt
            time.sleep(0.01)
        return replace(real(system, *args), status="stalled")

    monkeypatch.setattr(lf, "solve_multiple_shooting", late)
    planner = Planner(CASES[4].name, threads=1)
    t, X = planner.initial_paths()[2].junctions(8, planner.scenario.horizon)
    settings = LeapfrogSettings(
        final="multiple-shooting", final_retry_sweeps=0, final_least_squares=0
    )
    run = leapfrog(planner.problem, t, X, flow=planner.flow, settings=settings, deadline=deadline)
    assert not run.success and arcs == [4]  # without the limit: 4, 8 and 16 arcs
    # A run whose limit passed before its final solve (cut short, its arcs not merged) tries
    # simple shooting, and multiple shooting only on a level of a few arcs.
    from leapfrog_planner.planning.leapfrog.local import LocalSolver

    local = LocalSolver(
        planner.problem, planner.flow, LeapfrogSettings(final="auto", final_least_squares=0)
    )
    ends = (planner.scenario.start, planner.scenario.goal, 0.0, planner.scenario.horizon)

    def level(q):
        t, X = planner.initial_paths()[2].junctions(q, planner.scenario.horizon)
        return Junctions(t, X, np.ones((q, 3)), np.ones((q, 3)), np.zeros(q))

    cut = lf.FinalSolver(local, planner.flow, *ends, deadline=time.perf_counter())
    for q, tried in ((8, [8]), (lf.LATE_ARCS, [lf.LATE_ARCS]), (lf.LATE_ARCS + 2, [])):
        arcs.clear()
        found = cut.solve(np.ones(3), level(q))
        assert arcs == tried and found.root is not None
    arcs.clear()
    lf.FinalSolver(local, planner.flow, *ends).solve(np.ones(3), level(8))
    assert arcs == [8, 16, 32]  # without a limit (the monkeypatched solves fail)


# --------------------------------------------------------------------------- q = 2


@pytest.mark.parametrize("method", [MNM, NM])
def test_two_partitions_is_simple_shooting(case1, method):
    """At q = 2 no sweep runs: the final simple shooting starts from the first arc's costate.

    That costate comes from the first half of the initial path (start to its midpoint), solved
    from the affine guess. From the straight path, simple shooting from it lands on the 38.73
    extremal of spec section 5, not the optimum 10.3232: the sweeps are what find the optimum.
    (The three-point turn the plan runs besides it lands on the optimum even so.)
    """
    planner, path = case1
    r = plan(CASE1.name, partitions=2, method=method)
    assert r.success, r.message
    assert r.sweeps == 0 and r.history == ()
    assert r.final_solver == "shooting"
    assert rel(r.cost, OPTIMUM_1) <= 1e-5
    straight = Planner(CASE1.name, partitions=2, method=method).run_path(path)
    assert straight.clear and straight.run.history == ()

    settings = LeapfrogSettings(method=method)
    shoot = replace(settings.shooting, samples=0, method=method)
    t, X = path.junctions(2, 1.0)
    arc = solve_shooting(planner.problem, t[0], X[0], t[1], X[1], settings=shoot)
    assert arc.success, arc.message
    final = replace(settings.final_shooting, samples=0, method=method)
    whole = solve_shooting(
        planner.problem, 0.0, CASE1.start, 1.0, CASE1.goal, guess=arc.costate0, settings=final
    )
    assert whole.success, whole.message
    cost = straight.validation.cost
    assert rel(cost, whole.cost) <= 1e-8
    np.testing.assert_allclose(straight.run.costate0, whole.costate0, rtol=0, atol=1e-8)
    assert cost == pytest.approx(38.73, abs=5e-3)
    assert cost > OPTIMUM_1 + 20.0


# --------------------------------------------------------------------------- settings


def test_default_settings_are_documented_values():
    s = LeapfrogSettings()
    assert (s.method, s.partitions, s.final) == (MNM, 8, "auto")
    assert (s.max_sweeps, s.sweeps_per_level, s.reduce_tol, s.jump_tol) == (60, 10, 1e-3, 1e-6)


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("method", "x", "unknown method 'x'"),
        ("partitions", 1, "partitions"),
        ("partitions", 3.5, "partitions"),
        ("max_sweeps", 0, "max_sweeps"),
        ("sweeps_per_level", 0, "sweeps_per_level"),
        ("reduce_tol", 0.0, "reduce_tol"),
        ("jump_tol", 0.0, "jump_tol"),
        ("final", "x", "final"),
        ("max_split_depth", -1, "max_split_depth"),
        ("attempt_iterations", 1.5, "attempt_iterations"),
        ("partitions", 8.0, "partitions: expected an integer >= 2, got number 8.0"),
        ("max_sweeps", True, "max_sweeps: expected an integer >= 1, got boolean true"),
        ("continuation_min_step", 0.5, "continuation_min_step"),  # above the first step
        ("continuation_first_step", 0.0, "continuation_first_step"),
        ("continuation_steps", 0, "continuation_steps"),
        ("max_refinements", -1, "max_refinements"),
        ("attempt_stall_window", -1, "attempt_stall_window"),
        ("two_arc_attempt", "yes", "two_arc_attempt"),
        ("local", "modified-newton", "step object"),
        ("fused_sweeps", 1, "fused_sweeps"),
        ("final_retry_sweeps", -1, "final_retry_sweeps"),
        ("final_retry_jump", 0.0, "final_retry_jump"),
        ("final_refinements", -1, "final_refinements"),
        ("final_refinements", 7, "final_refinements"),
        ("fewest_arcs", 1, "fewest_arcs"),
        ("fewest_arcs", 4.0, "fewest_arcs"),
    ],
)
def test_leapfrog_settings_reject_bad_values(option, value, message):
    with pytest.raises(SettingsError, match=message):
        LeapfrogSettings(**{option: value})


# --------------------------------------------------------------------------- local failures


def straight_junctions(scenario, q: int):
    """Junctions on the straight chord with linear heading: on case 2 it crosses both discs."""
    t = np.linspace(0.0, 1.0, q + 1)
    return t, scenario.start + (scenario.goal - scenario.start) * t[:, None]


def test_failed_and_rejected_local_problems_keep_the_cost_monotone():
    """From an infeasible start (through the obstacles of case 2) local solves fail or are
    rejected (measured with q = 4: one failure in sweep 1, one rejection in sweep 3); the
    junctions stay, the cost never rises."""
    planner = Planner(CASES[2].name)
    t, X = straight_junctions(planner.scenario, 4)
    run = leapfrog(planner.problem, t, X, settings=LeapfrogSettings(partitions=4))
    assert run.success, run.message
    assert sum(h.failures + h.rejected for h in run.history) > 0
    costs = np.array([run.initial_cost] + [h.cost for h in run.history])
    assert np.all(np.isfinite(costs))
    assert np.all(np.diff(costs) <= 1e-12 * costs[:-1])
    assert run.cost_increases == 0
    v = validate(
        planner.problem, 0.0, planner.scenario.start, 1.0, planner.scenario.goal, run.costate0
    )
    assert v.end_state_error <= 1e-8 and v.max_dH_du <= 1e-10


def test_an_unsolvable_initial_segment_fails_cleanly():
    """Without a curve to split along, a segment whose two-point problem fails ends the run."""
    planner = Planner(CASES[2].name)
    t, X = straight_junctions(planner.scenario, 8)
    run = leapfrog(planner.problem, t, X, settings=LeapfrogSettings(partitions=8))
    assert not run.success
    assert run.costate0 is None and run.final_solver is None
    assert run.history == () and run.initial_cost == math.inf
    i = run.failed_segment
    assert 0 <= i < 8 and f"the two-point problem of initial segment {i} failed (" in run.message


# --------------------------------------------------------------------------- refinement


def test_refined_arcs_are_the_same_piecewise_extremal(case1):
    """Case 1's optimal extremal cut into 4 arcs, then refined: same junctions every other
    point, same cost, and no costate jump at the new junctions."""
    planner, _ = case1
    flow = planner.flow
    t = np.linspace(0.0, 1.0, 5)
    z = [np.concatenate([CASE1.start, EXTREMAL_COSTATE[1]])]
    cost = []
    for i in range(4):
        r = flow(t[i], z[-1], t[i + 1])
        z.append(r.z)
        cost.append(r.cost)
    Z = np.array(z)
    arcs = Junctions(t=t, X=Z[:, :3].copy(), lam0=Z[:-1, 3:].copy(), lam1=Z[1:, 3:].copy(),
                 cost=np.array(cost))  # fmt: skip
    fine = arcs.refined(flow)
    assert fine.q == 8
    np.testing.assert_array_equal(fine.t[::2], t)
    np.testing.assert_array_equal(fine.X[::2], arcs.X)
    assert rel(fine.cost.sum(), arcs.cost.sum()) <= 1e-12
    assert np.all(fine.cost > 0)
    assert fine.max_jump() <= 1e-9


def test_a_level_ending_with_a_failing_local_problem_is_refined():
    """Random scenario 52 of seed 1 (the sweep's default generator): classical Newton, one
    initial path. At q = 4 one local problem keeps failing; halving on from there made the final
    solve diverge (measured). Refining (q = 4 -> 8) lets it converge."""
    sc = generate_one(GeneratorSpec(n=500, seed=1, obstacles=(3, 10)), 52)
    planner = Planner(sc, method="newton", initial_paths=1, threads=1)
    path = planner.initial_paths()[0]
    t, X = path.junctions(8, sc.horizon)
    guide = PathGuide(planner.problem, path, sc.horizon)

    def run(**options):
        settings = replace(planner.settings.leapfrog, **options)
        return leapfrog(planner.problem, t, X, guide=guide, settings=settings, flow=planner.flow)

    without = run(max_refinements=0, final_retry_sweeps=0)  # (the retry rescues it as well)
    assert not without.success
    refined = run()
    assert refined.success, refined.message
    qs = [h.q for h in refined.history]
    assert any(b == 2 * a for a, b in zip(qs, qs[1:], strict=False))  # a level was refined
    assert refined.cost_increases == 0
    v = validate(planner.problem, 0.0, sc.start, sc.horizon, sc.goal, refined.costate0)
    assert v.end_state_error <= 1e-8


def test_failed_final_solves_are_retried_after_more_sweeps_at_the_last_level():
    """Random scenario 250 of seed 1, classical Newton, one initial path: q = 4 was left at a
    costate jump of 0.05, and simple and multiple shooting over the whole horizon both diverged
    from there (measured). Sweeping q = 4 on brings the jump down, and simple shooting converges."""
    sc = generate_one(GeneratorSpec(n=500, seed=1, obstacles=(3, 10)), 250)
    planner = Planner(sc, method=NM, initial_paths=1, threads=1)
    path = planner.initial_paths()[0]
    t, X = path.junctions(planner.settings.leapfrog.partitions, sc.horizon)
    guide = PathGuide(planner.problem, path, sc.horizon)
    settings = replace(planner.settings.leapfrog, final_retry_sweeps=0, final_least_squares=0)
    # the path alone (a plan would go on to paths at a wider margin, and converge)
    without = leapfrog(planner.problem, t, X, guide=guide, settings=settings, flow=planner.flow)
    assert not without.success and "final solve failed" in without.message
    # (Levenberg-Marquardt, the default after Newton's multiple shooting fails, converges there
    # without the retry: the retry is tested without it.)
    trust = replace(settings, final_least_squares=LeapfrogSettings().final_least_squares)
    lm = leapfrog(planner.problem, t, X, guide=guide, settings=trust, flow=planner.flow)
    assert lm.success and lm.final_solver == "multiple-shooting"
    assert len(lm.history) == len(without.history)
    r = plan(sc, method=NM, initial_paths=1, threads=1, final_least_squares=0)
    assert r.initial_path == path.label
    assert r.success, r.message
    assert r.final_solver == "shooting" and "after the final solves had failed" in r.message
    retry = r.history[len(without.history) :]
    assert 0 < len(retry) <= LeapfrogSettings().final_retry_sweeps
    assert all(h.q == 4 for h in retry)
    # the same sweeps up to the first final solves
    assert [h.cost for h in r.history[: len(without.history)]] == [h.cost for h in without.history]
    costs = np.array([r.initial_cost] + [h.cost for h in r.history])
    assert np.all(np.diff(costs) <= 1e-12 * costs[:-1]) and r.cost_increases == 0
    assert r.end_state_error <= 1e-8


def test_a_run_that_ends_at_its_fewest_arcs_also_sweeps_on_when_the_final_solves_fail():
    """The same path with ``fewest_arcs = 4`` (as a long route keeps its arcs short): the run's
    last level is q = 4, not q = 2, and the final solves fail from it as they did above. That
    level is swept on too, and the final solve converges (without: failed)."""
    sc = generate_one(GeneratorSpec(n=500, seed=1, obstacles=(3, 10)), 250)
    planner = Planner(sc, method=NM, initial_paths=1, threads=1)
    path = planner.initial_paths()[0]
    t, X = path.junctions(8, sc.horizon)
    guide = PathGuide(planner.problem, path, sc.horizon)

    def run(**options):
        settings = replace(
            planner.settings.leapfrog, fewest_arcs=4, final_least_squares=0, **options
        )
        return leapfrog(planner.problem, t, X, guide=guide, settings=settings, flow=planner.flow)

    without = run(final_retry_sweeps=0)
    assert not without.success and "final solve failed" in without.message
    assert without.history[-1].q == 4
    r = run()
    assert r.success, r.message
    assert "after the final solves had failed" in r.message
    retry = r.history[len(without.history) :]
    assert retry and all(h.q == 4 for h in retry)
    assert [h.cost for h in r.history[: len(without.history)]] == [h.cost for h in without.history]
    v = validate(planner.problem, 0.0, sc.start, sc.horizon, sc.goal, r.costate0)
    assert v.end_state_error <= 1e-8


# --------------------------------------------------------------------------- initial path


def test_initial_segments_go_to_continuation_before_the_affine_guess(monkeypatch):
    """On the initial path, a segment whose warm guess and path costate fail at the full weight
    is solved next by continuation (its first solve at weight 0), not from the affine guess at
    the full weight. Paper case 4's second initial path has such segments."""
    import leapfrog_planner.planning.leapfrog.local as lf

    calls = []
    real = lf.LocalShooter.__call__

    def spy(self, t0, x0, t1, x1, guess=None):
        r = real(self, t0, x0, t1, x1, guess)
        calls.append((self.problem.penalty.weight, guess is None, r.success))
        return r

    monkeypatch.setattr(lf.LocalShooter, "__call__", spy)
    planner = Planner(CASES[4].name, threads=1)
    sc, W = planner.scenario, planner.problem.penalty.weight
    path = planner.initial_paths()[1]
    t, X = path.junctions(8, sc.horizon)
    guide = PathGuide(planner.problem, path, sc.horizon)
    settings = LeapfrogSettings(max_sweeps=1)
    run = leapfrog(planner.problem, t, X, guide=guide, flow=planner.flow, settings=settings)
    assert run.initial_cost < np.inf
    fit, solved = [], 0
    for c in calls:  # the initial path's calls: until its 8 segments are solved at weight W
        fit.append(c)
        solved += c[0] == W and c[2]
        if solved == 8:
            break
    assert fit[0] == (W, False, True)  # the first segment: the path's costate
    # Failed attempts at the full weight (warm, then the path's costate) go to continuation.
    failed = [k for k, c in enumerate(fit) if c == (W, False, False)]
    assert len(failed) >= 2
    assert any(fit[k + 1][0] == 0.0 for k in failed)
    assert all(fit[k + 1][0] in (0.0, W) for k in failed)
    assert not any(c[1] for c in fit if c[0] == W)  # never the affine guess at the full weight
    # Without a guide the first segment starts from the affine guess, as the paper's does.
    calls.clear()
    leapfrog(planner.problem, t, X, flow=planner.flow, settings=settings)
    assert calls[0] == (W, True, True)


# --------------------------------------------------------------------------- two-arc attempt


def test_two_arc_attempts_reach_the_same_optimum_with_less_work():
    """Paper case 3, MNM, one initial path: local problems whose warm start fails are solved as
    two arcs through their junction. Same optimum as with the paper's local simple shooting
    only, and (measured) about half the flow evaluations, since continuation is rarely needed."""
    runs = {
        flag: Planner(
            CASES[3].name, initial_paths=1, extra_paths=0, threads=1, two_arc_attempt=flag
        ).plan()
        for flag in (True, False)
    }
    for r in runs.values():
        assert r.status == "converged" and r.end_state_error <= 1e-8
    assert rel(runs[True].cost, runs[False].cost) <= 1e-8
    assert runs[True].f_evals < 0.75 * runs[False].f_evals


def _multiple_shooting_calls(monkeypatch, run) -> list:
    """The arguments of every multiple-shooting solve made by ``run()``."""
    from leapfrog_planner.planning.leapfrog import final, local

    calls = []
    real = local.solve_multiple_shooting

    def spy(system, w0, method, settings, compiled):
        calls.append((system, np.array(w0, dtype=float), method, settings))
        return real(system, w0, method, settings, compiled)

    for module in (local, final):  # the two-arc attempts and the final fallback
        monkeypatch.setattr(module, "solve_multiple_shooting", spy)
    run()
    monkeypatch.undo()
    return calls


def test_compiled_multiple_shooting_is_the_python_loop_bit_for_bit(monkeypatch):
    """The two-arc attempts of paper case 3 (one path; NM, MNM, NLEQ-ERR; converging and failing)
    and the final multiple-shooting fallback of paper case 4's third path (q = 4, coarse then
    polished) run as one compiled call each; the shared Python loop on the same system is the
    reference. Statuses, messages, counts, iterates and histories are identical, bit for bit."""
    from leapfrog_planner.bvp.multiple_shooting import solve_multiple_shooting
    from leapfrog_planner.roots import solve_root

    calls = []
    for method in (NM, MNM, "nleq-err"):
        calls += _multiple_shooting_calls(
            monkeypatch,
            lambda m=method: Planner(CASES[3].name, method=m, initial_paths=1, threads=1).plan(),
        )
    planner = Planner(CASES[4].name, threads=1)
    t, X = planner.initial_paths()[2].junctions(8, planner.scenario.horizon)
    final = _multiple_shooting_calls(
        monkeypatch, lambda: leapfrog(planner.problem, t, X, flow=planner.flow)
    )
    assert [c[0].q for c in final] == [4, 4]
    outcomes = set()
    for system, w0, method, settings in calls + final:
        with np.errstate(over="ignore", invalid="ignore"):
            a = solve_multiple_shooting(system, w0, method, settings)
            b = solve_root(system, w0, method, settings)
        assert (a.status, a.message, a.iterations, a.f_evals, a.jac_evals) == (
            b.status, b.message, b.iterations, b.f_evals, b.jac_evals,
        )  # fmt: skip
        for name in ("x", "F", "residual_norms", "step_sizes"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        outcomes.add((system.q, str(a.status)))
    assert {(2, "converged"), (4, "converged")} <= outcomes
    assert any(q == 2 and status != "converged" for q, status in outcomes), outcomes


@pytest.mark.parametrize("method", [NM, MNM])
@pytest.mark.parametrize("case", [1, 3])
def test_the_compiled_local_newton_changes_nothing_but_time(case, method):
    """Leapfrog with every simple and multiple shooting in the shared Python loop, against the
    default (NM and MNM compiled): same sweeps, iterations, evaluations (both loops evaluate F
    alone where convergence is predicted) and the same optimum."""
    s = LeapfrogSettings()
    python = {
        "shooting": replace(s.shooting, compiled=False),
        "final_shooting": replace(s.final_shooting, compiled=False),
    }
    runs = [
        Planner(CASES[case].name, method=method, initial_paths=1, threads=1, **kw).plan()
        for kw in ({}, python)
    ]
    fast, ref = runs
    assert fast.status == ref.status == "converged"
    assert [h.q for h in fast.history] == [h.q for h in ref.history]
    assert fast.newton_iterations == ref.newton_iterations
    assert fast.f_evals == ref.f_evals
    assert fast.cost == ref.cost


def test_the_python_loop_does_the_compiled_sweeps_work_where_warm_attempts_fail_again():
    """A random layout (general preset, seed 1, #94) where sweeps pose local problems that
    failed before: the compiled sweep tries each warm guess before the sweep's memory of
    failures is asked, and so must the Python loop (which runs while the compiled loops
    compile, and for methods they do not fuse). The same answer, evaluations and iterations,
    bit for bit (it made 9 fewer evaluations when the memory was asked first)."""
    s = LeapfrogSettings()
    python = {
        "shooting": replace(s.shooting, compiled=False),
        "final_shooting": replace(s.final_shooting, compiled=False),
    }
    task = generate_one(GeneratorSpec.preset("general", n=95, seed=1), 94)
    fast, ref = (Planner(task, **kw).plan() for kw in ({}, python))
    assert fast.status == ref.status == "converged"
    assert (fast.f_evals, fast.newton_iterations) == (ref.f_evals, ref.newton_iterations)
    assert fast.cost == ref.cost


def _sweeps_fused_and_python(monkeypatch, run):
    """``run(fused_sweeps=...)`` with the compiled warm sweep and with every junction from
    Python, each with its counted integrator work."""
    from leapfrog_planner.bvp.shooting import LocalShooter
    from leapfrog_planner.experiments.profiling import count_work

    calls = []
    kernel = LocalShooter.warm_sweep
    monkeypatch.setattr(
        LocalShooter, "warm_sweep", lambda self, *a: calls.append(1) or kernel(self, *a)
    )
    out = []
    for fused in (True, False):
        calls.clear()
        out.append(count_work(lambda fused=fused: run(fused_sweeps=fused)))
        assert bool(calls) == fused  # the compiled sweep ran, or not at all
    return out


def _same_sweeps(a, b):
    assert len(a) == len(b) > 0
    for ha, hb in zip(a, b, strict=True):
        assert (ha.t == hb.t).all() and (ha.X == hb.X).all()
        assert ha.cost == hb.cost and ha.max_costate_jump == hb.max_costate_jump
        assert (ha.newton_iterations, ha.f_evals, ha.failures, ha.rejected) == (
            hb.newton_iterations,
            hb.f_evals,
            hb.failures,
            hb.rejected,
        )


@pytest.mark.parametrize("method", [NM, MNM, "nleq-err"])
def test_the_compiled_warm_sweep_is_the_python_sweep_bit_for_bit(monkeypatch, method):
    """Paper case 3 (one path): its sweeps have warm attempts that fail and go on to two arcs
    and to continuation from Python, between compiled stretches. Every sweep record, the
    answer and the integrator work are identical with and without the compiled sweep."""
    fast, ref = _sweeps_fused_and_python(
        monkeypatch,
        lambda **kw: Planner(CASES[3].name, method=method, initial_paths=1, threads=1, **kw).plan(),
    )
    _same_sweeps(fast.value.history, ref.value.history)
    assert (fast.value.costate0 == ref.value.costate0).all()
    assert fast.value.cost == ref.value.cost
    assert (fast.steps, fast.integrations, fast.jacobian_calls) == (
        ref.steps,
        ref.integrations,
        ref.jacobian_calls,
    )


def test_the_compiled_warm_sweep_keeps_failures_and_rejections(monkeypatch):
    """From the straight chord through case 2's obstacles (q = 4) a local problem fails and
    another extremal is rejected as dearer: the compiled sweep hands both back alike."""
    planner = Planner(CASES[2].name)
    t, X = straight_junctions(planner.scenario, 4)
    fast, ref = _sweeps_fused_and_python(
        monkeypatch,
        lambda **kw: leapfrog(planner.problem, t, X, settings=LeapfrogSettings(partitions=4, **kw)),
    )
    assert sum(h.failures for h in fast.value.history) > 0
    assert sum(h.rejected for h in fast.value.history) > 0
    _same_sweeps(fast.value.history, ref.value.history)
    assert (fast.value.costate0 == ref.value.costate0).all()
    assert fast.steps == ref.steps and fast.integrations == ref.integrations


# --------------------------------------------------------------------------- the rule for q


def _rec(cost, jump=1.0, failures=0):
    return SweepRecord(1, 8, cost, jump, 0, 0, failures, 0, 0.0, np.zeros(9), np.zeros((9, 3)))


def test_next_level_is_a_pure_rule_of_the_sweep_record():
    """Without integrating anything: halve when settled, stay while progressing, refine a
    level that ends with failures (at most max_refinements times), and after refinements ask
    for ten times less decrease per refinement."""
    from leapfrog_planner.planning.leapfrog import Level, LevelState, next_level

    s = LeapfrogSettings()
    fresh = LevelState()
    # 1% decrease: progress, stay; 0.01%: settled, halve; a tiny jump settles too.
    assert next_level(_rec(99.0), 100.0, fresh, s) == (Level.STAY, LevelState(1, 0, 0))
    assert next_level(_rec(99.99), 100.0, fresh, s) == (Level.HALVE, LevelState())
    assert next_level(_rec(90.0, jump=1e-7), 100.0, fresh, s)[0] is Level.HALVE
    # Settled but a local problem failed: stay once, then (two stalls) refine.
    move, state = next_level(_rec(99.99, failures=1), 100.0, fresh, s)
    assert (move, state) == (Level.STAY, LevelState(1, 1, 0))
    assert next_level(_rec(99.99, failures=1), 100.0, state, s) == (
        Level.REFINE,
        LevelState(0, 0, 1),
    )
    # Refinements are spent: halve instead.
    spent = LevelState(1, 1, s.max_refinements)
    assert next_level(_rec(99.9999, failures=1), 100.0, spent, s)[0] is Level.HALVE
    # After one refinement, a 0.05% decrease is progress (the bar is 0.01%).
    assert next_level(_rec(99.95), 100.0, LevelState(0, 0, 1), s)[0] is Level.STAY
    # The level's sweep budget ends it whatever the progress.
    last = LevelState(s.sweeps_per_level - 1, 0, 0)
    assert next_level(_rec(50.0), 100.0, last, s)[0] is Level.HALVE
    # A level of 8 arcs whose halving would keep fewer than fewest_arcs ends the sweeps.
    assert next_level(_rec(99.99), 100.0, fresh, replace(s, fewest_arcs=4))[0] is Level.HALVE
    assert next_level(_rec(99.99), 100.0, fresh, replace(s, fewest_arcs=5)) == (
        Level.FINAL,
        LevelState(),
    )


def test_a_sweep_that_moved_no_junction_ends_its_level():
    """Every local problem failed (or was rejected): the next sweep would repeat it, so the
    level ends at once, refined while refinements are left, else halved."""
    from leapfrog_planner.planning.leapfrog import Level, LevelState, next_level
    from leapfrog_planner.planning.leapfrog.levels import idle

    s = LeapfrogSettings()
    stuck = _rec(100.0, failures=7)  # q = 8: seven local problems, all failed
    assert idle(stuck) and not idle(_rec(100.0, failures=6)) and not idle(_rec(100.0))
    assert next_level(stuck, 100.0, LevelState(), s) == (Level.REFINE, LevelState(0, 0, 1))
    spent = LevelState(0, 0, s.max_refinements)
    assert next_level(stuck, 100.0, spent, s)[0] is Level.HALVE
    # one failure short of idle, and settled: the level sweeps once more, as before
    assert next_level(_rec(100.0, failures=6), 100.0, LevelState(), s)[0] is Level.STAY


class _Forgetful(dict):
    """A memory that never holds what is asked for, and counts the questions it was asked again."""

    repeats = 0

    def __contains__(self, key):
        _Forgetful.repeats += dict.__contains__(self, key)
        return False

    def get(self, key, default=None):
        _Forgetful.repeats += dict.__contains__(self, key)
        return default


def test_a_local_problem_that_failed_is_not_solved_again_with_the_same_data(monkeypatch):
    """Random scenario 13 of seed 1: stuck junctions pose the same failing local problems sweep
    after sweep. Skipping those (every strategy is deterministic) changes nothing but the work."""
    from leapfrog_planner.planning.leapfrog import local

    sc = generate_one(GeneratorSpec(n=500, seed=1), 13)
    remembering = plan(sc, threads=1)
    init = local.LocalSolver.__init__

    def forgetful(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self._failed = _Forgetful()

    monkeypatch.setattr(local.LocalSolver, "__init__", forgetful)
    _Forgetful.repeats = 0
    trying = plan(sc, threads=1)
    assert _Forgetful.repeats >= 10  # the same failing problem, posed again
    assert trying.status == remembering.status and trying.cost == remembering.cost
    assert [h.cost for h in trying.history] == [h.cost for h in remembering.history]
    pairs = zip(trying.history, remembering.history, strict=True)
    assert all(np.array_equal(a.X, b.X) for a, b in pairs)
    assert trying.f_evals > remembering.f_evals


# --------------------------------------------------------------------------- a bound known late


class _LateBound:
    """A :class:`LateBound` that is not known until ``after`` questions have been asked."""

    def __init__(self, bound: float, after: int):
        self.bound, self.after, self.asked = bound, after, 0

    def value(self):
        self.asked += 1
        return self.bound if self.asked > self.after else None

    def wait(self):
        return self.bound


def _same_run(a, b):
    assert (a.status, a.message, a.initial_cost) == (b.status, b.message, b.initial_cost)
    assert (a.newton_iterations, a.f_evals, a.cost_increases) == (
        b.newton_iterations, b.f_evals, b.cost_increases,
    )  # fmt: skip
    assert [h.cost for h in a.history] == [h.cost for h in b.history]
    assert (a.arcs is None) == (b.arcs is None)
    if a.arcs is not None:
        np.testing.assert_array_equal(a.arcs.lam0, b.arcs.lam0)
        np.testing.assert_array_equal(a.arcs.X, b.arcs.X)
    if a.costate0 is not None:
        np.testing.assert_array_equal(a.costate0, b.costate0)


@pytest.mark.parametrize("after", [0, 2, 5, 1000])
def test_a_bound_known_late_stops_a_run_as_if_known_from_its_start(case1, after):
    """A run raced against others in other threads learns their bound when they end: it is
    abandoned at the first sweep above the bound, with what it had then, whenever it learns
    it (after 0, 2 or 5 sweeps, or only before the final solve)."""
    from leapfrog_planner.planning.leapfrog.stop import FIRST_JUDGED_SWEEP

    planner, path = case1
    t, X = path.junctions(8, 1.0)

    def run(stop_above):
        return leapfrog(planner.problem, t, X, flow=planner.flow, stop_above=stop_above)

    free = run(math.inf)
    costs = [h.cost for h in free.history]
    assert len(costs) >= 8 and all(np.diff(costs) < 0)
    within = 0.5 * (costs[4] + costs[5])  # Leapfrog's cost falls: above it from the first
    abandoned = run(within)
    assert abandoned.status.value == "abandoned"
    assert len(abandoned.history) == FIRST_JUDGED_SWEEP  # (the first sweep is never judged)
    _same_run(run(_LateBound(within, after)), abandoned)
    _same_run(run(_LateBound(2.0 * costs[0], after)), free)  # never above it


def test_no_refinement_is_begun_that_would_end_past_the_time_limit(monkeypatch):
    """A refined level of multiple shooting (twice the arcs) costs at least twice the level
    before it: one that would end past the plan's time limit is not begun (on 100 arcs and
    more, a refinement begun just before the limit ran 3 s past it). Here each level takes
    25 ms an arc pair and fails: 4 arcs (50 ms), 8 (100 ms), and 16 arcs (200 ms) would end
    past a limit 0.25 s away."""
    import time

    import leapfrog_planner.planning.leapfrog.final as lf
    from leapfrog_planner.planning.leapfrog.local import LocalSolver

    arcs = []
    one = np.ones(1)
    stalled = lf.RootResult(np.zeros(3), one, lf.RootStatus.STALLED, "stalled", 1, 1, 1, one, one)

    def slow(system, *args):
        arcs.append(system.q)
        time.sleep(0.0125 * system.q)
        return stalled

    monkeypatch.setattr(lf, "solve_multiple_shooting", slow)
    planner = Planner(CASES[4].name, threads=1)
    settings = LeapfrogSettings(final="multiple-shooting", final_least_squares=0)
    local = LocalSolver(planner.problem, planner.flow, settings)
    ends = (planner.scenario.start, planner.scenario.goal, 0.0, planner.scenario.horizon)
    t, X = planner.initial_paths()[2].junctions(4, planner.scenario.horizon)
    level = Junctions(t, X, np.ones((4, 3)), np.ones((4, 3)), np.zeros(4))
    start = time.perf_counter()
    solver = lf.FinalSolver(local, planner.flow, *ends, deadline=start + 0.25)
    found = solver.solve(np.ones(3), level)
    assert not found.success and arcs == [4, 8]
    assert time.perf_counter() < start + 0.25
    arcs.clear()
    lf.FinalSolver(local, planner.flow, *ends).solve(np.ones(3), level)
    assert arcs == [4, 8, 16]  # without a limit
