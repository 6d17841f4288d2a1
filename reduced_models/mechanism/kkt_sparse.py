"""Sparse KKT linear algebra: SuperLU solves and the inertia (stability) test.

Solves use SuperLU with its default fill-reducing column order and partial pivoting.

Inertia: a symmetric matrix factorised as ``P A P^T = L U`` with the *same* permutation on
rows and columns and no off-diagonal pivot has ``U = D L^T`` (the LU factorisation without
pivoting is unique and ``P A P^T`` is symmetric), so ``P A P^T = L D L^T`` is a congruence and,
by Sylvester's law of inertia, ``A`` has as many negative eigenvalues as ``D = diag(U)`` has
negative entries.  SuperLU gives such a factorisation in its symmetric mode (diagonal pivots
preferred, natural column order on a matrix we permute ourselves) whenever it returns
``perm_r == perm_c``; that is checked on every factorisation, and a diagonal pivot is accepted
only above ``THRESH`` times the largest entry of its column (threshold pivoting: the growth,
hence the sign of each pivot, stays under control).

The order matters for a KKT matrix: multipliers (and the axial forces of inextensible chained
segments) have zero diagonals, which cannot be pivots until one of their neighbours has been
eliminated.  ``kkt_order`` orders the unknowns with a usable diagonal by reverse Cuthill-McKee
(banded for chains of segments) and puts each zero-diagonal unknown right after its last
neighbour, where the elimination has filled its diagonal with a Schur complement.  When the
check fails anyway, the caller falls back to a dense Bunch-Kaufman LDL^T (``DENSE_MAX``) or
reports the stability as not assessed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu

THRESH = 0.1  # smallest |diagonal pivot| / max |entry| of its column accepted (else: fallback)
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


def ldl(A: sp.csc_matrix) -> tuple[Callable[[np.ndarray], np.ndarray], np.ndarray] | None:
    """Symmetric LDL^T of ``A`` (module doc): (solve, pivots D) or None when SuperLU had to
    pivot off the diagonal (inertia not certified)."""
    perm = kkt_order(A)
    B = A[perm][:, perm].tocsc()
    try:
        lu = splu(
            B,
            permc_spec="NATURAL",
            diag_pivot_thresh=THRESH,
            options={"SymmetricMode": True},
        )
    except RuntimeError:
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None

    def solve_a(rhs: np.ndarray) -> np.ndarray:
        x = np.empty_like(rhs)
        x[perm] = lu.solve(rhs[perm])
        return x

    return solve_a, lu.U.diagonal()


def inertia(d: np.ndarray) -> tuple[int | None, float]:
    """Negative pivots of a diagonal D and min |d| / max |d| ((None, rel) when singular)."""
    mags = np.abs(d)
    rel = float(mags.min() / max(mags.max(), 1e-300)) if len(d) else 1.0
    if rel <= 1e-13:
        return None, rel
    return int(np.count_nonzero(d < 0)), rel
