"""The work-precision benchmark: independent references, error curves, ratios, files."""

from __future__ import annotations

import csv
import math

import pytest

from leapfrog_planner.experiments.work_precision import (
    METHODS,
    Point,
    WorkPrecisionSettings,
    _time_at,
    ratios,
    run_work_precision,
    write_work_precision,
)


@pytest.fixture(scope="module")
def small():
    pytest.importorskip("casadi")
    s = WorkPrecisionSettings(
        cases=(1,), general=0, repeat=1, meshes=(25, 100, 400), leapfrog_tols=(1e-4, 1e-10),
        bvp_tols=(1e-4, 1e-8),
    )  # fmt: skip
    return run_work_precision(s)


def test_references_are_independent_and_agree(small):
    (ref,) = small.references
    # Leapfrog re-checked at rtol 1e-13 and IPOPT extrapolated in the mesh: the same optimum.
    assert ref.leapfrog == pytest.approx(10.323202, rel=1e-6)
    assert ref.agreement < 1e-6


def test_every_method_has_its_curve_and_the_errors_behave(small):
    name = small.references[0].scenario
    for method in METHODS:
        assert small.curve(name, method), method
    ipopt = sorted(small.curve(name, "ipopt"), key=lambda p: p.knob)
    errors = [p.error for p in ipopt]
    assert errors == sorted(errors, reverse=True)  # finer meshes, smaller errors
    assert errors[1] > 1e-5  # 100 intervals carry the mesh's error
    assert all(p.error < 1e-6 for p in small.curve(name, "leapfrog"))
    bvp = sorted(small.curve(name, "solve_bvp"), key=lambda p: -p.knob)
    assert bvp[-1].error < bvp[0].error and all(p.status == "ok" for p in bvp)


def test_ratios_and_files(small, tmp_path):
    lines = [r.text for r in ratios(small)]
    assert any("at relative cost error 1e-06" in t for t in lines)
    assert any("IPOPT's accuracy on 100 intervals" in t for t in lines)
    # Meshes up to 400 do not reach 1e-6 on case 1: said, not hidden.
    assert any("unreachable for IPOPT" in t for t in lines)
    files = write_work_precision(small, tmp_path)
    assert {p.name for p in files} == {"work_precision.csv", "work_precision.md",
                                       "work_precision.png"}  # fmt: skip
    rows = list(csv.DictReader((tmp_path / "work_precision.csv").open()))
    assert len(rows) == len(small.points) and {r["method"] for r in rows} == set(METHODS)
    assert (tmp_path / "work_precision.png").stat().st_size > 10_000


def test_time_at_interpolates_log_log_and_knows_unreachable():
    def p(t, e, status="ok"):
        return Point("s", "ipopt", 0, t, 1.0, e, status)

    curve = [p(0.01, 1e-3), p(0.1, 1e-5), p(1.0, 1e-7)]
    assert _time_at(curve, 1e-4) == pytest.approx(math.sqrt(0.01 * 0.1))
    assert _time_at(curve, 1e-3) == pytest.approx(0.01)
    assert _time_at(curve, 1e-8) is None
    assert _time_at([p(0.5, 1e-9, "other extremal")], 1e-6) is None
