"""Rigid links as exact constraints of the FE system (never meshed).

A rigid link is a rigid body: its two end rotations are one rotation DOF ``theta`` (merged in
the DOF numbering, ``assembly.build``), and every segment ``a -> b`` of it (segments are split
at load points along the link) keeps its drawn chord ``X = X_b - X_a`` rotated by ``theta``::

    c(d) = d_b - d_a - (R(theta) - I) X = 0          (2 equations per segment)

enforced by Lagrange multipliers ``mu`` (two extra DOFs per segment, in length units: the
constraint force is ``kappa mu`` with ``kappa = Kref / Lref^2``, so the constraint rows of the
residual ``kappa c`` are forces like every other row).  Block DOFs
``[ua, va, ub, vb, theta, mu_x, mu_y]``; with ``g = R(theta) X``:

* residual ``f = kappa [-mu, mu, mu_x g_y - mu_y g_x, c]``;
* tangent (symmetric): ``d c / d(ua, ub) = -I, I``, ``d c / d theta = (g_y, -g_x)`` and the
  constraint's second derivative ``d2 c / d theta2 = g`` gives ``K_theta,theta =
  kappa mu . g`` (the term a linearised constraint would miss; exact, analytic).

The equilibrium solved is exact: the links keep their lengths and angles to round-off, with
no compliance.  Pins between rigid bodies and flexible members keep their own rotation DOFs.

Stability.  The KKT tangent is indefinite by construction (one negative eigenvalue per
constraint), so the static stability tests see instead ``stability_blocks``: the Hessian of
the augmented Lagrangian ``W + rho J^T J`` on the displacement DOFs and a positive diagonal
on the multipliers.  By Debreu's lemma it is positive definite exactly when the Hessian ``W``
restricted to the constraints' tangent space is, for any ``rho`` above a threshold set by the
negative geometric stiffness (forces / length); ``rho = RHO_FACTOR Kref / Lref^2`` is far
above it.  The lowest eigenvalue (and a critical factor located on it) carries a relative
perturbation ~ 1 / RHO_FACTOR, as the stiff elements' did; the equilibria do not.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager, nullcontext

import numpy as np

RHO_FACTOR = 1e6  # augmented-Lagrangian stiffness of the stability test / (Kref / Lref^2)


def _g(dd: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``g = R(theta) X`` of every segment, components (nc,) each."""
    th = dd[:, 4]
    c, s = np.cos(th), np.sin(th)
    return c * X[:, 0] - s * X[:, 1], s * X[:, 0] + c * X[:, 1]


def violation(dd: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Constraint values ``c`` (nc, 2) (length) from block DOFs ``dd`` (nc, 7)."""
    gx, gy = _g(dd, X)
    out = dd[:, 2:4] - dd[:, 0:2]
    out[:, 0] -= gx - X[:, 0]
    out[:, 1] -= gy - X[:, 1]
    return out


def forces(dd: np.ndarray, X: np.ndarray, kappa: float) -> np.ndarray:
    """Residual blocks (nc, 7) of the constraint family (module docstring)."""
    gx, gy = _g(dd, X)
    mu = dd[:, 5:7]
    f = np.empty_like(dd)
    f[:, 0:2] = -kappa * mu
    f[:, 2:4] = kappa * mu
    f[:, 4] = kappa * (mu[:, 0] * gy - mu[:, 1] * gx)
    f[:, 5:7] = kappa * violation(dd, X)
    return f


def tangent(dd: np.ndarray, X: np.ndarray, kappa: float) -> np.ndarray:
    """Tangent blocks (nc, 7, 7) of the constraint family (exact, symmetric)."""
    gx, gy = _g(dd, X)
    K = np.zeros((dd.shape[0], 7, 7))
    for i, j, v in ((0, 5, -kappa), (1, 6, -kappa), (2, 5, kappa), (3, 6, kappa)):
        K[:, i, j] = K[:, j, i] = v
    K[:, 4, 5] = K[:, 5, 4] = kappa * gy
    K[:, 4, 6] = K[:, 6, 4] = -kappa * gx
    K[:, 4, 4] = kappa * (dd[:, 5] * gx + dd[:, 6] * gy)
    return K


def stability_blocks(dd: np.ndarray, X: np.ndarray, kappa: float, rho: float) -> np.ndarray:
    """Blocks (nc, 7, 7) replacing ``tangent`` in the stability tests: ``rho J^T J`` plus the
    multipliers' second-derivative term on the displacement DOFs, ``rho`` on the multipliers
    (module docstring)."""
    gx, gy = _g(dd, X)
    J = np.zeros((dd.shape[0], 2, 5))
    J[:, 0, 0] = J[:, 1, 1] = -1.0
    J[:, 0, 2] = J[:, 1, 3] = 1.0
    J[:, 0, 4], J[:, 1, 4] = gy, -gx
    K = np.zeros((dd.shape[0], 7, 7))
    K[:, :5, :5] = rho * np.einsum("nki,nkj->nij", J, J)
    K[:, 4, 4] += kappa * (dd[:, 5] * gx + dd[:, 6] * gy)
    K[:, 5, 5] = K[:, 6, 6] = rho
    return K


def stability_view(system: object) -> object:
    """Context in which ``system``'s tangents are the stability blocks (a no-op context for
    systems without rigid-link constraints)."""
    if getattr(system, "con_dofs", None) is None or system.con_dofs.shape[0] == 0:
        return nullcontext()
    return _view(system)


@contextmanager
def _view(system: object) -> Iterator[object]:
    old = system.stab_mode
    system.stab_mode = True
    try:
        yield system
    finally:
        system.stab_mode = old


__all__ = ["RHO_FACTOR", "forces", "stability_blocks", "stability_view", "tangent", "violation"]
