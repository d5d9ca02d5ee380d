"""The map's smooth penalty field (world/field.py): its meaning (a disc's penalty), its smoothness
(gradient and Hessian against finite differences, no jump across the spline's knots, no kink in
a corridor), the map's yaw, and obstacles as data (a new map compiles nothing)."""

import math
from pathlib import Path

import numpy as np
import pytest

from leapfrog_planner.world import OccupancyMap
from leapfrog_planner.world.field import field_penalty_rows, field_penalty_terms, field_u
from leapfrog_planner.world.obstacle_map import ObstacleMap

W, N = 100.0, 2


def terms(om: ObstacleMap, xy, hessian=True) -> np.ndarray:
    xy = np.ascontiguousarray(np.asarray(xy, dtype=float).reshape(-1, 2))
    out = np.empty((xy.shape[0], 6))
    field_penalty_rows(xy, om.field, W, N, hessian, out)
    return out


def disc_map(radius_cells: int, h: float = 0.01, yaw: float = 0.0, centre=(0.3, -0.2)):
    """A map of ``h`` cells holding one disc (the cells whose centre lies inside it), its centre
    ``centre`` in the map's frame."""
    n = 2 * radius_cells + 80
    j, i = np.meshgrid(np.arange(n) + 0.5, np.arange(n) + 0.5)
    cx, cy = n / 2 + centre[0], n / 2 + centre[1]
    data = np.where(np.hypot(j - cx, i - cy) <= radius_cells, 100, 0).astype(np.int8)
    return OccupancyMap(data, h, (-n * h / 2, -n * h / 2, yaw)), (centre[0] * h, centre[1] * h)


def test_an_isolated_disc_gives_the_disc_penalty_where_it_matters():
    """A disc of radius R drawn into cells, with the length scale R and no footprint: the
    penalty's level sets lie where the disc's do, to 1% of R, wherever the penalty is between
    1e-3 W and W (the cells, taken as squares, can only place the edge to about half a cell:
    R = 64 cells here); there P itself is within 5% of the disc's at the edge."""
    R = 64
    occ, (cx, cy) = disc_map(R)
    h = occ.resolution
    om = ObstacleMap(occ, radius=0.0, length=R * h, unknown_is_occupied=False)
    rng = np.random.default_rng(1)
    ang = rng.uniform(-math.pi, math.pi, 4000)
    r = R * h * rng.uniform(0.8, 2.2, 4000)
    xy = np.column_stack([cx + r * np.cos(ang), cy + r * np.sin(ang)])
    u_disc = r / (R * h)
    u = np.array([field_u(x, y, om.field, False)[0] for x, y in xy])
    P_disc = W * np.exp(-(u_disc ** (2 * N)))
    matters = (P_disc > 1e-3 * W) & (P_disc < W)
    assert matters.sum() > 1000
    assert np.abs(u - u_disc)[matters].max() < 0.01
    edge = matters & (np.abs(u_disc - 1.0) < 0.05)
    P = terms(om, xy, hessian=False)[:, 0]
    assert np.abs(P / P_disc - 1.0)[edge].max() < 0.05


@pytest.fixture(scope="module")
def room():
    """A 4 x 3 m room at 5 cm with a wall at 20 degrees, a pillar and a corridor."""
    h = 0.05
    n_y, n_x = 60, 80
    j, i = np.meshgrid(np.arange(n_x) + 0.5, np.arange(n_y) + 0.5)
    x, y = j * h, i * h
    data = np.zeros((n_y, n_x), np.int8)
    data[(np.abs((y - 0.6) - np.tan(0.35) * (x - 0.5)) < 0.06) & (x < 2.0)] = 100
    data[np.hypot(x - 3.0, y - 2.2) < 0.2] = 100
    data[(np.abs(y - 2.6) < 0.1) & (x > 1.0) & (x < 2.4)] = 100
    data[(np.abs(y - 1.7) < 0.1) & (x > 1.0) & (x < 2.4)] = 100
    return ObstacleMap(OccupancyMap(data, h, (0.0, 0.0, 0.0)), radius=0.1, length=0.25)


def sample_points(om, n=3000, seed=2):
    rng = np.random.default_rng(seed)
    xy = np.column_stack([rng.uniform(0.1, 3.9, n * 4), rng.uniform(0.1, 2.9, n * 4)])
    P = terms(om, xy, hessian=False)[:, 0]
    return xy[(P > 1e-3 * W) & (P < 0.99 * W)][:n]


def test_gradient_and_hessian_match_finite_differences(room):
    xy = sample_points(room)
    t = terms(room, xy)
    eps = 1e-6
    for k, (dx, dy) in enumerate(((eps, 0.0), (0.0, eps))):
        plus = terms(room, xy + [dx, dy])
        minus = terms(room, xy - [dx, dy])
        grad = (plus[:, 0] - minus[:, 0]) / (2 * eps)
        assert np.abs(grad - t[:, 1 + k]).max() < 1e-6 * np.abs(t[:, 1:3]).max()
        hess = (plus[:, 1:3] - minus[:, 1:3]) / (2 * eps)
        want = t[:, [3, 4]] if k == 0 else t[:, [4, 5]]
        assert np.abs(hess - want).max() < 1e-5 * np.abs(t[:, 3:]).max()


def test_the_hessian_does_not_jump_across_the_knot_lines(room):
    """P is C2: on both sides of a line of spline nodes (1e-7 cell apart) the Hessian agrees to
    what its derivative gives over that step; a kink would leave an O(1) jump."""
    h = room.field.h
    xy = sample_points(room, 500)
    x_knot = room.field.x0 + np.round((xy[:, 0] - room.field.x0) / h) * h
    left = terms(room, np.column_stack([x_knot - 1e-7 * h, xy[:, 1]]))
    right = terms(room, np.column_stack([x_knot + 1e-7 * h, xy[:, 1]]))
    scale = np.abs(terms(room, xy)[:, 3:]).max()
    assert np.abs(left[:, 3:] - right[:, 3:]).max() < 1e-5 * scale


