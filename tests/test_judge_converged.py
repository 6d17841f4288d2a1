"""Converged means right (issue 23): scenes written outside the project where a ``converged``
answer was wrong or a snap went unreported, each checked against an exact answer."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import cases
import reports

FIXTURES = Path(__file__).parent / "fixtures"
R2, R3, X_C = 40.2, 107.1, 140.0111793630614  # DAS-2D Ex. 5: crank, coupler, drawn slider x
B0 = np.array([34.814221232134436, 20.1])  # drawn crank tip


def _link_lengths(step: object) -> tuple[float, float]:
    """Crank |OB| and coupler |BC| of a DAS-2D Ex. 5 state (O fixed, C on the x axis)."""
    o = step.outputs
    b = B0 + (o["crank_tip.ux"], o["crank_tip.uy"])
    c = np.array([X_C + o["slider.ux"], o["slider.uy"]])
    return float(np.hypot(*b)), float(np.hypot(*(c - b)))


@pytest.mark.parametrize(
    ("model", "reason"),
    [("replay", "rigid link"), ("fem-8", "rigid link"), ("kinetostatic", "near t = -73.1")],
)
def test_slider_driven_past_reach_keeps_rigid_links_or_fails_with_the_reason(model, reason):
    """The slider cannot come closer than r3 - r2 = 66.9 mm to the crank pivot, i.e. past
    -73.11 mm: every returned state keeps both links at their lengths and the run fails there."""
    sol = reports.solve(cases.load(str(FIXTURES / "das2d-ex5-past-reach.toml")), model)
    assert sol.status == "failed"
    assert reason in sol.message
    for st in sol.steps:
        crank, coupler = _link_lengths(st)
        assert crank == pytest.approx(R2, rel=1e-4)
        assert coupler == pytest.approx(R3, rel=1e-4)
    reach = (R3 - R2) - X_C
    assert reach <= min(st.factor for st in sol.steps) <= reach + 2.5  # fails at the reach
    assert math.isfinite(sol.steps[-1].outputs["driver.force"])
