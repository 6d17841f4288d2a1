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


class Solver:
    """Newton solves on one system; ``lam_free`` makes the load factor the driver's unknown."""

    def __init__(self, sysm: MechanismSystem, tol: float = TOL, max_iter: int = MAX_ITER) -> None:
        self.s = sysm
        self.tol, self.max_iter = tol, max_iter
        self.f = sysm.free
        self.nf = len(self.f)
        self.cs = None

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
        K = np.empty((nf + m, nf + m))
        K[:nf, :nf] = W
        K[:nf, nf:] = Jf.T
        K[nf:, :nf] = Jf
        K[nf:, nf:] = 0.0
        if lam_free:
            K[:nf, nf + d] = s.reduced_load(st.q)
        if self.cs is None:
            self.cs = s.cscale()
        res = max(
            float(np.max(np.abs(r) / s.rscale[f], initial=0.0)),
            float(np.max(np.abs(c) / self.cs, initial=0.0)),
        )
        return np.concatenate([r, c]), K, res

    def newton(self, st: State, lam_free: bool = False) -> State:
        """Newton from ``st`` (not modified); raises SolveError when it does not converge."""
        q, mu, lam = st.q.copy(), st.mu.copy(), st.lam
        s, f, nf = self.s, self.f, self.nf
        d = self.driver_index()
        kind = np.array(s.lay.kind)[f]
        cap = np.where(kind == "r", 0.5, np.where(kind == "p", np.inf, 0.25 * s.lay.Lref))
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
            try:
                dx = np.linalg.solve(K, -R)
            except np.linalg.LinAlgError:
                dx = np.linalg.lstsq(K, -R, rcond=None)[0]
            if not np.all(np.isfinite(dx)):
                raise SolveError("singular KKT matrix (mechanism at a singular configuration)")
            big = float(np.max(np.abs(dx[:nf]) / cap, initial=0.0))
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
        try:
            return np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            return np.linalg.lstsq(K, rhs, rcond=None)[0]

    def stable(self, st: State, hold_driver: bool) -> tuple[bool | None, float]:
        """Reduced-Hessian verdict and the lowest scaled eigenvalue (module doc)."""
        s, f, nf = self.s, self.f, self.nf
        K = st.K if st.K is not None and not st.lam_free else self.kkt(st)[1]
        d = self.driver_index()
        keep = np.ones(K.shape[0], bool)
        if d is not None and not hold_driver:
            keep[nf + d] = False
        K = K[np.ix_(keep, keep)]
        sc = np.concatenate([1.0 / np.sqrt(s.rscale[f]), np.ones(K.shape[0] - nf)])
        cs = self.cs if d is None or hold_driver else np.delete(self.cs, d)
        sc[nf:] = 1.0 / np.sqrt(cs)
        ev = np.linalg.eigvalsh(sc[:, None] * K * sc[None, :])
        n_p = sum(len(ch.w) for ch in s.chains)
        m = K.shape[0] - nf
        scale = float(np.max(np.abs(ev), initial=1.0))
        small = np.abs(ev) <= 1e-11 * scale
        n_neg = int(np.sum(ev < 0))
        # the eigenvalue that would change sign: the (m + n_p + 1)-th smallest
        j = min(m + n_p, len(ev) - 1)
        lowest = float(ev[j]) / scale if len(ev) else 0.0
        if np.any(small):
            return None, lowest
        return n_neg == m + n_p, lowest


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
    while (t1 - t) * (t1 - t0) > 1e-14 * max(abs(t1 - t0), 1e-300):
        step = h if abs(h) < abs(t1 - t) else t1 - t
        try:
            dx = solver.tangent(st, wrt, lam_free) * rate
            pred = State(st.q.copy(), st.mu.copy(), st.lam)
            pred.q[solver.f] += step * dx[:nf]
            pred.mu = pred.mu + step * dx[nf:]
            if lam_free:
                d = solver.driver_index()
                pred.lam = st.lam + step * dx[nf + d]
                pred.mu[d] = 0.0
            pred = set_t(pred, t + step)
            try:
                new = solver.newton(pred, lam_free)
            except SolveError:
                new = solver.newton(set_t(State(st.q, st.mu, st.lam), t + step), lam_free)
        except SolveError as err:
            cuts += 1
            if cuts > max_cuts:
                raise SolveError(f"step cut {max_cuts} times near t = {t:.6g}: {err}") from None
            h = step / 2.0
            continue
        its += new.iterations
        st, t = new, t + step
        if new.iterations <= 4:
            h = 2.0 * step
    st.iterations = its
    return st
