"""Tests of the direct method with the final time free (``direct_free.solve_direct_free``).

In free space between two poses on one line the optimum drives straight at constant speed, and
RK4 is exact for constant controls along a line, so the transcription meets the closed form on
any mesh (derived in the module's docstring): unicycle ``T* = D / sqrt(2k)``, ``J* = D sqrt(2k)``;
diff-drive of wheel radius ``r``: ``T* = D / (r sqrt(k))``, ``J* = 2 D sqrt(k) / r``.

With a disc centred on that line the straight path is still an extremal (by symmetry), now at a
varying speed: the problem is autonomous and ``T`` free, so the Hamiltonian vanishes, which for
the unicycle on a line is ``v^2 / 2 = k + P(x)``; then ``J = integral of sqrt(2 (k + P)) dx``
and ``T = integral of dx / sqrt(2 (k + P))`` along the line, a quadrature to check against.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

from scipy.integrate import quad  # noqa: E402

from leapfrog_planner.errors import ScenarioError, SettingsError  # noqa: E402
from leapfrog_planner.planning.direct import (  # noqa: E402
    DirectTranscription,
    richardson,
    solve_direct,
)
from leapfrog_planner.planning.direct_free import solve_direct_free  # noqa: E402

REFERENCE = Path(__file__).parent / "data" / "free_time_direct.json"


def rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


@pytest.mark.parametrize("k", [0.1, 1.0, 10.0])
@pytest.mark.parametrize("distance", [1.0, 3.5])
def test_unicycle_closed_form(k, distance):
    result = solve_direct_free(
        [0, 0, 0], [distance, 0, 0], [], k, horizon_guess=1.0, intervals=20, multistart=False
    )
    assert result.success, result.message
    assert rel(result.horizon, distance / math.sqrt(2 * k)) < 1e-6
    assert rel(result.cost, distance * math.sqrt(2 * k)) < 1e-6
    assert result.t[0] == 0.0 and result.t[-1] == result.horizon
    np.testing.assert_allclose(result.controls[:, 0], math.sqrt(2 * k), rtol=1e-6)
    np.testing.assert_allclose(result.controls[:, 1], 0.0, atol=1e-8)
    assert result.end_state_error < 1e-8


def test_multistart_finds_the_closed_form():
    """The built-in guesses (arcs, coarse mesh then refined) end on the straight optimum."""
    k, distance = 2.0, 2.0
    result = solve_direct_free([0, 0, 0], [distance, 0, 0], [], k, horizon_guess=3.0, intervals=60)
    assert result.success, result.message
    assert rel(result.horizon, distance / math.sqrt(2 * k)) < 1e-6
    assert rel(result.cost, distance * math.sqrt(2 * k)) < 1e-6


def test_through_a_disc_on_the_line_matches_the_quadrature():
    """A disc centred on the line, time dear enough (k = 10) that the straight path through it
    is worth it: the speed follows v^2 / 2 = k + P; meshes 100 and 200, Richardson-extrapolated,
    meet the quadratures of J and T."""
    k, distance, (cx, radius, weight) = 10.0, 1.5, (0.75, 0.2, 100.0)

    def penalty(x):
        return weight * math.exp(-((((x - cx) / radius) ** 2) ** 2))

    cost = quad(lambda x: math.sqrt(2 * (k + penalty(x))), 0, distance, points=[cx])[0]
    horizon = quad(lambda x: 1 / math.sqrt(2 * (k + penalty(x))), 0, distance, points=[cx])[0]
    obstacles = [[cx, 0, radius]]
    coarse, fine = [
        solve_direct_free(
            [0, 0, 0],
            [distance, 0, 0],
            obstacles,
            k,
            horizon_guess=1.0,
            intervals=n,
            multistart=False,
        )
        for n in (100, 200)
    ]
    assert coarse.success and fine.success
    assert np.max(np.abs(fine.states[:, 1])) < 1e-9  # straight through the disc
    assert fine.min_clearance == pytest.approx(-radius)
    assert rel(richardson(coarse.cost, fine.cost), cost) < 1e-6
    assert rel(richardson(coarse.horizon, fine.horizon), horizon) < 3e-6


@pytest.mark.parametrize("radius", [0.5, 1.0])
def test_diff_drive_closed_form(radius):
    k, distance = 1.5, 2.0
    result = solve_direct_free(
        [0, 0, 0],
        [distance, 0, 0],
        [],
        k,
        horizon_guess=1.0,
        intervals=20,
        model="diff-drive",
        wheel_radius=radius,
        axle_length=0.3,
        multistart=False,
    )
    assert result.success, result.message
    assert rel(result.horizon, distance / (radius * math.sqrt(k))) < 1e-6
    assert rel(result.cost, 2 * distance * math.sqrt(k) / radius) < 1e-6
    np.testing.assert_allclose(result.controls, math.sqrt(k), rtol=1e-6)  # both wheels at v/r


@pytest.mark.parametrize("k", [0.3, 3.0])
def test_fixed_time_at_the_free_optimum_agrees(k):
    """At the free optimum's T, the fixed-T solve on the same mesh finds the same trajectory:
    its cost is the free cost less k T."""
    start, goal, obstacles = [0, 0, 0], [2, 0, 0], [[1.0, 0.1, 0.3]]
    free = solve_direct_free(start, goal, obstacles, k, horizon_guess=1.0, intervals=40)
    assert free.success, free.message
    fixed = solve_direct(start, goal, free.horizon, obstacles, intervals=40)
    assert fixed.success and fixed.horizon == free.horizon
    assert rel(fixed.cost, free.cost - k * free.horizon) < 1e-8
    np.testing.assert_allclose(fixed.states, free.states, atol=1e-5)


def test_the_horizon_bound_binds_and_is_reported():
    """T* = 2 / sqrt(2) ~ 1.41 lies above the bound 1: the solve stops there and says so."""
    result = solve_direct_free(
        [0, 0, 0],
        [2, 0, 0],
        [],
        1.0,
        horizon_guess=0.5,
        horizon_bounds=(0.1, 1.0),
        intervals=20,
        multistart=False,
    )
    assert result.success
    assert rel(result.horizon, 1.0) < 1e-6
    assert rel(result.cost, 1.0 + 2.0**2 / 2) < 1e-6  # k T + D^2 / (2 T) at T = 1
    assert "at a bound" in result.message


BAD = [
    ({"time_weight": 0.0}, ScenarioError, "time_weight: must be > 0"),
    ({"time_weight": -1.0}, ScenarioError, "time_weight: must be > 0"),
    ({"time_weight": math.nan}, ScenarioError, "time_weight: must be finite"),
    ({"time_weight": math.inf}, ScenarioError, "time_weight: must be finite"),
    ({"time_weight": "1"}, ScenarioError, "time_weight: expected a number"),
    ({"horizon_guess": 0.0}, SettingsError, "horizon_guess: must be > 0"),
    ({"horizon_guess": math.nan}, SettingsError, "horizon_guess: must be finite"),
    ({"horizon_guess": 5.0, "horizon_bounds": (1, 2)}, SettingsError, "horizon_guess: must lie"),
    ({"horizon_bounds": (2.0, 1.0)}, SettingsError, "horizon_bounds: need 0 < lo < hi"),
    ({"horizon_bounds": (1.0, 1.0)}, SettingsError, "horizon_bounds: need 0 < lo < hi"),
    ({"horizon_bounds": (0.0, 2.0)}, SettingsError, "horizon_bounds: need 0 < lo < hi"),
    ({"horizon_bounds": (0.5, math.inf)}, SettingsError, "horizon_bounds[1]: must be finite"),
    ({"horizon_bounds": (0.5,)}, SettingsError, "horizon_bounds: expected 2 numbers"),
]


@pytest.mark.parametrize(("change", "error", "text"), BAD)
def test_bad_input_one_line_errors(change, error, text):
    args = {"time_weight": 1.0, "horizon_guess": 1.0, "horizon_bounds": None, **change}
    k = args.pop("time_weight")
    with pytest.raises(error) as info:
        solve_direct_free([0, 0, 0], [1, 0, 0], [], k, intervals=4, multistart=False, **args)
    message = str(info.value)
    assert text in message and "\n" not in message


def test_fixed_transcription_refuses_a_price_of_time():
    transcription = DirectTranscription(0, 4)
    with pytest.raises(SettingsError, match="only for a free-time transcription"):
        transcription.solve([0, 0, 0], [1, 0, 0], 1.0, [], time_weight=1.0)
    with pytest.raises(SettingsError, match="free_time: expected True or False"):
        DirectTranscription(0, 4, free_time=1)


def test_fixed_solve_reports_its_horizon():
    result = solve_direct([0, 0, 0], [1, 0, 0], 2.5, [], intervals=10, multistart=False)
    assert result.horizon == 2.5 and result.t[-1] == 2.5


def test_reference_file_is_well_formed():
    """tests/data/free_time_direct.json (benchmarks/free_time_direct_reference.py): the four
    paper cases at k = 0.1, 1, 10, each with J = integral + k T, so J > k T; T shrinks and J
    grows as time gets dearer."""
    rows = json.loads(REFERENCE.read_text())
    keys = {"case", "k", "cost", "horizon", "cost_fine", "horizon_fine", "min_clearance"}
    assert len(rows) == 12 and all(set(row) == keys for row in rows)
    for case in {row["case"] for row in rows}:
        mine = sorted((row for row in rows if row["case"] == case), key=lambda row: row["k"])
        assert [row["k"] for row in mine] == [0.1, 1.0, 10.0]
        assert all(row["cost"] > row["k"] * row["horizon"] > 0 for row in mine)
        assert all(rel(row["cost"], row["cost_fine"]) < 1e-3 for row in mine)
        assert mine[0]["horizon"] > mine[1]["horizon"] > mine[2]["horizon"]
        assert mine[0]["cost"] < mine[1]["cost"] < mine[2]["cost"]


def test_reference_case_3_at_high_k_is_the_straight_quadrature():
    """Paper case 3 at k = 10 drives straight along its diagonal, through the disc on it (start
    and goal headings lie along it): its reference cost is the line's quadrature (as above)."""
    rows = json.loads(REFERENCE.read_text())
    row = next(r for r in rows if r["case"] == "paper-case-3" and r["k"] == 10)
    discs = np.array([[0.5, 0.5, 0.15], [0.2, 0.6, 0.1], [0.75, 0.3, 0.1]])

    def speed(s):  # along the diagonal from (0, 0) to (1, 1), s the arc length
        d2 = np.sum((s / math.sqrt(2) - discs[:, :2]) ** 2, axis=1) / discs[:, 2] ** 2
        return math.sqrt(2 * (10.0 + float(np.sum(100.0 * np.exp(-(d2**2))))))

    cost = quad(speed, 0, math.sqrt(2), points=[0.5 * math.sqrt(2)])[0]
    assert rel(row["cost"], cost) < 1e-6
    assert row["min_clearance"] == pytest.approx(-0.15, abs=1e-6)


def test_reference_case_1_scales_with_the_price_of_time():
    """Without discs a change of time scale maps the problems at k and c^2 k onto each other
    (J * c, T / c), in the transcription too: case 1's J grows as sqrt(k) and T falls as it."""
    rows = {r["k"]: r for r in json.loads(REFERENCE.read_text()) if r["case"] == "paper-case-1"}
    for k in (1.0, 10.0):
        scale = math.sqrt(k / 0.1)
        assert rel(rows[k]["cost"], scale * rows[0.1]["cost"]) < 1e-7
        assert rel(rows[k]["horizon"], rows[0.1]["horizon"] / scale) < 1e-7
        assert rows[k]["min_clearance"] is None
