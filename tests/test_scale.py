"""Cost that grows gently with the number of obstacles: the grid-indexed geometry and penalty
agree with the brute-force loops, and a thousand obstacles plan without memory blow-up."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

from leapfrog_planner.batch.generate import GeneratorSpec, generate
from leapfrog_planner.model.penalty import (
    clearance,
    grid_penalty_terms,
    obstacle_grid,
    penalty_terms,
)
from leapfrog_planner.planning.initial_path import initial_paths
from leapfrog_planner.planning.initial_path.geometry import (
    _clearance_loops,
    segment_distance,
    smallest_clearance,
)
from leapfrog_planner.planning.initial_path.spatial import (
    disc_grid,
    disc_pairs,
    points_inside,
    segments_cut,
)


def _layout(rng, m, kind):
    """Discs of a few kinds: ordinary, tiny, one huge among small ones, all equal."""
    C = rng.uniform(0.0, 5.0, (m, 2))
    if kind == "tiny":
        R = rng.uniform(1e-6, 1e-4, m)
    elif kind == "huge":
        R = rng.uniform(0.01, 0.1, m)
        R[m // 2] = 50.0
    elif kind == "equal":
        C = np.round(C, 1)  # many discs on common lines and cell borders
        R = np.full(m, 0.25)
    else:
        R = rng.uniform(0.01, 0.6, m)
    return C, R


def _probe_points(rng, grid, n):
    """Random points inside and outside the grid, and points exactly on cell borders."""
    inside = rng.uniform(-1.0, 6.0, (n, 2))
    k = rng.integers(-1, max(grid.nx, grid.ny) + 2, (n, 2))
    border = np.column_stack([grid.ox + k[:, 0] * grid.h, grid.oy + k[:, 1] * grid.h])
    far = rng.uniform(-1e3, 1e3, (8, 2))
    return np.vstack([inside, border, far, [[grid.ox, grid.oy]]])


KINDS = ("ordinary", "tiny", "huge", "equal")


@pytest.mark.parametrize("kind", KINDS)
def test_grid_point_and_pair_queries_match_brute_force(kind):
    rng = np.random.default_rng(len(kind))
    for m in (1, 7, 120):
        C, R = _layout(rng, m, kind)
        grid = disc_grid(C, R)
        tol = 1e-9
        xy = _probe_points(rng, grid, 400)
        gap = np.hypot(xy[:, None, 0] - C[None, :, 0], xy[:, None, 1] - C[None, :, 1])
        brute = np.any(gap < R[None, :] - tol, axis=1)
        assert np.array_equal(points_inside(xy, grid, tol), brute)
        # Every pair of overlapping discs is found, each once.
        i, j = disc_pairs(grid, 0.0)
        D = np.hypot(C[:, None, 0] - C[None, :, 0], C[:, None, 1] - C[None, :, 1])
        want = {
            (a, b) for a, b in zip(*np.nonzero(D < R[:, None] + R[None, :]), strict=True) if a != b
        }
        got = list(zip(i.tolist(), j.tolist(), strict=True))
        assert len(got) == len(set(got)) and want <= set(got)


@pytest.mark.parametrize("kind", KINDS)
def test_grid_segment_test_matches_brute_force(kind):
    rng = np.random.default_rng(10 + len(kind))
    for m in (1, 9, 150):
        C, R = _layout(rng, m, kind)
        grid = disc_grid(C, R)
        pts = _probe_points(rng, grid, 300)
        a = pts[rng.integers(0, pts.shape[0], 600)]
        b = pts[rng.integers(0, pts.shape[0], 600)]
        b[:20] = a[:20]  # segments of length 0
        b[20:40, 0] = a[20:40, 0]  # vertical
        b[40:60, 1] = a[40:60, 1]  # horizontal
        tol = 1e-9
        brute = np.any(segment_distance(a, b, C) < R[None, :] - tol, axis=1)
        assert np.array_equal(segments_cut(a, b, grid, tol), brute)


@pytest.mark.parametrize("kind", KINDS)
def test_indexed_clearance_equals_the_loops(kind):
    rng = np.random.default_rng(20 + len(kind))
    for m, n in ((40, 50), (300, 700), (900, 300)):
        C, R = _layout(rng, m, kind)
        obs = np.column_stack([C, R])
        xy = rng.uniform(-1.0, 6.0, (n, 2))
        assert smallest_clearance(xy, obs) == _clearance_loops(xy, obs)
        d = np.linalg.norm(xy[:, None, :] - obs[None, :, :2], axis=2) - obs[None, :, 2]
        assert np.array_equal(clearance(xy, obs), d.min(axis=0))
    xy[3, 1] = np.nan  # as the loops have it
    assert np.array_equal(smallest_clearance(xy, obs), _clearance_loops(xy, obs), equal_nan=True)


@pytest.mark.parametrize("weight, exponent", [(100.0, 2), (1.0, 1), (6400.0, 3), (0.5, 2)])
@pytest.mark.parametrize("kind", KINDS)
def test_grid_penalty_is_the_plain_loop_bit_for_bit(kind, weight, exponent):
    rng = np.random.default_rng(30 + len(kind) + exponent)
    C, R = _layout(rng, 200, kind)
    obs = np.column_stack([C, R])
    grid = obstacle_grid(obs, weight, exponent)
    border = [
        (grid.ox + kx * grid.h, grid.oy + ky * grid.h)
        for kx in range(-1, grid.nx + 2, max(grid.nx // 7, 1))
        for ky in range(-1, grid.ny + 2, max(grid.ny // 7, 1))
    ]
    near = C[rng.integers(0, C.shape[0], 300)] + rng.normal(0.0, 0.3, (300, 2))
    points = np.vstack([rng.uniform(-2.0, 7.0, (1500, 2)), near, border, [[1e300, 0.0]]])
    for hessian in (False, True):
        for x, y in points:
            want = penalty_terms(x, y, obs, weight, exponent, hessian)
            assert grid_penalty_terms(x, y, grid, weight, exponent, hessian) == want
    # A lower weight than the grid's also sums the same terms; nan falls back to the loop.
    assert grid_penalty_terms(1.0, 2.0, grid, weight / 4, exponent, True) == penalty_terms(
        1.0, 2.0, obs, weight / 4, exponent, True
    )
    got = grid_penalty_terms(np.nan, 2.0, grid, weight, exponent, False)
    assert all(math.isnan(v) for v in got[:3])


def test_a_thousand_obstacles_plan_their_initial_paths_in_linear_memory():
    spec = GeneratorSpec(
        n=1,
        seed=5,
        obstacles=(1000, 1000),
        workspace=(0.0, 0.0, 12.6, 12.6),
        radius=(0.03, 0.08),
        obstacle_gap=0.03,
        min_distance=9.0,
        clearance=0.1,
    )
    (sc,) = list(generate(spec))
    obs = sc.footprint_obstacles
    initial_paths(sc.start, sc.goal, obs[:150], k=3)  # compiles the loops outside the count
    tracemalloc.start()
    try:
        paths = initial_paths(sc.start, sc.goal, obs, k=3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert paths and all(p.min_clearance >= 0.0 for p in paths)
    # Linear: a generous 100 kB per obstacle (all pairs' tangents would take gigabytes).
    assert peak < 100e3 * obs.shape[0], peak


def test_pruned_tangent_graph_finds_the_same_paths(monkeypatch):
    """Keeping only the usable, free common tangents changes how arcs are split, not the
    paths: the same classes, lengths and polylines to rounding."""
    from leapfrog_planner.planning.initial_path import tangent_graph

    (sc,) = list(
        generate(
            GeneratorSpec(
                n=1,
                seed=3,
                obstacles=(160, 160),
                workspace=(0.0, 0.0, 5.0, 5.0),
                radius=(0.03, 0.12),
                obstacle_gap=0.02,
                min_distance=3.5,
                clearance=0.1,
            )
        )
    )
    runs = []
    for limit in (10**9, 10):
        monkeypatch.setattr(tangent_graph, "PRUNE_ABOVE", limit)
        runs.append(initial_paths(sc.start, sc.goal, sc.footprint_obstacles, k=4))
    full, pruned = runs
    assert [p.signature for p in full] == [p.signature for p in pruned]
    for a, b in zip(full, pruned, strict=True):
        assert a.label == b.label
        assert a.length == pytest.approx(b.length, rel=1e-12)
        assert a.polyline.shape == b.polyline.shape
        np.testing.assert_allclose(a.polyline, b.polyline, rtol=0, atol=1e-12)
