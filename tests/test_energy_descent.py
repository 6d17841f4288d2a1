"""Energy descent at a fixed load (``fem_reference/statics/descent.py``) against closed forms.

A rigid bar of length b pinned to ground at O with a torsion spring k (free at the drawn,
horizontal angle) carries a dead load P straight down at its tip.  With theta its angle from
the horizontal, the total potential is ``k theta^2 / 2 + P b sin(theta)``: equilibria at
``k theta + P b cos(theta) = 0``, stable where ``k - P b sin(theta) > 0``.  At P b / k = 5
there are three: stable near -1.31 rad (hanging below), unstable near 1.99 (held up against
the spring), stable near 3.38 (swung over).  Displaced from the unstable one by +-0.01 rad,
a damped bar falls to the stable state on that side -- the answer the descent must give,
through the exact-rigid-link (KKT) path of the FE.  The bar is drawn rotated, in mm, so no
axis is special.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import cases
from fem_reference.assembly import build
from fem_reference.statics import descent
from fem_reference.statics import static as S

K_SPRING, B, RATIO = 2.0e3, 40.0, 5.0  # N mm / rad, mm, P b / k
ANGLE = math.radians(23.0)  # the drawing's rotation: "horizontal" is this direction


def _scene():
    c, s = math.cos(ANGLE), math.sin(ANGLE)
    P = RATIO * K_SPRING / B
    # the load is "straight down" in the drawing's frame: (0, -P) rotated by ANGLE
    return cases.loads(f"""
[case]
name = "bar-over-spring"
title = "rigid bar on a torsion spring under a dead tip load"
units = "mm-N-MPa"
[[nodes]]
id = "O"
x = 3.0
y = -2.0
[[nodes]]
id = "T"
x = {3.0 + B * c!r}
y = {-2.0 + B * s!r}
[[members]]
id = "bar"
from = "O"
to = "T"
kind = "rigid"
[[supports]]
node = "O"
type = "pin"
[[torsion_springs]]
id = "k"
node = "O"
member_a = "bar"
stiffness = {K_SPRING!r}
free_angle_deg = 0.0
[[loads]]
id = "P"
node = "T"
fx = {P * s!r}
fy = {-P * c!r}
[analysis]
kind = "load"
steps = 1
[[outputs]]
name = "tip"
node = "T"
""")


def _roots() -> tuple[float, float, float]:
    f = lambda t: t + RATIO * math.cos(t)  # noqa: E731 - k theta + P b cos(theta), / k
    return brentq(f, -math.pi / 2, 0.0), brentq(f, 1.0, 2.9), brentq(f, 2.95, 4.7)


def _tip(theta: float) -> np.ndarray:
    a = ANGLE + theta
    return np.array([B * math.cos(a), B * math.sin(a)])


def _angle(system, u: np.ndarray) -> float:
    """The bar's angle from the drawn direction, from the tip displacement (rad)."""
    out = system.outputs(u)
    d = np.array([out["tip.ux"], out["tip.uy"]]) + _tip(0.0)
    return math.atan2(d[1], d[0]) - ANGLE


@pytest.fixture(scope="module")
def held():
    """The system and its unstable equilibrium (Newton from the closed-form angle)."""
    system = build(_scene(), 1, exact_rigid=True)
    theta = _roots()[1]
    u = np.zeros(system.ndof)
    (iux, cx, _), (iuy, cy, _) = (system.output_functional(f"tip.{q}") for q in ("ux", "uy"))
    u[iux], u[iuy] = (_tip(theta) - _tip(0.0)) / np.array([cx, cy])
    u[np.asarray(system.is_rotation, dtype=bool)] = theta
    st = S.newton(system, u, 1.0, S.Options())
    assert _angle(system, st.u) == pytest.approx(theta, abs=1e-9)
    return system, st


@pytest.mark.parametrize("side", [-1, 1])
def test_the_bar_falls_to_the_stable_state_on_its_side(held, side):
    system, st = held
    below, _, over = _roots()
    rot = np.asarray(system.is_rotation, dtype=bool)
    (iux, _, _), (iuy, _, _) = (system.output_functional(f"tip.{q}") for q in ("ux", "uy"))
    u0 = st.u.copy()
    # turn the bar by 0.01 rad: rotation DOFs and the tip together (a state off equilibrium)
    theta = _angle(system, st.u) + side * 1e-2
    u0[rot] = theta
    u0[iux], u0[iuy] = _tip(theta) - _tip(0.0)
    land = descent.relax(system, u0, 1.0, S.Options())
    want = over if side > 0 else below
    assert land.u[rot] == pytest.approx(want, abs=1e-8)  # the bar's rotation DOF
    assert math.remainder(_angle(system, land.u) - want, 2 * math.pi) == pytest.approx(0, abs=1e-8)
    assert K_SPRING - RATIO * K_SPRING * math.sin(want) > 0.0  # the closed form calls it stable
    assert descent.positive_definite(system, _stability_tangent(system, land))


def test_an_unstable_equilibrium_is_not_convex(held):
    system, st = held
    assert not descent.positive_definite(system, _stability_tangent(system, st))


def _stability_tangent(system, st):
    from fem_reference.rigid import stability_view

    with stability_view(system):
        return system.residual_and_tangent(st.u, st.lam)[1]
