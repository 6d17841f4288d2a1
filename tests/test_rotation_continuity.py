"""Rotations are continuous along a path (issue 23, item 3): every model that answers the
roll-up of a cantilever under an end moment past one full turn (ML/EI to 3 pi; the exact
end rotation is ML/EI, a circle wound one and a half times) reports a rotation that changes by
less than pi between its steps -- never an angle wrapped to (-pi, pi] -- and the exact models
end at 3 pi."""

import dataclasses
import math

import numpy as np
import pytest

import cases
import reports

MODELS = (
    "elastica",
    "linear-1",
    "linear-8",
    "bcm",
    "cbcm-8",
    "prb-1r",
    "prb-3r",
    "prb-fsm-16",
    "fem-16",
)
EXACT = ("elastica", "fem-16")


def rollup(turns: float = 1.5):
    scene = cases.load("pure-moment-rollup")  # L = EI = 1, M = 2 pi at factor 1
    a = dataclasses.replace(scene.analysis, steps=12, factor_end=turns)
    return dataclasses.replace(scene, analysis=a)


@pytest.mark.parametrize("model", MODELS)
def test_end_rotation_is_continuous_past_a_full_turn(model):
    sol = reports.solve(rollup(), model)
    assert sol.status == "converged", sol.message
    rot = np.array([s.outputs["tip.rot"] for s in sol.steps])
    assert np.all(np.abs(np.diff(rot)) < math.pi), rot
    if model in EXACT:
        assert rot[-1] == pytest.approx(3 * math.pi, rel=1e-3)
