"""Sparse KKT linear algebra: SuperLU solves and the inertia (stability) test.

Solves use SuperLU with its default fill-reducing column order and partial pivoting.

Inertia: a symmetric matrix factorised as ``P A P^T = L U`` with the *same* permutation on
rows and columns and no off-diagonal pivot has ``U = D L^T`` (the LU factorisation without
pivoting is unique and ``P A P^T`` is symmetric), so ``P A P^T = L D L^T`` is a congruence and,
by Sylvester's law of inertia, ``A`` has as many negative eigenvalues as ``D = diag(U)`` has
negative entries.  SuperLU gives such a factorisation in its symmetric mode (diagonal pivots,
natural column order on a matrix we permute ourselves) whenever it returns
``perm_r == perm_c``; that is checked on every factorisation.  Without pivoting for size the
growth of the factors is not bounded a priori, so the factorisation is certified a posteriori
by Weyl's inequality: the computed factors are exact for ``P A P^T + E``, whose eigenvalues
differ from those of ``P A P^T`` by at most ``||E||_2``; when ``||E||_2`` is below a tenth of
the smallest |eigenvalue| (``||E||_2 <= sqrt(||E||_1 ||E||_inf)``; the smallest |eigenvalue|
by inverse iteration with the factors), no eigenvalue can have changed sign and the count of
negative pivots is the inertia of A.  Near-singularity is judged on that eigenvalue too (a
tiny pivot can sit beside a huge one in a regular matrix when nothing pivots for size).

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

MARGIN = 0.1  # certified when ||E||_2 <= MARGIN * min |eigenvalue| (Weyl)
SINGULAR = 1e-13  # min |eigenvalue| / ||A||_1 below which the matrix counts as singular
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


def ldl(A: sp.csc_matrix, nf: int) -> tuple[Callable, np.ndarray, float] | None:
    """Symmetric LDL^T of the KKT matrix ``A`` (``nf`` primal unknowns first; module doc):
    (solve, pivots D of a congruent matrix, min |eigenvalue| / norm), or None when SuperLU had
    to pivot off the diagonal or the backward error could change the inertia."""
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
    E = abs(P.T @ (lu.L @ lu.U) @ P - B)
    e2 = np.sqrt(float(E.sum(axis=0).max()) * float(E.sum(axis=1).max())) if E.nnz else 0.0
    low = _min_eig(lu.solve, n)
    rel = low / max(float(abs(B).sum(axis=0).max()), 1e-300)
    if not e2 <= MARGIN * low:
        return None

    def solve_a(rhs: np.ndarray) -> np.ndarray:
        b = T.T @ rhs
        y = np.empty_like(b)
        y[perm] = lu.solve(b[perm])
        return T @ y

    return solve_a, lu.U.diagonal(), rel


def _min_eig(solve: Callable[[np.ndarray], np.ndarray], n: int, steps: int = 4) -> float:
    """Smallest |eigenvalue| of a symmetric matrix by inverse iteration (0 if singular)."""
    x = np.random.default_rng(0).standard_normal(n)
    low = np.inf
    for _ in range(steps):
        x /= np.linalg.norm(x)
        x = solve(x)
        nx = float(np.linalg.norm(x))
        if not np.isfinite(nx) or nx == 0.0:
            return 0.0
        low = 1.0 / nx
    return low


def inertia(d: np.ndarray, rel: float) -> tuple[int | None, float]:
    """Negative pivots of D, and ``rel`` (smallest |eigenvalue| / norm): (None, rel) when
    the matrix is numerically singular."""
    if rel <= SINGULAR:
        return None, rel
    return int(np.count_nonzero(d < 0)), rel
