"""Limit loads as references: ``factor.max`` / ``factor.min`` along a path."""

from __future__ import annotations

import pytest

from reports.verdicts.errors import reference_checks


def steps(factors):
    return [{"factor": f, "outputs": {}} for f in factors]


REF = {
    "output": "factor.max",
    "value": 18.5,
    "kind": "published",
    "source": "s",
    "rationale": "r",
    "tolerance": 5e-3,
}


def test_interior_maximum_is_checked():
    (chk,) = reference_checks([REF], steps([0.0, 10.0, 18.55, 12.0, -9.4, 5.0]), True)
    assert chk["model_value"] == 18.55
    assert chk["passed"] is True
    (low,) = reference_checks(
        [{**REF, "output": "factor.min", "value": -9.0}], steps([0.0, 18.0, -9.4, 3.0]), True
    )
    assert low["model_value"] == -9.4 and low["passed"] is False  # 4.4 % off


def test_path_ending_on_its_maximum_is_not_a_limit_load():
    (chk,) = reference_checks([REF], steps([0.0, 10.0, 18.5]), False)
    assert chk["model_value"] is None and chk["passed"] is None


@pytest.mark.parametrize("value,passed", [(18.59, True), (18.6, False)])
def test_tolerance_band(value, passed):
    (chk,) = reference_checks([REF], steps([0.0, value, 1.0]), True)
    assert chk["passed"] is passed


def test_reference_on_a_decreasing_driver_path_is_interpolated():
    """Energy analyses drive a coordinate from 0 towards negative values (DAS-2D Ex. 5)."""
    ref = {**REF, "output": "driver.force", "value": -12.776, "at_factor": -16.279}
    path = [{"factor": -2.0 * i, "outputs": {"driver.force": -12.7 - 0.01 * i}} for i in range(11)]
    (chk,) = reference_checks([ref], path, True)
    assert chk["note"] == "interpolated"
    assert chk["model_value"] == pytest.approx(-12.7 - 0.01 * 16.279 / 2.0)


def _path(pairs):
    return [{"factor": f, "outputs": {"apex.uy": u}} for f, u in pairs]


def test_a_path_stuck_short_of_the_reference_is_not_called_accurate():
    """A snap-through traced against apex.uy (factor rises, falls, rises): a model that never
    moves (an axially locked, inextensible truss) must score the displacement it never
    reached, not ~0 from pairing every one of its steps with the reference's first point."""
    from reports.verdicts.errors import path_errors

    ref = _path([(0.0, 0.0), (0.3, -0.05), (0.38, -0.1), (0.0, -0.15), (-0.3, -0.2), (1.0, -0.25)])
    stuck = _path([(f, 0.0) for f in (0.0, 5.0, 50.0, 100.0)])
    err = path_errors(stuck, ref, length=2.0, stop_output="apex.uy")
    assert err["abscissa"] == "apex.uy" and err["coverage"] == 0.0
    # own scale: the apex travels 0.25, the model none of it (100 %); over L = 2: 12.5 %
    assert err["summary"] == pytest.approx(1.0)
    assert err["summary_L"] == pytest.approx(0.25 / 2.0)
    exact = path_errors(ref, ref, length=2.0, stop_output="apex.uy")
    assert exact["summary"] == pytest.approx(0.0, abs=1e-15) and exact["coverage"] == 1.0
