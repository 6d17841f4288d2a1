"""``reports.api.checked``: a converged answer whose state is no answer is failed at it."""

from __future__ import annotations

import math

import pytest

import cases
from reduced_models.base import Solution, Step
from reports.api import checked

SCENE = cases.load("cantilever-tip-load")
ZERO = {"tip.ux": 0.0, "tip.uy": 0.0, "tip.rot": 0.0}


def answer(energy: float, uy: float = -0.1) -> Solution:
    steps = (Step(0.0, ZERO, 0.0, 1, True), Step(1.0, {**ZERO, "tip.uy": uy}, energy, 3, True))
    return Solution(SCENE.name, "dummy", "converged", "", steps)


@pytest.mark.parametrize("energy", [math.inf, -math.inf])
def test_infinite_energy_fails_at_its_step(energy: float) -> None:
    sol = checked(SCENE, answer(energy))
    assert sol.status == "failed"
    assert "energy is infinite" in sol.message and "factor 1" in sol.message
    assert len(sol.steps) == 1  # the states before it are kept


def test_nan_output_fails_and_not_computed_energy_passes() -> None:
    assert checked(SCENE, answer(math.nan, uy=math.nan)).status == "failed"
    assert checked(SCENE, answer(math.nan)).status == "converged"  # NaN energy: not computed
    assert checked(SCENE, answer(0.02)).status == "converged"
