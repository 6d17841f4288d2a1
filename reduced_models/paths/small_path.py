"""Load continuation for a few unknowns on plain Python floats.

The same algorithm as ``continuation.minimize_path`` (Newton at each load factor, step
halving on failure and growth after easy steps, cubic Hermite predictor from the path
tangents, branch keeping by stability and turning-back tests, the factorisation deciding
positive definiteness) for up to ``MAX_N`` unknowns, written on lists of floats: for a
handful of unknowns a numpy call costs more than the arithmetic it does, and a 20-step path
of a 1-DOF PRB model then costs what its equations cost.  The Hessian of a PRB chain in
absolute link angles is tridiagonal: ``L D L^T`` (its pivots give positive definiteness)
costs O(n); an indefinite one is solved by pivoted LU.  ``continuation`` stays the general
solver (banded, sparse, unsymmetric, retractions, step caps).

Convergence is judged as there, on the state returned: the iterate x_k is accepted when its
own scaled Newton correction ``max |dx_i / scale_i| <= xtol`` and its residual
``max |g(x_k)| <= gtol``; its factorisation then gives the path tangent and (pivots of
``L D L^T``) its stability, with no extra evaluation.

Functions handed in: ``grad_hess(x, lam) -> (g, d, e)`` with ``x``, ``g`` and the Hessian's
diagonal ``d`` lists of n floats and its off-diagonal ``e`` a list of n - 1, or
``-> (g, H)`` with a dense symmetric (possibly indefinite) H as a list of rows, solved by
pivoted LU, whose stability is then judged by ``stability(x, lam) -> bool | None`` (a mixed
Lagrangian's inertia test), or ``-> (g, solve)`` with ``solve(b) -> list`` solving the tangent
system in closed form (raising ZeroDivisionError when singular; fixed unknowns are then the
caller's, and stability is judged by ``stability``); ``load_gradient(x, lam) -> dg/dlam``
(list).  ``max_step`` caps ``|dx_i / scale_i|`` per update (the update is shortened as a
whole), as there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from reduced_models.paths.path_result import PathResult, limit_note
from reduced_models.paths.stepper import Recorder, follow

MAX_N = 24  # above, numpy's banded solves beat Python loops


def _ldl(d: list, e: list, n: int) -> tuple[list, list] | None:
    """H = L D L^T for the symmetric tridiagonal H = tridiag(e, d, e): pivots D (n) and
    multipliers l (n + 1, l_0 = l_n = 0); None if a pivot is not positive (H not positive
    definite: the caller switches to pivoted LU)."""
    D, m = [0.0] * n, [0.0] * (n + 1)
    Dp = d[0]
    if not Dp > 0.0:
        return None
    D[0] = Dp
    for i in range(1, n):
        li = e[i - 1] / Dp
        Dp = d[i] - li * e[i - 1]
        if not Dp > 0.0:
            return None
        D[i], m[i] = Dp, li
    return D, m


def _ldl_factor_solve(d: list, e: list, b: list, n: int) -> tuple[tuple, list] | None:
    """``_ldl`` and ``_ldl_solve`` of b in one pass (the Newton loop's common case)."""
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


def _lu(H: list, n: int) -> tuple[list, list] | None:
    """LU with partial pivoting (rows permuted in place of a copy); None if singular."""
    A = [row[:] for row in H]
    piv = list(range(n))
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(A[i][k]))
        if A[p][k] == 0.0:
            return None
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


def _factor(d: list, e: list, n: int) -> tuple[tuple, bool]:
    """(factor, positive definite?) of tridiag(e, d, e); raises ZeroDivisionError if singular."""
    piv = _ldl(d, e, n)
    if piv is not None:
        return ("ldl", piv), True
    H = [[0.0] * n for _ in range(n)]
    for i in range(n):
        H[i][i] = d[i]
        if i < n - 1:
            H[i][i + 1] = H[i + 1][i] = e[i]
    fac = _lu(H, n)
    if fac is None:
        raise ZeroDivisionError("singular matrix")
    return ("lu", fac), False


def _solve(factor: tuple, b: Sequence[float], n: int) -> list:
    if factor[0] == "fn":
        return factor[1](b)
    return _ldl_solve(factor[1], b, n) if factor[0] == "ldl" else _lu_solve(factor[1], b, n)


