"""Modes of the replay's tangent: the Rayleigh damping at the start, the static stability
test of a settled state, the softest frequency, and the lumped masses that make a system
without mass on some DOFs integrable.

Small systems (up to ``DENSE_EIG_MAX`` DOFs) use dense ``eigh``; larger ones shift-invert
``eigsh`` from a fixed start vector (``banded.arpack_start``: a random one made replays
differ in their last bits from run to run); a positive definite banded tangent uses banded
inverse iteration warm-started from the previous mode (``band.lowest_mode``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fem_reference.banded import arpack_start
from fem_reference.replay.band import lowest_mode
from fem_reference.replay.integrator import ReplayError

if TYPE_CHECKING:
    from fem_reference.replay.integrator import GenAlpha, State


def dof_weights(system: object, L: float) -> np.ndarray:
    """(ndof,) weights making every DOF a length: 1 for translations, L for rotations.

    Uses ``system.is_rotation`` (bool mask) or ``system.rotation_dofs`` (indices) if present.
    """
    w = np.ones(system.ndof)
    rot = getattr(system, "is_rotation", None)  # FEMSystem: (ndof,) bool
    if rot is None:
        rot = getattr(system, "rotation_dofs", None)
    if rot is not None:
        w[np.asarray(rot() if callable(rot) else rot)] = L
    return w


DENSE_EIG_MAX = 120  # DOFs; above, eigsh (measured crossover ~150)


def lowest_modes(K: sp.spmatrix, M: sp.spmatrix, k: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` lowest eigenpairs of the symmetric part of (K, M): values (k,), vectors (n, k).

    Dense for small systems (up to 120 DOFs dense ``eigh`` costs 0.3-0.6 ms against ~3 ms for
    shift-invert ``eigsh``, whose sparse LU and ARPACK set-up dominate there); shift-invert
    ``eigsh`` around zero otherwise (a settled state has no strongly negative eigenvalue, so
    the ones nearest zero contain the lowest).
    """
    n = K.shape[0]
    Ks = 0.5 * (K + K.T)
    k = min(k, n)
    if n <= DENSE_EIG_MAX or k >= n - 1:
        vals, vecs = sla.eigh(Ks.toarray(), M.toarray(), subset_by_index=[0, k - 1])
        return vals, vecs
    scale = abs(Ks.diagonal()).mean() / max(abs(M.diagonal()).mean(), 1e-300)
    for sigma in (0.0, -1e-6 * scale, -1e-3 * scale):
        try:
            vals, vecs = spla.eigsh(
                Ks.tocsc(), k=k + 2, M=M.tocsc(), sigma=sigma, which="LM", v0=arpack_start(n)
            )
            order = np.argsort(vals)[:k]
            return vals[order], vecs[:, order]
        except (RuntimeError, spla.ArpackError):
            continue
    vals, vecs = sla.eigh(Ks.toarray(), M.toarray(), subset_by_index=[0, k - 1])
    return vals, vecs


def rayleigh(K0: sp.spmatrix, M: sp.spmatrix, zeta: float) -> tuple[float, float, float, str]:
    """Rayleigh coefficients (a0, a1) giving ratio ``zeta`` at the two lowest modes of (K0, M).

    Returns a0, a1, the reference circular frequency omega_1 (rad / time) and a note.
    Zero-stiffness (mechanism) modes are skipped; an indefinite K0 (preloaded start) gets mass
    damping only.
    """
    vals, _ = lowest_modes(K0, M, k=min(K0.shape[0], 6))
    pos = vals[vals > 1e-9 * max(abs(vals).max(), 1e-300)]
    if pos.size == 0:
        raise ReplayError("no positive stiffness mode at the start: cannot choose damping")
    w1 = math.sqrt(pos[0])
    w2 = math.sqrt(pos[1]) if pos.size > 1 else 3.0 * w1
    if vals[0] < -1e-9 * abs(vals).max():
        return 2 * zeta * w1, 0.0, w1, "mass-proportional (indefinite K0)"
    a0, a1 = 2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2)
    return a0, a1, w1, f"Rayleigh a0={a0:.4g}, a1={a1:.4g} (current tangent)"


def tangent_test(
    K: sp.spmatrix, G: np.ndarray, M: sp.spmatrix, bw: int | None = None, warm: dict | None = None
) -> tuple[float, np.ndarray]:
    """Lowest eigenvalue of the tangent K (on the null space of the constraint rows G) against
    M, and its mode (ndof,): the static stability test at a settled state.  With a
    half-bandwidth ``bw`` and a ``warm`` dict: banded inverse iteration when K is positive
    definite (``band.lowest_mode``), else the dense test."""
    if bw is not None and warm is not None and not G.shape[0]:
        out = lowest_mode(sp.csr_matrix(K), sp.csr_matrix(M), bw, warm)
        if out is not None:
            return out
    if G.shape[0]:
        Z = sla.null_space(G)
        Kd, Md = Z.T @ (0.5 * (K + K.T)) @ Z, Z.T @ (M @ Z)
        vals, vecs = sla.eigh(Kd, Md, subset_by_index=[0, 0])
        return float(vals[0]), Z @ vecs[:, 0]
    vals, vecs = lowest_modes(K, M, k=1)
    return float(vals[0]), vecs[:, 0]


def point_masses(M: sp.spmatrix, w: np.ndarray, skip: np.ndarray | None = None) -> tuple:
    """M with a lumped mass on every DOF that has none (a node joining only springs, a
    rigid-body scene): the mean translational diagonal mass (1 if there is none) times w^2
    (inertia for rotations).  Settled states do not depend on it; without it the dynamics
    is singular.  ``skip``: algebraic DOFs, left massless.  Returns (M, number added)."""
    M = sp.csr_matrix(M)
    d = M.diagonal()
    empty = d <= 0.0
    if skip is not None:
        empty[np.asarray(skip)] = False
    if not empty.any():
        return M, 0
    trans = (d > 0.0) & (w == 1.0)
    m = float(d[trans].mean()) if trans.any() else 1.0
    add = np.where(empty, m * w * w, 0.0)
    return (M + sp.diags(add)).tocsr(), int(empty.sum())


def soft_frequency(system: object, integ: GenAlpha, s: State) -> float | None:
    """Lowest circular frequency of the current tangent (coordinate held for a servo system:
    ``modal_pair_at``), or None if it is not positive (no mode to damp critically)."""
    at = getattr(system, "modal_pair_at", None)
    if at is not None:
        K, M = at(s.q, s.lam)
    else:
        K, M = sp.csr_matrix(system.residual_and_tangent(s.q, s.lam)[1]), integ.M
    try:
        lam = float(lowest_modes(K, M, k=1)[0][0])
    except (ValueError, np.linalg.LinAlgError, RuntimeError, spla.ArpackError):
        return None
    return math.sqrt(lam) if lam > 0.0 else None
