"""Linear-algebra layer of the load continuation: band storage and direct LAPACK solves.

``Banded`` holds a square matrix in LAPACK general band storage.  ``solve_linear`` and the
private ``_factor_solve``/``_resolve`` pair solve ``H x = rhs`` for a dense ``numpy.ndarray``
(LAPACK ``dgesv``, or ``dposv`` -- Cholesky -- on request), a ``Banded`` (``dgbsv`` or
``dpbsv``) or a ``scipy.sparse`` matrix (``splu``) and keep the factorisation for further
right-hand sides.  The LAPACK drivers are called directly: for the small systems of reduced
models the argument checking of ``numpy.linalg.solve`` / ``scipy.linalg.solve_banded`` costs
more than the factorisation.  ``hessian_positive_definite`` is the default stability test of
``engine.minimize_path`` where no Cholesky solve decided it; ``_fix_dense``/``_fix_sparse``/
``Banded.fix`` replace the rows and columns of supported unknowns by identity rows, keeping
the band structure.  ``Arrays`` is the engine's arithmetic on numpy arrays (``floats.Floats``
is the same on plain floats).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

__all__ = [
    "Arrays",
    "Banded",
    "hessian_positive_definite",
    "solve_linear",
]


@dataclass
class Banded:
    """A square matrix in LAPACK general band storage.

    Attributes
    ----------
    ab : (l + u + 1, n) array, ``ab[u + i - j, j] = A[i, j]``.
    l, u : numbers of sub- and super-diagonals.
    symmetric : True if A is symmetric (enables the Cholesky test in ``positive_definite``).
    """

    ab: np.ndarray
    l: int
    u: int
    symmetric: bool = True

    @property
    def n(self) -> int:
        """Matrix size."""
        return self.ab.shape[1]

    def to_dense(self) -> np.ndarray:
        """Dense (n, n) copy (tests and debugging only)."""
        n = self.n
        A = np.zeros((n, n))
        for k in range(-self.l, self.u + 1):  # loop over diagonals, not over elements
            if abs(k) < n:
                A += np.diag(self.ab[self.u - k, max(k, 0) : n + min(k, 0)], k)
        return A

    def upper(self) -> np.ndarray:
        """Upper symmetric band storage (u + 1, n) for ``solveh_banded``/``eigvals_banded``."""
        return self.ab[: self.u + 1]

    def fix(self, idx: np.ndarray | tuple[int, ...]) -> None:
        """Replace rows and columns ``idx`` by identity rows/columns (in place)."""
        key = idx if isinstance(idx, tuple) else tuple(np.atleast_1d(idx).tolist())
        zero, diag = _band_fix_index(self.n, self.l, self.u, key)
        if not self.ab.flags.c_contiguous:
            self.ab = np.ascontiguousarray(self.ab)
        flat = self.ab.reshape(-1)  # a view of the C-contiguous storage
        flat[zero] = 0.0
        flat[diag] = 1.0


@functools.lru_cache(maxsize=64)
def _band_fix_index(n: int, l: int, u: int, idx: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """Flat band-storage positions of the rows/columns ``idx`` and of their diagonal."""
    k = np.asarray(idx, dtype=int)[:, None]
    d = np.arange(-l, u + 1)[None, :]
    rows = np.broadcast_to(u - d, (k.size, d.size))
    col_k = np.broadcast_to(k, rows.shape)  # column k holds (k - d, k)
    ok1 = (k - d >= 0) & (k - d < n)
    col_kd = np.broadcast_to(k + d, rows.shape)  # row k holds (k, k + d) at column k + d
    ok2 = (col_kd >= 0) & (col_kd < n)
    zero = np.concatenate([rows[ok1] * n + col_k[ok1], rows[ok2] * n + col_kd[ok2]])
    return zero, u * n + k[:, 0]


def _fix_dense(H: np.ndarray, idx: np.ndarray) -> np.ndarray:
    H = np.array(H, dtype=float)
    H[idx, :] = 0.0
    H[:, idx] = 0.0
    H[idx, idx] = 1.0
    return H


def _fix_sparse(H: sp.spmatrix, idx: np.ndarray, n: int) -> sp.csc_matrix:
    keep = np.ones(n)
    keep[idx] = 0.0
    D = sp.diags(keep)
    E = sp.diags(1.0 - keep)
    return (D @ H @ D + E).tocsc()


_dposv, _dpotrs = lapack.dposv, lapack.dpotrs
_dgesv, _dgetrs = lapack.dgesv, lapack.dgetrs
_dpbsv, _dpbtrs = lapack.dpbsv, lapack.dpbtrs
_dgbsv, _dgbtrs = lapack.dgbsv, lapack.dgbtrs


def _absmax(v: np.ndarray) -> float:
    """max |v_i| (nan if any entry is not finite).

    Small vectors go through a Python list: for a handful of entries the two numpy calls
    cost four times more, and this runs twice per Newton iteration.
    """
    if v.size > 32:
        return float(abs(v).max())
    lst = v.tolist()
    m = max(map(abs, lst))
    return m if math.isfinite(sum(lst)) else math.nan


def _factor_solve(H: object, rhs: np.ndarray, chol: bool) -> tuple[np.ndarray, bool | None, tuple]:
    """Solve ``H x = rhs`` and keep the factorisation.

    ``chol``: try Cholesky first (H symmetric by the caller's guarantee).  Returns
    ``(x, pd, factor)``: ``pd`` is True/False when a Cholesky attempt decided positive
    definiteness, else None; ``factor`` is handed to ``_resolve`` for more right-hand sides.
    Raises ``numpy.linalg.LinAlgError`` for an exactly singular matrix.
    """
    pd = None
    if type(H) is np.ndarray:  # the common small dense case first
        if chol:
            c, x, info = _dposv(H, rhs)
            if info == 0:
                return x, True, ("po", c)
            pd = False
        lu, piv, x, info = _dgesv(H, rhs)
        if info > 0:
            raise np.linalg.LinAlgError("singular matrix")
        return x, pd, ("ge", lu, piv)
    if isinstance(H, Banded):
        if chol and H.symmetric and H.l == H.u:
            c, x, info = _dpbsv(H.ab[: H.u + 1], rhs)
            if info == 0:
                return x, True, ("pb", c)
            pd = False
        n, lo, up = H.ab.shape[1], H.l, H.u
        ab = np.empty((2 * lo + up + 1, n), order="F")  # dgbsv wants l extra rows for fill-in
        ab[lo:] = H.ab
        lub, piv, x, info = _dgbsv(lo, up, ab, rhs, overwrite_ab=1)
        if info > 0:
            raise np.linalg.LinAlgError("singular banded matrix")
        return x, pd, ("gb", lub, piv, lo, up)
    if sp.issparse(H):
        try:
            lu = spla.splu(sp.csc_matrix(H))
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise np.linalg.LinAlgError(str(exc)) from None
        return lu.solve(rhs), None, ("sp", lu)
    return _factor_solve(np.asarray(H, dtype=float), rhs, chol)


def _resolve(factor: tuple, rhs: np.ndarray) -> np.ndarray:
    """Solve with a factorisation kept by ``_factor_solve``."""
    kind = factor[0]
    if kind == "po":
        return _dpotrs(factor[1], rhs)[0]
    if kind == "ge":
        return _dgetrs(factor[1], factor[2], rhs)[0]
    if kind == "pb":
        return _dpbtrs(factor[1], rhs)[0]
    if kind == "gb":
        _, lub, piv, lo, up = factor
        return _dgbtrs(lub, lo, up, rhs, piv)[0]
    return factor[1].solve(rhs)


def solve_linear(H: object, rhs: np.ndarray) -> np.ndarray:
    """Solve ``H x = rhs`` for a dense, ``Banded`` or sparse ``H`` (raises LinAlgError)."""
    x = _factor_solve(H, np.asarray(rhs, dtype=float), False)[0]
    if not np.all(np.isfinite(x)):
        raise np.linalg.LinAlgError("singular matrix")
    return x


def hessian_positive_definite(H: object) -> bool | None:
    """Is the Hessian positive definite (``engine.positive_definite`` where no Newton solve
    decided it)?

    Dense and symmetric ``Banded`` matrices use a Cholesky factorisation; sparse or
    unsymmetric matrices give None (not assessed).
    """
    if isinstance(H, Banded):
        if not H.symmetric:
            return None
        return lapack.dpbtrf(H.upper())[1] == 0
    if sp.issparse(H):
        return None
    H = np.asarray(H, dtype=float)
    if not np.allclose(H, H.T, rtol=1e-9, atol=1e-12 * np.max(np.abs(H))):
        return None
    return lapack.dpotrf(H)[1] == 0


class Arrays:
    """Vector arithmetic and tangent solves of ``engine`` on numpy arrays (dense, ``Banded``
    or sparse tangents); the methods of ``floats.Floats``.

    Parameters
    ----------
    n : number of unknowns.
    fixed : indices of unknowns held at their start value (identity equations).
    inv_scale : (n,) 1 / typical size of each unknown, or None (unit scales).
    cap : (n,) 1 / (scale * max_step) per unknown, or None (no damping).
    """

    def __init__(
        self, n: int, fixed: np.ndarray, inv_scale: np.ndarray | None, cap: np.ndarray | None
    ) -> None:
        self.n, self.fixed, self.w, self.cap = n, fixed, inv_scale, cap
        self.fixed_key = tuple(fixed.tolist())
        self.has_fixed = bool(self.fixed_key)

    @staticmethod
    def vector(x: object) -> np.ndarray:
        """A state as this arithmetic holds it."""
        return np.array(x, dtype=float)

    def evaluate(self, grad_hess: object, x: np.ndarray, lam: float) -> tuple[np.ndarray, object]:
        """``grad_hess`` with the fixed unknowns replaced by identity equations."""
        g, H = grad_hess(x, lam)
        fixed = self.fixed
        if fixed.size:
            g = np.array(g, dtype=float)
            g[fixed] = 0.0
            if isinstance(H, Banded):
                H.fix(self.fixed_key)
            elif sp.issparse(H):
                H = _fix_sparse(H, fixed, self.n)
            else:
                H = _fix_dense(H, fixed)
        return g, H

    absmax = staticmethod(_absmax)
    factor_solve = staticmethod(_factor_solve)

    def size(self, v: np.ndarray) -> float:
        """max |v_i| * inv_scale_i."""
        return _absmax(v if self.w is None else v * self.w)

    @staticmethod
    def resolve(factor: tuple, b: np.ndarray) -> np.ndarray:
        """H^-1 b with a factor kept by ``factor_solve``."""
        return _resolve(factor, b)

    def damp(self, v: np.ndarray) -> np.ndarray:
        """``v`` shortened as a whole so that max |v_i| * cap_i <= 1."""
        over = float((abs(v) * self.cap).max())
        return v / over if over > 1.0 else v

    def zero_fixed(self, v: np.ndarray) -> np.ndarray:
        """``v`` with the fixed entries set to zero."""
        if self.fixed.size:
            v = np.array(v, dtype=float)
            v[self.fixed] = 0.0
        return v

    @staticmethod
    def finite(v: np.ndarray) -> bool:
        """Every entry finite."""
        return math.isfinite(v.dot(v))

    @staticmethod
    def sub(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """a - b."""
        return a - b

    @staticmethod
    def add(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """a + b."""
        return a + b

    @staticmethod
    def neg(a: np.ndarray) -> np.ndarray:
        """-a (in place: ``a`` is a fresh solve)."""
        a *= -1.0
        return a

    @staticmethod
    def times(a: np.ndarray, s: float) -> np.ndarray:
        """a * s."""
        return a * s

    @staticmethod
    def comb(
        t: np.ndarray, a1: float, b: np.ndarray, a2: float, q: np.ndarray | None, a3: float
    ) -> np.ndarray:
        """t a1 + b a2 (+ q a3 when q is given)."""
        out = t * a1 + b * a2
        if q is not None:
            out += q * a3
        return out

    def wdot(self, a: np.ndarray, b: np.ndarray) -> float:
        """Scaled dot product (a w) . (b w)."""
        if self.w is None:
            return float(a.dot(b))
        return float((a * self.w).dot(b * self.w))

    @staticmethod
    def min_abs_eig(H: object) -> float:
        """Smallest |eigenvalue| of the symmetric part of H (a diagnosis after failure,
        never in the Newton loop)."""
        A = H.to_dense() if isinstance(H, Banded) else (H.toarray() if sp.issparse(H) else H)
        A = np.asarray(A, dtype=float)
        return float(np.min(np.abs(np.linalg.eigvalsh(0.5 * (A + A.T)))))