class _Newton:
    """Newton at a fixed load factor (fixed unknowns replaced by identity equations)."""

    def __init__(self, grad_hess: Callable, n: int, fixed: tuple, inv_scale: list, xtol: float,
                 gtol: float | None, max_iter: int, cap: list | None = None,
                 stability: Callable | None = None) -> None:  # fmt: skip
        self.gh, self.n, self.fixed = grad_hess, n, fixed
        self.inv_scale, self.xtol, self.gtol, self.max_iter = inv_scale, xtol, gtol, max_iter
        self.cap, self.stability = cap, stability
        self.unit = all(w == 1.0 for w in inv_scale)  # unit scales: no products per update
        # (g, d, e) from grad_hess, unit scales, no damping, pd stability: ``solve_tri``
        # (known after the first evaluation)
        self.plain = self.unit and cap is None and stability is None
        self.tri = False
        self.fn = False  # a closed-form solve from grad_hess, nothing fixed: ``solve_fn``

    def evaluate(self, x: list, lam: float) -> tuple[list, tuple]:
        """Residual and Hessian: ``(d, e)`` tridiagonal or a dense list of rows."""
        g, *H = self.gh(x, lam)
        n = self.n
        if not self.fixed:
            return g, (tuple(H) if len(H) == 2 else H[0])
        if len(H) == 2:  # tridiagonal (d, e)
            d, e = H
            for i in self.fixed:
                g[i], d[i] = 0.0, 1.0
                if i:
                    e[i - 1] = 0.0
                if i < n - 1:
                    e[i] = 0.0
            return g, (d, e)
        (A,) = H
        if callable(A):  # a closed-form tangent solve (fixed unknowns are the caller's)
            return g, A
        for i in self.fixed:
            g[i] = 0.0
            for j in range(n):
                A[i][j] = A[j][i] = 0.0
            A[i][i] = 1.0
        return g, A

    def factor(self, H: tuple | list) -> tuple[tuple, bool | None]:
        """Factor and positive definiteness (None for a dense, possibly indefinite H)."""
        if type(H) is tuple:
            return _factor(*H, self.n)
        if callable(H):
            return ("fn", H), None
        fac = _lu(H, self.n)
        if fac is None:
            raise ZeroDivisionError("singular matrix")
        return ("lu", fac), None

    def factor_solve(self, H: tuple | list, b: list) -> tuple[tuple, bool | None, list]:
        """``factor`` and the solution of H s = b (fused for a positive definite
        tridiagonal H)."""
        if type(H) is tuple:
            fs = _ldl_factor_solve(H[0], H[1], b, self.n)
            if fs is not None:
                return ("ldl", fs[0]), True, fs[1]
        factor, pd = self.factor(H)
        return factor, pd, _solve(factor, b, self.n)

    def solve_tri(self, x: list, lam: float) -> tuple[tuple | None, int, str]:
        """``solve`` for the plain tridiagonal case: no dispatch per iteration."""
        gh, n, xtol, gtol, isfinite = self.gh, self.n, self.xtol, self.gtol, math.isfinite
        fixed, last = self.fixed, self.n - 1
        prev_res = math.inf
        for it in range(1, self.max_iter + 1):
            g, d, e = gh(x, lam)
            for i in fixed:  # identity equations (as ``evaluate``)
                g[i], d[i] = 0.0, 1.0
                if i:
                    e[i - 1] = 0.0
                if i < last:
                    e[i] = 0.0
            res = max(map(abs, g))
            if not isfinite(res + sum(g)):
                return None, it, "non-finite residual"
            fs = _ldl_factor_solve(d, e, g, n)
            if fs is None:  # indefinite: pivoted LU for this iterate
                return self.solve(x, lam, it - 1)
            sol = fs[1]
            size = max(map(abs, sol))
            if not isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    return (x, res, True, x, ("ldl", fs[0])), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            prev_res = res
            x = [a - b for a, b in zip(x, sol)]
        return None, self.max_iter, f"no convergence in {self.max_iter} its"

    def solve_fn(self, x: list, lam: float) -> tuple[tuple | None, int, str]:
        """``solve`` for a closed-form tangent solve with nothing fixed: no dispatch."""
        gh, xtol, gtol, cap, inv = self.gh, self.xtol, self.gtol, self.cap, self.inv_scale
        unit, isfinite = self.unit, math.isfinite
        prev_res = math.inf
        for it in range(1, self.max_iter + 1):
            g, tangent_solve = gh(x, lam)
            res = max(map(abs, g))
            if not isfinite(res + sum(g)):
                return None, it, "non-finite residual"
            try:
                sol = tangent_solve(g)
            except ZeroDivisionError as exc:
                return None, it, f"singular tangent ({exc})"
            size = max(map(abs, sol)) if unit else max([abs(s * w) for s, w in zip(sol, inv)])
            if not isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    st = None if self.stability is None else self.stability(x, lam)
                    return (x, res, st, x, ("fn", tangent_solve)), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            elif cap is not None:  # damping: the update shortened as a whole
                over = max([abs(s) * c for s, c in zip(sol, cap)])
                if over > 1.0:
                    sol = [s / over for s in sol]
            prev_res = res
            x = [a - b for a, b in zip(x, sol)]
        return None, self.max_iter, f"no convergence in {self.max_iter} its"

    def solve(self, x: list, lam: float, done: int = 0) -> tuple[tuple | None, int, str]:
        """((x, res, stable, x, factor) or None, iterations, reason): as
        ``continuation._Solver.newton``, the accepted state is the evaluated iterate x_k
        whose own correction and residual are small (no extra evaluation)."""
        inv, xtol, gtol, cap = self.inv_scale, self.xtol, self.gtol, self.cap
        evaluate, factor_solve = self.evaluate, self.factor_solve
        prev_res = math.inf
        for it in range(1 + done, self.max_iter + 1):
            g, H = evaluate(x, lam)
            self.tri = self.plain and type(H) is tuple
            self.fn = not self.fixed and callable(H)
            res = max(map(abs, g))
            if not math.isfinite(res + sum(g)):
                return None, it, "non-finite residual"
            try:
                factor, pd, sol = factor_solve(H, g)
            except ZeroDivisionError as exc:
                return None, it, f"singular tangent ({exc})"
            size = max(map(abs, sol)) if self.unit else max(abs(s * w) for s, w in zip(sol, inv))
            if not math.isfinite(size):
                return None, it, "singular tangent"
            if size <= xtol:
                if gtol is None or res <= gtol:
                    st = pd if self.stability is None else self.stability(x, lam)
                    return (x, res, st, x, factor), it, ""
                if res > 0.5 * prev_res:
                    return None, it, f"residual {res:.3g} stalls above gtol {gtol:.3g}"
            elif size > 1e6:
                return None, it, "Newton diverged"
            elif cap is not None:  # damping: the update shortened as a whole
                over = max(abs(s) * c for s, c in zip(sol, cap))
                if over > 1.0:
                    sol = [s / over for s in sol]
            prev_res = res
            x = [a - b for a, b in zip(x, sol)]
        return None, self.max_iter, f"no convergence in {self.max_iter} its"


