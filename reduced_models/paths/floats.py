"""The arithmetics of ``engine.minimize_path`` on plain Python floats, for a few unknowns.

For a handful of unknowns a numpy call costs more than the arithmetic it does, so a path of
up to ``MAX_N`` unknowns handed in as a list of floats is followed with ``Floats``, one
unknown handed in as a bare float with ``Scalar`` (the same algorithm: ``engine`` calls the
methods below where the array arithmetic, ``linalg.Arrays``, calls numpy and LAPACK).  No
scipy here: a model solved on floats imports no sparse or LAPACK layer.

``Floats``: vectors are lists of n floats, ``grad_hess(x, lam) -> (g, H)`` with H either

* ``(d, e)``: a symmetric tridiagonal matrix, its diagonal (n) and off-diagonal (n - 1) --
  the Hessian of a PRB chain in absolute link angles.  ``L D L^T`` costs O(n) and its pivots
  decide positive definiteness on the way; an indefinite H is solved by pivoted LU;
* a callable ``solve(b) -> list`` solving the tangent system in closed form (raising
  ZeroDivisionError when singular; unknowns held fixed are then the caller's, and stability
  is judged by the ``stability`` function handed to the engine).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

# the float arithmetic for at most this many unknowns: measured, a 20-step path of a PRB chain
# on floats costs about half the numpy/LAPACK one at 4 to 8 angles, as much at 24 to 32
MAX_N = 24


def _ldl_factor_solve(d: list, e: list, b: list, n: int) -> tuple[tuple, list] | None:
    """H = L D L^T for H = tridiag(e, d, e) and the solution of H y = b in one pass: ((pivots
    D (n), multipliers m (n + 1, m_0 = m_n = 0)), y); None if a pivot is not positive (H not
    positive definite: the caller switches to pivoted LU)."""
    D, m, y = [0.0] * n, [0.0] * (n + 1), [0.0] * n
    Dp = d[0]
    if not Dp > 0.0:
        return None
    D[0] = Dp
    acc = y[0] = b[0]
    for i in range(1, n):
        ei = e[i - 1]
        li = ei / Dp
        Dp = d[i] - li * ei
        if not Dp > 0.0:
            return None
        D[i], m[i] = Dp, li
        acc = y[i] = b[i] - li * acc
    acc = 0.0
    for i in range(n - 1, -1, -1):
        acc = y[i] = y[i] / D[i] - m[i + 1] * acc
    return (D, m), y


def _ldl_solve(fac: tuple, b: Sequence[float], n: int) -> list:
    D, m = fac
    y = [0.0] * n
    acc = 0.0
    for i in range(n):
        acc = b[i] - m[i] * acc
        y[i] = acc
    acc = 0.0
    for i in range(n - 1, -1, -1):
        acc = y[i] / D[i] - m[i + 1] * acc
        y[i] = acc
    return y


def _lu(H: list, n: int) -> tuple[list, list]:
    """LU with partial pivoting of a list of rows (rows permuted in a copy); raises
    ZeroDivisionError if singular."""
    A = [row[:] for row in H]
    piv = list(range(n))
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(A[i][k]))
        if A[p][k] == 0.0:
            raise ZeroDivisionError("singular matrix")
        if p != k:
            A[k], A[p] = A[p], A[k]
            piv[k], piv[p] = piv[p], piv[k]
        for i in range(k + 1, n):
            f = A[i][k] / A[k][k]
            A[i][k] = f
            for j in range(k + 1, n):
                A[i][j] -= f * A[k][j]
    return A, piv


def _lu_solve(fac: tuple, b: Sequence[float], n: int) -> list:
    A, piv = fac
    y = [b[p] for p in piv]
    for i in range(n):
        y[i] -= sum(A[i][k] * y[k] for k in range(i))
    for i in range(n - 1, -1, -1):
        y[i] = (y[i] - sum(A[i][k] * y[k] for k in range(i + 1, n))) / A[i][i]
    return y


def _dense(d: list, e: list, n: int) -> list:
    """tridiag(e, d, e) as a list of rows."""
    H = [[0.0] * n for _ in range(n)]
    for i in range(n):
        H[i][i] = d[i]
        if i < n - 1:
            H[i][i + 1] = H[i + 1][i] = e[i]
    return H


class Floats:
    """Vector arithmetic and tangent solves of ``engine`` on lists of floats.

    Parameters
    ----------
    n : number of unknowns.
    fixed : indices of unknowns held at their start value (identity equations).
    inv_scale : (n,) 1 / typical size of each unknown, or None (unit scales).
    cap : (n,) 1 / (scale * max_step) per unknown, or None (no damping).
    """

    def __init__(
        self, n: int, fixed: Sequence[int], inv_scale: list | None, cap: list | None
    ) -> None:
        self.n, self.fixed = n, tuple(int(i) for i in fixed)
        self.has_fixed = bool(self.fixed)
        self.w, self.cap = inv_scale, cap

    @staticmethod
    def vector(x: Sequence[float]) -> list:
        """A state as this arithmetic holds it."""
        return [float(v) for v in x]

    def evaluate(self, grad_hess: Callable, x: list, lam: float) -> tuple[list, object]:
        """``grad_hess`` with the fixed unknowns replaced by identity equations."""
        g, H = grad_hess(x, lam)
        if self.fixed and type(H) is tuple:  # tridiagonal (d, e)
            d, e = H
            last = self.n - 1
            for i in self.fixed:
                g[i], d[i] = 0.0, 1.0
                if i:
                    e[i - 1] = 0.0
                if i < last:
                    e[i] = 0.0
        return g, H

    @staticmethod
    def absmax(v: list) -> float:
        """max |v_i| (nan if an entry is not finite: max() may step over a nan)."""
        m = max(map(abs, v))
        return m if math.isfinite(sum(v)) else math.nan

    def size(self, v: list) -> float:
        """max |v_i| * inv_scale_i."""
        if self.w is None:
            return max(map(abs, v))
        return max([abs(a * w) for a, w in zip(v, self.w)])

    def factor_solve(self, H: object, g: list, chol: bool) -> tuple[list, bool | None, tuple]:
        """(H^-1 g, positive definite? (None: not decided), factor); ``chol`` is ignored:
        the ``L D L^T`` of a tridiagonal H always decides definiteness."""
        n = self.n
        if callable(H):
            return H(g), None, ("fn", H)
        d, e = H
        fs = _ldl_factor_solve(d, e, g, n)
        if fs is not None:
            return fs[1], True, ("ldl", fs[0])
        fac = _lu(_dense(d, e, n), n)
        return _lu_solve(fac, g, n), False, ("lu", fac)

    def resolve(self, factor: tuple, b: list) -> list:
        """H^-1 b with a factor kept by ``factor_solve``."""
        kind = factor[0]
        if kind == "fn":
            return factor[1](b)
        return (_ldl_solve if kind == "ldl" else _lu_solve)(factor[1], b, self.n)

    def damp(self, v: list) -> list:
        """``v`` shortened as a whole so that max |v_i| * cap_i <= 1."""
        over = max([abs(a) * c for a, c in zip(v, self.cap)])
        return [a / over for a in v] if over > 1.0 else v

    def zero_fixed(self, v: list) -> list:
        """``v`` with the fixed entries set to zero."""
        for i in self.fixed:
            v[i] = 0.0
        return v

    @staticmethod
    def finite(v: list) -> bool:
        """Every entry finite (a sum is finite iff every entry is)."""
        return math.isfinite(sum(v))

    @staticmethod
    def sub(a: list, b: list) -> list:
        """a - b."""
        return [x - y for x, y in zip(a, b)]

    @staticmethod
    def add(a: list, b: list) -> list:
        """a + b."""
        return [x + y for x, y in zip(a, b)]

    @staticmethod
    def neg(a: list) -> list:
        """-a."""
        return [-x for x in a]

    @staticmethod
    def times(a: list, s: float) -> list:
        """a * s."""
        return [x * s for x in a]

    @staticmethod
    def comb(t: list, a1: float, b: list, a2: float, q: list | None, a3: float) -> list:
        """t a1 + b a2 (+ q a3 when q is given)."""
        if q is None:
            return [x * a1 + y * a2 for x, y in zip(t, b)]
        return [x * a1 + y * a2 + z * a3 for x, y, z in zip(t, b, q)]

    def wdot(self, a: list, b: list) -> float:
        """Scaled dot product sum (a_i w_i) (b_i w_i)."""
        if self.w is None:
            return sum([x * y for x, y in zip(a, b)])
        return sum([(x * w) * (y * w) for x, y, w in zip(a, b, self.w)])

    def min_abs_eig(self, H: object) -> float:
        """Smallest |eigenvalue| of H (a diagnosis after a failure, never in Newton)."""
        n = self.n
        if callable(H):  # |eig(H)| = 1 / |eig(H^-1)|, columns by unit right-hand sides
            inv = np.array([H([float(i == j) for i in range(n)]) for j in range(n)], dtype=float)
            return 1.0 / float(np.max(np.abs(np.linalg.eigvals(inv))))
        A = np.array(_dense(*H, n), dtype=float)
        return float(np.min(np.abs(np.linalg.eigvalsh(A))))


class Scalar:
    """``Floats`` for one unknown held as a bare float (``prb-1r``'s pivot angle): for one
    unknown the lists of ``Floats`` cost more than the equation itself.  ``grad_hess(x, lam)
    -> (g, h)``, the residual and its derivative; ``h > 0`` is positive definiteness."""

    n = 1
    cap = None

    def __init__(self, inv_scale: float | None, cap: float | None) -> None:
        self.w, self.cap = inv_scale, cap
        self.has_fixed = False

    @staticmethod
    def vector(x: float) -> float:
        """A state as this arithmetic holds it."""
        return float(x)

    @staticmethod
    def evaluate(grad_hess: Callable, x: float, lam: float) -> tuple[float, float]:
        """``grad_hess`` (nothing is fixed: a held single unknown is no path)."""
        return grad_hess(x, lam)

    @staticmethod
    def absmax(v: float) -> float:
        """|v| (nan stays nan)."""
        return abs(v)

    def size(self, v: float) -> float:
        """|v| * inv_scale."""
        return abs(v) if self.w is None else abs(v * self.w)

    @staticmethod
    def factor_solve(h: float, g: float, chol: bool) -> tuple[float, bool, float]:
        """(g / h, h > 0, h); raises ZeroDivisionError if h = 0."""
        if h == 0.0:
            raise ZeroDivisionError("singular matrix")
        return g / h, h > 0.0, h

    @staticmethod
    def resolve(h: float, b: float) -> float:
        """b / h."""
        return b / h

    def damp(self, v: float) -> float:
        """``v`` shortened so that |v| * cap <= 1."""
        over = abs(v) * self.cap
        return v / over if over > 1.0 else v

    @staticmethod
    def zero_fixed(v: float) -> float:
        """``v`` (nothing is fixed)."""
        return v

    @staticmethod
    def finite(v: float) -> bool:
        """``v`` is finite."""
        return math.isfinite(v)

    @staticmethod
    def sub(a: float, b: float) -> float:
        """a - b."""
        return a - b

    @staticmethod
    def add(a: float, b: float) -> float:
        """a + b."""
        return a + b

    @staticmethod
    def neg(a: float) -> float:
        """-a."""
        return -a

    @staticmethod
    def times(a: float, s: float) -> float:
        """a * s."""
        return a * s

    @staticmethod
    def comb(t: float, a1: float, b: float, a2: float, q: float | None, a3: float) -> float:
        """t a1 + b a2 (+ q a3 when q is given)."""
        return t * a1 + b * a2 if q is None else t * a1 + b * a2 + q * a3

    def wdot(self, a: float, b: float) -> float:
        """Scaled product (a w) (b w)."""
        return a * b if self.w is None else (a * self.w) * (b * self.w)

    @staticmethod
    def min_abs_eig(h: float) -> float:
        """|h|."""
        return abs(h)
