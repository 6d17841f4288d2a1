"""Constrained Newton (KKT), continuation with step cutting, and stability on the manifold.

Equilibrium of a ``MechanismSystem`` at load factor ``lam``:

    r(q, mu) = grad Pi(q; lam) + J(q)^T mu = 0   (free unknowns),   c(q) = 0,

solved by Newton on the KKT system ``[[W, J^T], [J, 0]]`` with ``W = Hess Pi + sum mu_k
Hess c_k``.  In a *distance* solve the load factor is unknown and takes the place of the
driver row's multiplier (the driver is then a target, not a force).  Convergence is judged
on the state handed back: max |r_i| / rscale_i and max |c_j| / cscale_j both <= tol.

Stability (``Step.stable``): the reduced Hessian ``Z^T W Z`` on the tangent space of the
constraints (driver held in energy analyses) is positive definite iff the KKT matrix has
exactly ``m + n_p`` negative eigenvalues and none near zero (inertia additivity; n_p = number
of axial multipliers of chained segments, each of which brings one negative eigenvalue).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import lapack

if TYPE_CHECKING:
    from reduced_models.mechanism.system import MechanismSystem

TOL = 1e-10
MAX_ITER = 30


class SolveError(RuntimeError):
    """Newton did not converge (message = reason)."""


@dataclass
class State:
    """A converged equilibrium: unknowns, multipliers (driver row: -driver force), factor."""

    q: np.ndarray
    mu: np.ndarray
    lam: float
    iterations: int = 0
    residual: float = 0.0
    K: np.ndarray | None = None  # KKT matrix at this state (reused by tangent/stability)
    lam_free: bool = False
    ldl: tuple | None = None  # (lu, piv, sc): LDL^T of the scaled K from ``Solver.stable``


class Solver:
    """Newton solves on one system; ``lam_free`` makes the load factor the driver's unknown."""

    def __init__(self, sysm: MechanismSystem, tol: float = TOL, max_iter: int = MAX_ITER) -> None:
        self.s = sysm
        self.tol, self.max_iter = tol, max_iter
        self.f = sysm.free
        self.nf = len(self.f)
        self.cs = None
        self._irs = None
        self._stab_key: tuple | None = None
        self._cap: np.ndarray | None = None
        self.memo: tuple | None = None  # last (path kind, t, x, dx) for the Hermite predictor

    def driver_index(self) -> int | None:
        """Row of the driver in the stacked constraint vector (None without a driver)."""
        s = self.s
        if s.driver_row is None:
            return None
        return s.m - s.linear.m + s.driver_row

    def kkt(self, st: State, lam_free: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
        """Residual (nf + m,) and KKT matrix at a state; the scaled residual norm."""
        s, f = self.s, self.f
        mu = st.mu.copy()
        d = self.driver_index()
        if lam_free:
            mu[d] = 0.0
        g, W, c, Jf = s.reduced(st.q, st.lam, mu)
        r = g + Jf.T @ mu
        nf, m = self.nf, len(c)
        K = np.zeros((nf + m, nf + m))
        K[:nf, :nf] = W
        K[:nf, nf:] = Jf.T
        K[nf:, :nf] = Jf
        if lam_free:
            K[:nf, nf + d] = s.reduced_load(st.q)
        if self.cs is None:
            self.cs = s.cscale()
        if self._irs is None:
            self._irs = 1.0 / s.rscale[f]
            self._ics = 1.0 / self.cs
        res = float(np.abs(r * self._irs).max()) if nf else 0.0
        if m:
            res = max(res, float(np.abs(c * self._ics).max()))
        return np.concatenate([r, c]), K, res

    def newton(self, st: State, lam_free: bool = False) -> State:
        """Newton from ``st`` (not modified); raises SolveError when it does not converge."""
        q, mu, lam = st.q.copy(), st.mu.copy(), st.lam
        s, f, nf = self.s, self.f, self.nf
        d = self.driver_index()
        if self._cap is None:  # damping: at most 0.5 rad / 0.25 L per update, none in p
            kind = np.array(s.lay.kind)[f]
            self._cap = 1.0 / np.where(
                kind == "r", 0.5, np.where(kind == "p", np.inf, 0.25 * s.lay.Lref)
            )
        icap = self._cap
        prev = np.inf
        for it in range(self.max_iter + 1):
            cur = State(q, mu, lam)
            R, K, res = self.kkt(cur, lam_free)
            if not np.all(np.isfinite(R)):
                raise SolveError("non-finite residual")
            if res <= self.tol:
                return State(q, mu, lam, it, res, K, lam_free)
            if it == self.max_iter or (it > 8 and res > 1e3 * prev):
                break
            prev = res
            dx = _solve(K, -R)
            if not np.all(np.isfinite(dx)):
                raise SolveError("singular KKT matrix (mechanism at a singular configuration)")
            big = float(np.max(np.abs(dx[:nf]) * icap, initial=0.0))
            if big > 1.0:
                dx /= big
            q = q.copy()
            q[f] += dx[:nf]
            mu = mu + dx[nf:]
            if lam_free:
                lam = lam + mu[d]
                mu[d] = 0.0
        raise SolveError(
            f"Newton did not converge in {self.max_iter} iterations (residual {res:.2e})"
        )

    def tangent(self, st: State, wrt: str, lam_free: bool = False) -> np.ndarray:
        """d(q_free, mu)/dt along the equilibrium path, t = load factor (``wrt="lam"``) or
        the driver value (``"driver"``; in its units: length or rad); (nf + m,)."""
        K = st.K if st.K is not None and st.lam_free == lam_free else self.kkt(st, lam_free)[1]
        rhs = np.zeros(K.shape[0])
        if wrt == "lam":
            rhs[: self.nf] = -self.s.reduced_load(st.q)
        else:
            rhs[self.nf + self.driver_index()] = 1.0
        if st.ldl is not None and not lam_free and len(st.ldl[2]) == len(rhs):
            # the stability check factorised diag(sc) K diag(sc) at this state already
            lu, piv, sc = st.ldl
            x, info = lapack.dsytrs(lu, piv, sc * rhs, lower=1)
            if info == 0 and np.all(np.isfinite(x)):
                return sc * x
        return _solve(K, rhs)

    def stable(self, st: State, hold_driver: bool) -> tuple[bool | None, float]:
        """Reduced-Hessian verdict and the lowest scaled eigenvalue (module doc)."""
        s, f, nf = self.s, self.f, self.nf
        K = st.K if st.K is not None and not st.lam_free else self.kkt(st)[1]
        d = self.driver_index()
        key = (K.shape[0], hold_driver)
        if self._stab_key != key:  # congruence scaling (keeps the inertia) and kept rows
            keep = np.ones(K.shape[0], bool)
            if d is not None and not hold_driver:
                keep[nf + d] = False
            cs = self.cs if d is None or hold_driver else np.delete(self.cs, d)
            sc = np.concatenate([1.0 / np.sqrt(s.rscale[f]), 1.0 / np.sqrt(cs)])
            n_p = sum(len(ch.w) for ch in s.chains)
            self._stab = (np.flatnonzero(keep), np.outer(sc, sc), bool(np.all(keep)), sc, n_p)
            self._stab_key = key
        keep, S, full, sc, n_p = self._stab
        A = K * S if full else K[np.ix_(keep, keep)] * S
        m = A.shape[0] - nf
        if A.size == 0:
            return True, 1.0
        lu, piv, info = lapack.dsytrf(A, lower=1)[:3]
        if info < 0:
            return None, 0.0
        if full and not st.lam_free:
            st.ldl = (lu, piv, sc)  # reused by ``tangent`` at this state
        n_neg, pivot = _inertia(lu, piv)
        if n_neg is None:
            return None, pivot
        return n_neg == m + n_p, pivot


def _solve(K: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """LAPACK dgesv (least squares if singular); the argument checks of numpy.linalg.solve
    cost more than the factorisation at these sizes."""
    _, _, x, info = lapack.dgesv(K, rhs)
    if info != 0 or not np.all(np.isfinite(x)):
        return np.linalg.lstsq(K, rhs, rcond=None)[0]
    return x


def _inertia(lu: np.ndarray, piv: np.ndarray) -> tuple[int | None, float]:
    """Number of negative eigenvalues of a symmetric matrix from its Bunch-Kaufman LDL^T
    factors (LAPACK dsytrf, lower; Sylvester's law of inertia), and the smallest |eigenvalue
    of D| relative to the largest; (None, pivot) when the matrix is numerically singular."""
    d = np.diag(lu)
    two = np.flatnonzero(piv < 0)  # 2x2 blocks: rows k, k+1 share a negative pivot index
    starts = two[::2]
    one = np.ones(len(d), bool)
    one[starts] = one[starts + 1] = False
    a, c, b = d[starts], d[starts + 1], lu[starts + 1, starts]
    det, tr = a * c - b * b, a + c
    disc = np.sqrt(np.maximum((a - c) ** 2 / 4 + b * b, 0.0))
    neg = int(np.count_nonzero(d[one] < 0) + np.count_nonzero(det < 0))
    neg += 2 * int(np.count_nonzero((det >= 0) & (tr < 0)))
    mags = np.abs(np.concatenate([d[one], tr / 2 - disc, tr / 2 + disc]))
    rel = float(mags.min() / max(mags.max(), 1e-300))
    if rel <= 1e-13:
        return None, rel
    return neg, rel


def follow(
    solver: Solver,
    st: State,
    t0: float,
    t1: float,
    set_t: Callable[[State, float], State],
    wrt: str,
    lam_free: bool = False,
    max_cuts: int = 12,
    rate: float = 1.0,
) -> State:
    """Move the path parameter from t0 to t1 (``set_t(state, t) -> state`` applies it),
    with tangent predictor and step halving; raises SolveError after ``max_cuts`` cuts.
    ``rate``: d(solver parameter)/dt (driver in degrees: pi/180)."""
    t, h, cuts, its = t0, t1 - t0, 0, 0
    nf = solver.nf
    d = solver.driver_index() if lam_free else None
    while (t1 - t) * (t1 - t0) > 1e-14 * max(abs(t1 - t0), 1e-300):
        step = h if abs(h) < abs(t1 - t) else t1 - t
        try:
            dx = solver.tangent(st, wrt, lam_free) * rate
            x = np.concatenate([st.q[solver.f], st.mu])
            if lam_free:
                x[nf + d] = st.lam  # the load factor sits in the driver multiplier's slot
            xp = _predict(solver, (wrt, lam_free), t, x, dx, t + step)
            pred = State(st.q.copy(), xp[nf:].copy(), st.lam)
            pred.q[solver.f] = xp[:nf]
            if lam_free:
                pred.lam = float(xp[nf + d])
                pred.mu[d] = 0.0
            pred = set_t(pred, t + step)
            try:
                new = solver.newton(pred, lam_free)
            except SolveError:
                solver.memo = None
                new = solver.newton(set_t(State(st.q, st.mu, st.lam), t + step), lam_free)
        except SolveError as err:
            cuts += 1
            if cuts > max_cuts:
                raise SolveError(f"step cut {max_cuts} times near t = {t:.6g}: {err}") from None
            h = step / 2.0
            continue
        solver.memo = ((wrt, lam_free), t, x, dx)
        its += new.iterations
        st, t = new, t + step
        if new.iterations <= 4:
            h = 2.0 * step
    st.iterations = its
    return st


def _predict(
    solver: Solver, kind: tuple, t: float, x: np.ndarray, dx: np.ndarray, t_new: float
) -> np.ndarray:
    """Predictor: cubic Hermite through the previous and the current converged state and
    their tangents (extrapolated to ``t_new``), else the tangent line.  The Hermite cubic is
    dropped when it runs more than 3x further than the tangent line (a tangent blowing up
    near a limit or bifurcation point)."""
    line = x + (t_new - t) * dx
    memo = getattr(solver, "memo", None)
    if memo is None or memo[0] != kind or memo[1] == t or len(memo[2]) != len(x):
        return line
    _, t0, x0, dx0 = memo
    H = t - t0
    tau = (t_new - t0) / H
    h00, h10 = 2 * tau**3 - 3 * tau**2 + 1, tau**3 - 2 * tau**2 + tau
    h01, h11 = -2 * tau**3 + 3 * tau**2, tau**3 - tau**2
    cubic = h00 * x0 + h10 * H * dx0 + h01 * x + h11 * H * dx
    if np.linalg.norm(cubic - x) > 3.0 * np.linalg.norm(line - x):
        return line
    return cubic
