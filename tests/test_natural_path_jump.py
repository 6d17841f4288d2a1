"""An imperfect column just past its Euler load: one load step of load control may carry
Newton from the knee of the natural path onto a *stable* part of the complementary branch
(the column bent against its imperfection).  No stability change flags it; the step's jump
does (``bifurcation.Watch.snap``), and a retrace that reaches the step's factor without a
limit point is the natural path, whose state is kept (issue 23, item 2).

The natural path of a cantilever column with a transverse tip force ``Q = imperfection x P``
bends towards ``Q`` all along (Timoshenko & Gere 1961, Sec. 1.11, below the Euler load:
v(L) = Q (tan kL - kL) / (P k) > 0); the exact elastica of the same scene is the reference.
"""

from __future__ import annotations

import math

import pytest

import reports
from tests.test_judge_converged import column


@pytest.mark.parametrize("imperfection", [1e-3, -1e-3])
@pytest.mark.parametrize("model", ["fem-16", "fem-auto"])
def test_imperfect_column_at_one_and_a_half_euler_bends_towards_its_imperfection(
    model, imperfection
):
    scene = column(1.5, imperfection, steps=40)  # the step to 1.0125 x Euler jumped across
    exact = reports.solve(scene, "elastica")
    sol = reports.solve(scene, model)
    assert sol.status == "converged", sol.message
    assert all(st.stable for st in sol.steps)
    for st in sol.steps[1:]:  # never on the other side of the axis
        assert math.copysign(1.0, st.outputs["tip.uy"]) == math.copysign(1.0, imperfection)
    end, want = sol.steps[-1].outputs, exact.steps[-1].outputs
    tol = 2 * 1.5 * math.pi**2 / 4 / 1e4 + 5e-3  # the stretch P/EA the elastica lacks + mesh
    assert end["tip.uy"] == pytest.approx(want["tip.uy"], rel=tol)
    assert end["tip.rot"] == pytest.approx(want["tip.rot"], rel=tol)
