"""The discrete system interface shared by the static FE solvers and the dynamics replay.

``assembly.build(scene, n_elements)`` returns an object satisfying ``DiscreteSystem``: the
scene's free degrees of freedom after supports and joints, with the residual, tangent, mass and
result recovery the solvers need.  Static solvers (``static.py``) and the damped replay
(``replay.py``) only talk to this interface, so both judge the *same* discretisation.

Conventions
-----------
* ``u`` : (ndof,) free-DOF vector (translations in length units, rotations in rad).
* ``lam`` : load factor (dead and follower loads scale with it; prescribed driver
  coordinates too, through ``driver_value``).
* residual ``r(u, lam) = f_int(u) - lam * f_ext(u)``; equilibrium is ``r = 0``.
* tangent ``K(u, lam) = dr/du`` (material + geometric + follower load stiffness), a
  ``scipy.sparse.csr_matrix`` of shape (ndof, ndof).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import scipy.sparse as sp

from reduced_models.base import Step


class DiscreteSystem(Protocol):
    """What ``fem_reference.assembly.build`` returns."""

    ndof: int

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """r(u, lam), shape (ndof,)."""
        ...

    def residual_and_tangent(self, u: np.ndarray, lam: float) -> tuple[np.ndarray, sp.csr_matrix]:
        """r(u, lam) and K = dr/du."""
        ...

    def external(self, u: np.ndarray) -> np.ndarray:
        """f_ext(u) at load factor 1 (depends on u only through follower loads), (ndof,)."""
        ...

    def mass(self) -> sp.csr_matrix:
        """Consistent (or lumped, documented) mass matrix on the free DOFs, (ndof, ndof)."""
        ...

    def strain_energy(self, u: np.ndarray) -> float:
        """Elastic energy stored in members and springs."""
        ...

    def step(self, u: np.ndarray, lam: float, iterations: int, stable: bool | None) -> Step:
        """Recover outputs, shapes, energy and max stress of state ``u`` as a ``Step``."""
        ...

    def length_scale(self) -> float:
        """A characteristic length of the scene (largest member length) for tolerances."""
        ...
