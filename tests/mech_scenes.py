"""Inline mechanism scenes for the assembler tests (catalog-independent)."""

from __future__ import annotations

import math

import cases

DX = math.sqrt(37.1**2 - (23.2 - 15.0) ** 2)

FOURBAR = f"""
[case]
name = "bistable-four-bar-test"
title = "Four-bar with a compliant rocker (crank 15, coupler 37.1, rocker 43.2 mm)"
units = "mm-N-MPa"

[[nodes]]
id = "O"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 0.0
y = 15.0

[[nodes]]
id = "C"
x = {DX!r}
y = 23.2

[[nodes]]
id = "D"
x = {DX!r}
y = -20.0

[[members]]
id = "crank"
from = "O"
to = "B"
kind = "rigid"
end_b = "pin"

[[members]]
id = "coupler"
from = "B"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "rocker"
from = "D"
to = "C"
kind = "flexible"
E = 1400.0
width = 5.0
thickness = 1.5
end_b = "pin"

[[supports]]
node = "O"
type = "pin"

[[supports]]
node = "D"
type = "clamp"

[[outputs]]
name = "tip"
node = "C"
"""

ENERGY = """
[analysis]
kind = "energy"
steps = 120

[analysis.driver]
kind = "rotation"
member = "crank"
start = 0.0
stop = 120.0
"""

PEAUCELLIER = """
[case]
name = "peaucellier-test"
title = "Peaucellier-Lipkin straight-line linkage"
units = "nondim"

[[nodes]]
id = "O"
x = 0.0
y = 0.0

[[nodes]]
id = "O2"
x = 1.0
y = 0.0

[[nodes]]
id = "A"
x = {ax!r}
y = {ay!r}

[[nodes]]
id = "C"
x = {cx!r}
y = {cy!r}

[[nodes]]
id = "D"
x = {dx!r}
y = {dy!r}

[[nodes]]
id = "P"
x = {px!r}
y = {py!r}

[[members]]
id = "crank"
from = "O2"
to = "A"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "OC"
from = "O"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "OD"
from = "O"
to = "D"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "AC"
from = "A"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "AD"
from = "A"
to = "D"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "PC"
from = "P"
to = "C"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[members]]
id = "PD"
from = "P"
to = "D"
kind = "rigid"
end_a = "pin"
end_b = "pin"

[[supports]]
node = "O"
type = "pin"

[[supports]]
node = "O2"
type = "pin"

[analysis]
kind = "kinematics"
steps = 40
mobility = 1

[analysis.driver]
kind = "rotation"
member = "crank"
start = -20.0
stop = 20.0

[[outputs]]
name = "tracer"
node = "P"
"""


def peaucellier(theta_deg: float = 120.0, long: float = 2.0, short: float = 1.5) -> cases.Scene:
    """Peaucellier-Lipkin cell: fixed pivots O (0, 0) and O2 (1, 0), crank O2-A = 1 (A on a
    circle through O, so P moves on the line x = (long^2 - short^2) / 2)."""
    t = math.radians(theta_deg)
    ax, ay = 1.0 + math.cos(t), math.sin(t)
    r = math.hypot(ax, ay)
    ux, uy = ax / r, ay / r
    # P on the ray OA with |OA| |OP| = long^2 - short^2
    rp = (long**2 - short**2) / r
    px, py = rp * ux, rp * uy
    # rhombus A-C-P-D: C and D at distance `short` from A and P, `long` from O
    mx, my = (ax + px) / 2, (ay + py) / 2
    half = math.sqrt(short**2 - ((rp - r) / 2) ** 2)  # half the rhombus diagonal C-D
    cx, cy = mx - uy * half, my + ux * half
    dx, dy = mx + uy * half, my - ux * half
    text = PEAUCELLIER.format(ax=ax, ay=ay, cx=cx, cy=cy, dx=dx, dy=dy, px=px, py=py)
    return cases.loads(text, source="peaucellier.toml")


def fourbar(extra: str = ENERGY) -> cases.Scene:
    """The compliant-rocker four-bar with an analysis block."""
    return cases.loads(FOURBAR + extra, source="fourbar.toml")


TOGGLE = """
[case]
name = "toggle-test"
title = "Toggle linkage, knee driven down against a constant slider load"
units = "m-N-Pa"

[[nodes]]
id = "A"
x = 0.0
y = 0.0

[[nodes]]
id = "B"
x = 0.08660254037844388
y = 0.05

[[nodes]]
id = "C"
x = 0.17320508075688776
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

[[loads]]
id = "workpiece"
node = "C"
fx = -10.0

[analysis]
kind = "energy"
steps = 40

[analysis.driver]
kind = "displacement"
node = "B"
direction = "y"
start = 0.0
stop = -0.04

[analysis.ma]
output = "slider"
direction = "x"

[[outputs]]
name = "slider"
node = "C"

[[outputs]]
name = "knee"
node = "B"
"""


def toggle() -> cases.Scene:
    """Toggle clamp: ma = dy_B/dx_C = -1/(2 tan alpha), F_in = -20 tan(alpha) N (closed form)."""
    return cases.loads(TOGGLE, source="toggle.toml")