def _min_abs_eig(newton: _Newton, x: Sequence[float], lam: float) -> float:
    """Smallest |eigenvalue| of the Hessian at ``(x, lam)`` (a diagnosis after failure)."""
    _, H = newton.evaluate([float(v) for v in x], lam)
    if isinstance(H, tuple):
        d, e = H
        A = np.diag(d) + np.diag(e, 1) + np.diag(e, -1)
    elif callable(H):  # a closed-form solve: |eig(H)| = 1 / |eig(H^-1)|, columns by unit rhs
        n = newton.n
        inv = np.array([H([float(i == j) for i in range(n)]) for j in range(n)], dtype=float)
        return 1.0 / float(np.max(np.abs(np.linalg.eigvals(inv))))
    else:
        A = np.array(H, dtype=float)
    return float(np.min(np.abs(np.linalg.eigvalsh(0.5 * (A + A.T)))))


def _diagnose(newton: _Newton, x: Sequence[float], lam: float, x0: Sequence[float],
              lam0: float) -> str:  # fmt: skip
    """Why load control stopped (``path_result.limit_note``)."""
    try:
        ratio = _min_abs_eig(newton, x, lam) / max(_min_abs_eig(newton, x0, lam0), 1e-300)
    except (np.linalg.LinAlgError, ValueError):
        ratio = float("nan")
    return limit_note(ratio, lam)


def minimize_path_small(
    grad_hess: Callable,
    x0: Sequence[float],
    factors: Sequence[float],
    *,
    scale: Sequence[float] | None = None,
    xtol: float = 1e-10,
    gtol: float | None = None,
    max_iter: int = 25,
    max_cuts: int = 10,
    fixed: Sequence[int] = (),
    load_gradient: Callable | None = None,
    max_step: Sequence[float] | None = None,
    stability: Callable | None = None,
) -> PathResult:
    """``continuation.minimize_path`` (symmetric H, positive-definiteness stability, branch
    keeping) on plain floats for ``len(x0) <= MAX_N`` unknowns; see the module docstring."""
    x = [float(v) for v in x0]
    n = len(x)
    inv = [1.0 / float(s) for s in scale] if scale is not None else [1.0] * n
    fixed = tuple(int(i) for i in fixed)
    cap = None
    if max_step is not None:  # 1 / (scale * max_step): |dx_i| * cap_i <= 1 per update
        cap = [w / float(m) for w, m in zip(inv, max_step)]
    newton = _Newton(grad_hess, n, fixed, inv, xtol, gtol, max_iter, cap, stability)

    factors = [float(f) for f in factors]
    rec = Recorder(n)
    engine = _Engine(newton, rec, fixed, inv, load_gradient, x, factors[0] if factors else 0.0)
    return rec.result(*follow(engine, x, factors, max_cuts))


