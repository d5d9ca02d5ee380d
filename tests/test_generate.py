"""The random scenario generator: deterministic, stable subsets, constraints hold, round trip."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from leapfrog_planner.batch.generate import (
    GeneratorError,
    GeneratorSpec,
    generate,
    generate_one,
    parse_range,
    write_scenarios,
)
from leapfrog_planner.errors import SettingsError
from leapfrog_planner.planning.scenario import load_scenario


def test_same_seed_same_scenarios_and_subsets_are_stable():
    a = list(generate(GeneratorSpec(n=20, seed=7)))
    b = list(generate(GeneratorSpec(n=20, seed=7)))
    assert a == b
    # Scenario i depends on (seed, i) only: a shorter set is a prefix, any index rebuilds alone.
    assert list(generate(GeneratorSpec(n=5, seed=7))) == a[:5]
    assert generate_one(GeneratorSpec(n=1, seed=7), 13) == a[13]
    c = list(generate(GeneratorSpec(n=20, seed=8)))
    assert all(x != y for x, y in zip(a, c, strict=True))
    assert len({s.name for s in a}) == 20 and a[3].name == "random-s7-00003"


def test_constraints_hold():
    spec = GeneratorSpec(
        n=200,
        seed=3,
        obstacles=(3, 10),
        radius=(0.05, 0.2),
        workspace=(-1.0, 0.0, 2.0, 2.5),
        min_distance=1.2,
        clearance=0.07,
        obstacle_gap=0.01,
        heading_spread=0.3,
        horizon=1.5,
    )
    counts = set()
    for sc in generate(spec):
        obs = sc.obstacles
        counts.add(len(obs))
        assert 3 <= len(obs) <= 10
        assert np.all((obs[:, 2] >= 0.05) & (obs[:, 2] <= 0.2))
        assert np.all((obs[:, 0] >= -1) & (obs[:, 0] <= 2) & (obs[:, 1] >= 0) & (obs[:, 1] <= 2.5))
        for i in range(len(obs)):
            for j in range(i):
                d = math.hypot(*(obs[i, :2] - obs[j, :2]))
                assert d >= obs[i, 2] + obs[j, 2] + 0.01 - 1e-12
        s, g = sc.start, sc.goal
        assert math.hypot(*(g[:2] - s[:2])) >= 1.2
        for p in (s, g):
            assert -1 <= p[0] <= 2 and 0 <= p[1] <= 2.5
            gaps = np.hypot(obs[:, 0] - p[0], obs[:, 1] - p[1]) - obs[:, 2]
            assert gaps.min() >= 0.07 - 1e-12
        direction = math.atan2(g[1] - s[1], g[0] - s[0])
        assert abs(s[2] - direction) <= 0.3 + 1e-12 and abs(g[2] - direction) <= 0.3 + 1e-12
        assert sc.horizon == 1.5
    assert counts == set(range(3, 11))  # the whole range is used


def test_fixed_obstacle_count_and_ranges():
    assert parse_range("3..10") == (3, 10)
    assert parse_range("7") == (7, 7)
    assert parse_range("0.05..0.2", float) == (0.05, 0.2)
    for bad in ("3..", "a..b", "..4", ""):
        with pytest.raises(SettingsError):
            parse_range(bad)
    assert all(len(s.obstacles) == 7 for s in generate(GeneratorSpec(n=10, obstacles=(7, 7))))


@pytest.mark.parametrize(
    "kw",
    [
        {"n": -1},
        {"obstacles": (5, 3)},
        {"radius": (0.0, 0.1)},
        {"radius": (0.3, 0.1)},
        {"workspace": (0, 0, 0, 1)},
        {"min_distance": 10.0},
        {"horizon": 0.0},
        {"prefix": "a b"},
        {"seed": -3},
        {"seed": True},
        {"n": 3.0},
        {"obstacles": (1.0, 3)},
        {"clearance": float("nan")},
    ],
)
def test_bad_spec_is_refused(kw):
    with pytest.raises(SettingsError):
        GeneratorSpec(**kw)


def test_impossible_constraints_raise_generator_error():
    spec = GeneratorSpec(n=1, obstacles=(30, 30), radius=(0.4, 0.5), max_attempts=50)
    with pytest.raises(GeneratorError, match="no room for obstacle"):
        generate_one(spec, 0)


def test_files_load_back_equal_and_rewriting_is_harmless(tmp_path):
    spec = GeneratorSpec(n=4, seed=11)
    paths = write_scenarios(spec, tmp_path / "set")
    assert [p.name for p in paths] == [f"random-s11-{i:05d}.toml" for i in range(4)]
    for p, sc in zip(paths, generate(spec), strict=True):
        assert load_scenario(p) == sc
    before = [p.read_bytes() for p in paths]
    write_scenarios(spec, tmp_path / "set")  # same content: fine
    assert [p.read_bytes() for p in paths] == before
    with pytest.raises(GeneratorError, match="other content"):
        write_scenarios(GeneratorSpec(n=4, seed=11, horizon=2.0), tmp_path / "set")


def test_cli_generate(tmp_path):
    run = lambda *a: subprocess.run(  # noqa: E731
        [sys.executable, "-m", "leapfrog_planner.cli", "generate", *a],
        capture_output=True,
        text=True,
    )
    out = tmp_path / "g"
    r = run("--n", "5", "--obstacles", "3..10", "--seed", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    files = sorted(out.glob("*.toml"))
    assert len(files) == 5
    assert [load_scenario(f) for f in files] == list(generate(GeneratorSpec(n=5, seed=1)))
    bad = run("--n", "5", "--obstacles", "9..2", "--out", str(tmp_path / "bad"))
    assert bad.returncode == 2
    assert bad.stderr.strip().count("\n") == 0 and "9" in bad.stderr
    assert not (tmp_path / "bad").exists()


def test_horizon_range_draws_last_and_leaves_the_rest_as_it_was():
    fixed = list(generate(GeneratorSpec(n=30, seed=4)))
    assert fixed == list(generate(GeneratorSpec(n=30, seed=4, horizon=(1.0, 1.0))))
    ranged = list(generate(GeneratorSpec(n=30, seed=4, horizon=(0.5, 3.0))))
    horizons = [s.horizon for s in ranged]
    assert all(0.5 <= h <= 3.0 for h in horizons) and max(horizons) - min(horizons) > 1.5
    for a, b in zip(fixed, ranged, strict=True):  # positions, headings, obstacles unchanged
        assert np.array_equal(a.start, b.start) and np.array_equal(a.goal, b.goal)
        assert np.array_equal(a.obstacles, b.obstacles)
    with pytest.raises(SettingsError, match="horizon: min"):
        GeneratorSpec(horizon=(2.0, 1.0))


def test_general_preset_has_headings_in_every_direction():
    spec = GeneratorSpec.preset("general", n=300, seed=2)
    assert spec.prefix == "general" and spec.workspace == (0.0, 0.0, 3.0, 3.0)
    off = []
    for sc in generate(spec):
        s, g = sc.start, sc.goal
        direction = math.atan2(g[1] - s[1], g[0] - s[0])
        off += [s[2] - direction, g[2] - direction]
        assert 0.5 <= sc.horizon <= 3.0 and math.hypot(*(g[:2] - s[:2])) >= 1.0
        assert 1 <= len(sc.obstacles) <= 9 and np.all(sc.obstacles[:, 2] <= 0.4)
    off = np.abs(off)
    assert off.max() <= math.pi and np.mean(off > math.pi / 2) > 0.4  # half point away
    # An option overrides the preset's value; an unknown preset is refused.
    assert GeneratorSpec.preset("general", horizon=2.0).horizon == (2.0, 2.0)
    assert GeneratorSpec.preset("default") == GeneratorSpec()
    with pytest.raises(SettingsError, match="unknown preset"):
        GeneratorSpec.preset("hard")


def test_cli_preset_and_horizon_range(tmp_path):
    out = tmp_path / "g"
    r = subprocess.run(
        [sys.executable, "-m", "leapfrog_planner.cli", "generate", "--n", "3", "--preset",
         "general", "--horizon", "2..2.5", "--seed", "9", "--out", str(out)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    got = [load_scenario(f) for f in sorted(out.glob("*.toml"))]
    assert got == list(generate(GeneratorSpec.preset("general", n=3, seed=9, horizon=(2, 2.5))))
    assert [s.name for s in got] == [f"general-s9-{i:05d}" for i in range(3)]
