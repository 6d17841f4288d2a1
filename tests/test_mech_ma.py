"""Mechanical advantage with a load as the input, and of a compliant mechanism (issue 21).

References (never the assembler's own numbers):
* closed form, load input: along a load path every load is dead and proportional, so the
  power balance of ``[analysis.ma]`` (F_in ds_in = dU + F_out ds_out, dU = the work of all
  loads) gives F_out = the output load itself: a toggle pressing a workpiece P with a hand
  force F has ma = P / F at every step, whatever stores energy (spring or beam).  The rigid
  toggle's equilibrium is closed form too (virtual work with the spring at the ground pin):
  lam L (-F cos(th) + 2 P sin(th)) = k (th - th0).
* fem-auto, driver input: the compliant toggle (clamped flexible lower link) driven at the
  knee against a workpiece; each model's ma is held to twice its own driving-force error
  against fem-auto (re-measured here) plus 1e-3.
"""

from __future__ import annotations

import math

import pytest

import cases
from reports.api import solve

RIGID = cases.loads(
    """[case]
name = "toggle-load-input"
title = "toggle with a load input"
units = "mm-N-MPa"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 86.60254037844386
y = 50.0

[[nodes]]
id = "C"
x = 173.20508075688772
y = 0.0

[[members]]
id = "lower"
from = "A"
to = "B"
kind = "rigid"
end_b = "pin"

[[members]]
id = "upper"
from = "B"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[supports]]
node = "A"
type = "pin"

[[supports]]
node = "C"
type = "slider"
angle_deg = 0.0

[[torsion_springs]]
id = "k"
node = "A"
member_a = "lower"
stiffness = 5000.0
free_angle_deg = 0.0

[[loads]]
id = "hand"
node = "B"
fy = -10.0

[[loads]]
id = "workpiece"
node = "C"
fx = -4.0

[analysis]
kind = "load"
steps = 10

[analysis.ma]
output = "slider"
direction = "x"
input = "hand"

[[outputs]]
name = "slider"
node = "C"

[[outputs]]
name = "knee"
node = "B"
""",
    "toggle-load-input",
)
# the compliant toggle (a 100 mm leaf welded to ground, pinned to a rigid link on a slider),
# shared by the load-input and the driver-input scene
TOGGLE = """[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 86.60254037844386
y = 50.0

[[nodes]]
id = "C"
x = 173.20508075688772
y = 0.0

[[members]]
id = "lower"
from = "A"
to = "B"
kind = "flexible"
E = 2300.0
width = 10.0
thickness = 2.0
end_b = "pin"

[[members]]
id = "upper"
from = "B"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[supports]]
node = "A"
type = "clamp"

[[supports]]
node = "C"
type = "slider"
angle_deg = 0.0

[[loads]]
id = "workpiece"
node = "C"
fx = -0.4

[[outputs]]
name = "slider"
node = "C"

[[outputs]]
name = "knee"
node = "B"
"""
COMPLIANT = cases.loads(
    """[case]
name = "compliant-toggle-load-input"
title = "toggle with a load input"
units = "mm-N-MPa"

[[loads]]
id = "hand"
node = "B"
fy = -1.0

[analysis]
kind = "load"
steps = 10

[analysis.ma]
output = "slider"
direction = "x"
input = "hand"
"""
    + TOGGLE,
    "compliant-toggle-load-input",
)
DRIVEN = cases.loads(
    """[case]
name = "compliant-toggle-driver"
title = "toggle with a load input"
units = "mm-N-MPa"

[analysis]
kind = "energy"
steps = 20

[analysis.driver]
kind = "displacement"
node = "B"
direction = "y"
start = 0.0
stop = -20.0

[analysis.ma]
output = "slider"
direction = "x"
input = "driver"
"""
    + TOGGLE,
    "compliant-toggle-driver",
)
L, K, F, P = 100.0, 5000.0, 10.0, 4.0  # link (mm), spring (N mm/rad), hand and workpiece (N)


def test_load_input_ma_of_the_rigid_toggle_is_closed_form() -> None:
    sol = solve(RIGID, "kinetostatic")
    assert sol.ok, sol.message
    for s in sol.steps[1:]:
        o, lam = s.outputs, s.factor
        th = math.atan2(50.0 + o["knee.uy"], 86.60254037844386 + o["knee.ux"])
        assert o["ma"] == pytest.approx(P / F, rel=1e-9)
        balance = lam * L * (-F * math.cos(th) + 2.0 * P * math.sin(th)) - K * (th - math.pi / 6)
        assert abs(balance) <= 1e-9 * K
    assert math.isnan(sol.steps[0].outputs["ma"])  # no input force at factor 0


@pytest.mark.parametrize("model", ["cbcm-4", "prb-3r", "linear-4"])
def test_load_input_ma_of_a_compliant_toggle_is_the_load_ratio(model: str) -> None:
    sol = solve(COMPLIANT, model)
    assert sol.ok, sol.message
    for s in sol.steps[1:]:
        assert s.outputs["ma"] == pytest.approx(0.4, rel=1e-8)  # 0.4 N workpiece / 1 N hand


@pytest.fixture(scope="module")
def fem():
    sol = solve(DRIVEN, "fem-auto")
    assert sol.ok, sol.message
    return sol


@pytest.mark.parametrize("model", ["cbcm-4", "prb-3r"])
def test_compliant_toggle_ma_against_fem_auto(fem, model: str) -> None:
    sol = solve(DRIVEN, model)
    assert sol.ok, sol.message
    pairs = list(zip(sol.steps, fem.steps))[1:-1]  # fem-auto's ma: central differences
    ferr = max(abs(a.outputs["driver.force"] / b.outputs["driver.force"] - 1.0) for a, b in pairs)
    for a, b in pairs:
        assert abs(a.outputs["ma"] / b.outputs["ma"] - 1.0) <= 2.0 * ferr + 1e-3, (
            a.factor,
            a.outputs["ma"],
            b.outputs["ma"],
            ferr,
        )