class _Engine:
    """``minimize_path_small``'s arithmetic for ``stepper.follow`` (plain float lists)."""

    def __init__(
        self,
        newton: _Newton,
        rec: Recorder,
        fixed: tuple[int, ...],
        inv: list,
        load_gradient: Callable | None,
        x0: list,
        lam0: float,
    ) -> None:
        self.newton, self.rec, self.fixed, self.inv = newton, rec, fixed, inv
        self.load_gradient, self.x0, self.lam0, self.n = load_gradient, x0, lam0, len(x0)
        nw = newton
        self.solve = nw.solve_tri if nw.tri else nw.solve_fn if nw.fn else nw.solve

    def state(self, c: tuple) -> list:
        return c[0]

    def tangent(self, c: tuple, lam: float) -> list | None:
        if self.load_gradient is None or self.n == 0:
            return None
        dg = self.load_gradient(c[3], lam)
        for i in self.fixed:
            dg[i] = 0.0
        t = [-v for v in _solve(c[4], dg, self.n)]
        return t if math.isfinite(sum(t)) else None  # a sum is finite iff every entry is

    def predict(
        self,
        x_cur: list,
        x_prev: list | None,
        t_cur: list | None,
        t_prev: list | None,
        s: float,
        lam_cur: float,
        lam_prev: float | None,
    ) -> list | None:
        return _predict(x_cur, x_prev, t_cur, t_prev, s, lam_cur, lam_prev, self.inv)

    def branch_jump(
        self,
        cur: tuple,
        conv: tuple,
        x_cur: list,
        x_prev: list | None,
        lam_cur: float,
        lam_prev: float | None,
    ) -> str:
        """As ``continuation``'s: the stable branch left, or the path turned back."""
        if cur[2] is True and conv[2] is False:
            return "the step left the stable branch"
        if x_prev is not None and lam_cur != lam_prev:
            back = sum(
                [(a - b) * (b - c) * w * w for a, b, c, w in zip(conv[0], x_cur, x_prev, self.inv)]
            )
            if back < 0:
                return "the path turned back (branch jump)"
        return ""

    def diagnose(self, c: tuple, lam: float) -> str:
        return _diagnose(self.newton, c[0], lam, self.x0, self.lam0)

    def record(self, c: tuple, lam: float, its: int, cuts: int) -> None:
        self.rec.add(lam, c[0], its, cuts, c[1], c[2])


def _predict(
    x_cur: list,
    x_prev: list | None,
    t_cur: list | None,
    t_prev: list | None,
    s: float,
    lam_cur: float,
    lam_prev: float | None,
    inv: list,
) -> list | None:
    """Start of the next Newton solve: cubic Hermite, tangent line or secant (as
    ``continuation.minimize_path``); None: from the current state."""
    if x_prev is None or lam_cur == lam_prev:
        return None if t_cur is None else [c + t * s for c, t in zip(x_cur, t_cur)]
    h = lam_cur - lam_prev
    r = -s / h
    if t_cur is None:
        return [c + (p - c) * r for c, p in zip(x_cur, x_prev)]
    u = s / h
    c2 = u * u
    c3 = c2 + c2 * u if t_prev is not None else 0.0
    a1, a2, a3 = s + h * (c2 + c3), c2 + 2.0 * c3, h * c3
    # one pass: the Hermite point, the secant point and their scaled squared lengths
    poly, secant, size_p, size_s = [], [], 0.0, 0.0
    for c, p, t, q, w in zip(x_cur, x_prev, t_cur, t_prev or t_cur, inv):
        b = p - c
        d = t * a1 + b * a2 + q * a3  # a3 = 0 without t_prev
        poly.append(c + d)
        secant.append(c + b * r)
        size_p += (d * w) ** 2
        size_s += (b * w) ** 2
    # the polynomial runs more than 3 times further than the secant (scaled 2-norms): keep
    # the secant (a tangent blowing up next to a bifurcation or limit point)
    return poly if size_p <= 9.0 * r * r * size_s else secant