def test_no_kink_along_the_middle_of_a_corridor(room):
    """Between two walls the smoothed distance has no ridge: across the corridor's middle the
    second derivative stays of the size of the walls' own (a kink gives a spike of 1/h)."""
    ys = np.linspace(1.9, 2.4, 201)
    xy = np.column_stack([np.full_like(ys, 1.7), ys])
    t = terms(room, xy)
    mid = np.abs(ys - 2.15) < 0.03
    assert np.all(np.isfinite(t))
    assert np.abs(t[mid, 5]).max() < 0.5 * np.abs(t[:, 5]).max()
    # P rises smoothly towards both walls and has one minimum in between
    P = t[:, 0]
    k = int(np.argmin(P))
    assert abs(ys[k] - 2.15) < 0.03
    assert np.all(np.diff(P[: k + 1]) <= 1e-12) and np.all(np.diff(P[k:]) >= -1e-12)


def test_the_maps_yaw_is_honoured():
    """The same cells with the origin turned by 0.7 rad: the field at corresponding points is
    the same, its gradient and Hessian turned with it."""
    occ, _ = disc_map(8, h=0.05, centre=(2.3, -1.1))
    turned = OccupancyMap(occ.data, occ.resolution, (1.0, -2.0, 0.7))
    a, b = ObstacleMap(occ, 0.05), ObstacleMap(turned, 0.05)
    rng = np.random.default_rng(3)
    u, v = rng.uniform(20, 76, 300), rng.uniform(20, 76, 300)
    pa = np.column_stack(occ.grid_to_world(u, v))
    pb = np.column_stack(turned.grid_to_world(u, v))
    ta, tb = terms(a, pa), terms(b, pb)
    c, s = math.cos(0.7 - occ.origin[2]), math.sin(0.7 - occ.origin[2])
    Rm = np.array([[c, -s], [s, c]])
    assert np.allclose(ta[:, 0], tb[:, 0], rtol=1e-9, atol=1e-12)
    assert np.allclose(ta[:, 1:3] @ Rm.T, tb[:, 1:3], atol=1e-7 * np.abs(ta[:, 1:3]).max())
    Ha = ta[:, [3, 4, 4, 5]].reshape(-1, 2, 2)
    Hb = tb[:, [3, 4, 4, 5]].reshape(-1, 2, 2)
    assert np.allclose(Rm @ Ha @ Rm.T, Hb, atol=1e-6 * np.abs(Ha).max())


def test_beyond_the_map_the_outside_policy_holds():
    occ, _ = disc_map(4, h=0.05)
    far = np.array([[50.0, 50.0]])
    blocked = ObstacleMap(occ, 0.1, unknown_is_occupied=True)
    free = ObstacleMap(occ, 0.1, unknown_is_occupied=False)
    assert terms(blocked, far)[0, 0] == W and np.all(terms(blocked, far)[0, 1:] == 0)
    assert np.all(terms(free, far) == 0.0)


def test_a_new_map_compiles_nothing():
    """Obstacles are data: maps of other sizes, yaws and length scales use the compiled
    evaluator's one signature (per flag of want_hessian)."""
    first = ObstacleMap(disc_map(5, h=0.05)[0], 0.1)
    field_penalty_terms(0.1, 0.2, first.field, W, N, True)
    before = len(field_penalty_terms.signatures)
    for cells, yaw, length in ((9, 0.3, None), (3, -1.0, 0.5)):
        occ, _ = disc_map(cells, h=0.02, yaw=yaw)
        om = ObstacleMap(occ, 0.05, length)
        field_penalty_terms(0.1, 0.2, om.field, W, N, True)
    assert len(field_penalty_terms.signatures) == before


def test_length_scale_below_two_cells_is_refused():
    occ, _ = disc_map(4, h=0.05)
    with pytest.raises(ValueError, match="map.length: 0.05 m is less than two cells"):
        ObstacleMap(occ, 0.0, 0.05)


def test_newton_converges_quadratically_on_a_map():
    """Simple shooting by Newton's method along the depot's racks (the penalty in play: the
    path passes 0.2 m from the footprint's edge): |F| falls quadratically down to the flow's
    reproducibility on a map (about 1e-9; 1e-12 with discs)."""
    from leapfrog_planner.bvp.shooting import ShootingSettings, solve_shooting
    from leapfrog_planner.compiled.kernels import model_info
    from leapfrog_planner.integrate.problem import ObstaclePenalty, OptimalControlProblem
    from leapfrog_planner.roots import RootSettings
    from leapfrog_planner.world import load_ros_map

    depot = load_ros_map(Path(__file__).parent / "data" / "maps" / "depot.yaml")
    world = ObstacleMap(depot, radius=0.2)
    problem = OptimalControlProblem(
        model_info("unicycle"), ObstaclePenalty(np.zeros((0, 3)), 1.0, 2, world)
    )
    settings = ShootingSettings(root=RootSettings(tol=1e-8), inexact=False, compiled=False)
    r = solve_shooting(problem, 0.0, [14.3, 4.3, 0.0], 3.0, [16.8, 4.3, 0.0], method="newton",
                       settings=settings)  # fmt: skip
    e = r.root.residual_norms
    assert r.success and e.size >= 5
    assert 0.0 < problem.penalty.clearance(r.trajectory.x[:, :2]).min() < 0.25
    assert np.all(e[1:] <= 0.6 * e[:-1] ** 2)  # |F_k+1| <= C |F_k|^2 with C about 0.5
