"""Circular-arc members (``sweep_deg``): exact geometry shared by the schema and the FE.

A flexible member with ``sweep_deg = theta`` is the circular arc from its ``from`` node ``a``
to its ``to`` node ``b`` turning counter-clockwise through the central angle theta (negative:
clockwise).  With chord c = |b - a|: radius R = c / (2 sin(|theta| / 2)), arc length
R |theta|, signed curvature kappa = theta / (R |theta|), and the tangent at ``a`` is the
chord direction turned by -theta/2.  Points at arc length s:
``a + sin(kappa s) / kappa t0 + (1 - cos(kappa s)) / kappa n0`` (n0 = t0 turned by +90 deg).
"""

from __future__ import annotations

import math

import numpy as np

MAX_SWEEP_DEG = 359.0  # a closed circle has no chord


def arc_length(chord: float, sweep_deg: float) -> float:
    """Length of the arc over ``chord`` turning through ``sweep_deg`` (the chord if 0)."""
    th = abs(math.radians(sweep_deg))
    if th == 0.0:
        return chord
    return chord * th / (2.0 * math.sin(0.5 * th))


def arc_points(
    a: tuple[float, float], b: tuple[float, float], sweep_deg: float, s: np.ndarray
) -> np.ndarray:
    """Points (n, 2) at arc lengths ``s`` (n,) from ``a`` along the arc to ``b``."""
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    c = math.hypot(dx, dy)
    s = np.asarray(s, dtype=float)
    th = math.radians(sweep_deg)
    if th == 0.0:
        return np.column_stack([ax + dx / c * s, ay + dy / c * s])
    L = arc_length(c, sweep_deg)
    k = th / L
    phi = math.atan2(dy, dx) - 0.5 * th
    t0 = np.array([math.cos(phi), math.sin(phi)])
    n0 = np.array([-t0[1], t0[0]])
    ks = k * s
    return np.array([ax, ay]) + np.outer(np.sin(ks) / k, t0) + np.outer((1.0 - np.cos(ks)) / k, n0)
