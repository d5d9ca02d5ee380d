"""Units of time: the horizon enters the problem only through ``W T^2``, and the planner
converges on one layout from T = 0.1 to T = 100.

For a control-affine model with a quadratic control cost, ``t = T s`` and ``u = u~ / T`` turn
``int_0^T (|u|^2 / 2 + P) dt`` into ``(1 / T) int_0^1 (|u~|^2 / 2 + T^2 P) ds``: the problem at
horizon ``T`` and weight ``W`` is the problem at horizon 1 and weight ``W T^2``, with the same
path and ``1 / T`` times the cost.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner import plan
from leapfrog_planner.planning.planner import penalty_margin
from leapfrog_planner.planning.scenario import load_scenario

DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize("T", [0.5, 3.0])
def test_horizon_is_weight_times_T_squared(T):
    sc = load_scenario("paper-case-1")
    long = plan(replace(sc, horizon=T))
    unit = plan(replace(sc, horizon=1.0, weight=sc.weight * T * T))
    assert long.success and unit.success
    assert long.cost == pytest.approx(unit.cost / T, rel=1e-8)
    s = np.linspace(0.0, 1.0, 41)
    for k in range(3):
        a = np.interp(s * T, long.trajectory.t, long.trajectory.x[:, k])
        b = np.interp(s, unit.trajectory.t, unit.trajectory.x[:, k])
        np.testing.assert_allclose(a, b, atol=1e-3)  # linear interpolation of 1001 samples


@pytest.mark.parametrize("name", ["units-a", "units-b"])
@pytest.mark.parametrize("T", [0.1, 1.0, 10.0, 100.0])
def test_same_layout_converges_from_tenth_to_hundred(name, T):
    """units-a needs the obstacle weight raised 64-fold at T = 0.1 (the penalty is 100 times
    weaker against the control energy); units-b needs the penalty-aware margin at T = 100."""
    sc = replace(load_scenario(DATA / f"{name}.toml"), horizon=T)
    r = plan(sc)
    assert r.success, r.message
    assert r.min_clearance >= 0.0


def test_penalty_margin_grows_with_the_horizon():
    sc = load_scenario(DATA / "units-b.toml")
    margins = [penalty_margin(replace(sc, horizon=T)) for T in (0.01, 1.0, 10.0, 100.0)]
    assert margins[0] == 0.0  # the penalty never exceeds the energy of so fast a drive
    assert margins[1] < margins[2] < margins[3]
    r = float(np.mean(sc.obstacles[:, 2]))
    assert margins[3] < r  # ln(W / e)^(1/4) < 2 for any sane weight and horizon
    assert penalty_margin(replace(sc, obstacles=np.zeros((0, 3)))) == 0.0
    assert penalty_margin(replace(sc, weight=0.0)) == 0.0
