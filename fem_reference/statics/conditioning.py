"""How far round-off alone moves a located critical factor.

``bifurcation.Watch.locate`` finds the factor where the lowest eigenvalue of the symmetric
tangent crosses zero along the fundamental path.  The assembled tangent's entries carry a
relative round-off of order eps (element formulas evaluated on nodal values that are
themselves rounded to eps of their size), so by first-order perturbation theory the crossing
is determined only to::

    delta lam = eps |phi|^T |K_c| |phi| / |d(phi^T K phi) / d lam|

with ``phi`` the critical mode, ``|K_c|`` the entrywise absolute symmetric tangent at the
critical state and the derivative taken along the path.  On a fine mesh of stiff, slender
members ``|K|`` (axial entries ~ N, bending ~ N^3 for N elements) dwarfs the mode's energy:
a bistable switch on 32 elements per member gives 6e-7 of the factor, on 8 elements 2e-9;
moving its node coordinates by 4e-16 (relative) moved fem-32's located factor by 1.5e-7 and
fem-8's by 2e-9.  The same scene in other coordinates or units is such a perturbation, so a
located factor is reproducible only to this figure, and every located point reports it
(``factor_roundoff``, in factor units) instead of implying more digits than it has.
"""

from __future__ import annotations

import math

import numpy as np

from fem_reference.rigid import stability_view
from fem_reference.statics import static as S


def _symmetric_tangent(system: object, st: S.State) -> object:
    with stability_view(system):  # exact rigid links: the augmented Lagrangian Hessian
        _, K = system.residual_and_tangent(st.u, st.lam)
    return 0.5 * (K + K.T)


def factor_roundoff(
    system: object, prev: S.State, crit: S.State, lam_c: float, phi: np.ndarray
) -> float | None:
    """Round-off bound of the located critical factor ``lam_c`` (factor units; module
    docstring), the path derivative of ``phi^T K phi`` taken as its secant between the
    stable state ``prev`` and the critical state ``crit`` (an estimate to a small factor:
    the quadratic form is smooth along the path).  None where the form does not change
    along the step or a tangent cannot be evaluated."""
    if prev.lam == lam_c:
        return None
    try:
        Kc, Kp = _symmetric_tangent(system, crit), _symmetric_tangent(system, prev)
    except (S.SolveError, ValueError, FloatingPointError):
        return None
    slope = (float(phi @ (Kp @ phi)) - float(phi @ (Kc @ phi))) / (prev.lam - lam_c)
    a = np.abs(phi)
    bound = np.finfo(float).eps * float(a @ (abs(Kc) @ a))
    out = bound / abs(slope) if slope != 0.0 else math.inf
    return float(out) if math.isfinite(out) else None
