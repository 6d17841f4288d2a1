"""PRB-1R under a pure end moment warns exactly where Howell's range ends (issue 23, item 6).

Howell (Compliant Mechanisms, Wiley 2001, Sec. 5.6; /work/shared/PARAMETERS.md): end-moment
parameters gamma = 0.7346, c_theta = 1.5164, K_Theta = 2.0643, valid to a beam end angle
theta_0 = c_theta * Theta of 124.4 deg.  Under a pure moment the exact end angle is
theta_0 = M L / (E I) (a circular arc), so a ramp to theta_0 = 120 deg stays inside and one to
130 deg leaves it at the first step past 124.4 deg.
"""

import dataclasses
import math

import pytest

import cases
import reports

LIMIT_DEG = 124.4  # Howell's end-angle limit for the end-moment parameters


def ramp(end_deg: float, steps: int = 26):
    """pure-moment-rollup (L = EI = 1, M = 2 pi at factor 1) ramped to theta_0 = end_deg."""
    scene = cases.load("pure-moment-rollup")
    a = dataclasses.replace(scene.analysis, steps=steps, factor_end=end_deg / 360.0)
    return reports.solve(dataclasses.replace(scene, analysis=a), "prb-1r")


def test_inside_howells_range_no_warning_and_the_exact_end_angle():
    sol = ramp(120.0)
    assert sol.status == "converged", sol.message
    assert "outside validity range" not in sol.message
    for s in sol.steps:  # the PRB end angle c_theta * Theta is the arc's M L / EI
        assert s.outputs["tip.rot"] == pytest.approx(2 * math.pi * s.factor, abs=1e-3)


def test_past_howells_range_warned_from_the_first_step_beyond_it():
    sol = ramp(130.0)
    first = next(s.factor for s in sol.steps if 360.0 * s.factor > LIMIT_DEG)
    assert "outside validity range: PRB angle" in sol.message
    assert f"(from factor {first:.4g})" in sol.message
