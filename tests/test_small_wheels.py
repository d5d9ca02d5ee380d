"""A differential drive with small wheels (a TurtleBot3: r = 0.033, b = 0.16): its costates
are about 1/r^2 times the unicycle's, and the final multiple shooting's polish at rtol 1e-12
then stalls at |F| of 1e-10 to 1e-9, the rounding of its defects (see
``bvp.multiple_shooting.within_costate_scale``)."""

from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.bvp.multiple_shooting import MultipleShootingSystem, within_costate_scale
from leapfrog_planner.planning.planner import Planner
from leapfrog_planner.planning.scenario import Scenario
from leapfrog_planner.planning.search import raised_weight
from leapfrog_planner.roots import RootResult, RootStatus

MAPS = Path(__file__).parent / "data" / "maps"

TB3 = {
    "name": "tb3-burger-diff-drive",
    "horizon": 24.0,
    "start": [1.7094907422577208, 1.366613879969421, 0.3593083756744502],
    "goal": [-1.733228488614012, 0.5220608270906197, -2.5982682253559073],
    "robot": {"model": "diff-drive", "wheel_radius": 0.033, "axle_length": 0.16, "radius": 0.2},
    "penalty": {"weight": 1.0, "exponent": 2},
    "map": {"file": str(MAPS / "tb3_sandbox.yaml"), "unknown": "occupied"},
}


def _stalled(norm: float, costate: float) -> tuple[RootResult, MultipleShootingSystem]:
    t = np.array([0.0, 1.0, 2.0])
    ms = MultipleShootingSystem(None, t, np.zeros(3), np.ones(3))
    x = np.concatenate([[costate, 0.0, 0.0], [0.5, 0.5, 0.5, costate, 0.0, 0.0]])
    F = np.full(x.size, norm / np.sqrt(x.size))
    root = RootResult(
        x=x, F=F, status=RootStatus.STALLED, message="stalled", iterations=9, f_evals=20,
        jac_evals=9, residual_norms=np.array([1e-6, norm]), step_sizes=np.ones(1),
    )  # fmt: skip
    return root, ms


def test_a_polish_stalled_within_the_tolerance_times_the_costates_counts_as_converged():
    root, ms = _stalled(2e-10, 300.0)
    assert within_costate_scale(root, ms, 1e-10).success
    for norm, costate in [(2e-10, 0.9), (1e-7, 300.0), (np.nan, 300.0)]:
        root, ms = _stalled(norm, costate)
        assert within_costate_scale(root, ms, 1e-10) is root  # left failed


@pytest.mark.slow  # about 25 s warm (a plan of 20 runs), more when the kernels compile
def test_a_turtlebot3_on_its_map_finds_a_clear_extremal():
    # Once every extremal passed through a wall: the polishes of two runs at weight 1 and of
    # the only extremal at weight 4 stalled at 1e-10 to 7e-10, so the weight was raised no
    # further than 4 ("collides"). Then: cost 861.955 at weight 64, clearance 0.071. With the
    # raises by the wheels' effort (12.2, 150, 1836): cost 852.784 at weight 150.
    result = Planner(TB3).plan()
    assert result.status == "converged"
    assert result.weight <= 150.0
    assert result.min_clearance > 0.0
    assert result.end_state_error <= 1e-8
    assert result.max_dH_du <= 1e-8
    assert result.cost <= 862.0


def test_an_extremal_through_a_disc_is_raised_by_the_wheels_effort_until_one_clears():
    """The TurtleBot3's wheels pay 1836 times the unicycle's effort for the same motion
    (``2 / r^2``), so at weight 1 its extremals drive through a disc, and so they did at the
    unicycle's raises (4, 16, 64: ``collides``). The raises grow by ``1836^(1/3)`` instead:
    the answer is a clear extremal at weight 1836^(2/3) = 150, and the message says so."""
    sc = Scenario(
        name="tb3-disc", horizon=4.0, start=np.zeros(3), goal=np.array([2.0, 0.0, 0.0]),
        obstacles=np.array([[1.0, 0.05, 0.3]]), model="diff-drive",
        model_parameters={"wheel_radius": 0.033, "axle_length": 0.16}, weight=1.0,
    )  # fmt: skip
    scale = 2.0 / 0.033**2
    assert [raised_weight(sc, k) for k in range(4)] == pytest.approx(
        [1.0, scale ** (1 / 3), scale ** (2 / 3), scale], rel=1e-9
    )
    result = Planner(sc).plan()
    assert result.status == "converged" and result.min_clearance > 0.0
    assert 1.0 < result.weight <= scale
    assert f"raised from 1 to {result.weight:g}" in result.message
    assert result.end_state_error <= 1e-8 and result.max_dH_du <= 1e-8


def test_the_unicycle_and_the_car_keep_raises_of_four():
    for model, n in [("unicycle", 3), ("car", 4), ("diff-drive", 3)]:
        sc = Scenario(
            name="x", horizon=1.0, start=np.zeros(n), goal=np.ones(n), model=model, weight=1.0
        )
        assert [raised_weight(sc, k) for k in range(4)] == [1.0, 4.0, 16.0, 64.0]


def test_a_raised_answer_says_what_the_scenario_weight_gave():
    """The message of an answer at a raised weight: what its own path's extremal did at the
    scenario's weight, or, for a path first run at the raise (ranked there), what they all did."""
    from types import SimpleNamespace

    from leapfrog_planner.planning import answer

    class Run(SimpleNamespace):
        def same_line(self, other):
            return self.line == other.line

    def run(line, raises, weight, inside=None):
        clear = None if inside is None else SimpleNamespace(clearance=np.array([-inside]))
        return Run(line=line, raises=raises, weight=weight, extremal=clear is not None,
                   validation=clear)  # fmt: skip

    runs = [run(1, 0, 1.0, 0.2), run(2, 0, 1.0), run(1, 1, 12.2, -0.01), run(3, 1, 12.2, -0.02)]
    said = answer._raised(runs[2], runs, 0.0)
    assert said == (
        "the obstacle weight was raised from 1 to 12.2 to clear the obstacles"
        " (at 1 the extremal passed 0.2 inside one)"
    )
    said = answer._raised(runs[3], runs, 0.0)
    assert said.endswith(
        "(at 1 every extremal found passed through an obstacle or too close to one)"
    )
