"""Linear algebra of the static solvers: banded LU, tangent factorisation and the inertia /
lowest eigenvalue of the symmetric tangent part.

After reverse Cuthill-McKee renumbering (``assembly.build``) member chains have a narrow band,
so the tangent is factorised by LAPACK ``dgbtrf`` in band storage (``scatter.BandScatter``
assembles straight into it); wide patterns fall back to SuperLU on csr.

Stability (``band_stability``): the symmetric part of the tangent, scaled to force*length
units, is positive definite iff the banded Cholesky ``dpbtrf`` succeeds (Sylvester: every
pivot positive).  Its lowest eigenvalue comes from inverse iteration with that Cholesky
factor, warm-started from the previous call's eigenvector (successive steps of a path have
nearly the same lowest mode).  Only an indefinite matrix needs more: the eigenvalues below
zero by bisection (``scipy.linalg.eig_banded``, LAPACK ``dsbevx``).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

BAND_MAX = 48  # widest half-band factorised in band storage (else SuperLU)
# dsbevx forms the n x n reduction matrix whenever a subset of eigenvalues is asked for
# (O(n^2) work: ~0.3 ms at n = 200, ~100 ms at n = 3000); beyond this size an indefinite
# matrix goes to the sparse LDL^T / shift-invert path of ``static.stability`` instead
EIG_BANDED_MAX = 1000

_dgbtrf = sla.lapack.dgbtrf
_dgbtrs = sla.lapack.dgbtrs
_dpbtrf = sla.lapack.dpbtrf
_dpbtrs = sla.lapack.dpbtrs


def vdot(a: np.ndarray, b: np.ndarray) -> float:
    """a . b by numpy's own (pairwise, single-threaded) sum, not BLAS ``ddot``: OpenBLAS runs
    ``ddot`` multi-threaded above ~10k entries, which on shared cores made a 4096-element
    solve many times slower than pinned to one thread."""
    return float(np.add.reduce(a * b))


def arpack_start(n: int) -> np.ndarray:
    """(n,) a fixed starting vector for ARPACK (``eigsh``'s ``v0``).  Without one ARPACK draws
    a random start, and its converged eigenpairs differ in the last bits from call to call:
    the replay's Rayleigh damping (from the two lowest modes) made the same scene's replay
    differ run to run, by 3e-7 in a bistable switch's located snap factor.  A fixed
    pseudo-random vector (not ``ones``, which a mirror-symmetric structure's antisymmetric
    mode can be orthogonal to) keeps every mode reachable."""
    return np.random.default_rng(20260101).standard_normal(n)


class SingularTangent(RuntimeError):
    """The tangent is exactly singular (a zero pivot)."""


class BandedLU:
    """LAPACK banded LU (``dgbtrf``/``dgbtrs``) of a matrix in ``dgbtrf`` band storage.

    Parameters
    ----------
    ab : (3 bw + 1, n) band storage, ``A[i, j]`` at ``ab[2 bw + i - j, j]``; overwritten when
        Fortran-ordered.
    bw : half-bandwidth.
    """

    def __init__(self, ab: np.ndarray, bw: int):
        self.lu, self.piv, info = _dgbtrf(ab, bw, bw, overwrite_ab=True)
        if info > 0:
            raise SingularTangent("singular tangent (zero pivot in banded LU)")
        self.bw = bw

    @classmethod
    def from_csr(cls, K: sp.csr_matrix, bw: int) -> BandedLU:
        """Band LU of a csr matrix with half-bandwidth ``bw``."""
        return cls(csr_to_band(K, bw), bw)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with A x = b."""
        x, info = _dgbtrs(self.lu, self.bw, self.bw, b, self.piv)
        return x


def csr_to_band(K: sp.csr_matrix, bw: int) -> np.ndarray:
    """csr (n, n) -> ``dgbtrf`` band storage (3 bw + 1, n), Fortran order."""
    n = K.shape[0]
    rows = np.repeat(np.arange(n), np.diff(K.indptr))
    ab = np.zeros((3 * bw + 1, n), order="F")
    np.add.at(ab, (2 * bw + rows - K.indices, K.indices), K.data)
    return ab


def factor(K: sp.csr_matrix, bw: int | None = None) -> object:
    """LU of a csr tangent: banded LAPACK when the (RCM-ordered) band is narrow, else SuperLU.
    Raises ``SingularTangent``."""
    if bw is not None and bw <= BAND_MAX:
        return BandedLU.from_csr(K, bw)
    try:
        return spla.splu(K.tocsc())
    except RuntimeError as e:  # exactly singular
        raise SingularTangent(f"singular tangent ({e})") from None


# -- stability of the symmetric part --------------------------------------------------------


def symmetric_upper_band(ab: np.ndarray, bw: int, scale: np.ndarray) -> np.ndarray:
    """``D (K + K^T)/2 D`` in LAPACK symmetric upper band storage (bw + 1, n), Fortran order,
    from ``K`` in ``dgbtrf`` storage ``ab`` (3 bw + 1, n); ``D = diag(scale)``.

    Entry (i, j), i <= j, of the result sits at ``[bw + i - j, j]``; with ``k = j - i`` it is
    ``(ab[2 bw - k, j] + ab[2 bw + k, j - k]) / 2 * scale[j - k] * scale[j]`` (one vector
    operation per diagonal, bw + 1 of them).
    """
    n = ab.shape[1]
    if n == 0:
        return np.zeros((bw + 1, 0), order="F")
    dst, a, b, i, j = _sym_index(bw, n)  # all diagonals at once: one gather per operand
    flat = ab.ravel(order="F")  # a view of the Fortran-ordered band (a copy otherwise)
    up = np.zeros((bw + 1) * n)
    up[dst] = (flat[a] + flat[b]) * (0.5 * scale[i] * scale[j])
    return up.reshape(n, bw + 1).T  # Fortran order


@functools.lru_cache(maxsize=64)
def _sym_index(bw: int, n: int) -> tuple[np.ndarray, ...]:
    """Flat (Fortran-order) positions for ``symmetric_upper_band``: destination ``[bw - k,
    j]`` in the (bw + 1, n) band, sources ``[2 bw - k, j]`` and ``[2 bw + k, j - k]`` in the
    (3 bw + 1, n) band, and the scale indices ``i = j - k``, ``j``, for every entry (i, j) of
    the upper band."""
    k = np.concatenate([np.full(n - kk, kk) for kk in range(min(bw, n - 1) + 1)])
    j = np.concatenate([np.arange(kk, n) for kk in range(min(bw, n - 1) + 1)])
    i = j - k
    ld = 3 * bw + 1
    return (j * (bw + 1) + bw - k, j * ld + 2 * bw - k, i * ld + 2 * bw + k, i, j)


def inf_norm(up: np.ndarray, bw: int) -> float:
    """Max absolute row sum of the symmetric band matrix (an upper bound of |eigenvalues|)."""
    n = up.shape[1]
    a = np.abs(up)
    rs = a[bw].copy()
    for k in range(1, min(bw, n - 1) + 1):
        rs[k:] += a[bw - k, k:]  # entries (j - k, j) counted in row j - k and row j
        rs[: n - k] += a[bw - k, k:]
    return float(rs.max(initial=0.0))


def hold_dof(up: np.ndarray, bw: int, m: int, value: float) -> None:
    """Decouple DOF ``m`` in place: zero its row/column, put ``value`` on the diagonal.  With
    ``value`` above every eigenvalue the inertia and the lowest eigenvalue are those of the
    matrix with row/column m removed."""
    n = up.shape[1]
    for k in range(1, bw + 1):
        if m - k >= 0:
            up[bw - k, m] = 0.0  # (m - k, m)
        if m + k < n:
            up[bw - k, m + k] = 0.0  # (m, m + k)
    up[bw, m] = value


def _start_vector(n: int) -> np.ndarray:
    x = np.cos(np.arange(n) * 0.7071) + 0.5  # deterministic, not orthogonal to low modes
    return x / math.sqrt(vdot(x, x))


def inverse_iteration(
    solve: object, n: int, x0: np.ndarray | None = None, tol: float = 1e-10, max_it: int = 80
) -> tuple[float, np.ndarray | None]:
    """Eigenvalue of smallest magnitude of a symmetric matrix given ``solve(b) = A^-1 b``
    (inverse iteration with Rayleigh quotients, relative tolerance ``tol``).

    Returns (eigenvalue, eigenvector); (nan, None) if it does not settle."""
    x = _start_vector(n) if x0 is None or x0.shape != (n,) else x0 / math.sqrt(vdot(x0, x0))
    mu = math.nan
    for _ in range(max_it):
        y = solve(x)
        ny = math.sqrt(vdot(y, y))
        if not np.isfinite(ny) or ny == 0.0:
            return math.nan, None
        new = vdot(x, y) / (ny * ny)
        x = y / ny
        if abs(new - mu) <= tol * abs(new):
            return new, x
        mu = new
    return math.nan, None


def band_stability(
    up: np.ndarray, bw: int, warm: dict | None = None, chol: tuple | None = None
) -> dict | None:
    """Inertia and lowest eigenvalue of a symmetric band matrix (upper storage (bw + 1, n)).

    ``stable`` = positive definite = ``dpbtrf`` succeeds; then ``min_eig`` by inverse
    iteration on the Cholesky factor (``warm['x']`` is the start vector and receives the new
    eigenvector).  Otherwise the eigenvalues below ``tol = 100 eps ||A||_inf`` (the accuracy
    of bisection) are found by bisection (``dsbevx``): ``n_neg`` = the count of those below
    ``-tol``, ``min_eig`` = the lowest (a matrix that is only semi-definite to round-off is
    reported unstable with ``n_neg = 0``, as a zero pivot of the LDL^T path did).

    ``chol``: ``dpbtrf(up, lower=0)``'s result when the caller has it already.

    Returns ``{'stable': bool, 'min_eig': float, 'n_neg': int}``, or None for an indefinite
    matrix larger than ``EIG_BANDED_MAX`` (the caller uses a sparse method).
    """
    n = up.shape[1]
    chol, info = chol if chol is not None else _dpbtrf(up, lower=0)
    if info == 0:
        x0 = None if warm is None else warm.get("x")

        def solve(b: np.ndarray) -> np.ndarray:
            return _dpbtrs(chol, b, lower=0)[0]

        lam, x = inverse_iteration(solve, n, x0)
        if x is None and x0 is not None:  # a stale warm start: retry from the fixed vector
            lam, x = inverse_iteration(solve, n)
        if warm is not None and x is not None:
            warm["x"] = x
        if not lam < 0.0:
            return {"stable": True, "min_eig": lam, "n_neg": 0}
        # Cholesky ran through on an ill-conditioned (EA L^2/EI ~ 1e8) indefinite matrix:
        # the eigenvalue found on its factor is the verdict, the bisection below the count
    if n > EIG_BANDED_MAX:
        return None
    norm = inf_norm(up, bw)
    tol = 100.0 * np.finfo(float).eps * max(norm, 1e-300)
    try:
        w = sla.eig_banded(up, eigvals_only=True, select="v", select_range=(-2.0 * norm - 1.0, tol))
    except (np.linalg.LinAlgError, ValueError):  # pragma: no cover - LAPACK failure
        return {"stable": False, "min_eig": math.nan, "n_neg": 0}
    n_neg = int(np.sum(w < -tol))
    mn = float(np.min(w)) if w.size else 0.0
    return {"stable": False, "min_eig": mn, "n_neg": n_neg}
