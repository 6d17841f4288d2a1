"""A driver that cannot move from the drawn position is declined, not guessed
(``reduced_models.mechanism.analyses.stalled_driver``; issue 23, item 5).

Closed forms (kinematics of the drawing, not the code's numbers):

* a crank of length r drawn at angle a from the x axis moves its tip by r (-sin a, cos a) per
  radian: driven along x, it is stationary at a = 0; along y at a = 90 deg.  Prescribing a
  stationary coordinate picks the crank's sense by round-off (the answer changed with the
  drawing's orientation), so the model declines; an oblique crank moves either way;
* DAS-2D Ex. 3 (the guided shuttle between two straight legs): with inextensible straight
  legs (PRB-3R, PRB-FSM) the shuttle's travel shortens the legs to first order, which no
  admissible motion does (a toggle at full extension); with axially compliant members
  (PRB-2RPR, CBCM) the travel is free and the sweep runs.
"""

from __future__ import annotations

import math

import pytest

import cases
from reports.api import solve

STALLED = "the driver cannot move from the drawn position"


def crank(angle_deg: float, direction: str) -> cases.Scene:
    """A 20 mm rigid crank pinned at O, held by a torsion spring, its tip T driven along
    ``direction`` by 2 mm (energy analysis)."""
    a = math.radians(angle_deg)
    return cases.loads(
        f"""
[case]
name = "crank-{angle_deg:g}-{direction}"
title = "a sprung crank driven at its tip"
units = "mm-N-MPa"

[[nodes]]
id = "O"
x = 0.0
y = 0.0

[[nodes]]
id = "T"
x = {20.0 * math.cos(a)!r}
y = {20.0 * math.sin(a)!r}

[[members]]
id = "crank"
from = "O"
to = "T"
kind = "rigid"

[[supports]]
node = "O"
type = "pin"

[[torsion_springs]]
id = "k"
node = "O"
member_a = "crank"
stiffness = 100.0

[analysis]
kind = "energy"
steps = 4

[analysis.driver]
kind = "displacement"
node = "T"
direction = "{direction}"
start = 0.0
stop = 2.0

[[outputs]]
name = "tip"
node = "T"
""",
        f"crank-{angle_deg:g}-{direction}",
    )


@pytest.mark.parametrize(("angle", "direction"), [(0.0, "x"), (90.0, "y"), (180.0, "x")])
def test_a_crank_tip_driven_along_the_crank_is_declined(angle, direction) -> None:
    sol = solve(crank(angle, direction), "kinetostatic")
    assert sol.status == "not-applicable", (sol.status, sol.message)
    assert STALLED in sol.message


@pytest.mark.parametrize(("angle", "direction"), [(0.0, "y"), (90.0, "x"), (30.0, "x")])
def test_a_crank_tip_driven_across_the_crank_moves(angle, direction) -> None:
    """Closed form: tip at T + r (cos(a + t) - cos a, ...), spring torque k t, so the driven
    coordinate's value and the crank's turn agree (the energy k t^2 / 2 at the last step)."""
    sol = solve(crank(angle, direction), "kinetostatic")
    assert sol.ok, sol.message
    a = math.radians(angle)
    last = sol.steps[-1]
    # the turn t that moves the tip's driven coordinate by 2 mm from the drawn pose
    if direction == "x":
        t = math.acos(math.cos(a) + 2.0 / 20.0) - a
    else:
        t = math.asin(math.sin(a) + 2.0 / 20.0) - a
    assert last.energy == pytest.approx(0.5 * 100.0 * t * t, rel=1e-8)


@pytest.mark.parametrize("model", ["prb-3r", "prb-2r", "prb-fsm-4"])
def test_straight_inextensible_legs_decline_the_shuttle_travel(model) -> None:
    sol = solve(cases.load("das2d-ex3-bistable-switch"), model)
    assert sol.status == "not-applicable", (sol.status, sol.message)
    assert STALLED in sol.message


def test_axially_compliant_legs_trace_the_shuttle_travel() -> None:
    """PRB-2RPR's stretching middle links let the legs shorten: the sweep runs and its
    largest load factor is the case's fem-auto snap factor within the case's 2 %."""
    scene = cases.load("das2d-ex3-bistable-switch")
    sol = solve(scene, "prb-2rpr")
    assert sol.ok, sol.message
    ref = next(r for r in scene.references if r.output == "factor.max")
    assert max(s.factor for s in sol.steps) == pytest.approx(ref.value, rel=ref.tolerance)
