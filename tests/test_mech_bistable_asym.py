"""An asymmetric bistable scene separates the forward and backward barriers (issue 23,
item 6): the von Mises truss of two linear springs (``von-mises-spring-truss``) with a soft
vertical spring from the apex to the ground below it.

Closed form (apex on the axis by symmetry, driven down by w): the truss springs have length
``L(w) = sqrt(a^2 + (h - w)^2)`` and free length ``L0 = sqrt(a^2 + h^2)``, the vertical spring
is stretched by w, so ``U(w) = k (L - L0)^2 + k_v w^2 / 2``.  Its stationary points (roots of
``dU/dw``, bracketed and solved by brentq on the closed form) are the stable positions w = 0
and w2 < 2h and the unstable one wu; barriers ``U(wu) - U(0)`` forward and ``U(wu) - U(w2)``
backward -- different, since the second stable position stores ``k_v w2^2 / 2``.
"""

import math

import pytest
from scipy.optimize import brentq

import cases
import reports

A, H, K, KV, DROP = 0.1, 0.02, 2.0e4, 25.0, 1.0
L0 = math.hypot(A, H)

SCENE = f"""
[case]
name = "von-mises-offset"
title = "von Mises spring truss with a vertical apex spring"
units = "m-N-Pa"
[[nodes]]
id = "L"
x = {-A}
y = 0.0
[[nodes]]
id = "C"
x = 0.0
y = {H}
[[nodes]]
id = "R"
x = {A}
y = 0.0
[[nodes]]
id = "G"
x = 0.0
y = {H - DROP}
[[members]]
id = "left"
from = "L"
to = "C"
kind = "spring"
k = {K}
[[members]]
id = "right"
from = "C"
to = "R"
kind = "spring"
k = {K}
[[members]]
id = "vertical"
from = "G"
to = "C"
kind = "spring"
k = {KV}
[[supports]]
node = "L"
type = "pin"
[[supports]]
node = "R"
type = "pin"
[[supports]]
node = "G"
type = "pin"
[analysis]
kind = "synthesis"
steps = 96
[analysis.driver]
kind = "displacement"
node = "C"
direction = "y"
start = 0.0
stop = -0.048
[analysis.synthesis]
goal = "bistable"
[[outputs]]
name = "apex"
node = "C"
"""


def energy(w: float) -> float:
    """U(w) of the closed form (J)."""
    return K * (math.hypot(A, H - w) - L0) ** 2 + 0.5 * KV * w * w


def slope(w: float) -> float:
    """dU/dw (N)."""
    length = math.hypot(A, H - w)
    return -2.0 * K * (length - L0) * (H - w) / length + KV * w


def test_forward_and_backward_barriers_match_the_closed_form():
    wu = brentq(slope, 0.5 * H, 1.2 * H)
    w2 = brentq(slope, 1.2 * H, 2.0 * H)
    forward, backward = energy(wu) - energy(0.0), energy(wu) - energy(w2)
    assert forward - backward > 0.2 * forward  # the scene does separate them
    sol = reports.solve(cases.loads(SCENE, source="von-mises-offset.toml"), "kinetostatic")
    assert sol.status == "converged", sol.message
    b = sol.extras["bistable"]
    assert b["bistable"], sol.message
    assert b["stable"] == pytest.approx([0.0, -w2], abs=1e-4 * H)
    assert b["unstable"] == pytest.approx(-wu, abs=1e-4 * H)
    assert b["barrier"]["forward"] == pytest.approx(forward, rel=1e-4)
    assert b["barrier"]["backward"] == pytest.approx(backward, rel=1e-4)
