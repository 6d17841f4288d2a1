"""Sparse KKT linear algebra: SuperLU solves and the inertia (stability) test.

Solves use SuperLU with its default fill-reducing column order and partial pivoting.

Inertia: a symmetric matrix factorised as ``P A P^T = L U`` with the *same* permutation on
rows and columns and no off-diagonal pivot has ``U = D L^T`` (the LU factorisation without
pivoting is unique and ``P A P^T`` is symmetric), so ``P A P^T = L D L^T`` is a congruence and,
by Sylvester's law of inertia, ``A`` has as many negative eigenvalues as ``D = diag(U)`` has
negative entries.  SuperLU gives such a factorisation in its symmetric mode (diagonal pivots,
natural column order on a matrix we permute ourselves) whenever it returns
``perm_r == perm_c``; that is checked on every factorisation.  Without pivoting for size the
growth of the factors is not bounded a priori, so the factorisation is certified a
posteriori: ``max |L U - P A P^T| <= BACKWARD max |A|`` -- the computed D is then exactly the
inertia of a matrix that close to A, the guarantee a backward-stable dense LDL^T gives.

The order matters for a KKT matrix: multipliers (and the axial forces of inextensible chained
segments) have zero diagonals, which cannot be pivots until one of their neighbours has been
eliminated, and so do the angle unknowns of rigid links (no stiffness of their own).  Two
exact steps make an order without zero pivots:

* congruence ``A' = T^T A T``, ``T = [[I, 0], [R, I]]`` (same inertia): with one entry
  ``R_kj = rho / J_kj`` per zero-diagonal primal unknown j (k: its largest constraint row),
  ``A'`` = ``[[W + J^T R + R^T J, J^T], [J, 0]]`` has ``2 rho`` added to that diagonal and
  fill only along constraint row k (``rho``: the largest entry of A);
* ``kkt_order``: reverse Cuthill-McKee on the unknowns with a usable diagonal (banded for
  chains of segments), each zero-diagonal unknown (multipliers, axial forces) right after its
  last neighbour, where the elimination has filled its diagonal with a Schur complement.

When a check fails anyway the caller falls back to a dense Bunch-Kaufman LDL^T
(``newton.DENSE_MAX``) or reports the stability as not assessed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu

BACKWARD = 1e-10  # largest relative backward error of a certified LDL^T
LATE = 1e-3  # |a_ii| below LATE * max_j |a_ij|: a zero-diagonal unknown, ordered late


def solve(K: sp.csc_matrix, rhs: np.ndarray) -> np.ndarray:
    """``K x = rhs`` by SuperLU (NaN when K is singular)."""
    try:
        return splu(K).solve(rhs)
    except RuntimeError:  # exactly singular factor
        return np.full(len(rhs), np.nan)


def kkt_order(A: sp.csc_matrix) -> np.ndarray:
    """Symmetric elimination order (module doc): RCM on the unknowns with a usable diagonal,
    each zero-diagonal unknown right after its last neighbour."""
    n = A.shape[0]
    absA = abs(A).tocsc()
    rowmax = np.asarray(absA.max(axis=0).todense()).ravel()  # symmetric: column max
    late = np.abs(A.diagonal()) <= LATE * rowmax
    early = np.flatnonzero(~late)
    sub = absA[early][:, early].tocsr()
    pos = np.full(n, -1.0)
    pos[early[reverse_cuthill_mckee(sub, symmetric_mode=True)]] = np.arange(len(early))
    key = pos.copy()
    lidx = np.flatnonzero(late)
    if len(lidx):
        cols = absA[:, lidx]
        starts = cols.indptr[:-1]
        vals = np.append(pos[cols.indices], -1.0)  # sentinel for empty columns
        last = np.maximum.reduceat(vals, np.minimum(starts, len(vals) - 1))
        last[np.diff(cols.indptr) == 0] = -1.0
        key[lidx] = np.where(last >= 0, last + 0.5, n)
    return np.argsort(key, kind="stable")


def _lift(A: sp.csc_matrix, nf: int) -> sp.csc_matrix:
    """``T`` of the congruence that gives zero-diagonal primal unknowns a diagonal (module
    doc); identity when none needs it."""
    n = A.shape[0]
    absA = abs(A).tocsc()
    colmax = np.asarray(absA.max(axis=0).todense()).ravel()
    weak = np.flatnonzero(np.abs(A.diagonal()[:nf]) <= LATE * colmax[:nf])
    Jb = A[nf:, :][:, weak].tocsc()  # constraint rows x weak primal columns
    if len(weak) == 0 or Jb.nnz == 0:
        return sp.identity(n, format="csc")
    k = np.asarray(abs(Jb).argmax(axis=0)).ravel()
    jk = np.asarray(Jb[k, np.arange(len(weak))]).ravel()
    ok = jk != 0.0
    rho = float(colmax.max())
    R = sp.csc_matrix((rho / jk[ok], (nf + k[ok], weak[ok])), shape=(n, n))
    return (sp.identity(n, format="csc") + R).tocsc()


def ldl(A: sp.csc_matrix, nf: int) -> tuple[Callable[[np.ndarray], np.ndarray], np.ndarray] | None:
    """Symmetric LDL^T of the KKT matrix ``A`` (``nf`` primal unknowns first; module doc):
    (solve, pivots D of a congruent matrix), or None when SuperLU had to pivot off the
    diagonal or the backward error is too large (inertia not certified)."""
    T = _lift(A, nf)
    A2 = (T.T @ A @ T).tocsc()
    perm = kkt_order(A2)
    B = A2[perm][:, perm].tocsc()
    try:
        lu = splu(
            B,
            permc_spec="NATURAL",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    n = B.shape[0]
    P = sp.csc_matrix((np.ones(n), (lu.perm_r, np.arange(n))), shape=(n, n))
    err = abs(P.T @ (lu.L @ lu.U) @ P - B).max()
    if not err <= BACKWARD * abs(B).max():
        return None

    def solve_a(rhs: np.ndarray) -> np.ndarray:
        b = T.T @ rhs
        y = np.empty_like(b)
        y[perm] = lu.solve(b[perm])
        return T @ y

    return solve_a, lu.U.diagonal()


def inertia(
    d: np.ndarray, solve_a: Callable[[np.ndarray], np.ndarray], A: sp.csc_matrix
) -> tuple[int | None, float]:
    """Negative pivots of D and the smallest |eigenvalue| of A relative to its norm, ((None,
    rel) when A is numerically singular).  Without pivoting for size a tiny pivot may sit
    beside a huge one in a regular matrix, so nearness to singularity is judged on A itself:
    a few steps of inverse iteration (the factorisation's solve) estimate min |lambda|."""
    n = A.shape[0]
    if n == 0:
        return 0, 1.0
    x = np.random.default_rng(0).standard_normal(n)
    lam = np.inf
    for _ in range(4):
        x /= np.linalg.norm(x)
        y = solve_a(x)
        ny = float(np.linalg.norm(y))
        if not np.isfinite(ny) or ny == 0.0:
            return None, 0.0
        lam = 1.0 / ny
        x = y
    rel = lam / max(float(abs(A).sum(axis=0).max()), 1e-300)
    if rel <= 1e-13:
        return None, rel
    return int(np.count_nonzero(d < 0)), rel
